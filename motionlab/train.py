"""Train any motionlab model from the command line.

    python -m motionlab.train conv_ae                             # synthetic data, laptop size
    python -m motionlab.train conv_ae --data path/to/cmu/bvh --set window=20
    python -m motionlab.train conv_ae --paper --device cuda --out runs/conv_ae.pt
    python -m motionlab.train vae --conv-ae conv_ae.pt            # Motegi's VAE on its features
    python -m motionlab.train dfn --stage-epochs frame=15 sequence=15 dynamics=30 --lr 3e-3
    python -m motionlab.train moglow --paper --max-steps 1000     # the paper's schedule, cut short

The model's config decides the frame rate and window length of the data; ``--set
name=value`` changes any config field. ``--paper`` takes the paper's architecture
(``Config.paper()``) and training schedule (the model card's ``schedule``, at the end of
the model's file); options given on
the command line win over both. A GPU is used when there is one (``--device``).
The checkpoint holds the weights, config, normaliser and data description, and loads
with ``motionlab.training.load_checkpoint``.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path

import torch

from . import checks, data, training
from . import models

DEFAULTS = {"epochs": 30, **{name: getattr(training.TrainConfig(), name)
                             for name in ("batch_size", "lr", "schedule", "warmup_steps", "grad_clip", "max_steps")}}
"""Without ``--paper``: :class:`motionlab.training.TrainConfig`'s defaults (the one place they are
written), except 30 epochs instead of 20: a command-line run is a longer one than a notebook's."""

FLAGS = {"epochs": "--epochs", "batch_size": "--batch-size", "lr": "--lr", "schedule": "--schedule",
         "warmup_steps": "--warmup-steps", "max_steps": "--max-steps", "stage_epochs": "--stage-epochs"}
"""The settings the command line can give (its value then wins over the paper's)."""

# ----------------------------------------------------------------------------------------
# argparse ``type=`` functions: a bad value becomes a usage error (exit code 2) naming the option.
# ----------------------------------------------------------------------------------------


def _whole(minimum: int):
    """A whole number >= ``minimum``."""
    def parse(text: str) -> int:
        try:
            return checks.whole(int(text), "value", minimum)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {minimum}, got {text!r}") from None
    return parse


def _positive(maximum: float | None = None):
    """A finite number > 0 (and <= ``maximum``)."""
    def parse(text: str) -> float:
        try:
            return checks.positive(float(text), "value", maximum)
        except ValueError:
            at_most = "" if maximum is None else f" and <= {maximum:g}"
            raise argparse.ArgumentTypeError(f"expected a finite number > 0{at_most}, got {text!r}") from None
    return parse


def _source(text: str) -> str:
    """``synthetic`` or a folder or file that exists."""
    if text != "synthetic" and not Path(text).exists():
        raise argparse.ArgumentTypeError(f"{text!r} is neither 'synthetic' nor an existing folder or file")
    return text


def _device(text: str) -> str:
    """``auto`` or a name torch knows (``cpu``, ``cuda``, ``cuda:1``, ...)."""
    if text != "auto":
        try:
            torch.device(text)
        except RuntimeError:
            raise argparse.ArgumentTypeError(f"expected auto, cpu, cuda, cuda:1, ..., got {text!r}") from None
    return text


def _out(text: str) -> str:
    """A checkpoint path (not a folder)."""
    if Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is a folder; give a file name such as {text}/model.pt")
    return text


def _stage_epochs(text: str) -> tuple[str, int]:
    """``STAGE=EPOCHS``, e.g. ``frame=15`` (the model's stages are checked once it is known)."""
    stage, sep, number = text.partition("=")
    if not sep or not stage:
        raise argparse.ArgumentTypeError(f"expected STAGE=EPOCHS, got {text!r}")
    return stage, _whole(1)(number)


def _conv_ae(text: str) -> tuple[str, training.Checkpoint]:
    """The path of a conv_ae checkpoint made by this command, and the checkpoint."""
    from .models.conv_ae import ConvAutoencoder
    try:
        checkpoint = training.load_checkpoint(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    if not isinstance(checkpoint.model, ConvAutoencoder) or checkpoint.normalizer is None:
        raise argparse.ArgumentTypeError(
            f"{text} holds a {type(checkpoint.model).__name__}, not a conv_ae checkpoint with its "
            "normaliser (make one with: python -m motionlab.train conv_ae --out PATH.pt)")
    return text, checkpoint


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m motionlab.train", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("model", choices=models.FILES, help="which model to train")
    parser.add_argument("--data", default="synthetic", type=_source,
                        help="'synthetic' or a folder of CMU .bvh files")
    parser.add_argument("--paper", action="store_true",
                        help="the paper's architecture and training schedule (prints which values the "
                             "paper gives and which are stated choices); explicit options win")
    parser.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE", help="change config fields")
    parser.add_argument("--epochs", type=_whole(1), default=None,
                        help=f"passes over the data (default {DEFAULTS['epochs']}; with --max-steps alone: "
                             "as many as the steps need)")
    parser.add_argument("--batch-size", type=_whole(1), default=None,
                        help=f"windows per step (default {DEFAULTS['batch_size']})")
    parser.add_argument("--lr", type=_positive(), default=None,
                        help=f"Adam's learning rate (default {DEFAULTS['lr']:g})")
    parser.add_argument("--schedule", choices=["cosine", "constant"], default=None,
                        help=f"learning-rate schedule (default {DEFAULTS['schedule']})")
    parser.add_argument("--warmup-steps", type=_whole(0), default=None,
                        help="steps of linear learning-rate warm-up (default 0)")
    parser.add_argument("--max-steps", type=_whole(1), default=None,
                        help="stop after this many optimiser steps (dfn: per stage)")
    parser.add_argument("--stage-epochs", type=_stage_epochs, nargs="+", default=None, metavar="STAGE=N",
                        help="dfn only: epochs of each stage, e.g. frame=15 sequence=15 dynamics=30 "
                             "(default: --epochs for each)")
    parser.add_argument("--conv-ae", type=_conv_ae, default=None, metavar="PATH.pt",
                        help="vae only (required): the conv_ae checkpoint whose features the VAE models")
    parser.add_argument("--window-s", type=_positive(checks.MAX_SECONDS), default=None,
                        help="dfn only: seconds per training window (default 2 on synthetic data, "
                             "1 on a folder: most CMU trials are short)")
    parser.add_argument("--seed", type=_whole(0), default=0)
    parser.add_argument("--device", default="auto", type=_device, help="auto, cpu, cuda, cuda:1, ...")
    parser.add_argument("--normalization", default="per_feature", choices=["per_feature", "shared_pose"])
    parser.add_argument("--synthetic-clips", type=_whole(1), default=40)
    parser.add_argument("--out", default=None, type=_out, help="checkpoint path (default: <model>.pt)")
    parser.add_argument("--half", action="store_true", help="store the weights as float16 (half the size)")
    parser.add_argument("--stride", type=_positive(checks.MAX_SECONDS), default=None,
                        help="seconds between window starts (default: half a window)")
    parser.add_argument("--save-every", type=_whole(1), default=None, metavar="STEPS",
                        help="keep the run's state in OUT.state every STEPS steps (and at the end)")
    parser.add_argument("--save-every-minutes", type=_positive(24 * 60), default=None, metavar="MINUTES",
                        help="... and/or every MINUTES of training")
    parser.add_argument("--precision", choices=sorted(training.PRECISIONS), default="fp32",
                        help="fp32, or mixed precision: bf16 (CPUs with bfloat16, recent GPUs) or fp16 "
                             "(GPUs; with a gradient scaler); flows keep their log-determinants in fp32")
    parser.add_argument("--resume", action="store_true",
                        help="continue from OUT.state where an earlier run stopped (same options); "
                             "the result equals a run that never stopped")
    return parser


def check_model_options(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Options that belong to one model: required there, a usage error elsewhere."""
    if args.model == "vae" and args.conv_ae is None:
        parser.error("--conv-ae: vae models a conv AE's features; give its checkpoint "
                     "(python -m motionlab.train conv_ae --out conv_ae.pt, then --conv-ae conv_ae.pt)")
    for option, name, model in [("--conv-ae", "conv_ae", "vae"), ("--window-s", "window_s", "dfn")]:
        if getattr(args, name) is not None and args.model != model:
            parser.error(f"{option}: only for {model}" + (" (other models: --set window=FRAMES)"
                                                         if name == "window_s" else ""))
    if args.stage_epochs:
        stages = [stage for stage, _ in args.stage_epochs]
        known = models.card(args.model).stages
        if not known:
            parser.error(f"--stage-epochs: only for a model trained in stages "
                         f"({', '.join(c.name for c in models.cards().values() if c.stages)})")
        unknown = [stage for stage in stages if stage not in known]
        if unknown:
            parser.error(f"--stage-epochs: {args.model}'s stages are {', '.join(known)}, not {', '.join(unknown)}")
        twice = sorted({s for s in stages if stages.count(s) > 1})
        if twice:
            parser.error(f"--stage-epochs: {', '.join(twice)} given twice")


def parse_overrides(config_class, items: list[str]) -> dict:
    """``["filters=64", "depool=linear"]`` -> typed values for ``config_class``'s fields."""
    fields = {f.name: f for f in dataclasses.fields(config_class)}
    defaults = config_class()
    changes = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or name not in fields:
            raise ValueError(f"--set {item!r}: expected NAME=VALUE with NAME one of {', '.join(fields)}")
        default = getattr(defaults, name)
        kind = type(default)
        try:
            if kind is bool:
                if text.lower() not in ("1", "true", "yes", "0", "false", "no"):
                    raise ValueError(text)
                changes[name] = text.lower() in ("1", "true", "yes")
            elif kind is tuple:                          # "64,128" -> (64, 128), typed like the default's items
                item_kind = type(default[0]) if default else int
                changes[name] = tuple(item_kind(part) for part in text.split(",") if part.strip())
            else:
                changes[name] = kind(text)
        except (TypeError, ValueError):
            raise ValueError(f"--set {item!r}: {text!r} is not a {kind.__name__}") from None
    return changes


def build_config(parser: argparse.ArgumentParser, args: argparse.Namespace):
    """The model's config: laptop or paper sizes, with ``--set`` changes (a usage error if bad)."""
    config_class = models.card(args.model).config
    try:
        changes = parse_overrides(config_class, args.set)          # its messages name --set
        if args.model == "vae":                                    # the conv AE decides the input size
            if "n_inputs" in changes:
                raise ValueError("--set n_inputs: the VAE's input size comes from --conv-ae")
            ae = args.conv_ae[1].model.config
            changes["n_inputs"] = ae.window // 2 * ae.filters
        config = config_class.paper(**changes) if args.paper else config_class(**changes)
        if hasattr(config, "fps"):
            checks.rate(config.fps, "fps")
    except (TypeError, ValueError) as err:
        parser.error(str(err) if str(err).startswith("--set") else f"--set: {err}")
    return config


def dfn_window_s(parser: argparse.ArgumentParser, args: argparse.Namespace, config) -> float:
    """DFN's window (its config has none): ``--window-s``, else notebook 07's 2 s on synthetic
    data and 1 s on a folder (most CMU trials are short); at least ``horizon + 1`` frames."""
    window_s = args.window_s or (2.0 if args.data == "synthetic" else 1.0)
    if round(window_s * config.fps) < config.horizon + 1:
        parser.error(f"--window-s: {window_s:g} s is fewer than horizon + 1 = {config.horizon + 1} "
                     f"frames at {config.fps:g} fps")
    return window_s


# ----------------------------------------------------------------------------------------
# The training plan: defaults, the paper's schedule, the command line's options
# ----------------------------------------------------------------------------------------

@dataclasses.dataclass
class Plan:
    """How to train: what becomes each :class:`training.TrainConfig`, and where it came from.

    ``epochs = None`` means "as many as ``max_steps`` need". ``stage_epochs`` (dfn only)
    gives each stage its epochs. ``from_paper``, ``choices`` and ``given`` are the lines
    :meth:`describe` prints (the first two always with ``--paper``).
    """

    epochs: int | None
    batch_size: int
    lr: float
    schedule: str
    warmup_steps: int
    grad_clip: float | None
    max_steps: int | None
    stage_epochs: dict[str, int | None]
    seed: int = 0
    device: str = "auto"
    paper: bool = False
    save_every_steps: int | None = None
    save_every_s: float | None = None
    precision: str = "fp32"
    from_paper: list[str] = dataclasses.field(default_factory=list)
    choices: list[str] = dataclasses.field(default_factory=list)
    given: list[str] = dataclasses.field(default_factory=list)

    def train_config(self, n_train: int, stage: str | None = None) -> training.TrainConfig:
        """The TrainConfig for ``n_train`` training examples (and one DFN ``stage``)."""
        epochs = self.stage_epochs[stage] if stage is not None else self.epochs
        if epochs is None:                           # as many epochs as max_steps need
            batches = n_train // self.batch_size if n_train > self.batch_size else 1   # train() drops the last
            epochs = math.ceil(self.max_steps / batches)
        return training.TrainConfig(epochs=epochs, batch_size=self.batch_size, lr=self.lr,
                                    schedule=self.schedule, warmup_steps=self.warmup_steps,
                                    grad_clip=self.grad_clip, max_steps=self.max_steps,
                                    seed=self.seed, device=self.device, save_every_steps=self.save_every_steps,
                                    save_every_s=self.save_every_s, estimate=self.paper,
                                    precision=self.precision)

    def describe(self) -> str:
        lines = []
        for title, items, always in [("from the paper", self.from_paper, self.paper),
                                     ("stated choices (not in the paper)", self.choices, self.paper),
                                     ("given on the command line", self.given, False)]:
            if items or always:
                lines += [f"{title}:"] + [f"  {item}" for item in items or ["nothing"]]
        per_stage = " per stage" if self.stage_epochs else ""
        epochs = self.stage_epochs or {"": self.epochs}
        if all(n is None for n in epochs.values()):
            shown = f"{self.max_steps} steps{per_stage}"
        else:
            shown = "epochs " + ", ".join(f"{stage} {'until max-steps' if n is None else n}".strip()
                                          for stage, n in epochs.items())
            shown += f", at most {self.max_steps} steps{per_stage}" if self.max_steps else ""
        warmup = f" after {self.warmup_steps} warm-up steps" if self.warmup_steps else ""
        lines.append(f"training: {shown}, batch {self.batch_size}, Adam lr {self.lr:g} "
                     f"({self.schedule}{warmup}), gradient-norm clip {self.grad_clip}")
        return "\n".join(lines)


def _show(value) -> str:
    if isinstance(value, dict):
        return " ".join(f"{k}={v}" for k, v in value.items())
    return f"{value:g}" if isinstance(value, float) else str(value)


def training_plan(args: argparse.Namespace) -> Plan:
    """Defaults, overridden by the paper's schedule (``--paper``), overridden by the options
    given on the command line (``--epochs`` also over the paper's epochs per stage;
    ``--stage-epochs`` over the stages it names)."""
    given = {name: getattr(args, name) for name in FLAGS if getattr(args, name) is not None}
    given_stages = dict(given.pop("stage_epochs", []))
    values, from_paper, choices = {}, [], []
    card = models.card(args.model)
    for name, setting in (card.schedule.items() if args.paper else ()):
        winner = "epochs" if name == "stage_epochs" else name          # the option that beats it
        if winner in given:
            note = f"  [not used: {FLAGS[winner]} given]"
        elif name not in ("optimizer", "stages"):                      # those two only document
            values[name], note = setting.value, ""
        else:
            note = ""
        (from_paper if setting.from_paper else choices).append(
            f"{name.replace('_', ' ')}: {_show(setting.value)}  ({setting.source}){note}")
    values.update(given)
    if values.get("max_steps") is not None:
        values.setdefault("epochs", None)            # --max-steps alone: exactly that many steps
    for name, default in DEFAULTS.items():
        values.setdefault(name, default)
    paper_stages = values.pop("stage_epochs", {})
    stage_epochs = ({stage: given_stages.get(stage, paper_stages.get(stage, values["epochs"]))
                     for stage in card.stages})
    shown_given = [f"{FLAGS[name]} {_show(value)}" for name, value in given.items()]
    if given_stages:
        shown_given.append(f"--stage-epochs {_show(given_stages)}")
    return Plan(**values, stage_epochs=stage_epochs, seed=args.seed, device=args.device, paper=args.paper,
                save_every_steps=args.save_every, precision=args.precision,
                save_every_s=None if args.save_every_minutes is None else 60 * args.save_every_minutes,
                from_paper=from_paper, choices=choices, given=shown_given)


# ----------------------------------------------------------------------------------------
# Training, one function per kind of model
# ----------------------------------------------------------------------------------------

def _prepare(args: argparse.Namespace, fps: float, window_s: float) -> data.MotionData:
    clips = data.load(args.data, fps=fps, n_clips=args.synthetic_clips, seed=args.seed)
    prepared = data.prepare(clips, window_s=window_s, stride_s=args.stride, seed=args.seed,
                            normalization=args.normalization,
                            augment_with=models.card(args.model).augment)
    say(prepared.summary())
    return prepared


def say(*text) -> None:
    """Print, from one process only (rank 0) when several train together under torchrun."""
    if training.distributed()[0] == 0:
        print(*text)


def state_path(args: argparse.Namespace) -> Path:
    """Where a run keeps its state for ``--resume``: ``OUT.state`` beside the checkpoint."""
    out = Path(args.out or f"{args.model}.pt")
    return out.with_name(out.name + ".state")


def _state(args: argparse.Namespace) -> dict:
    """``training.train``'s state_file and resume for these options (none without --save-every*/--resume)."""
    if args.resume or args.save_every or args.save_every_minutes:
        return {"state_file": state_path(args), "resume": args.resume}
    return {}


def _model(args: argparse.Namespace, config) -> torch.nn.Module:
    model_class = models.card(args.model).model
    say(f"model: {model_class.__name__}({config})")
    training.seed_everything(args.seed)          # the same command line starts from the same weights
    return model_class(config)


def train_windows(args, config, plan: Plan) -> tuple[torch.nn.Module, training.History, dict]:
    """conv_ae, vae_lstm, lstm, glow, moglow: windows of the config's length and frame rate."""
    prepared = _prepare(args, config.fps, config.window / config.fps)
    model = _model(args, config)
    history = training.train(model, prepared, plan.train_config(len(prepared.train)), **_state(args))
    return model, history, {"data": prepared}


def _conv_features(conv_ae, prepared: data.MotionData, motion_normalizer, split: str) -> torch.Tensor:
    """Flattened conv AE features of one split's windows, normalised as the conv AE was trained."""
    windows = prepared.normalizer.denormalize(getattr(prepared, split).windows)
    with torch.no_grad():
        return conv_ae.encode(motion_normalizer.normalize(windows)).flatten(1)


def train_vae(args, config, plan: Plan) -> tuple[torch.nn.Module, training.History, dict]:
    """Motegi's VAE (§IV) on the standardised, flattened features of the ``--conv-ae``
    checkpoint's encoder, as notebook 03 trains it. The checkpoint's normaliser is the
    feature normaliser; its description names the conv AE and holds the motion normaliser,
    all that :class:`motionlab.models.vae.MotionVAE` needs besides."""
    path, checkpoint = args.conv_ae
    conv_ae, motion_normalizer = checkpoint.model.eval(), checkpoint.normalizer
    prepared = _prepare(args, conv_ae.config.fps, conv_ae.config.window / conv_ae.config.fps)
    features = {split: _conv_features(conv_ae, prepared, motion_normalizer, split)
                for split in ("train", "val", "test")}
    feature_normalizer = data.Normalizer.fit(features["train"].numpy())
    sets = {split: data.MotionDataset(feature_normalizer.normalize(f)) for split, f in features.items()}
    say(f"features: conv AE {path} -> {conv_ae.config.window // 2} x {conv_ae.config.filters} "
          f"= {config.n_inputs} per window")
    model = _model(args, config)
    history = training.train(model, (sets["train"], sets["val"]), plan.train_config(len(sets["train"])),
                             **_state(args))
    description = {**prepared.description, "conv_ae": str(path),
                   "motion_normalizer": motion_normalizer.state_dict(),
                   "features": "conv_ae.encode(motion_normalizer.normalize(windows)).flatten(1), "
                               "standardised by the checkpoint's normaliser"}
    return model, history, {"normalizer": feature_normalizer, "description": description}


def _joined(histories: dict[str, training.History]) -> training.History:
    """The stages' histories as one, steps counted on; each row says its ``stage`` (0, 1, 2)."""
    joined, offset = training.History(), 0
    for k, history in enumerate(histories.values()):
        joined.train += [{**row, "step": row["step"] + offset, "stage": k} for row in history.train]
        joined.val += [{**row, "step": row["step"] + offset, "stage": k} for row in history.val]
        joined.seconds += history.seconds
        offset += len(history.train)
    return joined


def train_dfn(args, config, plan: Plan) -> tuple[torch.nn.Module, training.History, dict]:
    """Dynamic Future Net: the frame autoencoder, the sequence autoencoder, the dynamics
    model, one after another (Chen §5.6; :func:`motionlab.training.train_stages`)."""
    prepared = _prepare(args, config.fps, args.window_s)
    model = _model(args, config)
    configs = {stage: plan.train_config(len(prepared.train), stage) for stage in models.card("dfn").stages}
    histories = training.train_stages(model, prepared, configs, **_state(args))
    for stage, history in histories.items():
        say(f"stage {stage}: {len(history.train)} steps, final loss {history.series('loss')[1][-1]:.4f}")
    return model, _joined(histories), {"data": prepared}


TRAINERS = {"vae": train_vae, "dfn": train_dfn}
"""Models trained in their own way; every other one is :func:`train_windows`."""


def main(argv: list[str] | None = None) -> training.History:
    parser = build_parser()
    args = parser.parse_args(argv)
    check_model_options(parser, args)
    config = build_config(parser, args)
    if args.model == "dfn":
        args.window_s = dfn_window_s(parser, args, config)
    plan = training_plan(args)
    joined = training.init_distributed()               # under torchrun: one process per GPU / CPU share
    rank, world = training.distributed()
    try:
        if plan.batch_size % world:
            parser.error(f"--batch-size: {plan.batch_size} windows do not split over {world} processes; "
                         f"give a multiple of {world} (the batch is the global one)")
        if rank == 0:
            print(plan.describe())
            device = training.pick_device(args.device)
            print(f"device: {device}" + (f" x {world} processes ({torch.distributed.get_backend()})" if joined else ""))
            print(f"batch: {plan.batch_size} windows per step in all ({plan.batch_size // world} per process "
                  f"x {world} process{'es' if world > 1 else ''})")
        model, history, saved = TRAINERS.get(args.model, train_windows)(args, config, plan)
        out = args.out or f"{args.model}.pt"
        if rank == 0:
            training.save_checkpoint(out, model.cpu(), history=history, half=args.half, **saved)
            summary = f"trained in {history.seconds:.1f} s; final training loss {history.series('loss')[1][-1]:.4f}"
            if history.val:
                summary += f", validation loss {history.last('loss'):.4f}"
            print(f"{summary}\nsaved {out}")
        if joined:
            torch.distributed.barrier()                # every process leaves together, after rank 0 saved
    finally:
        if joined:
            torch.distributed.destroy_process_group()
    return history


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
