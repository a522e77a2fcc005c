"""MoGlow and Glow with their feet anchored where they were planted (``foot_anchor``,
:mod:`motionlab.models.anchor`) against the shipped models: the likelihood, the feet, the
bones and the claims.

    python -m motionlab.recipes moglow_foot_anchor --folder data/cache  # the shipped one: legs anchored, m seen
    python -m motionlab.train moglow --synthetic-clips 200 --epochs 60 --lr 3e-3 --batch-size 32 --half \\
        --set foot_anchor=true --out data/cache/moglow_feet_only.pt      # the first design: the feet alone
    python -m motionlab.train glow --synthetic-clips 200 --stride 1.0 --epochs 20 --lr 2e-3 --batch-size 32 \\
        --half --set foot_anchor=true leg_anchor=true --out data/cache/glow_foot_anchor.pt  # Glow's recipe, anchored
    python benchmarks/foot_anchor.py data/cache/moglow_foot_anchor.pt data/cache/glow_foot_anchor.pt

``foot_anchor`` makes the flow model each ankle's (and, without ``leg_anchor``, toe's) ``x, z``
less where it would be had it stayed planted since the previous frame: a shift by a function
of the conditioning, so the likelihood stays exact (log-determinant 0); ``leg_anchor`` models
the toes less their ankles and the knees less the midpoint of hip and ankle, in the same
frame (still log-determinant 0). For the shipped MoGlow (history dropout
0.95) and each checkpoint given: the test NLL (bits per predicted frame on the held-out
built-in windows, as notebook 08's table); along the walk and run presets for 10 s
(4 samples; the data's four bodies beside) at temperatures 0, 0.3 and 1: foot skating raw
and finished (``contacts.finish``), against the data's, bone drift (feet held in place by
legs that stretch skate little: read the two together) and stepping from the 2nd second
against the data's; and the §5.3 claims at the notebook's temperature 0.3: it follows the
control (walks when told, stops when told: ``claims.follows_control``) and a 30-s sample
along the circle keeps moving (``claims.keeps_moving``).

A Glow checkpoint is set beside the shipped Glow: the test NLL; the first 4-s window of
each path (Glow draws whole windows) at temperatures 0, 0.5 (notebook 05's) and 1, raw and
finished, with the mean bone drift and the most-stretched bone's; and notebook 05's claim,
``claims.moves_like_data`` on the held-out windows at each temperature.
"""
from __future__ import annotations

import argparse


import numpy as np

from motionlab import claims, comparison, contacts, experiments, metrics, pretrained, training
from motionlab.models.glow import Glow
from motionlab.representation import N_POSE, to_positions
from motionlab.skeleton import LOCOMOTION

FPS = 20.0
STEER_S, LONG_S = 10.0, 30.0
TEMPERATURES = (0.0, 0.3, 1.0)
GLOW_TEMPERATURES = (0.0, 0.5, 1.0)
SECONDS_GLOW, N = 4.0, 4


def verdict_line(verdict) -> str:
    return "holds" if verdict else "fails: " + "; ".join(verdict.failures)


def worst_bone(positions: np.ndarray) -> tuple[str, float]:
    """The bone whose length changes most over time (``std / mean``, averaged over samples)."""
    lengths = LOCOMOTION.bone_lengths(positions)
    drift = (lengths.std(axis=-2) / lengths.mean(axis=-2)).reshape(-1, lengths.shape[-1]).mean(0)
    child = LOCOMOTION.bones[int(drift.argmax())][1]
    return LOCOMOTION.names[child], float(drift.max())


def header(label: str, model, last: str) -> None:
    """The model's test NLL, then the head of its feet table (``last``: the final column)."""
    nll, _ = comparison.held_out_nll(model, experiments.held_out_windows(comparison.TEST_WINDOW, FPS))
    print(f"\n### {label} (foot_anchor={model.config.foot_anchor}): test NLL {nll:.1f} bits/frame\n")
    print("| path, temperature | skating raw (cm/s) | finished (cm/s) | data's (cm/s) | raw / data | finished / data "
          f"| bone drift raw (%) | most-stretched bone: the joint it ends in, % | {last} |")
    print("|---|---|---|---|---|---|---|---|---|")


def feet_row(path: str, t: float, samples: np.ndarray, data: np.ndarray, last: str) -> None:
    """One row: ``samples``' feet raw and finished against the ``data`` bodies, and their bones."""
    positions, data_positions = to_positions(samples, FPS), to_positions(data, FPS)
    floor = contacts.planted_heights(data_positions)
    raw = metrics.foot_skating(positions, FPS, rest_height_m=floor)
    finished = metrics.foot_skating(contacts.finish(samples, FPS, planted_height_m=floor).positions, FPS,
                                    rest_height_m=floor)
    reference = metrics.foot_skating(data_positions, FPS, rest_height_m=floor)
    bone, stretch = worst_bone(positions)
    print(f"| {path}, τ = {t:g} | {100 * raw:.1f} | {100 * finished:.1f} | {100 * reference:.1f} "
          f"| {raw / reference:.1f} | {finished / reference:.2f} | {100 * metrics.bone_length_drift(positions):.1f} "
          f"| {bone} {100 * stretch:.0f} | {last} |")


def report(label: str, model) -> None:
    header(label, model, "stepping / data, seconds 2-10")
    reports = {}
    for path in ("walk", "run"):
        for t in TEMPERATURES:
            r = reports[path, t] = experiments.steering_report(model, path, STEER_S, temperature=t)
            ratios = r["stepping"][1:] / r["data stepping"][1:]
            feet_row(path, t, r["samples"], r["data"], f"{ratios.min():.2f}-{ratios.max():.2f}")
    walk = reports["walk", 0.3]
    stop = experiments.steering_report(model, "walk, then stop", STEER_S, temperature=0.3)
    follows = claims.follows_control(walk["samples"], walk["data stepping"], stop["samples"], stop["control"], FPS,
                                     name=label)
    samples, walks = experiments.steer(model, "circle", LONG_S, temperature=0.3)
    moving = claims.keeps_moving(samples, walks, FPS, name=label)
    print(f"\n§5.3 at τ = 0.3: follows the control: {verdict_line(follows)}; a {LONG_S:g}-s sample keeps moving: "
          f"{verdict_line(moving)}")


def report_glow(label: str, model) -> None:
    header(label, model, "stepping, leg swing / data")
    window = next(e for e in comparison.ENTRIES if e.name == "glow").window
    for path in ("walk", "run"):
        walks = experiments.preset_walks(path, SECONDS_GLOW, FPS, N, lead_frames=comparison.PREFIX_FRAMES)
        truth = walks[:, comparison.PREFIX_FRAMES:][:, :window]
        for t in GLOW_TEMPERATURES:
            samples = model.generate(truth[0, :, N_POSE:], n=N, temperature=t).features
            stepping = metrics.stepping_speed(samples, FPS).mean() / metrics.stepping_speed(truth, FPS).mean()
            swing = metrics.leg_swing(samples) / metrics.leg_swing(truth)
            feet_row(path, t, samples, truth, f"{stepping:.2f}, {swing:.2f}")
    sweep = experiments.temperature_sweep(model, experiments.held_out_windows(model.config.window, FPS),
                                          GLOW_TEMPERATURES)
    print("\nnotebook 05's claim (moves like the data, held-out windows): "
          + "; ".join(f"τ = {t:g}: {verdict_line(v)}" for t, v in sweep.items()))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoints", nargs="*",
                        help="MoGlow or Glow checkpoints to compare (e.g. trained with foot_anchor)")
    args = parser.parse_args(argv)
    models = {path: training.load_checkpoint(path).model.eval() for path in args.checkpoints}
    glows = [path for path, model in models.items() if isinstance(model, Glow)]
    if (len(glows) < len(models) or not models) and "moglow" in pretrained.available():
        report("shipped MoGlow", pretrained.load("moglow"))
    if glows and "glow" in pretrained.available():
        report_glow("shipped Glow", pretrained.load("glow"))
    for path, model in models.items():
        (report_glow if isinstance(model, Glow) else report)(path, model)


if __name__ == "__main__":
    main()
