"""Load and preprocess the real CMU clips; print timings, round-trip errors and metrics.

    python benchmarks/real_data.py [folder]      # default: ../shared/mocap/cmu

Prints three tables: time per stage, the representation round trip, and the quality
metrics of the real clips (the reference every generative model is compared with).
"""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from motionlab import bvh, data, metrics, representation as rep

FPS = 20


def timed(fn, *args, repeat=3, **kwargs):
    best, result = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn(*args, **kwargs)
        best = min(best, time.perf_counter() - start)
    return best, result


def main(folder: Path) -> None:
    files = sorted(folder.glob("*.bvh"))
    if not files:
        sys.exit(f"no .bvh files in {folder}")
    n_frames = sum(bvh.read(f).n_frames for f in files)
    print(f"{len(files)} clips, {n_frames} frames at 120 fps ({n_frames / 120 / 60:.1f} min) in {folder}\n")

    import_s = min(float(subprocess.run(
        [sys.executable, "-c", "import time; t = time.perf_counter(); import motionlab; "
                               "print(time.perf_counter() - t)"],
        capture_output=True, text=True, check=True).stdout) for _ in range(3))
    t_parse, _ = timed(lambda: [bvh.read(f) for f in files])
    t_fk, _ = timed(lambda: [bvh.read(f).world_positions() for f in files])
    t_load, clips = timed(data.load, folder, fps=FPS)
    t_feat, feats = timed(lambda: [c.features() for c in clips])
    t_prep, prepared = timed(data.prepare, clips, window_s=4.0)
    print("| stage (best of 3) | seconds |\n|---|---|")
    for name, t in [("import motionlab", import_s), ("parse all BVH", t_parse),
                    ("parse + forward kinematics", t_fk),
                    (f"load: parse + FK + 21 joints + resample to {FPS} fps", t_load),
                    ("features (root-local pose + control)", t_feat),
                    ("prepare: split, augment x4, window 4 s, normalise", t_prep)]:
        print(f"| {name} | {t:.3f} |")
    print()
    print(prepared.summary(), "\n")

    errors = {}
    for fps in (120, FPS):
        worst = 0.0
        for f in files:
            clip = data.load_bvh(f, fps=fps)
            back = rep.to_positions(clip.features(), fps, rep.root_start(clip.positions, fps))
            worst = max(worst, np.abs(back - clip.positions).max())
        errors[fps] = worst
    print("| round trip world -> features -> world | max error (m) |\n|---|---|")
    for fps, err in errors.items():
        print(f"| {fps} fps, all clips | {err:.2e} |")
    print()

    print(f"| clip | frames @ {FPS} fps | cruising speed (m/s) | foot skating (cm/s) | "
          "bone-length drift (%) |\n|---|---|---|---|---|")
    rows = []
    for clip, f in zip(clips, feats):
        speed = np.percentile(np.abs(f[:, 63]), 90)
        m = metrics.summarize(clip.positions, FPS)
        rows.append([speed, m["foot skating (cm/s)"], m["bone-length drift (%)"]])
        print(f"| {clip.name} | {clip.n_frames} | {speed:.2f} | {rows[-1][1]:.2f} | {rows[-1][2]:.3f} |")
    rows = np.array(rows)
    print(f"| **median** | | {np.median(rows[:, 0]):.2f} | {np.median(rows[:, 1]):.2f} | "
          f"{np.median(rows[:, 2]):.3f} |")
    print(f"| **mean** | | {rows[:, 0].mean():.2f} | {rows[:, 1].mean():.2f} | {rows[:, 2].mean():.3f} |")


if __name__ == "__main__":
    default = Path(__file__).resolve().parents[1].parent / "shared" / "mocap" / "cmu"
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else default)
