"""CMU trials in both formats: load times, and how far ASF/AMC and BVH positions differ.

    python benchmarks/asfamc.py [asfamc_folder [bvh_folder]]
    # default: ../shared/mocap/cmu_asfamc and ../shared/mocap/cmu

Prints two tables. The first times loading every trial present in both folders (best of
3): parsing alone, then parsing plus forward kinematics to the 21 locomotion joints in
metres. The second compares the two formats per trial, in metres after conversion:

* below the thorax (hips, legs, spine) the positions must agree: the BVH files were made
  from these AMC files, so the difference is rounding (printed to 5 decimals);
* above it the cgspeed BVH drops the thorax (and, for the fingers, the wrist), so neck,
  head and arms sit one thorax vector lower. The table gives that difference, the thorax
  length, and what is left once the dropped thorax/wrist vectors are added back.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from motionlab import asfamc, bvh, data
from motionlab.skeleton import LOCOMOTION

BELOW_THORAX = [LOCOMOTION.index(n) for n in asfamc.LOCOMOTION_BELOW_THORAX]
UPPER_BODY = [i for i in range(LOCOMOTION.n_joints) if i not in BELOW_THORAX]
FINGERS = [LOCOMOTION.index(n) for n in ("LeftHandIndex1", "RightHandIndex1")]


def best_of(repeat: int, fn):
    """``(seconds of the fastest of repeat runs, last result)``."""
    best, result = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def load_all_asfamc(amc_files: list[Path]) -> list[np.ndarray]:
    return [asfamc.load_locomotion(f)[0] for f in amc_files]


def parse_all_asfamc(amc_files: list[Path]) -> None:
    for f in amc_files:
        asfamc.read_amc(f, asfamc.read_asf(asfamc.skeleton_path(f)))


def dropped_vectors(amc_path: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """What the BVH leaves out, per locomotion joint: ``(frames, 21, 3)`` metres (thorax
    vector for neck, head and arms; plus the wrist vector for the fingers), and the thorax
    length in metres."""
    asf = asfamc.read_asf(asfamc.skeleton_path(amc_path))
    ends, names = asfamc.world_positions(asf, asfamc.read_amc(amc_path, asf))
    unit = asfamc.metres_per_unit(asf)

    def vector(bone):
        return (ends[:, names.index(bone)] - ends[:, names.index(asf.parents[bone])]) * unit

    dropped = np.zeros((len(ends), LOCOMOTION.n_joints, 3))
    dropped[:, UPPER_BODY] = vector("thorax")[:, None]
    for index, wrist in zip(FINGERS, ("lwrist", "rwrist")):
        dropped[:, index] += vector(wrist)
    return dropped, asf.bone("thorax").length * unit


def main(asfamc_dir: Path, bvh_dir: Path) -> None:
    trials = sorted(p.stem for p in asfamc_dir.glob("*.amc") if (bvh_dir / f"{p.stem}.bvh").is_file())
    if not trials:
        sys.exit(f"no trial is in both {asfamc_dir} (.amc) and {bvh_dir} (.bvh)")
    amc_files = [asfamc_dir / f"{t}.amc" for t in trials]
    bvh_files = [bvh_dir / f"{t}.bvh" for t in trials]
    sizes = {"ASF/AMC": sum(f.stat().st_size for f in amc_files),
             "BVH": sum(f.stat().st_size for f in bvh_files)}

    t_amc_parse, _ = best_of(3, lambda: parse_all_asfamc(amc_files))
    t_amc, from_amc = best_of(3, lambda: load_all_asfamc(amc_files))
    t_bvh_parse, _ = best_of(3, lambda: [bvh.read(f) for f in bvh_files])
    t_bvh, from_bvh = best_of(3, lambda: [data.load_bvh(f, drop_tpose=False).positions for f in bvh_files])
    n_frames = sum(len(p) for p in from_amc)
    print(f"{len(trials)} trials in both formats, {n_frames} frames at 120 fps\n")
    print("| format | MB | parse (s) | parse + FK -> 21 joints, metres (s) |\n|---|---|---|---|")
    for name, parse, load in (("ASF/AMC", t_amc_parse, t_amc), ("BVH", t_bvh_parse, t_bvh)):
        print(f"| {name} | {sizes[name] / 1e6:.1f} | {parse:.3f} | {load:.3f} |")
    print()

    print("| trial | frames | hips, legs, spine: max diff (mm) | neck, head, arms: max diff (cm) "
          "| thorax (cm) | fingers: max diff (cm) | above thorax, after adding the dropped "
          "vectors back (mm) |\n|---|---|---|---|---|---|---|")
    worst = np.zeros(5)
    for trial, amc_path, a, b in zip(trials, amc_files, from_amc, from_bvh):
        distance = np.linalg.norm(a - b, axis=-1)                          # (frames, 21) metres
        dropped, thorax = dropped_vectors(amc_path)
        body = [i for i in UPPER_BODY if i not in FINGERS]
        row = np.array([distance[:, BELOW_THORAX].max() * 1e3, distance[:, body].max() * 1e2,
                        thorax * 1e2, distance[:, FINGERS].max() * 1e2,
                        np.linalg.norm(a - b - dropped, axis=-1).max() * 1e3])
        worst = np.maximum(worst, row)
        print(f"| {trial} | {len(a)} | {row[0]:.5f} | {row[1]:.2f} | {row[2]:.2f} | {row[3]:.2f} "
              f"| {row[4]:.5f} |")
    print(f"| **max** | {n_frames} | **{worst[0]:.5f}** | **{worst[1]:.2f}** | {worst[2]:.2f} | "
          f"**{worst[3]:.2f}** | **{worst[4]:.5f}** |")


if __name__ == "__main__":
    shared = Path(__file__).resolve().parents[1].parent / "shared" / "mocap"
    args = [Path(a) for a in sys.argv[1:3]]
    main(args[0] if args else shared / "cmu_asfamc", args[1] if len(args) > 1 else shared / "cmu")
