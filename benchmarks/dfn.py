"""Dynamic Future Net (Chen et al. 2020): staged training, reconstruction, diversity, stability.

    python benchmarks/dfn.py [cmu_folder]      # default: ../shared/mocap/cmu if present

For synthetic data (2-s windows) and, when present, real CMU clips (1-s windows: most CMU
trials are under 3 s), split by clip and augmented by mirroring only (DFN has no control,
so time-reversed clips would teach it to walk backwards), trains the laptop DFN in its
three stages and prints:

* training time per stage and the last validation loss terms;
* reconstruction errors on the test windows (cm per joint, root frame): through the frame
  autoencoder (§5.1) and through the sequence autoencoder's summaries (§5.2);
* diversity over time: 16 samples of 30 s from each of 3 test prefixes of 10 frames, the
  mean distance of their poses to the samples' mean pose (Fig. 9 of the paper) at several
  times, against the training data's band;
* stability over the 30 s: the share of values in the training data's range, the pose
  speed (first and last 5 s) against the data's, foot skating and bone-length drift.
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")   # idle threads sleep: much faster on a busy CPU

import numpy as np  # noqa: E402
import torch  # noqa: E402

from motionlab import data, metrics, training  # noqa: E402
from motionlab import representation as rep  # noqa: E402
from motionlab.models.dfn import DFN, DFNConfig  # noqa: E402
from motionlab.training import train_stages  # noqa: E402

SAMPLES, SECONDS, PREFIX, PREFIXES = 16, 30, 10, 3
TIMES_S = (1, 2, 5, 10, 20, 30)


def world(features: np.ndarray, fps: float) -> np.ndarray:
    return np.stack([rep.to_positions(f, fps) for f in features])


def run(name: str, source, window_s: float, epochs: dict[str, int]) -> None:
    config = DFNConfig()
    fps = config.fps
    prepared = data.prepare(data.load(source, fps=fps), window_s=window_s, stride_s=0.5,
                            augment_with=("mirror",))
    normalizer = prepared.normalizer
    d = prepared.description
    print(f"## {name}: {len(d['clips']['train'])}/{len(d['clips']['val'])}/{len(d['clips']['test'])} "
          f"train/val/test clips, {len(prepared.train)} training windows of {d['window_frames']} frames "
          f"at {fps:g} fps\n")

    torch.manual_seed(0)
    model = DFN(config)
    configs = {stage: training.TrainConfig(epochs=epochs[stage], lr=3e-3, batch_size=64, progress=False)
               for stage in epochs}
    histories = train_stages(model, prepared, configs)
    print("| stage | epochs | training (s) | last validation terms |\n|---|---|---|---|")
    for stage, history in histories.items():
        terms = ", ".join(f"{k} {v:.3g}" for k, v in history.val[-1].items() if k not in ("step", "epoch"))
        print(f"| {stage} | {epochs[stage]} | {history.seconds:.1f} | {terms} |")

    test = prepared.test.windows
    truth = normalizer.denormalize(test.numpy())
    frame_rec = normalizer.denormalize(model.reconstruct(test).numpy())
    sequence_rec = normalizer.denormalize(model.reconstruct(test, through="sequence").numpy())
    n = sequence_rec.shape[1]
    print("\n| reconstruction of the test windows | pose error (cm per joint) | bone-length drift (%) |"
          "\n|---|---|---|")
    print(f"| frame autoencoder (§5.1) | {100 * metrics.pose_error(frame_rec, truth):.2f} | "
          f"{100 * metrics.bone_length_drift(world(frame_rec, fps)):.2f} |")
    print(f"| sequence autoencoder (§5.2) | {100 * metrics.pose_error(sequence_rec, truth[:, :n]):.2f} | "
          f"{100 * metrics.bone_length_drift(world(sequence_rec, fps)):.2f} |")
    print(f"| (the data) | 0 | {100 * metrics.bone_length_drift(world(truth, fps)):.2f} |")

    train_frames = normalizer.denormalize(prepared.train.windows.numpy()).reshape(-1, rep.N_FEATURES)
    band_mean, band_std = metrics.data_band(train_frames[:, rep.POSE])
    data_speed = metrics.frame_speed(truth[..., rep.POSE], fps).mean()
    frames = int(SECONDS * fps)
    print(f"\nDiversity: mean distance (m) of {SAMPLES} samples' poses to their mean pose, "
          f"averaged over the second before each time; training data band {band_mean:.2f} ± {band_std:.2f} m\n")
    print("| prefix | " + " | ".join(f"{t} s" for t in TIMES_S) + " | generation (s) |")
    print("|---|" + "---|" * (len(TIMES_S) + 1))
    stability = []
    for index in np.linspace(0, len(test) - 1, PREFIXES).astype(int):
        prefix = test[index:index + 1, :PREFIX].expand(SAMPLES, -1, -1)
        began = time.perf_counter()
        generated = model.sample(prefix, frames, generator=torch.Generator().manual_seed(int(index)))
        seconds = time.perf_counter() - began
        features = normalizer.denormalize(generated.numpy())
        if not np.isfinite(features).all():
            print(f"| test window {index} | non-finite values generated |")
            continue
        pose = features[..., rep.POSE]
        mean_distance = metrics.mean_distance_over_time(pose)[0]
        at = [mean_distance[max(0, int((t - 1) * fps)):int(t * fps)].mean() for t in TIMES_S]
        print(f"| test window {index} | " + " | ".join(f"{v:.2f}" for v in at) + f" | {seconds:.2f} |")
        inside = metrics.fraction_in_range(features, train_frames, atol=0.01)
        speed = metrics.frame_speed(pose, fps).mean(axis=0)
        positions = world(features, fps)[:, PREFIX:]
        five = int(5 * fps)
        stability.append((index, inside[PREFIX:].min(), inside[-five:].mean(), speed[PREFIX:PREFIX + five].mean(),
                          speed[-five:].mean(), 100 * metrics.foot_skating(positions, fps),
                          100 * metrics.bone_length_drift(positions)))
    truth_world = world(truth, fps)
    skating = 100 * metrics.foot_skating(truth_world, fps)
    print(f"\nStability over {SECONDS} s (pose speed: m/s over the 63 root-local coordinates; "
          f"the test data: {data_speed:.2f} m/s, foot skating {skating:.1f} cm/s, "
          f"bone-length drift {100 * metrics.bone_length_drift(truth_world):.2f} %)\n")
    print("| prefix | in range, worst frame | in range, last 5 s | pose speed, first 5 s | pose speed, last 5 s "
          "| foot skating (cm/s) | bone-length drift (%) |\n|---|---|---|---|---|---|---|")
    for index, worst, last, first_speed, last_speed, skating, drift in stability:
        print(f"| test window {index} | {worst:.3f} | {last:.3f} | {first_speed:.2f} | {last_speed:.2f} "
              f"| {skating:.1f} | {drift:.1f} |")
    print()


def main(cmu: Path | None) -> None:
    torch.set_num_threads(int(os.environ.get("OMP_NUM_THREADS", 2)))
    print("Dynamic Future Net (Chen et al. 2020), laptop config\n")
    run("synthetic (40 clips of 12 s)", "synthetic", window_s=2.0,
        epochs={"frame": 15, "sequence": 15, "dynamics": 30})
    if cmu is not None and cmu.is_dir() and any(cmu.glob("*.bvh")):
        run(f"real CMU ({cmu}), split by clip", cmu, window_s=1.0,
            epochs={"frame": 30, "sequence": 30, "dynamics": 60})


if __name__ == "__main__":
    default = Path(__file__).resolve().parents[1].parent / "shared" / "mocap" / "cmu"
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else default)
