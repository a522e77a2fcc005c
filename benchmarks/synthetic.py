"""The procedural locomotion generator: speed, gait figures, and quality beside real capture.

    python benchmarks/synthetic.py [cmu_folder]      # default: ../shared/mocap/cmu if present

Prints: the time to generate an hour of motion; cadence, stance fraction and control
recovery at steady speeds; foot skating and bone-length drift beside the real CMU clips.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from motionlab import data, metrics, representation as rep, synthetic as syn

FPS = 20


def best_of(n, fn):
    times = []
    for _ in range(n):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main(cmu: Path | None) -> None:
    print("| one hour of motion at 20 fps (best of 3) | seconds |\n|---|---|")
    print(f"| 360 clips of 10 s (`synthetic.dataset`) | {best_of(3, lambda: syn.dataset(360, 10.0, FPS)):.2f} |")
    print(f"| one clip of 3600 s (`synthetic.random_motion`) | "
          f"{best_of(3, lambda: syn.random_motion(3600.0, FPS)):.2f} |")
    print(f"| 60 clips of 10 s at 120 fps | {best_of(3, lambda: syn.dataset(60, 10.0, 120)):.2f} |\n")

    print("| command (fwd, side, turn) | steps/s | stance fraction | flight | recovered control |")
    print("|---|---|---|---|---|")
    for command in [(0.6, 0, 0), (1.0, 0, 0), (1.4, 0, 0), (1.8, 0, 0), (2.6, 0, 0), (3.4, 0, 0),
                    (4.0, 0, 0), (1.3, 0, 0.8), (-0.8, 0, 0), (0.1, 0.45, 0), (0, 0, 1.0)]:
        motion = syn.generate(np.tile(command, (int(20 * FPS), 1)), FPS)
        strikes = (np.diff(motion.contacts.astype(int), axis=0) == 1).sum() / (len(motion.contacts) / FPS)
        stance = motion.contacts.mean()
        flight = (~motion.contacts.any(axis=1)).mean()
        got = rep.to_features(motion.positions, FPS)[40:-40, rep.CONTROL].mean(axis=0)
        print(f"| {command} | {strikes:.2f} | {stance:.2f} | {flight:.2f} | "
              f"({got[0]:.2f}, {got[1]:.2f}, {got[2]:.2f}) |")
    print()

    ours = [syn.random_motion(12.0, FPS, seed=s).positions for s in range(40)]
    rows = {"synthetic, 40 random clips of 12 s": ours}
    if cmu is not None and cmu.is_dir():
        rows[f"real CMU, {cmu}"] = [c.positions for c in data.load(cmu, fps=FPS)]
    print("| data (20 fps) | foot skating, median (cm/s) | mean | bone-length drift, median (%) |")
    print("|---|---|---|---|")
    for name, clips in rows.items():
        skate = 100 * np.array([metrics.foot_skating(p, FPS) for p in clips])
        drift = 100 * np.array([metrics.bone_length_drift(p) for p in clips])
        print(f"| {name} | {np.median(skate):.2f} | {skate.mean():.2f} | {np.median(drift):.2e} |")


if __name__ == "__main__":
    default = Path(__file__).resolve().parents[1].parent / "shared" / "mocap" / "cmu"
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else default)
