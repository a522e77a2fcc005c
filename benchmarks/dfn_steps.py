"""Where Dynamic Future Net's steps fade: the stepping of its reconstructions and of its samples.

    python benchmarks/dfn_steps.py                                # the shipped DFN, 8 bodies
    python benchmarks/dfn_steps.py --checkpoint runs/dfn.pt --bodies 4

DFN's samples slide their feet more than any other model's (``benchmarks/feet.py``), and
they step less than the data. This finds the stage that loses the steps. Held-out built-in
bodies walk (1.3 m/s) or run (3.2 m/s) along the preset paths; 2.5 s in, when they move
steadily, half a second of each is DFN's prefix, and the next 10 s are the data's rows.
Stepping (``metrics.stepping_by_second``: the legs' stepping speed, second by second) as a
multiple of the data's, for:

* the frame autoencoder (§5.1): the data's frames encoded and decoded;
* the posterior (§5.4): the frames DFN makes from the states it infers from the data,
  ``x^ = MLP(z)`` with ``z`` from ``q(z | x, h, s)``: what its training reconstructs;
* samples from the prior (§6.1): the prefix continued for 10 s at temperatures 1 (notebook
  07's), 0.5 and 0 (the mean path), with their forward speed over the last 5 s.

Then the samples' feet (``metrics.foot_skating``, the data's planted heights) raw and
finished (``contacts.finish``), as a multiple of the data's, beside ``benchmarks/feet.py``'s
DFN rows, which continue a standing prefix instead.

A body kept on the walk or run path for 10 s is not what DFN learned from: its training clips
change activity every 1.5-4 s, so from a run the data itself slows down. The last table of
each path is that reference (``experiments.own_futures``): held-out random clips cut where
they walk (1-1.7 m/s) or run (2.8-4.5 m/s) through a prefix, what each clip did next, and
DFN's samples from the same cuts (``--bodies`` x 5 clips of 40 s).
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from motionlab import checkpoints, comparison, contacts, experiments, metrics, pretrained
from motionlab.models.dfn import DFN
from motionlab.representation import N_POSE, to_positions

FPS = 20.0
START_S, PREFIX, SECONDS = 2.5, 10, 10
TEMPERATURES = (1.0, 0.5, 0.0)
PATHS = ("walk", "run")
DFN_ENTRY = next(entry for entry in comparison.ENTRIES if entry.name == "dfn")
"""Notebook 08's DFN (``comparison.respond``): it continues a prefix, with no control, at τ = 1."""
OWN_SPEED = {"walk": (1.0, 1.7), "run": (2.8, 4.5)}
"""Forward speed (m/s) through the prefix of the cuts of random clips that walk, that run."""


def bodies_in_motion(path: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` held-out bodies on the preset ``path``: the prefix ``(n, PREFIX, 66)`` taken
    :data:`START_S` in (moving steadily) and the next :data:`SECONDS` ``(n, SECONDS * fps + 1, 66)``."""
    control = experiments.walked_preset(path, START_S + (PREFIX + 1) / FPS + SECONDS, FPS)
    walks = experiments.walks(control, FPS, n)
    start = int(START_S * FPS)
    return walks[:, start:start + PREFIX], walks[:, start + PREFIX:start + PREFIX + int(SECONDS * FPS) + 1]


def reconstructions(model: DFN, truth: np.ndarray) -> dict[str, np.ndarray]:
    """The data's frames through the frame autoencoder, and as the posterior's states make
    them (``x^ = MLP(z)``, ``z ~ q``: the frames its training reconstructs), data units."""
    norm = model.normalizer
    x = torch.tensor(norm.normalize(truth), dtype=torch.float32)
    with torch.no_grad():
        frames = model.frames_from_codes(model.codes(x))
        posterior = model.frames_from_codes(model.infer(x, generator=torch.Generator().manual_seed(0))["x_hat"])
    return {name: norm.denormalize(f.double().numpy()) for name, f in
            (("frame autoencoder", frames), ("posterior", posterior))}


def ratio_cells(stepping: np.ndarray, data: np.ndarray) -> str:
    """One cell per second of the data: the ratio, or a dash where ``stepping`` is shorter
    (the posterior's last second: its future summary needs frames past the window's end)."""
    seconds = min(len(stepping), len(data))
    return " | ".join([f"{r:.2f}" for r in stepping[:seconds] / data[:seconds]] + ["—"] * (len(data) - seconds))


def report(model: DFN, n: int) -> dict[str, dict[str, float]]:
    """Print the tables; returns, per path, each row's stepping ratio over the 10 s
    (``"mean"``), the samples' in the first second (``"first second"``), and the data's own
    future beside DFN's (``"own future"``, :func:`own_future`), tested."""
    out = {}
    for path in PATHS:
        prefix, truth = bodies_in_motion(path, n)
        data_steps = metrics.stepping_by_second(truth, FPS).mean(0)
        floor = contacts.planted_heights(to_positions(truth, FPS))
        data_skating = metrics.foot_skating(to_positions(truth, FPS), FPS, rest_height_m=floor)
        print(f"\n### {path}: stepping second by second, / the data's ({n} bodies; the data: "
              + ", ".join(f"{s:.2f}" for s in data_steps) + " m/s)\n")
        print("| frames | " + " | ".join(f"{s + 1} s" for s in range(len(data_steps)))
              + " | forward speed, last 5 s (m/s) |")
        print("|---|" + "---|" * (len(data_steps) + 1))
        last5 = slice(-int(5 * FPS), None)
        print(f"| data | {ratio_cells(data_steps, data_steps)} | {truth[:, last5, N_POSE].mean():.2f} |")
        rows, first, feet = {}, {}, []
        for name, frames in reconstructions(model, truth).items():
            steps = metrics.stepping_by_second(frames, FPS).mean(0)
            rows[name] = float((steps / data_steps[:len(steps)]).mean())
            print(f"| {name} | {ratio_cells(steps, data_steps)} | |")
        for t in TEMPERATURES:
            sample = comparison.respond(replace(DFN_ENTRY, temperature=t), model, truth[0, :, N_POSE:], prefix, n=n)
            steps = metrics.stepping_by_second(sample, FPS).mean(0)
            rows[f"prior, τ = {t:g}"] = float((steps / data_steps[:len(steps)]).mean())
            first[f"prior, τ = {t:g}"] = float(steps[0] / data_steps[0])
            print(f"| prior, τ = {t:g} | {ratio_cells(steps, data_steps)} | {sample[:, last5, N_POSE].mean():.2f} |")
            raw = metrics.foot_skating(to_positions(sample, FPS), FPS, rest_height_m=floor)
            done = contacts.finish(sample, FPS, planted_height_m=floor).positions
            feet.append((t, raw, metrics.foot_skating(done, FPS, rest_height_m=floor)))
        print(f"\nFoot skating, / the data's {100 * data_skating:.1f} cm/s: "
              + "; ".join(f"τ = {t:g}: raw {raw / data_skating:.2f} → finished {done / data_skating:.2f}"
                          for t, raw, done in feet))
        out[path] = {"mean": rows, "first second": first, "own future": own_future(model, path, n)}
    return out


def own_future(model: DFN, path: str, n: int) -> dict[str, np.ndarray]:
    """The data's own future beside DFN's (:func:`experiments.own_futures`): printed as a
    table; returns the data's stepping second by second (m/s) and DFN's as a multiple of it."""
    prefixes, futures = experiments.own_futures(OWN_SPEED[path], PREFIX, SECONDS, FPS, clips=max(4, 5 * n))
    sample = comparison.respond(DFN_ENTRY, model, futures[0, :, N_POSE:], prefixes, n=len(prefixes))
    data_steps = metrics.stepping_by_second(futures, FPS).mean(0)
    steps = metrics.stepping_by_second(sample, FPS).mean(0)
    last5 = slice(-int(5 * FPS), None)
    low, high = OWN_SPEED[path]
    print(f"\nThe data's own future: {len(prefixes)} cuts of held-out random clips moving at {low:g}-{high:g} m/s "
          "through the prefix, and what each clip did next (its activity changes every 1.5-4 s); DFN from the same "
          "cuts, τ = 1:\n")
    print("| frames | " + " | ".join(f"{s + 1} s" for s in range(len(data_steps)))
          + " | forward speed, last 5 s (m/s) |")
    print("|---|" + "---|" * (len(data_steps) + 1))
    print("| the clips' own future, stepping (m/s) | " + " | ".join(f"{v:.2f}" for v in data_steps)
          + f" | {futures[:, last5, N_POSE].mean():.2f} |")
    print(f"| DFN, / the clips' | {ratio_cells(steps, data_steps)} | {sample[:, last5, N_POSE].mean():.2f} |")
    own_positions = to_positions(futures, FPS)
    floor = contacts.planted_heights(own_positions)
    own_skating = metrics.foot_skating(own_positions, FPS, rest_height_m=floor)
    raw = metrics.foot_skating(to_positions(sample, FPS), FPS, rest_height_m=floor) / own_skating
    done = metrics.foot_skating(contacts.finish(sample, FPS, planted_height_m=floor).positions, FPS,
                                rest_height_m=floor) / own_skating
    print(f"\nFoot skating, / the clips' own {100 * own_skating:.1f} cm/s: "
          f"τ = 1: raw {raw:.2f} → finished {done:.2f}")
    return {"data": data_steps, "prior, τ = 1": steps / data_steps, "skating": (raw, done)}


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoint", type=Path, help="a DFN checkpoint (default: the shipped one)")
    parser.add_argument("--bodies", type=int, default=8, help="held-out bodies per path (1 to 64)")
    args = parser.parse_args(argv)
    if not 1 <= args.bodies <= 64:
        parser.error(f"--bodies: expected 1 to 64, got {args.bodies}")
    if args.checkpoint is None:
        model = pretrained.load("dfn")
    else:
        try:
            model = checkpoints.load_checkpoint(args.checkpoint).model
        except (OSError, ValueError) as error:
            parser.error(f"--checkpoint: {error}")
        if not isinstance(model, DFN):
            parser.error(f"--checkpoint: {args.checkpoint} holds a {type(model).__name__}, not a DFN")
    print(f"# Where DFN's steps fade ({args.checkpoint or 'the shipped DFN'})")
    return report(model, args.bodies)


if __name__ == "__main__":
    main(sys.argv[1:])
