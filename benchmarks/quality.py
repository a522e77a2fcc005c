"""Quality of the shipped models, one row per model, the data's own row first.

    python benchmarks/quality.py

Every model is loaded with ``motionlab.pretrained.load`` and measured on built-in clips
that no shipped model was trained on (``experiments.held_out_windows``, seeds from
10,000), with the measures of ``motionlab.metrics`` and the claim checks of
``motionlab.claims`` (targets fixed there). Rows for trivial baselines (the mean pose moved
along the true path, a constant pose) show what failing looks like. A model whose
checkpoint is missing is listed as such; ``make checkpoints`` makes them all.

Tables: (1) motion like the data: stepping, leg swing, ankle height, foot skating, bone
drift; (2) the conv autoencoder against trivial reconstructions; (3) the VAE's latent
axes; (4) the VAE-LSTM steered for 10 s at walking and running speed, second by second.
"""
from __future__ import annotations

import numpy as np
import torch

from motionlab import claims, experiments, metrics, pretrained
from motionlab.models.vae import axis_effects
from motionlab.representation import to_positions

FPS = 20.0
WINDOW = 80                                   # 4-s windows, the notebooks' default
STEER_S = 10.0


def report_row(name: str, features: np.ndarray, rest) -> None:
    r = metrics.locomotion_report(features, FPS, rest)
    print(f"| {name} | {r['stepping (m/s)']:.2f} | {100 * r['leg swing (m)']:.1f} | {100 * r['ankle height (m)']:.1f} "
          f"| {100 * r['foot skating (m/s)']:.2f} | {100 * r['bone drift']:.2f} |")


def load(name: str):
    if name not in pretrained.available():
        print(f"| {name} | not shipped (`make checkpoints`) | | | | |")
        return None
    return pretrained.load(name)


def verdict_line(verdict) -> str:
    return "holds" if verdict else "fails: " + "; ".join(verdict.failures)


def main() -> None:
    truth = experiments.held_out_windows(WINDOW, FPS)
    rest = metrics.foot_rest_heights(to_positions(truth, FPS))
    print(f"held-out built-in data: {len(truth)} windows of {WINDOW} frames at {FPS:g} fps\n")

    print("## 1. Motion like the data (4-s windows; models generate 64)\n")
    print("| rows | stepping (m/s) | leg swing (cm) | ankle height above planted (cm) | foot skating (cm/s) "
          "| bone drift (%) |")
    print("|---|---|---|---|---|---|")
    report_row("data (held-out windows)", truth, rest)
    mean = truth.reshape(-1, truth.shape[-1]).mean(0)
    report_row("baseline: mean pose on the true path", experiments.mean_pose_on_path(truth, mean), rest)
    report_row("baseline: constant pose", experiments.constant_pose(truth), rest)
    vae = load("vae")
    samples = None
    if vae is not None:
        samples = vae.generate(n=64, seed=0).features
        report_row("Motegi VAE, samples from the prior", samples, rest)
    vae_lstm = load("vae_lstm")
    if vae_lstm is not None:
        steered = vae_lstm.generate(truth[..., metrics.N_POSE:], n=len(truth), seed=0).features
        report_row("Habibie VAE-LSTM, given the held-out control", steered, rest)

    print("\n## 2. Conv autoencoder against trivial reconstructions (held-out windows)\n")
    conv_ae = load("conv_ae")
    if conv_ae is not None:
        norm = conv_ae.normalizer
        windows = truth[:, :conv_ae.config.window]
        with torch.no_grad():
            rebuilt = norm.denormalize(conv_ae.project(torch.tensor(norm.normalize(windows), dtype=torch.float32))
                                       .double().numpy())
        errors = {"conv AE": tuple(metrics.window_errors(rebuilt, windows, FPS).values())}
        for name, trivial in experiments.trivial_reconstructions(windows, norm.mean).items():
            errors[name] = tuple(metrics.window_errors(trivial, windows, FPS).values())
        print("| reconstruction | pose error (cm) | motion error (cm) |\n|---|---|---|")
        for name, (pose, motion) in errors.items():
            print(f"| {name} | {100 * pose:.2f} | {100 * motion:.2f} |")
        print(f"\nclaim: {verdict_line(claims.beats_trivial_reconstructions(errors, 'conv AE'))}")

    if vae is not None:
        print("\n## 3. Motegi VAE: samples and latent axes\n")
        print(f"samples move like the data: {verdict_line(claims.moves_like_data(samples, truth[:, :samples.shape[1]], FPS))}")
        effects = axis_effects(vae.decode, vae.vae.config.latent, metrics.describe_motion, n_bases=16,
                               low=0.05, high=0.95)
        spread = {name: float(v.std()) for name, v in metrics.describe_motion(truth[:, :samples.shape[1]]).items()}
        verdict = claims.axes_control_parts(effects, spread)
        print(verdict)

    if vae_lstm is not None:
        print(f"\n## 4. Habibie VAE-LSTM steered for {STEER_S:g} s (4 samples, walked preset paths)\n")
        print("| path | data stepping (m/s) | stepping / data, second by second | leg swing / data | claim |")
        print("|---|---|---|---|---|")
        for preset in ("walk", "run"):
            reference, swing = experiments.data_stepping(preset, STEER_S, FPS)
            motion = vae_lstm.generate(experiments.walked_preset(preset, STEER_S, FPS), n=4, seed=0).features
            verdict = claims.steps_steadily(motion, reference, swing, FPS, name=preset)
            ratios = metrics.stepping_by_second(motion, FPS).mean(0) / reference
            print(f"| {preset} | {reference.mean():.2f} | {' '.join(f'{r:.2f}' for r in ratios)} "
                  f"| {metrics.leg_swing(motion) / swing:.2f} | {verdict_line(verdict)} |")


if __name__ == "__main__":
    main()
