"""Train any motionlab model from the command line.

    python -m motionlab.train conv_ae                             # synthetic data, laptop size
    python -m motionlab.train conv_ae --data path/to/cmu/bvh --set window=20
    python -m motionlab.train conv_ae --paper --epochs 200 --device cuda --out runs/conv_ae.pt

The model's config decides the frame rate and window length of the data; ``--set
name=value`` changes any config field. A GPU is used when there is one (``--device``).
The checkpoint holds the weights, config, normaliser and data description, and loads
with ``motionlab.training.load_checkpoint``.
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib
import sys
from pathlib import Path

import torch

from . import checks, data, training
from .models import MODELS

# argparse ``type=`` functions: a bad value becomes a usage error (exit code 2) naming the option.


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


def main(argv: list[str] | None = None) -> training.History:
    parser = argparse.ArgumentParser(prog="python -m motionlab.train", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("model", choices=sorted(MODELS), help="which model to train")
    parser.add_argument("--data", default="synthetic", type=_source,
                        help="'synthetic' or a folder of CMU .bvh files")
    parser.add_argument("--paper", action="store_true", help="the paper's sizes instead of the laptop's")
    parser.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE", help="change config fields")
    parser.add_argument("--epochs", type=_whole(1), default=30)
    parser.add_argument("--batch-size", type=_whole(1), default=32)
    parser.add_argument("--lr", type=_positive(), default=1e-3)
    parser.add_argument("--seed", type=_whole(0), default=0)
    parser.add_argument("--device", default="auto", type=_device, help="auto, cpu, cuda, cuda:1, ...")
    parser.add_argument("--normalization", default="per_feature", choices=["per_feature", "shared_pose"])
    parser.add_argument("--synthetic-clips", type=_whole(1), default=40)
    parser.add_argument("--out", default=None, type=_out, help="checkpoint path (default: <model>.pt)")
    parser.add_argument("--half", action="store_true", help="store the weights as float16 (half the size)")
    parser.add_argument("--stride", type=_positive(checks.MAX_SECONDS), default=None,
                        help="seconds between window starts (default: half a window)")
    args = parser.parse_args(argv)

    module_name, model_name, config_name = MODELS[args.model]
    module = importlib.import_module(module_name)
    config_class = getattr(module, config_name)
    try:
        changes = parse_overrides(config_class, args.set)          # its messages name --set
        config = config_class.paper(**changes) if args.paper else config_class(**changes)
        checks.rate(config.fps, "fps")
    except (TypeError, ValueError) as err:
        parser.error(str(err) if str(err).startswith("--set") else f"--set: {err}")
    clips = data.load(args.data, fps=config.fps, n_clips=args.synthetic_clips, seed=args.seed)
    prepared = data.prepare(clips, window_s=config.window / config.fps, stride_s=args.stride, seed=args.seed,
                            normalization=args.normalization)
    print(prepared.summary())
    print(f"model: {model_name}({config})")
    print(f"device: {training.pick_device(args.device)}")
    model = getattr(module, model_name)(config)
    history = training.train(model, prepared, training.TrainConfig(
        epochs=args.epochs, batch_size=args.batch_size, lr=args.lr, seed=args.seed, device=args.device))
    out = args.out or f"{args.model}.pt"
    training.save_checkpoint(out, model.cpu(), prepared, history, half=args.half)
    summary = f"trained in {history.seconds:.1f} s; final training loss {history.series('loss')[1][-1]:.4f}"
    if history.val:
        summary += f", validation loss {history.last('loss'):.4f}"
    print(f"{summary}\nsaved {out}")
    return history


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
