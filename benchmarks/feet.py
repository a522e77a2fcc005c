"""Feet that stay planted: every shipped model raw and finished (bones put back to their
lengths, then the feet locked: ``motionlab.contacts``), walking and running.

    python benchmarks/feet.py                              # built-in bodies on the walk and run paths
    python benchmarks/feet.py --data ../shared/mocap/cmu   # also the 4-s windows of real clips
    python benchmarks/feet.py --paths side-step circle     # other preset paths
    python benchmarks/feet.py --data-bones                 # finished on the data's bone lengths
    python benchmarks/feet.py --samples 12 --checkpoint DFN=runs/dfn.pt   # a model of your own, 12 bodies

Section 1. Every model of notebook 08 (``comparison.ENTRIES``) follows the built-in walk
(1.3 m/s) and run (3.2 m/s) presets, as the data's bodies walk them from standing (or ``--paths``:
any of ``synthetic.PRESETS``) for 10 s, from four held-out bodies' standing half-second
(``--samples``: more bodies); the bodies on the same paths are the data's rows.
``--checkpoint LABEL=PATH`` measures a checkpoint of your own in the place of the shipped
model ``LABEL`` (a label of ``comparison.ENTRIES``), and only the models named so. A model without a
control draws freely (the VAE: 4-s windows; DFN continues the standing frames); Glow draws
the path's first 4-s window. The flows are measured at every temperature (and their
notebook's); the others at their notebook's. Per row: foot skating (``metrics.foot_skating``, the data's planted
heights) and its ratio to the data's, GMD's skating ratio (``metrics.skating_ratio``),
stepping and leg swing against the data's, bone drift, the feet's 99th-percentile
acceleration against the larger of the data's and the raw motion's, and for the finished
motion the share of contacts whose lock let go because the leg could not reach. A model with
a contact head is finished holding the contacts it drew as well as the detected ones
(``contacts.finish(..., drawn=...)``).

Section 2. The lock alone (no bone fitting) on the same samples: the bone drift it adds
(target: at most 0.1 % more than the raw motion's) and whether anything above the hips
moved; the contact thresholds; the causal lock's time per frame for one stream.

Section 2b. The causal lock (``contacts.FootLock``, as the live character runs it: each frame
locked with no later frame, contacts detected as it goes) beside the offline lock, on the
bone-fitted samples at each notebook's temperature: skating against the data's and the
feet's 99th-percentile acceleration. For a model with a contact head, also the causal lock
given the contacts the model drew besides the ones it detects (``FootLock.step(...,
drawn=...)``), as the live character runs such a model.

Section 3 (``--data``). notebook 08's table on the folder's 4-s windows: the shipped models
(trained on built-in clips), raw and finished, beside the real data.

Targets (reported, not asserted): finished skating <= 1.5x the data's for every generative
model on both paths; the lock adds no bone drift; stepping and leg swing >= 95 % of the
raw motion's; foot acceleration <= 1.5x the larger of the data's and the raw motion's;
the lock <= 1 ms per frame for one stream.
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from motionlab import comparison, contacts, experiments, metrics, pretrained, recipes, synthetic, training
from motionlab import models as models_module
from motionlab.representation import N_POSE, to_positions

FPS = comparison.FPS
SECONDS = 10.0
PATHS = ("walk", "run")
TEMPERATURES = (0.0, 0.25, 0.5, 0.75, 1.0)
N = 4
MIN_SWING_M = 0.05
"""Below this leg swing of the data's (a side-step's) the swing ratio is not printed."""


def measures(features: np.ndarray, data: np.ndarray, floor: np.ndarray, raw: np.ndarray | None = None) -> dict:
    """The row's figures for ``features`` ``(n, frames, 66)`` against the ``data`` bodies
    (and, for finished motion, against its ``raw`` form)."""
    positions, data_positions = to_positions(features, FPS), to_positions(data, FPS)
    raw_positions = positions if raw is None else to_positions(raw, FPS)
    skating = metrics.foot_skating(positions, FPS, rest_height_m=floor)
    data_swing = metrics.leg_swing(data)           # along the facing direction: about none on a side-step
    return {"skating": 100 * skating,
            "x data": skating / metrics.foot_skating(data_positions, FPS, rest_height_m=floor),
            "GMD": metrics.skating_ratio(positions, FPS, floor),
            "stepping": metrics.stepping_speed(features, FPS, smooth_s=0.1)[:, int(FPS):].mean()
            / metrics.stepping_speed(data, FPS, smooth_s=0.1)[:, int(FPS):].mean(),
            "swing": metrics.leg_swing(features) / data_swing if data_swing > MIN_SWING_M else np.nan,
            "drift": 100 * metrics.bone_length_drift(positions),
            "acc": metrics.foot_acceleration(positions, FPS) / max(metrics.foot_acceleration(data_positions, FPS),
                                                                   metrics.foot_acceleration(raw_positions, FPS))}


def line(label: str, m: dict, reach: float | None = None) -> str:
    swing = "—" if np.isnan(m["swing"]) else f"{m['swing']:.2f}"
    return (f"| {label} | {m['skating']:.1f} | {m['x data']:.2f} | {m['GMD']:.3f} | {m['stepping']:.2f} "
            f"| {swing} | {m['drift']:.2f} | {m['acc']:.2f} | "
            + ("" if reach is None else f"{100 * reach:.0f} %") + " |")


DRAWN = {}
"""``{(label, path, temperature): contacts}``: what a model with a contact head drew for the
samples of section 1 (``Generated.contacts``), for section 2b's causal lock."""


def samples_on(path: str, models: dict, n: int = N) -> tuple[np.ndarray, dict]:
    """``n`` of the data's bodies on a preset path and every model's samples on it, at every
    temperature for the flows: ``(data (n, frames, 66), {(label, temperature): features})``
    (and a contact head's drawn contacts into :data:`DRAWN`)."""
    walks = experiments.preset_walks(path, SECONDS, FPS, n, lead_frames=comparison.PREFIX_FRAMES)
    prefix, truth = walks[:, :comparison.PREFIX_FRAMES], walks[:, comparison.PREFIX_FRAMES:]
    out = {}
    for label, (entry, model) in models.items():
        flow = hasattr(model, "nll")                      # an exact likelihood: Glow and the MoGlows
        temperatures = sorted({*TEMPERATURES, entry.temperature}) if flow else (entry.temperature,)
        control = truth[0, :entry.window or truth.shape[1], N_POSE:]
        for t in temperatures:
            generated = comparison.respond(replace(entry, temperature=t), model, control, prefix, n=n, whole=True)
            out[label, t] = generated.features
            if generated.contacts is not None:
                DRAWN[label, path, t] = generated.contacts
    return truth, out


def section_1(models: dict, paths=PATHS, data_bones: bool = False, n: int = N) -> dict:
    print(f"## 1. Raw and finished (bones fitted, feet locked), on the built-in {' and '.join(paths)} paths "
          f"({SECONDS:g} s, {n} samples; the data: {n} held-out bodies"
          + ("; finished on the data's bone lengths" if data_bones else "") + ")\n")
    print("| model, path, temperature | skating (cm/s) | / data's | GMD ratio | stepping / data | leg swing / data "
          "| bone drift (%) | foot acc. p99 / max(data, raw) | IK out of reach |")
    print("|---|---|---|---|---|---|---|---|---|")
    kept = {}
    for path in paths:
        truth, generated = samples_on(path, models, n)
        floor = contacts.planted_heights(to_positions(truth, FPS))
        body = contacts.body_lengths(to_positions(truth, FPS)) if data_bones else None
        print(line(f"**data**, {path}", measures(truth, truth, floor)))
        for (label, t), features in generated.items():
            data = truth[:, :features.shape[1]]
            done = contacts.finish(features, FPS, planted_height_m=floor, bone_lengths=body,
                                   drawn=DRAWN.get((label, path, t)))
            print(line(f"{label}, {path}, τ = {t:g}", measures(features, data, floor)))
            print(line(f"{label}, {path}, τ = {t:g}, finished", measures(done.features, data, floor, features),
                       done.lock.out_of_reach))
            kept[label, path, t] = (features, floor, truth)
    return kept


def section_2(kept: dict) -> None:
    print("\n## 2. The lock alone (no bone fitting): what it adds to bone drift, and what it moves\n")
    print("| model, path, temperature | bone drift raw (%) | locked (%) | added (%) | joints above the hips moved |")
    print("|---|---|---|---|---|")
    above = [j for j in range(21) if j not in {k for leg in contacts.LEGS for k in leg[1:]}]
    for (label, path, t), (features, floor, _) in kept.items():
        positions = to_positions(features, FPS)
        locked = contacts.lock_feet(positions, FPS, planted_height_m=floor)
        raw, new = (100 * metrics.bone_length_drift(p) for p in (positions, locked))
        moved = int((np.abs(locked[..., above, :] - positions[..., above, :]) > 0).any(axis=(0, 1, 3)).sum())
        print(f"| {label}, {path}, τ = {t:g} | {raw:.3f} | {new:.3f} | {new - raw:+.4f} | {moved} |")
    print(f"\nthresholds: contact within {', '.join(f'{100 * h:g}' for h in contacts.CONTACT_HEIGHT_M[:2])} cm "
          f"(ankle, toe) of the planted height, slower than {contacts.CONTACT_SPEED_MS:g} m/s or "
          f"{contacts.BODY_FRACTION:g} x the hips' speed; released above "
          f"{contacts.RELEASE:g} x either; blend in {contacts.BLEND_S:g} s, out {contacts.RELEASE_S:g} s; "
          f"a low foot slowed into its landing spot over the last {contacts.APPROACH_S:g} s (offline; the causal "
          f"lock guesses the spot, contacts.LANDING_GUESS = {contacts.LANDING_GUESS:g})")
    features, floor, _ = next(iter(kept.values()))
    frames = to_positions(features[:1], FPS)[0]
    lock = contacts.FootLock(FPS, planted_height_m=floor)
    times = []
    for _ in range(3):
        lock.reset()
        began = time.perf_counter()
        for frame in frames:
            lock.step(frame)
        times.append((time.perf_counter() - began) / len(frames))
    print(f"the causal lock (contacts detected as it goes), one stream: {1000 * min(times):.3f} ms per frame "
          f"(best of 3 runs of {len(frames)} frames)")


def section_2b(kept: dict, models: dict) -> None:
    print("\n## 2b. The causal lock, as the live character uses it: bones fitted, then contacts detected and feet "
          "locked frame by frame, with no later frame (`contacts.FootLock`), at each notebook's temperature\n")
    print("| model, path, temperature | skating / data's: raw | finished (offline lock) | causal lock "
          "| causal, given the contacts the model drew too | foot acc. p99 / max(data, raw): offline | causal | "
          "causal, given them |")
    print("|---|---|---|---|---|---|---|---|")
    for (label, path, t), (features, floor, truth) in kept.items():
        if t != models[label][0].temperature:
            continue
        raw, data = to_positions(features, FPS), to_positions(truth[:, :features.shape[1]], FPS)
        fitted = contacts.fit_bones(raw)
        lock = contacts.FootLock(FPS, batch=len(fitted), planted_height_m=floor)
        streamed = np.stack([lock.step(fitted[:, frame]) for frame in range(fitted.shape[1])], axis=1)
        drawn = DRAWN.get((label, path, t))
        offline = contacts.lock(fitted, FPS, planted_height_m=floor, drawn=drawn).positions      # section 1's
        if drawn is not None:                 # as the live character locks a contact head's motion
            lock.reset()
            given = np.stack([lock.step(fitted[:, frame], drawn=drawn[:, frame]) for frame in range(fitted.shape[1])],
                             axis=1)
        reference = metrics.foot_skating(data, FPS, rest_height_m=floor)
        larger = max(metrics.foot_acceleration(data, FPS), metrics.foot_acceleration(raw, FPS))
        shown = (raw, offline, streamed) + (() if drawn is None else (given,))
        skate = [metrics.foot_skating(p, FPS, rest_height_m=floor) / reference for p in shown]
        acceleration = [metrics.foot_acceleration(p, FPS) / larger for p in shown[1:]]
        with_drawn = ("—", "—") if drawn is None else (f"{skate[3]:.2f}", f"{acceleration[2]:.2f}")
        print(f"| {label}, {path}, τ = {t:g} | {skate[0]:.2f} | {skate[1]:.2f} | {skate[2]:.2f} | {with_drawn[0]} "
              f"| {acceleration[0]:.2f} | {acceleration[1]:.2f} | {with_drawn[1]} |")


def section_3(models: dict, folder: str) -> None:
    windows = comparison.evaluation_windows(folder)
    print(f"\n## 3. The shipped models on {len(windows)} 4-s windows of {folder} (trained on built-in clips)\n")
    rows = comparison.table_rows(models, windows)
    print("| rows | stepping (m/s) | leg swing (cm) | foot skating (cm/s) | / data's | GMD ratio | bone drift (%) "
          "| foot acc. p99 (m/s²) | IK out of reach |")
    print("|---|---|---|---|---|---|---|---|---|")
    data = rows["data"]["foot skating (cm/s)"]
    for label, r in rows.items():
        reach = f"{100 * r['out of reach']:.0f} %" if "out of reach" in r else ""
        print(f"| {label} | {r['stepping (m/s)']:.2f} | {r['leg swing (cm)']:.1f} | {r['foot skating (cm/s)']:.1f} "
              f"| {r['foot skating (cm/s)'] / data:.2f} | {r['skating ratio']:.3f} | {r['bone drift (%)']:.2f} "
              f"| {r['foot acceleration (m/s²)']:.0f} | {reach} |")


def own_models(parser: argparse.ArgumentParser, pairs: list[str]) -> dict:
    """``{label: (entry, model)}`` for ``--checkpoint LABEL=PATH`` arguments."""
    entries = {e.label: e for e in comparison.ENTRIES}
    models = {}
    for pair in pairs:
        label, _, path = pair.partition("=")
        if label not in entries or not path:
            parser.error(f"--checkpoint: expected LABEL=PATH with LABEL one of {', '.join(entries)}, got {pair!r}")
        name = recipes.recipe(entries[label].name).model
        kind = models_module.card(name).model
        model = training.load_checkpoint(path).model
        if not isinstance(model, kind):
            parser.error(f"--checkpoint: {path} holds a {type(model).__name__}, not the {kind.__name__} of {label}")
        if name == "vae":                  # the feature VAE with the conv AE that decodes its features
            model = pretrained.load_motion_vae(path)
        models[label] = (entries[label], model)
    return models


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default=None, help="a folder of .bvh / .amc files for section 3")
    parser.add_argument("--paths", nargs="+", default=PATHS, choices=synthetic.PRESETS, metavar="PATH",
                        help=f"preset paths for section 1 (default: {' '.join(PATHS)}; any of "
                             f"{', '.join(synthetic.PRESETS)})")
    parser.add_argument("--data-bones", action="store_true",
                        help="finish every sample on the data's bone lengths (contacts.body_lengths of the "
                             "data's bodies) instead of its own median ones")
    parser.add_argument("--samples", type=int, default=N, metavar="N",
                        help=f"bodies per path in section 1, 1 to 64 (default: {N})")
    parser.add_argument("--checkpoint", action="append", default=[], metavar="LABEL=PATH",
                        help="measure the checkpoint PATH in the place of the shipped model LABEL "
                             f"({', '.join(e.label for e in comparison.ENTRIES)}); repeat for several. "
                             "Only the models named are measured")
    args = parser.parse_args(argv)
    if not 1 <= args.samples <= 64:
        parser.error(f"--samples: expected 1 to 64, got {args.samples}")
    # the checkpoints named (checked before anything loads), or every shipped model
    models = own_models(parser, args.checkpoint) if args.checkpoint else comparison.load_models()
    kept = section_1(models, args.paths, args.data_bones, args.samples)
    section_2(kept)
    section_2b(kept, models)
    if args.data:
        section_3(models, args.data)


if __name__ == "__main__":
    main()
