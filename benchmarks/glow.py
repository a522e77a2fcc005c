"""Train the fixed-length sequence Glow and print its likelihoods, sample quality and speed.

    python benchmarks/glow.py [cmu_folder] [--epochs N]   # default: ../shared/mocap/cmu if present
    python benchmarks/glow.py --speed-only                 # only the training-speed table

Three tables:

1. test negative log-likelihood in bits per frame (normalised units, and the data's own
   units: metres, m/s, rad/s) on synthetic data (4-s windows) and, when given, real CMU
   clips (1-s windows: most CMU trials are under 3 s), laptop config, conditioned on the
   control (eq. 10), beside a per-feature standard normal (what the normaliser alone gives);
2. foot skating, bone-length drift, leg swing and diversity of samples against
   temperature, beside the test data (samples follow the test windows' control; diversity:
   8 samples of one control);
3. training speed in steps per second at the laptop and paper (§5.2) sizes, batches of
   32 windows of 80 frames (paper size: a few steps only).
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
import torch

from motionlab import data, metrics, training
from motionlab import representation as rep
from motionlab.models.glow import Glow, GlowConfig

TEMPERATURES = (0.0, 0.5, 0.7, 1.0)


def world(features: np.ndarray, fps: float) -> np.ndarray:
    return rep.to_positions(features, fps)


def leg_swing(features: np.ndarray) -> float:
    """cm: std over each window of (left - right ankle) along the facing direction, mean over windows."""
    return 100 * metrics.leg_swing(features)


def train(source, config: GlowConfig, epochs: int):
    clips = data.load(source, fps=config.fps)
    prepared = data.prepare(clips, window_s=config.window / config.fps)
    torch.manual_seed(0)
    model = Glow(config)
    history = training.train(model, prepared, training.TrainConfig(epochs=epochs, lr=2e-3, progress=False))
    return model, prepared, history


def likelihood_row(name: str, model: Glow, prepared, history) -> None:
    test = prepared.test.windows
    normalised = model.nll(test)["bits/frame"]
    in_units = model.nll(test, prepared.normalizer)["bits/frame"]
    train_bits = model.nll(prepared.train.windows[:256])["bits/frame"]
    gaussian = model.n_modelled * 0.5 * math.log2(2 * math.pi * math.e)         # N(0, 1) per value
    d = prepared.description
    print(f"| {name} | {len(d['clips']['train'])}/{len(d['clips']['test'])} | {len(prepared.train)} x "
          f"{model.config.window} | {len(history.train)} | {history.seconds:.0f} | {train_bits:.1f} | "
          f"{normalised:.1f} | {gaussian:.1f} | {in_units:.1f} |")


def sample_rows(name: str, model: Glow, prepared) -> None:
    fps = model.config.fps
    test = prepared.test.windows
    test_features = prepared.normalizer.denormalize(test.numpy())
    original = world(test_features, fps)
    print(f"| {name}: test data | {100 * metrics.foot_skating(original, fps):.2f} | "
          f"{100 * metrics.bone_length_drift(original):.3f} | {leg_swing(test_features):.1f} | - |")
    one_control = test[:1, :, rep.CONTROL].expand(8, -1, -1)
    for temperature in TEMPERATURES:
        g = torch.Generator().manual_seed(0)
        samples = model.sample(len(test), control=test[..., rep.CONTROL], temperature=temperature, generator=g)
        sample_features = prepared.normalizer.denormalize(samples.numpy())
        positions = world(sample_features, fps)
        same = model.sample(8, control=one_control, temperature=temperature, generator=g)
        spread = metrics.diversity(world(prepared.normalizer.denormalize(same.numpy()), fps)).mean()
        print(f"| {name}: samples, T = {temperature:g} | {100 * metrics.foot_skating(positions, fps):.2f} | "
              f"{100 * metrics.bone_length_drift(positions):.3f} | {leg_swing(sample_features):.1f} | "
              f"{100 * spread:.1f} |")


def steps_per_second(config: GlowConfig, steps: int, batch: int = 32) -> float:
    torch.manual_seed(0)
    model = Glow(config)
    windows = torch.randn(batch, config.window, config.n_features)
    windows[..., list(config.constant_features)] = 0
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-4)

    def step():
        loss = model.loss(windows)["loss"]
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()

    step()                                                # warm-up (and ActNorm initialisation)
    began = time.perf_counter()
    for _ in range(steps):
        step()
    return steps / (time.perf_counter() - began)


def main(cmu: Path | None, epochs: int, speed_only: bool = False) -> None:
    torch.set_num_threads(2)
    if not speed_only:
        quality(cmu, epochs)
    print("\nTraining speed, batches of 32 windows of 80 frames, 2 CPU threads.\n")
    print("| size | parameters | steps/s |")
    print("|---|---|---|")
    for name, config, steps in [("laptop", GlowConfig(), 20), ("paper (§5.2: L=4, K=32, 512 channels)",
                                                               GlowConfig.paper(), 3)]:
        parameters = sum(p.numel() for p in Glow(config).parameters())
        print(f"| {name} | {parameters:,} | {steps_per_second(config, steps):.2f} |")


def quality(cmu: Path | None, epochs: int) -> None:
    runs = [("synthetic (40 clips of 12 s)", "synthetic", GlowConfig())]
    if cmu is not None and cmu.is_dir():
        runs.append((f"real CMU ({cmu.name}, 1-s windows)", cmu, GlowConfig(window=20)))
    trained = [(name, *train(source, config, epochs)) for name, source, config in runs]

    print(f"Glow, laptop config ({GlowConfig()}), {epochs} epochs, lr 2e-3, conditioned on the control\n")
    print("Test NLL, bits per frame, of the pose given the control (lower is better). Normalised "
          "units are what the model trains on; the data's units (metres, m/s, rad/s) add the "
          "normaliser's log-Jacobian.\n")
    print("| data | train/test clips | training windows x frames | steps | training (s) | train NLL "
          "(normalised) | test NLL (normalised) | N(0, 1) per value (normalised) | test NLL (data units) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, model, prepared, history in trained:
        likelihood_row(name, model, prepared, history)

    print("\nSamples that follow the test windows' control, against the test data itself.\n")
    print("| | foot skating (cm/s) | bone-length drift (%) | leg swing (cm) | diversity, 8 samples of one "
          "control (cm) |")
    print("|---|---|---|---|---|")
    for name, model, prepared, _ in trained:
        sample_rows(name.split(" (")[0], model, prepared)
    print(f"| CMU reference (metrics.CMU_REFERENCE) | {metrics.CMU_REFERENCE['foot skating (cm/s)']:.2f} | "
          f"{metrics.CMU_REFERENCE['bone-length drift (%)']:.3f} | - | - |")


if __name__ == "__main__":
    default = Path(__file__).resolve().parents[1].parent / "shared" / "mocap" / "cmu"
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("cmu", nargs="?", type=Path, default=default)
    parser.add_argument("--epochs", type=int, default=20)
    parser.add_argument("--speed-only", action="store_true", help="print only the training-speed table")
    args = parser.parse_args()
    main(args.cmu, args.epochs, args.speed_only)
