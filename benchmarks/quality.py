"""Quality of the shipped models, one row per model, the data's own row first.

    python benchmarks/quality.py                         # the shipped checkpoints
    python benchmarks/quality.py --data data/cache/cmu   # real clips (trains first: ~3 min)

Built-in data (the default): every model is loaded with ``motionlab.pretrained.load`` and
measured on built-in clips that no shipped model was trained on
(``experiments.held_out_windows``, seeds from 10,000). A model whose checkpoint is missing
is listed as such; ``make checkpoints`` makes them all.

A folder of motion capture (``--data``): the same recipes as ``make checkpoints`` (the
command line, ``python -m motionlab.train``), each for as many training steps as the
shipped model took, train each model on the folder's training clips, with 1-s windows as
the notebooks use for CMU's short trials, cached in
``data/cache/quality/`` (each file named by its command line, so that a recipe changed since
trains again); they are measured on the folder's test clips. On real data the
targets are reported, not required.

Both use the measures of ``motionlab.metrics`` and the claim checks of ``motionlab.claims``
(targets fixed there). Rows for trivial baselines (the mean pose moved along the true path,
a constant pose) show what failing looks like. Tables: (1) motion like the data: stepping,
leg swing, ankle height, foot skating, bone drift, each generative model raw and "with feet
locked" (bones put back to their lengths, feet locked: ``motionlab.contacts.finish``;
``benchmarks/feet.py`` has every measure of it); (2) the conv autoencoder against trivial
reconstructions; (3) the VAE's samples and latent axes; (4) the VAE-LSTM steered, second by
second (built-in: 10 s along walked paths at walking and running speed; real data: each
test clip of 3 s or more, by its own control); (5) MoGlow steered along the preset paths
for 10 s from standing, the data's bodies on the same paths beside it, its §5.3 claim for
the models with and without history dropout, and a 30-s sample's pose spread and
diversity (built-in data only); (4b) Glow, given each held-out window's control, at five
temperatures, against the targets of motion like the data (built-in data only); (6) DFN's 30-s futures from held-out prefixes against its
training data: the §6.3 claim (diversity that grows to the data's band, the data's share of
running, no freezing) and bone drift with the §5.1 rotation decoder (built-in data only);
(7) every shipped model side by side, notebook 08's table from the same functions
(``motionlab.comparison``), and stepping at commanded speeds (built-in bodies and paths); with
``--data`` the table shows the *shipped* models (trained on built-in clips) on 4-s windows of
the folder's clips, as notebook 08 does with ``MOTIONLAB_DATA`` set.
"""
from __future__ import annotations

import argparse
import hashlib
from pathlib import Path

import numpy as np
import torch

from motionlab import claims, comparison, contacts, data, experiments, metrics, pretrained, recipes, training
from motionlab import train as cli
from motionlab.models.vae import axis_effects
from motionlab.representation import to_positions

FPS = 20.0
WINDOW = 80                                   # 4-s windows on built-in data, the notebooks' default
REAL_WINDOW = 20                              # 1-s windows on real clips (most CMU trials are short)
STEER_S = 10.0
LONG_S = 30.0
TEMPERATURE = 0.3                             # MoGlow's sampling temperature, notebook 06's
MOGLOW_PRESETS = ("walk", "run", "circle", "side-step", "backwards", "stand still", "walk, then stop")
# MoGlow targets (steered along the presets, 10 s): stepping within ±20 % of the data's in
# every second from the 2nd, leg swing >= 80 %, skating <= 2x the data's, bone drift <= 2 %,
# a 30-s sample's late pose spread >= 70 % of the data's.
MOGLOW_TARGETS = {"stepping": 0.2, "leg swing": 0.8, "skating": 2.0, "bone drift": 0.02, "spread": 0.7}
REAL_STEER_S = 3.0
DFN_PREFIXES, DFN_SAMPLES, DFN_PREFIX_FRAMES = 8, 16, 10    # 8 held-out prefixes of 0.5 s, 16 samples each

SYNTHETIC_ONLY = ("--synthetic-clips", "--stride", "--epochs", "--conv-ae")
"""Options of a recipe (each with one value) that say how to use the built-in data; on real
clips ``trained_on`` gives its own stride, budget and conv AE."""


def on_real_clips(name: str) -> tuple[list[str], int]:
    """The ``make checkpoints`` recipe ``name`` (:data:`motionlab.recipes.RECIPES`) for real
    clips: its options without :data:`SYNTHETIC_ONLY` and ``--half``, ``window=REAL_WINDOW``
    added to its ``--set`` for the models that cut windows themselves; and its epochs."""
    options = list(recipes.RECIPES[name].options)
    kept, k = [], 0
    while k < len(options):
        if options[k] in SYNTHETIC_ONLY:
            k += 2                                          # the option and its value
        else:
            kept += [] if options[k] == "--half" else [options[k]]
            k += 1
    if name != "vae":                                       # the VAE's window is its conv AE's
        kept.insert(kept.index("--set") + 1, f"window={REAL_WINDOW}")
    return kept, int(options[options.index("--epochs") + 1])


def report_row(name: str, features: np.ndarray, rest, finished: bool = False) -> None:
    """One row of table 1; with ``finished`` a second row for the same motion with its bones
    put back to their lengths and its feet locked (``contacts.finish``)."""
    r = metrics.locomotion_report(features, FPS, rest)
    print(f"| {name} | {r['stepping (m/s)']:.2f} | {100 * r['leg swing (m)']:.1f} | {100 * r['ankle height (m)']:.1f} "
          f"| {100 * r['foot skating (m/s)']:.2f} | {100 * r['bone drift']:.2f} |")
    if finished:
        report_row(f"{name}, with feet locked", contacts.finish(features, FPS, planted_height_m=rest).features, rest)


def verdict_line(verdict) -> str:
    return "holds" if verdict else "fails: " + "; ".join(verdict.failures)


def shipped() -> tuple[dict, np.ndarray, dict]:
    """The shipped models and the held-out built-in windows."""
    models = {}
    for name in ("conv_ae", "vae", "vae_lstm", "glow", "moglow", "moglow_no_dropout", "dfn"):
        if name in pretrained.available():
            models[name] = pretrained.load(name)
        else:
            print(f"{name}: not shipped (`make checkpoints` makes it)")
    presets = {}
    if "vae_lstm" in models:
        for preset in ("walk", "run"):
            reference, swing = experiments.data_stepping(preset, STEER_S, FPS)
            presets[preset] = (experiments.walked_preset(preset, STEER_S, FPS), reference, swing)
    return models, experiments.held_out_windows(WINDOW, FPS), presets


def trained_on(folder: str) -> tuple[dict, np.ndarray, dict]:
    """Models trained on ``folder`` by the shipped recipes (cached), its test windows and the
    test clips to steer by."""
    cache = pretrained.CACHE / "quality" / Path(folder).resolve().name
    cache.mkdir(parents=True, exist_ok=True)
    common = ["--data", folder, "--half"]
    paths = {}
    for name in ("conv_ae", "vae", "vae_lstm"):
        options, epochs = on_real_clips(name)
        stride = ["--stride", "0.25"] if name != "vae_lstm" else []         # Motegi's models: a window every 0.25 s
        features = ["--conv-ae", str(paths["conv_ae"])] if name == "vae" else []
        argv = [name, *common, *features, *stride, *options]
        # the file is named by its command, so a recipe changed since is trained again
        paths[name] = path = cache / f"{name}-{hashlib.sha1(' '.join(argv).encode()).hexdigest()[:10]}.pt"
        if not path.exists():
            shipped_steps = len(training.load_checkpoint(pretrained.path(name)).history.train) \
                if name in pretrained.available() else None
            budget = ["--max-steps", str(shipped_steps)] if shipped_steps else ["--epochs", str(epochs)]
            print(f"training: python -m motionlab.train {' '.join(argv + budget)}")
            cli.main([*argv, *budget, "--out", str(path)])
    conv_ae, vae, vae_lstm = paths["conv_ae"], paths["vae"], paths["vae_lstm"]
    models = {"conv_ae": training.load_checkpoint(conv_ae).model, "vae": pretrained.load_motion_vae(vae),
              "vae_lstm": training.load_checkpoint(vae_lstm).model}         # in eval mode, normaliser kept
    clips = data.load(folder, fps=FPS)
    prepared = data.prepare(clips, window_s=REAL_WINDOW / FPS, stride_s=0.25)
    test = prepared.in_data_units(prepared.test.windows)
    steer = {}
    frames = int(REAL_STEER_S * FPS) + 1
    for clip in clips:
        if clip.name in prepared.description["clips"]["test"] and len(clip.features()) >= frames:
            features = clip.features()[:frames]
            swing = metrics.leg_swing(features[None])
            steer[clip.name] = (features[:, metrics.N_POSE:], metrics.stepping_by_second(features[None], FPS)[0],
                                swing)
    return models, test, steer


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default="synthetic",
                        help="'synthetic' (the shipped checkpoints) or a folder of .bvh / .amc files")
    args = parser.parse_args(argv)
    real = args.data != "synthetic"
    models, truth, steer = trained_on(args.data) if real else shipped()
    rest = metrics.foot_rest_heights(to_positions(truth, FPS))
    where = f"test clips of {args.data}" if real else "held-out built-in data"
    print(f"{where}: {len(truth)} windows of {truth.shape[1]} frames at {FPS:g} fps\n")

    print("## 1. Motion like the data (models generate 64 windows)\n")
    print("| rows | stepping (m/s) | leg swing (cm) | ankle height above planted (cm) | foot skating (cm/s) "
          "| bone drift (%) |")
    print("|---|---|---|---|---|---|")
    report_row("data (" + ("test windows" if real else "held-out windows") + ")", truth, rest)
    mean = truth.reshape(-1, truth.shape[-1]).mean(0)
    report_row("baseline: mean pose on the true path", experiments.mean_pose_on_path(truth, mean), rest)
    report_row("baseline: constant pose", experiments.constant_pose(truth), rest)
    vae, vae_lstm, conv_ae = models.get("vae"), models.get("vae_lstm"), models.get("conv_ae")
    samples = None
    if vae is not None:
        samples = vae.generate(n=64, seed=0).features
        report_row("Motegi VAE, samples from the prior", samples, rest, finished=True)
    if vae_lstm is not None:
        steered = vae_lstm.generate(truth[..., metrics.N_POSE:], n=len(truth), seed=0).features
        report_row("Habibie VAE-LSTM, given the test control", steered, rest, finished=True)

    print("\n## 2. Conv autoencoder against trivial reconstructions\n")
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
        print(claims.axes_control_parts(effects, spread))

    if vae_lstm is not None:
        what = f"by the control of each test clip of {REAL_STEER_S:g} s or more" if real else \
            f"for {STEER_S:g} s along walked preset paths"
        print(f"\n## 4. Habibie VAE-LSTM steered {what} (4 samples each)\n")
        print("| path | data stepping (m/s) | stepping / data, second by second | leg swing / data | claim |")
        print("|---|---|---|---|---|")
        for name, (control, reference, swing) in steer.items():
            motion = vae_lstm.generate(control, n=4, seed=0).features
            verdict = claims.steps_steadily(motion, reference, swing, FPS, name=name)
            ratios = metrics.stepping_by_second(motion, FPS).mean(0) / reference
            print(f"| {name} | {reference.mean():.2f} | {' '.join(f'{r:.2f}' for r in ratios)} "
                  f"| {metrics.leg_swing(motion) / swing:.2f} | {verdict_line(verdict)} |")

    if not real:
        glow_table(models, truth)
        moglow_tables(models)
        dfn_table(models)
    comparison_tables(args.data)


def glow_table(models: dict, truth: np.ndarray) -> None:
    """Section 4b: the shipped Glow's temperature sweep on the held-out windows."""
    model = models.get("glow")
    if model is None:
        return
    print("\n## 4b. Glow given each held-out window's control: the temperature sweep (one sample per window)\n")
    print("| temperature | stepping / data | leg swing / data | skating / data | bone drift (%) | motion like the data |")
    print("|---|---|---|---|---|---|")
    for t, verdict in experiments.temperature_sweep(model, truth).items():
        f = verdict.figures
        ratios = [f[f"{key}, samples"] / f[f"{key}, data"] for key in ("stepping (m/s)", "leg swing (m)",
                                                                      "foot skating (m/s)")]
        print(f"| {t:g} | {ratios[0]:.2f} | {ratios[1]:.2f} | {ratios[2]:.1f} | {100 * f['bone drift, samples']:.2f} "
              f"| {verdict_line(verdict)} |")


def moglow_tables(models: dict) -> None:
    """Section 5: the shipped MoGlow models steered along the preset paths."""
    model, no_dropout = models.get("moglow"), models.get("moglow_no_dropout")
    if model is None:
        return
    print(f"\n## 5. MoGlow steered for {STEER_S:g} s along preset paths from standing "
          f"(4 samples, temperature {TEMPERATURE:g}; data: 4 held-out bodies)\n")
    print("| path | data stepping (m/s) | stepping / data, seconds 2-10 | leg swing / data | skating (cm/s), "
          "model / data | bone drift (%) | targets |")
    print("|---|---|---|---|---|---|---|")
    reports = {}
    for name in MOGLOW_PRESETS:
        r = reports[name] = experiments.steering_report(model, name, STEER_S, temperature=TEMPERATURE)
        ours, theirs = r["model"], r["data report"]
        skating = ours["foot skating (m/s)"] / theirs["foot skating (m/s)"]
        feet = (f"{100 * ours['foot skating (m/s)']:.1f} / {100 * theirs['foot skating (m/s)']:.1f} "
                f"| {100 * ours['bone drift']:.2f}")
        if name in ("stand still", "walk, then stop"):
            steps = " ".join(f"{v:.2f}" for v in r["stepping"][1:])
            print(f"| {name} | {' '.join(f'{v:.2f}' for v in r['data stepping'][1:])} | model m/s: {steps} "
                  f"| | {feet} | see the claim below |")
            continue
        ratios = r["stepping"][1:] / r["data stepping"][1:]
        # leg swing is measured along the facing direction: side-stepping legs barely lead
        swing = ours["leg swing (m)"] / theirs["leg swing (m)"] if theirs["leg swing (m)"] > 0.1 else None
        missed = [label for label, ok in (
            ("stepping", bool((np.abs(ratios - 1) <= MOGLOW_TARGETS["stepping"]).all())),
            ("leg swing", swing is None or swing >= MOGLOW_TARGETS["leg swing"]),
            ("skating", skating <= MOGLOW_TARGETS["skating"]),
            ("bone drift", ours["bone drift"] <= MOGLOW_TARGETS["bone drift"])) if not ok]
        swing_cell = "n/a" if swing is None else f"{swing:.2f}"
        print(f"| {name} | {r['data stepping'][1:].mean():.2f} | {' '.join(f'{v:.2f}' for v in ratios)} "
              f"| {swing_cell} | {feet} | {'met' if not missed else 'missed: ' + ', '.join(missed)} |")

    print("\n§5.3, the body follows the control (told to walk: >= 70 % of the data's stepping from the "
          "2nd second; told to stop: < 0.15 m/s from 1 s after the command):")
    for label, m in (("dropout", model), ("no dropout", no_dropout)):
        if m is None:
            continue
        walk, stop = (reports["walk"], reports["walk, then stop"]) if m is model else \
            (experiments.steering_report(m, "walk", STEER_S, temperature=TEMPERATURE),
             experiments.steering_report(m, "walk, then stop", STEER_S, temperature=TEMPERATURE))
        verdict = claims.follows_control(walk["samples"], walk["data stepping"], stop["samples"], stop["control"],
                                         FPS, name=f"MoGlow, {label}")
        print(f"- {label} ({m.config.dropout:g}): {verdict_line(verdict)}; stepping after the stop "
              f"{' '.join(f'{v:.2f}' for v in stop['stepping'][6:])} m/s")

    print(f"\n{LONG_S:g}-s samples along the circle (§5.3's long samples; pose spread per 5 s against the data's):")
    for label, m in (("dropout", model), ("no dropout", no_dropout)):
        if m is None:
            continue
        samples, walks = experiments.steer(m, "circle", LONG_S, temperature=TEMPERATURE)
        verdict = claims.keeps_moving(samples, walks, FPS, name=f"MoGlow, {label}")
        ratios = [v for k, v in verdict.figures.items() if "pose spread" in k]
        late = slice(-int(5 * FPS), None)
        diversity = metrics.diversity(to_positions(samples, FPS))[late].mean()
        print(f"- {label}: {' '.join(f'{r:.2f}' for r in ratios)}: {verdict_line(verdict)}; the 4 samples' "
              f"diversity in the last 5 s {100 * diversity:.1f} cm (the data's 4 bodies: "
              f"{100 * metrics.diversity(to_positions(walks, FPS))[late].mean():.1f} cm)")


def dfn_futures(model, prefixes: np.ndarray, seconds: float = LONG_S) -> list[np.ndarray]:
    """DFN_SAMPLES futures of each prefix ``(k, frames, 66)``, prefix first: ``(n, frames, 66)`` each."""
    frames = int(round(seconds * FPS)) - prefixes.shape[1]
    return [np.concatenate([np.repeat(p[None], DFN_SAMPLES, 0),
                            model.generate(prefix=p, frames=frames, n=DFN_SAMPLES, seed=k).features], axis=1)
            for k, p in enumerate(prefixes)]


def dfn_table(models: dict) -> None:
    """Section 6: the shipped DFN's futures from held-out prefixes (Chen §6.3)."""
    model = models.get("dfn")
    if model is None:
        return
    description = model.description
    clips = data.load("synthetic", fps=FPS, n_clips=len(description["clips"]["train"]) + len(description["clips"]["val"])
                      + len(description["clips"]["test"]), seed=description["seed"])
    trained = data.prepare(clips, window_s=description["window_frames"] / FPS,
                           stride_s=description["stride_frames"] / FPS, seed=description["seed"],
                           augment_with=description["augment"])
    train_windows = trained.in_data_units(trained.train.windows)
    held_out = experiments.held_out_windows(DFN_PREFIX_FRAMES * 4, FPS)
    prefixes = held_out[np.linspace(0, len(held_out) - 1, DFN_PREFIXES).astype(int), :DFN_PREFIX_FRAMES]
    print(f"\n## 6. DFN: {LONG_S:g}-s futures of {DFN_PREFIXES} held-out prefixes of {DFN_PREFIX_FRAMES / FPS:g} s "
          f"({DFN_SAMPLES} samples each, temperature 1), against its training windows\n")
    print("| prefix | distance to mean pose, 0.5-1.5 s / 20-30 s (m) | faster than 2 m/s, last 10 s | pose speed, "
          "last 5 s (m/s) | bone drift (%) | foot skating (cm/s) |")
    print("|---|---|---|---|---|---|")
    rest = metrics.foot_rest_heights(to_positions(train_windows, FPS))
    futures = np.stack(dfn_futures(model, prefixes))                  # (prefixes, samples, frames, 66)
    for k, samples in enumerate(futures):
        f = claims.diverse_futures(samples, train_windows, FPS, DFN_PREFIX_FRAMES).figures
        generated = to_positions(samples[:, DFN_PREFIX_FRAMES:], FPS)
        print(f"| {k + 1} | {f['early distance to the mean pose (m), lowest']:.2f} / "
              f"{f['late distance to the mean pose (m), lowest']:.2f} "
              f"| {100 * f['share fast, late']:.0f} % | {f['pose speed at the end (m/s), lowest']:.2f} "
              f"| {100 * f['bone drift']:.4f} | {100 * metrics.foot_skating(generated, FPS, rest_height_m=rest):.1f} |")
    verdict = claims.diverse_futures(futures, train_windows, FPS, DFN_PREFIX_FRAMES)
    f = verdict.figures
    positions = to_positions(train_windows, FPS)
    data_skating, data_drift = metrics.foot_skating(positions, FPS), metrics.bone_length_drift(positions)
    print(f"| training data | band {f['data band, mean (m)']:.2f} ± {f['data band, std (m)']:.2f} "
          f"| {100 * f['share fast, data']:.0f} % | {f['pose speed, data (m/s)']:.2f} | {100 * data_drift:.4f} "
          f"| {100 * data_skating:.1f} |")
    print(f"\nall {futures.shape[0] * futures.shape[1]} futures: {100 * f['share fast, late']:.0f} % of "
          f"the last 10 s faster than 2 m/s (the data's {100 * f['share fast, data']:.0f} %; target within ±30 % of "
          f"it), bone drift {100 * f['bone drift']:.4f} % (target <= 0.5 %)")
    print(f"§6.3, futures diversify like the data: {verdict_line(verdict)}")

def comparison_tables(source: str = "synthetic") -> None:
    """Section 7: every shipped model on one test set, notebook 08's table and its claim.
    With a folder: the *shipped* models (trained on built-in clips) on its clips, as
    notebook 08 shows them with ``MOTIONLAB_DATA`` set."""
    models = comparison.load_models()
    if not models:
        return
    windows = comparison.evaluation_windows(source)
    rows, long = comparison.table_rows(models, windows), comparison.long_run(models)
    if source == "synthetic":
        where, label = "held-out windows", "held-out windows"
    else:
        where = f"windows of 4 s (one every second) of the clips in {source}, shipped models (trained on built-in clips)"
        label = "real windows"
    print(f"\n## 7. All the shipped models side by side (notebook 08): {len(windows)} {where}; "
          f"{comparison.PREFIX_FRAMES} frames of prefix, 30-s runs along the built-in circle; frames/s measured now\n")
    print(comparison.table(models, rows, long, comparison.generation_speed(models), data_label=label))
    following = comparison.speed_following(models)
    print("\nstepping (m/s) at the commanded speeds " + ", ".join(f"{v:g}" for v in comparison.SPEEDS) + " m/s:")
    for label, stepping in following.items():
        verdict = "" if label == "data" else \
            f": {verdict_line(claims.follows_speed(comparison.SPEEDS, stepping, following['data'], name=label))}"
        print(f"- {label}: {' '.join(f'{v:.2f}' for v in stepping)}{verdict}")


if __name__ == "__main__":
    main()
