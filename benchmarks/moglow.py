"""MoGlow quality: test likelihood, and the findings of §4.2 and §5.3, on synthetic and real data.

    python benchmarks/moglow.py [cmu_folder] [--epochs 60] [--retrain]

For each data set (the built-in synthetic data; real CMU clips when the folder exists,
default ../shared/mocap/cmu) four laptop-size models (`MoGlowConfig()` with their
recipes' changes: bones as lengths and directions, `motionlab.recipes`) are trained, or
on synthetic data (200 built-in clips, as notebook 06 and `make checkpoints`) loaded from
`motionlab/checkpoints/` when they fit: MoGlow with history dropout 0.95, the same without
dropout, and the Markov variant (feed-forward couplings) at the same width and widened to
the same number of weights ("Markov, wide").
It prints

1. test NLL in bits per predicted frame (normalised units and metres);
2. control following (§5.3): stepping speed (m/s, ankles smoothed over 0.1 s, last 2 of 4
   s) when the control says stand still and when it says walk, from real walking starts;
3. long samples (§5.3): pose spread (cm) over the first and last 5 s of a 20-s sample;
4. foot skating (cm/s) of 4-s walks in the world, beside the test data's.

Steering along the preset paths, second by second, is in `benchmarks/quality.py`.

CMU trials are short, so real data uses 1-s windows (10 predicted frames after τ = 10).
"""
from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from motionlab import data, metrics, pretrained, synthetic
from motionlab import representation as rep
from motionlab.experiments import control_following, long_sample_spread
from motionlab.models.moglow import MoGlow, MoGlowConfig

ROOT = Path(__file__).resolve().parents[1]
TEMPERATURE = 0.3


def models_for(prepared, config: MoGlowConfig, epochs: int, tag: str, retrain: bool) -> dict[str, MoGlow]:
    labels = {f"dropout {config.dropout:g}": "dropout", "no dropout": "no_dropout", "Markov": "markov",
              "Markov, wide": "markov_matched"}
    models = {}
    for label, variant in labels.items():
        model, history = pretrained.moglow_or_train(prepared, variant, config, epochs, retrain=retrain,
                                                  cache=ROOT / "data" / "cache" / f"moglow_{tag}_{variant}.pt")
        print(f"  {label:12} {len(history.train)} steps, {history.seconds:.0f} s of training")
        models[label] = model
    return models


def report(name: str, prepared, config: MoGlowConfig, epochs: int, retrain: bool) -> None:
    print(f"\n## {name}: {prepared.summary().splitlines()[0]}")
    models = models_for(prepared, config, epochs, name.split()[0].lower(), retrain)
    normalizer, test = prepared.normalizer, prepared.test.windows
    features = normalizer.denormalize(test.numpy())
    walking = np.flatnonzero(features[:, :config.history, 63].mean(axis=1) > 1.0)[:8]
    start = features[walking, :config.history]
    long_path = synthetic.walked_control(synthetic.random_control(20.0, config.fps, rng=3), config.fps)
    walk = synthetic.walked_control(synthetic.preset_control("walk", 4.0, config.fps, ramp_s=0.01), config.fps)
    data_world = np.stack([rep.to_positions(w, config.fps) for w in features])
    print(f"\n{'model':14}{'NLL bits/frame':>16}{'(metres)':>10}{'stepping m/s:':>15}{'still':>7}{'walk':>7}"
          f"{'spread cm:':>12}{'0-5 s':>7}{'15-20 s':>8}{'skating cm/s':>14}")
    for label, model in models.items():
        nll, nll_m = model.nll(test)["bits/frame"], model.nll(test, normalizer)["bits/frame"]
        row = f"{label:14}{nll:16.1f}{nll_m:10.0f}"
        if model.config.recurrent and len(start):
            following = control_following(model, start, temperature=TEMPERATURE)
            spread = long_sample_spread(model, start[:4], long_path, temperature=TEMPERATURE)
            walks = model.generate(walk, prefix=start, n=len(start), temperature=TEMPERATURE)
            skating = 100 * metrics.foot_skating(walks.positions, config.fps)
            row += (f"{'':15}{following['stand still']:7.2f}{following['walk']:7.2f}{'':12}"
                    f"{100 * spread['first']:7.1f}{100 * spread['last']:8.1f}{skating:14.2f}")
        print(row)
    if len(walking):
        print(f"{'test data':14}{'':26}{'':15}{'':7}"
              f"{metrics.stepping_speed(features[walking], config.fps, smooth_s=0.1).mean():7.2f}{'':12}"
              f"{100 * metrics.pose_spread(features[walking]).mean():7.1f}{'':8}"
              f"{100 * metrics.foot_skating(data_world, config.fps):14.2f}")
    else:
        print("(no test window starts at walking speed: no control-following measures)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cmu", nargs="?", default=str(ROOT.parent / "shared" / "mocap" / "cmu"))
    parser.add_argument("--epochs", type=int, default=60)
    parser.add_argument("--retrain", action="store_true", help="ignore shipped and cached checkpoints")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    config = MoGlowConfig()
    clips = data.load("synthetic", fps=config.fps, n_clips=200)
    report("Synthetic data", data.prepare(clips, window_s=config.window / config.fps), config, args.epochs,
           args.retrain)
    if Path(args.cmu).is_dir():
        real = replace(config, window=20)
        clips = data.load(args.cmu, fps=real.fps)
        report("CMU motion capture", data.prepare(clips, window_s=real.window / real.fps), real, args.epochs,
               args.retrain)
    else:
        print(f"\n(no CMU folder at {args.cmu}: real-data rows skipped)")


if __name__ == "__main__":
    main()
