"""The foot-contact velocity term (HuMoR, Rempe et al. 2021; EDGE, Tseng et al. 2023; MDM,
Tevet et al. 2023) in the models trained by reconstruction: do their feet stop sliding, and
what does it cost?

    python benchmarks/contact_term.py                                  # VAE-LSTM, weights 0 0.3 1 3 10
    python benchmarks/contact_term.py --model vae_lstm dfn --seeds 0 1 --jobs 20 --device cuda
    python benchmarks/contact_term.py --model vae_lstm dfn --epochs 1 --weights 1    # a smoke run
    python benchmarks/contact_term.py --weights 1 --bone-weights 1 10      # also the bone-length term
    python benchmarks/contact_term.py --weights 1 2 --skeleton             # on the skeleton output layer
    python benchmarks/contact_term.py --model conv_ae --weights 1 --skeleton   # the conv AE's, likewise
    python benchmarks/contact_term.py --weights 1 --foot-gate --skeleton   # gated feet, on a skeleton

Each model is trained by its recipe of ``make checkpoints`` (the Makefile; the command line
``python -m motionlab.train``) without the term and with each weight of ``--weights``
(``--set contact_weight=W``; defaults :data:`WEIGHTS`, chosen from the term's scale against
each loss), for the VAE-LSTM and the conv AE also with each of ``--bone-weights`` (``--set bone_weight=W``:
the squared error of the reconstruction's bone lengths, cm²; default 0, off; with ``--skeleton``
every VAE-LSTM or conv AE run has the skeleton output layer, ``--set skeleton=true``; with ``--foot-gate`` the VAE-LSTM's
gated feet, ``--set foot_gate=true``), for each of
``--seeds`` (the command line's seed: the training clips and the
first weights), ``--jobs`` trainings at a time in their own processes, their checkpoints and
logs in ``--out`` (a checkpoint already there is reused). ``--epochs`` changes the
VAE-LSTM's 20 epochs, and DFN's 10 / 10 / 20 and the conv AE's 40 in the same proportion.
``--model conv_ae`` trains Motegi's conv autoencoder (notebook 03's recipe, whose decoder is
also the VAE's, with ``--skeleton``; without it, the free decoder shipped before) and measures
its reconstructions of the held-out windows.

Then, per run, on the held-out built-in windows of notebook 08's table
(``comparison.table_rows``: one sample per window, 3.5 s judged; the data's planted foot
heights): the training time; the term itself on the held-out windows' reconstructions (the
VAE-LSTM's from ``z_1`` alone, the path that generates; DFN's through its sequence
autoencoder); foot skating as generated and after ``contacts.lock_feet``; pose error at 1 s
and 3 s; stepping and leg swing against the data's; bone drift; and the paper's claim: for
the VAE-LSTM its NLL bound, its reconstruction from ``z_1`` alone (notebook 04's measure of
the path that generates) and whether it keeps stepping along the walk and run presets for
10 s (``claims.steps_steadily``, notebook 04), for DFN whether 30-s futures of held-out
prefixes diversify like its training data (``claims.diverse_futures``, §6.3,
``benchmarks/quality.py`` section 6). Training runs on ``--device``; the measures on the CPU.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from motionlab import claims, comparison, contacts, data, experiments, metrics, training
from motionlab.models.vae_lstm import VAELSTM
from motionlab.representation import N_POSE, to_positions

REPO = Path(__file__).resolve().parents[1]
FPS = comparison.FPS
RECIPE_EPOCHS = 20
"""The VAE-LSTM's epochs in ``make checkpoints``; DFN's stages are scaled by ``--epochs / 20``."""
DFN_STAGE_EPOCHS = {"frame": 10, "sequence": 10, "dynamics": 20}
WEIGHTS = {"vae_lstm": (0.3, 1.0, 3.0, 10.0), "dfn": (0.03, 0.1, 0.3, 1.0), "conv_ae": (0.1, 1.0)}
"""Default weights per model. On the shipped VAE-LSTM the term is 0.24 (m/s)² per
reconstruction (the data's own planted feet: 0.005) beside a loss of 268 nats per frame, all
but about 1.7 of it the likelihood's constant; at weight 1 its gradient on the decoder is
0.7 times the rest of the loss's. DFN's losses are mean squared errors in normalised units
(0.06 and 0.15 for the frame and sequence stages) beside terms of 0.05 and 0.18 (m/s)²: at
weight 1 the term's gradient is 4 and 14 times theirs, so its weights are 10 times smaller."""
STEER_S = 10.0
DFN_PREFIXES, DFN_SAMPLES, DFN_PREFIX_FRAMES, DFN_FUTURE_S = 8, 16, 10, 30.0   # benchmarks/quality.py's


@dataclass(frozen=True)
class Run:
    model: str                     # "vae_lstm", "dfn" or "conv_ae"
    weight: float
    seed: int
    bone: float = 0.0              # the VAE-LSTM's or the conv AE's bone_weight
    skeleton: bool = False         # the skeleton output layer (the VAE-LSTM's or the conv AE's)
    gate: bool = False             # the VAE-LSTM's gated feet

    @property
    def label(self) -> str:
        return {"vae_lstm": "VAE-LSTM", "dfn": "DFN", "conv_ae": "conv AE"}[self.model] \
            + (", feet gated" if self.gate else "") + (" on a skeleton" if self.skeleton else "")

    def checkpoint(self, out: Path, epochs: int) -> Path:
        bone = f"_bone{self.bone:g}" if self.bone > 0 else ""
        bone += "_skeleton" if self.skeleton else ""
        bone += "_gate" if self.gate else ""
        return out / f"{self.model}_contact{self.weight:g}{bone}_seed{self.seed}_epochs{epochs}.pt"

    def command(self, epochs: int, device: str, path: Path) -> list[str]:
        """The ``make checkpoints`` recipe for this run (``python -m motionlab.train`` arguments)."""
        weight = [f"contact_weight={self.weight:g}"] if self.weight > 0 else []
        weight += [f"bone_weight={self.bone:g}"] if self.bone > 0 else []
        weight += ["skeleton=true"] if self.skeleton else []
        weight += ["foot_gate=true"] if self.gate else []
        if self.model == "vae_lstm":
            recipe = ["vae_lstm", "--synthetic-clips", "120", "--epochs", str(epochs), "--lr", "3e-3", "--half",
                      "--set", "observation_std=3.0", *weight]
        elif self.model == "conv_ae":                 # Motegi's conv AE, notebook 03's with --skeleton (40 epochs: twice 20)
            recipe = ["conv_ae", "--synthetic-clips", "100", "--stride", "1.0", "--normalization", "shared_pose",
                      "--epochs", str(2 * epochs), "--lr", "2e-3", "--half",
                      "--set", "depool=linear", "input_dropout=0.0", "l1=0.0", *weight]
        else:
            stages = [f"{stage}={max(1, round(n * epochs / RECIPE_EPOCHS))}" for stage, n in DFN_STAGE_EPOCHS.items()]
            recipe = ["dfn", "--synthetic-clips", "120", "--stride", "0.5", "--stage-epochs", *stages,
                      "--lr", "3e-3", "--batch-size", "64", "--half", *(["--set", *weight] if weight else [])]
        return [*recipe, "--seed", str(self.seed), "--device", device, "--out", str(path)]


def train_all(runs: list[Run], args: argparse.Namespace) -> None:
    """Train every run whose checkpoint is not in ``args.out`` yet, ``args.jobs`` at a time,
    each in its own process with ``args.threads`` CPU threads; a failed run stops the benchmark
    with the end of its log."""
    env = {**os.environ, "OMP_NUM_THREADS": str(args.threads), "MKL_NUM_THREADS": str(args.threads),
           "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))}

    def train(run: Run) -> None:
        path = run.checkpoint(args.out, args.epochs)
        log = path.with_suffix(".log")
        command = [sys.executable, "-m", "motionlab.train", *run.command(args.epochs, args.device, path)]
        print(f"training: python {' '.join(command[1:])}  (log: {log})", flush=True)
        with open(log, "w") as file:
            done = subprocess.run(command, stdout=file, stderr=subprocess.STDOUT, env=env, cwd=REPO)
        if done.returncode != 0:
            raise RuntimeError(f"{run}: training failed (exit {done.returncode}); the end of {log}:\n"
                               + "\n".join(log.read_text().splitlines()[-20:]))

    todo = [run for run in runs if not run.checkpoint(args.out, args.epochs).exists()]
    for run in runs:
        if run not in todo:
            print(f"reused: {run.checkpoint(args.out, args.epochs)}")
    began = time.perf_counter()
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        list(pool.map(train, todo))
    if todo:
        print(f"{len(todo)} trainings in {time.perf_counter() - began:.0f} s of wall time, {args.jobs} at a time\n")


def held_out_term(model, windows: np.ndarray) -> float:
    """The contact term on held-out ``windows`` (data units) as the model reconstructs them,
    (m/s)²: the VAE-LSTM from ``z_1`` alone (as it generates), its pose along the true control;
    DFN through its sequence autoencoder, piece by piece (what its frame and sequence stages
    train; the pieces are decoded apart, so no velocity is taken across their seams)."""
    x = torch.tensor(model.normalizer.normalize(windows), dtype=torch.float32)
    if isinstance(model, VAELSTM):
        r = model.reconstruct(x, free_running=True)
        r = torch.cat([r[..., :N_POSE], x[..., N_POSE:]], -1)
    else:
        H = model.config.horizon
        r = model.reconstruct(x, through="sequence").reshape(-1, H, x.shape[-1])
        x = x[:, :x.shape[1] // H * H].reshape(-1, H, x.shape[-1])
    with torch.no_grad():
        return float(model.contact_term(r, x))


def z1_reconstruction_cm(model, windows: np.ndarray) -> float:
    """Notebook 04's measure of the path that generates: the pose error (cm) of the held-out
    ``windows`` reconstructed by the VAE-LSTM from ``z_1`` alone (its posterior mean)."""
    x = torch.tensor(model.normalizer.normalize(windows), dtype=torch.float32)
    rebuilt = model.normalizer.denormalize(model.reconstruct(x, free_running=True).double().numpy())
    return 100 * metrics.pose_error(rebuilt, windows)


def locked_skating(features: np.ndarray, rest: np.ndarray) -> float:
    """Foot skating (cm/s, the data's planted heights) after :func:`contacts.lock_feet`."""
    locked = contacts.lock_feet(to_positions(features, FPS), FPS, planted_height_m=rest)
    return 100 * metrics.foot_skating(locked, FPS, rest_height_m=rest)


def vae_lstm_claim(model, presets: dict) -> claims.Verdict:
    """Notebook 04's check: 4 samples along the walk and run presets keep stepping (10 s)."""
    verdict = claims.Verdict("keeps stepping along walk and run")
    for preset, (control, reference, swing) in presets.items():
        motion = model.generate(control, n=4, seed=0).features
        one = claims.steps_steadily(motion, reference, swing, FPS, name=preset)
        verdict.failures += [f"{preset}: {why}" for why in one.failures]
    return verdict


def dfn_claim(model, description: dict) -> claims.Verdict:
    """§6.3 as ``benchmarks/quality.py`` checks it: 30-s futures of held-out prefixes against
    the model's training windows (remade from its checkpoint's data description)."""
    clips = data.load("synthetic", fps=FPS, n_clips=sum(len(c) for c in description["clips"].values()),
                      seed=description["seed"])
    trained = data.prepare(clips, window_s=description["window_frames"] / FPS,
                           stride_s=description["stride_frames"] / FPS, seed=description["seed"],
                           augment_with=description["augment"])
    held_out = experiments.held_out_windows(4 * DFN_PREFIX_FRAMES, FPS)
    prefixes = held_out[np.linspace(0, len(held_out) - 1, DFN_PREFIXES).astype(int), :DFN_PREFIX_FRAMES]
    frames = int(round(DFN_FUTURE_S * FPS)) - DFN_PREFIX_FRAMES
    futures = np.stack([np.concatenate([np.repeat(p[None], DFN_SAMPLES, 0),
                                        model.generate(prefix=p, frames=frames, n=DFN_SAMPLES, seed=k).features], 1)
                        for k, p in enumerate(prefixes)])
    return claims.diverse_futures(futures, trained.in_data_units(trained.train.windows), FPS, DFN_PREFIX_FRAMES)


def conv_ae_row(run: Run, checkpoint, windows: np.ndarray, rest: np.ndarray) -> list[str]:
    """The conv AE's row: its reconstructions of the held-out windows (pose along the windows'
    own control), and notebook 02's claim (it beats the trivial reconstructions). Returns the
    claim's failures."""
    model, norm = checkpoint.model, checkpoint.model.normalizer
    x = torch.tensor(norm.normalize(windows[:, :model.config.window]), dtype=torch.float32)
    with torch.no_grad():
        rebuilt = model.project(x)
        term = float(contacts.contact_velocity_loss(norm.denormalize(torch.cat([rebuilt[..., :N_POSE], x[..., N_POSE:]],
                                                                                -1)), norm.denormalize(x), FPS))
    truth = windows[:, :model.config.window]
    features = norm.denormalize(rebuilt.double().numpy())
    features[..., N_POSE:] = truth[..., N_POSE:]
    errors = {"conv AE": tuple(metrics.window_errors(features, truth, FPS).values())}
    for name, trivial in experiments.trivial_reconstructions(truth, norm.mean).items():
        errors[name] = tuple(metrics.window_errors(trivial, truth, FPS).values())
    verdict = claims.beats_trivial_reconstructions(errors, "conv AE")
    r = metrics.locomotion_report(features, FPS, rest)
    print(f"| {run.label} (reconstructions) | {run.weight:g} | {run.bone:g} | {run.seed} | {checkpoint.history.seconds:.0f} "
          f"| {term:.3f} "
          f"| {100 * r['foot skating (m/s)']:.1f} | {locked_skating(features, rest):.1f} "
          f"| pose {100 * errors['conv AE'][0]:.2f} | | | {100 * r['bone drift']:.2f} | n/a | n/a "
          f"| {'holds' if verdict else 'fails'} |", flush=True)
    return [f"conv AE, weight {run.weight:g}, seed {run.seed}: {why}" for why in verdict.failures]


def measure(runs: list[Run], args: argparse.Namespace) -> None:
    windows = comparison.evaluation_windows("synthetic")
    judged = windows[:, comparison.PREFIX_FRAMES:]
    rest = metrics.foot_rest_heights(to_positions(judged, FPS))
    entries = {e.name: e for e in comparison.ENTRIES}
    presets = {}
    if any(run.model == "vae_lstm" for run in runs):
        for preset in ("walk", "run"):
            reference, swing = experiments.data_stepping(preset, STEER_S, FPS)
            presets[preset] = (experiments.walked_preset(preset, STEER_S, FPS), reference, swing)
    judged_t = torch.tensor(judged)
    print(f"held-out built-in data: {len(windows)} windows of {windows.shape[1]} frames at {FPS:g} fps, the first "
          f"{comparison.PREFIX_FRAMES} the prefix of the models that continue motion\n")
    print("| model | contact weight | bone weight | seed | training (s) | contact term, held-out ((m/s)²) "
          "| foot skating (cm/s) | after lock_feet (cm/s) | pose error 1 s / 3 s (cm) | stepping / data | leg swing / data "
          "| bone drift (%) | NLL bound (bits/frame) | z_1-only reconstruction (cm) | paper's claim |")
    print("|" + "---|" * 15)
    data_row = comparison.table_rows({}, windows)["data"]
    own = float(contacts.contact_velocity_loss(judged_t, judged_t, FPS))
    print(f"| data | | | | | {own:.3f} | {data_row['foot skating (cm/s)']:.1f} "
          f"| {locked_skating(judged, rest):.1f} | | {data_row['stepping (m/s)']:.2f} m/s "
          f"| {data_row['leg swing (cm)']:.1f} cm | {data_row['bone drift (%)']:.2f} | | | |")
    failures = []
    for run in runs:
        path = run.checkpoint(args.out, args.epochs)
        checkpoint = training.load_checkpoint(path)
        model = checkpoint.model
        if run.model == "conv_ae":
            failures += conv_ae_row(run, checkpoint, windows, rest)
            continue
        models = {run.label: (entries[run.model], model)}
        rows = comparison.table_rows(models, windows)
        r = rows[run.label]
        sample = comparison.held_out_samples(models, windows)[run.label]
        verdict = vae_lstm_claim(model, presets) if run.model == "vae_lstm" else \
            dfn_claim(model, checkpoint.description)
        failures += [f"{run.label}, weight {run.weight:g}, bone weight {run.bone:g}, seed {run.seed}: {why}"
                     for why in verdict.failures]
        z1 = f"{z1_reconstruction_cm(model, windows):.1f}" if run.model == "vae_lstm" else "n/a"
        nll = "n/a" if not np.isfinite(r["test NLL (bits/frame)"]) else f"≤ {r['test NLL (bits/frame)']:.0f}"
        print(f"| {run.label} | {run.weight:g} | {run.bone:g} | {run.seed} | {checkpoint.history.seconds:.0f} "
              f"| {held_out_term(model, windows):.3f} | {r['foot skating (cm/s)']:.1f} "
              f"| {locked_skating(sample, rest):.1f} "
              f"| {r['pose error 1 s (cm)']:.1f} / {r['pose error 3 s (cm)']:.1f} "
              f"| {r['stepping (m/s)'] / data_row['stepping (m/s)']:.2f} "
              f"| {r['leg swing (cm)'] / data_row['leg swing (cm)']:.2f} | {r['bone drift (%)']:.2f} | {nll} "
              f"| {z1} | {'holds' if verdict else 'fails'} |", flush=True)
    print("\nThe VAE-LSTM's claim: steps steadily along walk and run for 10 s (claims.steps_steadily); "
          "DFN's: diverse futures (claims.diverse_futures, §6.3); the conv AE's: its reconstructions beat the "
          "trivial ones (claims.beats_trivial_reconstructions, notebook 02; pose error in cm).")
    for line in failures:
        print(f"- {line}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", nargs="+", choices=sorted(WEIGHTS), default=["vae_lstm"])
    parser.add_argument("--weights", nargs="+", type=float, default=None,
                        help="contact weights (> 0) besides 0, for every model (default: per model, "
                             + "; ".join(f"{m} {' '.join(f'{w:g}' for w in ws)}" for m, ws in WEIGHTS.items()) + ")")
    parser.add_argument("--bone-weights", nargs="+", type=float, default=[],
                        help="bone-length weights (> 0) besides 0, the VAE-LSTM and the conv AE only "
                             "(default: none)")
    parser.add_argument("--skeleton", action="store_true",
                        help="the VAE-LSTM's or the conv AE's runs with the skeleton output layer "
                             "(--set skeleton=true)")
    parser.add_argument("--foot-gate", action="store_true",
                        help="the VAE-LSTM's runs with its gated feet (--set foot_gate=true)")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0], help="seeds of the trainings (default 0)")
    parser.add_argument("--epochs", type=int, default=RECIPE_EPOCHS,
                        help=f"the VAE-LSTM's epochs (default {RECIPE_EPOCHS}, the recipe's); "
                             "DFN's stages scaled alike")
    parser.add_argument("--device", default="auto", help="where to train: auto, cpu, cuda, cuda:1, ...")
    parser.add_argument("--jobs", type=int, default=1, help="trainings at a time, each in its own process")
    parser.add_argument("--threads", type=int, default=None,
                        help="CPU threads per training (default: the CPU's cores shared among the jobs)")
    parser.add_argument("--out", type=Path, default=REPO / "data" / "cache" / "contact_term",
                        help="folder of the checkpoints and training logs")
    args = parser.parse_args(argv)
    if args.weights is not None and not all(np.isfinite(w) and w > 0 for w in args.weights):
        parser.error(f"--weights: expected numbers > 0 (0 is always run), got {args.weights}")
    if not all(np.isfinite(w) and w > 0 for w in args.bone_weights) \
            or (args.bone_weights and not set(args.model) <= {"vae_lstm", "conv_ae"}):
        parser.error(f"--bone-weights: expected numbers > 0, with --model vae_lstm or conv_ae only; "
                     f"got {args.bone_weights}")
    if args.skeleton and not set(args.model) <= {"vae_lstm", "conv_ae"}:
        parser.error("--skeleton: the VAE-LSTM's and the conv AE's option, with --model vae_lstm or conv_ae only")
    if args.foot_gate and args.model != ["vae_lstm"]:
        parser.error("--foot-gate: the VAE-LSTM's option, with --model vae_lstm only")
    if args.epochs < 1 or args.jobs < 1 or (args.threads is not None and args.threads < 1) \
            or any(s < 0 for s in args.seeds):
        parser.error("--epochs, --jobs and --threads: expected whole numbers >= 1; --seeds >= 0")
    args.threads = args.threads or max(1, (os.cpu_count() or 1) // args.jobs)
    args.out.mkdir(parents=True, exist_ok=True)
    runs = [Run(model, weight, seed, bone, args.skeleton, args.foot_gate) for model in args.model for seed in args.seeds
            for bone in (0.0, *args.bone_weights) for weight in (0.0, *(args.weights or WEIGHTS[model]))]
    print(f"{len(runs)} trainings on {args.device} ({args.jobs} at a time, {args.threads} CPU thread(s) each), "
          f"{args.epochs} epochs{'' if args.epochs == RECIPE_EPOCHS else f' (the recipe: {RECIPE_EPOCHS})'}; "
          f"checkpoints in {args.out}\n")
    train_all(runs, args)
    measure(runs, args)


if __name__ == "__main__":
    main()
