"""Train the temporal convolutional autoencoder and print its reconstruction errors.

    python benchmarks/conv_ae.py [cmu_folder]       # default: ../shared/mocap/cmu if present

For synthetic data (80-frame windows) and, when given, real CMU clips (20-frame windows:
most CMU trials are under 3 s), split by clip: training time, and pose and motion error
on the test clips in centimetres, beside the mean-pose baseline.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch

from motionlab import data, metrics, training
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder

EPOCHS = 60


def run(name: str, source, config: ConvAEConfig) -> None:
    clips = data.load(source, fps=config.fps)
    prepared = data.prepare(clips, window_s=config.window / config.fps, normalization="shared_pose")
    torch.manual_seed(0)
    model = ConvAutoencoder(config)
    history = training.train(model, prepared, training.TrainConfig(epochs=EPOCHS, lr=2e-3, progress=False))
    original = prepared.normalizer.denormalize(prepared.test.windows.numpy())
    rebuilt = prepared.normalizer.denormalize(model.project(prepared.test.windows).numpy())
    ours = metrics.window_errors(rebuilt, original, config.fps)
    mean = metrics.window_errors(np.broadcast_to(prepared.normalizer.mean, original.shape), original, config.fps)
    d = prepared.description
    print(f"| {name} | {len(d['clips']['train'])}/{len(d['clips']['test'])} | {len(prepared.train)} x "
          f"{config.window} | {history.seconds:.1f} | {100 * ours['pose error (m)']:.2f} | "
          f"{100 * ours['motion error (m)']:.1f} | {100 * mean['pose error (m)']:.1f} |")


def main(cmu: Path | None) -> None:
    torch.set_num_threads(2)
    print(f"conv autoencoder, laptop config, {EPOCHS} epochs, shared-pose normalisation\n")
    print("| data | train/test clips | training windows x frames | training (s) | test pose error (cm) "
          "| test motion error (cm) | mean-pose baseline (cm) |")
    print("|---|---|---|---|---|---|---|")
    run("synthetic (40 clips of 12 s)", "synthetic", ConvAEConfig())
    if cmu is not None and cmu.is_dir():
        run(f"real CMU ({cmu.name})", cmu, ConvAEConfig(window=20))


if __name__ == "__main__":
    default = Path(__file__).resolve().parents[1].parent / "shared" / "mocap" / "cmu"
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else default)
