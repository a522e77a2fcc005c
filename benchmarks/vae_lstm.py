"""Habibie et al.'s Tables 1 and 2 on our data: VAE-LSTM against LSTM-3LR baselines.

    python benchmarks/vae_lstm.py [cmu_folder]      # default: ../shared/mocap/cmu if present

For synthetic data (4-s windows) and, when given, real CMU clips (1-s windows: most CMU
trials are under 3 s), split by clip, trains the VAE-LSTM (laptop config, with and without
the free-running term), LSTM-3LR predicting its own control, and LSTM-3LR given the control.
Prints training times, then the motion error (world, Table 1) and pose error (root frame,
Table 2) on the test windows at the paper's horizons scaled to the window (frames 70, 90,
120, 160, 210 of 240), in cm per joint, and how the feet move (stepping speed in the root
frame, median ankle height, foot skating). The LSTMs are primed with the first quarter of
each window (the paper: 60 of 240 frames), the VAE-LSTM with 4 frames or none; VAE-LSTM
errors are the mean over 3 samples.
"""
from __future__ import annotations

import os
import sys
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")   # idle threads sleep: much faster on a busy CPU

import numpy as np  # noqa: E402
import torch  # noqa: E402

from motionlab import data, metrics, training  # noqa: E402
from motionlab import representation as rep  # noqa: E402
from motionlab.models.lstm import LSTMConfig, MotionLSTM  # noqa: E402
from motionlab.models.vae_lstm import VAELSTM, VAELSTMConfig  # noqa: E402
from motionlab.skeleton import LOCOMOTION  # noqa: E402

SAMPLES = 3
FEET = [LOCOMOTION.index("LeftFoot"), LOCOMOTION.index("RightFoot")]


def feet_report(features: np.ndarray, fps: float) -> np.ndarray:
    """Stepping (m/s: ankle speed in the root frame), median ankle height (cm), foot skating (cm/s)."""
    ankles = features[..., rep.POSE].reshape(*features.shape[:2], -1, 3)[:, :, FEET]
    stepping = metrics.stepping_speed(features, fps).mean()
    world = np.stack([rep.to_positions(w, fps) for w in features])
    return np.array([stepping, 100 * np.median(ankles[..., 1]), 100 * metrics.foot_skating(world, fps)])


def run(name: str, source, window: int, epochs: int, lstm_epochs: int) -> None:
    config = VAELSTMConfig(window=window)
    lstm_config = LSTMConfig(window=window, hidden=64)
    prepared = data.prepare(data.load(source, fps=config.fps), window_s=window / config.fps)
    d = prepared.description
    print(f"## {name}: {len(d['clips']['train'])}/{len(d['clips']['val'])}/{len(d['clips']['test'])} "
          f"train/val/test clips, {len(prepared.train)} training and {len(prepared.test)} test windows "
          f"of {window} frames at {config.fps:g} fps\n")

    models = {}
    jobs = [("VAE-LSTM", VAELSTM, config, epochs, 3e-3),
            ("VAE-LSTM, paper's objective (free_running=0)", VAELSTM, replace(config, free_running=0.0),
             epochs, 3e-3),
            ("LSTM-3LR, control predicted", MotionLSTM, lstm_config, lstm_epochs, 3e-3),
            ("LSTM-3LR, control given", MotionLSTM, replace(lstm_config, control="given"), lstm_epochs, 3e-3)]
    print("| model | parameters | epochs | training (s) |\n|---|---|---|---|")
    for label, cls, cfg, n_epochs, lr in jobs:
        torch.manual_seed(0)
        models[label] = cls(cfg)
        history = training.train(models[label], prepared, training.TrainConfig(epochs=n_epochs, lr=lr, progress=False))
        n_parameters = sum(p.numel() for p in models[label].parameters())
        print(f"| {label} | {n_parameters:,} | {n_epochs} | {history.seconds:.1f} |")

    test = prepared.test.windows
    truth = prepared.normalizer.denormalize(test.numpy())
    frames = test.shape[1]
    control = test[..., rep.CONTROL]
    prime = frames // 4
    horizons = [round(frames * f / 240) for f in (70, 90, 120, 160, 210)]
    generator = torch.Generator().manual_seed(0)
    vae, paper = models["VAE-LSTM"], models["VAE-LSTM, paper's objective (free_running=0)"]
    lstm, given = models["LSTM-3LR, control predicted"], models["LSTM-3LR, control given"]
    rows = {
        "LSTM-3LR, no control": (prime, "no", [lstm.sample(test[:, :prime], frames)]),
        "LSTM-3LR, true control fed back": (prime, "yes", [lstm.sample(test[:, :prime], frames, control)]),
        "LSTM-3LR trained with control": (prime, "yes", [given.sample(test[:, :prime], frames, control)]),
        "VAE-LSTM, 4 initial frames": (4, "yes", [vae.sample(control, test[:, :4], generator=generator)
                                                  for _ in range(SAMPLES)]),
        "VAE-LSTM, prior sample": (0, "yes", [vae.sample(control, generator=generator) for _ in range(SAMPLES)]),
        "VAE-LSTM (paper's objective), 4 initial frames": (4, "yes", [
            paper.sample(control, test[:, :4], generator=generator) for _ in range(SAMPLES)]),
    }
    mean_pose = np.broadcast_to(prepared.normalizer.mean, truth.shape).copy()
    mean_pose[..., rep.CONTROL] = truth[..., rep.CONTROL]
    errors, feet = {}, {"ground truth": feet_report(truth[:, prime:], config.fps)}
    for label, (_, _, samples) in rows.items():
        denormalised = [prepared.normalizer.denormalize(s.numpy()) for s in samples]
        per_sample = [metrics.errors_by_frame(s, truth, config.fps) for s in denormalised]
        errors[label] = [np.mean([e[k] for e in per_sample], 0) for k in (0, 1)]
        feet[label] = np.mean([feet_report(s[:, prime:], config.fps) for s in denormalised], 0)
    errors["mean pose, true control"] = list(metrics.errors_by_frame(mean_pose, truth, config.fps))
    rows["mean pose, true control"] = (0, "yes", None)

    for k, title in ((1, "Table 1: motion error (world)"), (0, "Table 2: pose error (root frame)")):
        print(f"\n{title}, cm per joint; frame {horizons[-1]} is "
              f"{(horizons[-1] - prime) / config.fps:.2f} s after the LSTMs' priming\n")
        print("| model | initial frames | control | " + " | ".join(f"frame {h}" for h in horizons) + " |")
        print("|---|---|---|" + "---|" * len(horizons))
        for label, values in errors.items():
            initial, given_control, _ = rows[label]
            print(f"| {label} | {initial} | {given_control} | "
                  + " | ".join(f"{100 * values[k][h - 1]:.1f}" for h in horizons) + " |")
    print("\nFeet over the predicted part of the test windows\n")
    print("| motion | stepping (m/s) | median ankle height (cm) | foot skating (cm/s) |\n|---|---|---|---|")
    for label, (stepping, height, skating) in feet.items():
        print(f"| {label} | {stepping:.2f} | {height:.1f} | {skating:.1f} |")
    print()


def main(cmu: Path | None) -> None:
    torch.set_num_threads(2)
    print("VAE-LSTM (Habibie et al. 2017) against LSTM-3LR, laptop configs\n")
    run("synthetic (40 clips of 12 s)", "synthetic", window=80, epochs=20, lstm_epochs=15)
    if cmu is not None and cmu.is_dir():
        run(f"real CMU ({cmu}), split by clip", cmu, window=20, epochs=30, lstm_epochs=20)


if __name__ == "__main__":
    default = Path(__file__).resolve().parents[1].parent / "shared" / "mocap" / "cmu"
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else default)
