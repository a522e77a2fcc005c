"""How to train and what happened: :class:`TrainConfig`, :class:`History`, the precisions
training may compute in, the error a non-finite loss raises, and seeding and device choice."""
from __future__ import annotations

import random
from dataclasses import dataclass, field

import numpy as np
import torch

from .. import checks


PRECISIONS = {"fp32": None, "bf16": torch.bfloat16, "fp16": torch.float16}
"""``TrainConfig.precision``: the dtype autocast computes in (``None``: float32 throughout)."""


@dataclass
class TrainConfig:
    """How to train (not what): the same for every model.

    Attributes:
        epochs: passes over the training windows.
        batch_size: windows per step.
        lr: peak learning rate of Adam.
        weight_decay: Adam's (L2) weight decay.
        schedule: ``"cosine"`` (decay to ``lr * min_lr_ratio`` over training) or ``"constant"``.
        warmup_steps: linear warm-up from 0 at the start.
        grad_clip: clip the gradient norm to this (``None``: no clipping).
        seed: seeds torch, numpy and Python, and the order of batches.
        device: ``"auto"`` (a GPU when there is one), ``"cpu"``, ``"cuda"``, ...
        max_steps: stop after this many steps (``None``: all epochs).
        num_threads: CPU threads for torch (``None``: torch's default).
        progress: show a progress bar.
        save_every_steps, save_every_s: with a ``state_file`` (see :func:`train`), save the
            run's state every this many steps and/or seconds (``None``: only at the end).
        estimate: before training, time a few steps on a copy of the model
            (:func:`seconds_per_step`) and print the expected time of the run.
        precision: ``"fp32"``, or mixed precision: ``"bf16"`` or ``"fp16"`` (``torch.autocast``
            around the loss; fp16 with a gradient scaler). Weights, Adam and the logged loss
            stay float32, and the flows keep their transforms and log-determinants in
            float32 (:func:`motionlab.models.flows.full_precision`).
    """

    epochs: int = 20
    batch_size: int = 32
    lr: float = 1e-3
    weight_decay: float = 0.0
    schedule: str = "cosine"
    min_lr_ratio: float = 0.1
    warmup_steps: int = 0
    grad_clip: float | None = 1.0
    seed: int = 0
    device: str = "auto"
    max_steps: int | None = None
    num_threads: int | None = None
    progress: bool = True
    save_every_steps: int | None = None
    save_every_s: float | None = None
    estimate: bool = False
    precision: str = "fp32"

    def __post_init__(self):
        checks.config(self, positive_fields=("lr", "grad_clip", "save_every_s"), non_negative_fields=("weight_decay",),
                      fraction_fields=("min_lr_ratio",), zero_allowed=("warmup_steps", "seed"))
        if self.epochs < 1 or self.batch_size < 1 or self.lr <= 0:
            raise ValueError(f"epochs, batch_size and lr must be positive, got {self.epochs}, "
                             f"{self.batch_size}, {self.lr}")
        if self.schedule not in ("cosine", "constant"):
            raise ValueError(f"schedule: expected 'cosine' or 'constant', got {self.schedule!r}")
        if self.precision not in PRECISIONS:
            raise ValueError(f"precision: expected one of {', '.join(PRECISIONS)}, got {self.precision!r}")
        if (self.save_every_steps is not None and self.save_every_steps < 1) or \
                (self.save_every_s is not None and not self.save_every_s > 0):
            raise ValueError(f"save_every_steps and save_every_s must be positive, got "
                             f"{self.save_every_steps}, {self.save_every_s}")


@dataclass
class History:
    """What happened during training.

    Attributes:
        train: one dict per step: ``step``, ``epoch``, ``lr`` and the model's loss terms.
        val: one dict per epoch: ``step``, ``epoch`` and the mean loss terms on validation.
        seconds: wall-clock training time.
    """

    train: list[dict[str, float]] = field(default_factory=list)
    val: list[dict[str, float]] = field(default_factory=list)
    seconds: float = 0.0

    def series(self, key: str = "loss", split: str = "train") -> tuple[np.ndarray, np.ndarray]:
        """``(steps, values)`` of one logged quantity."""
        rows = getattr(self, split)
        rows = [r for r in rows if key in r]
        if not rows:
            raise ValueError(f"key: {key!r} was not logged in {split!r}")
        return np.array([r["step"] for r in rows]), np.array([r[key] for r in rows])

    def last(self, key: str = "loss", split: str = "val") -> float:
        return float(self.series(key, split)[1][-1])

    def to_dict(self) -> dict:
        return {"train": self.train, "val": self.val, "seconds": self.seconds}

    @classmethod
    def from_dict(cls, state: dict) -> "History":
        """The inverse of :meth:`to_dict`; ``ValueError`` if ``state`` is not such a dict."""
        def rows(key: str) -> list[dict[str, float]]:
            value = state.get(key, [])
            if not isinstance(value, list) or not all(
                    isinstance(row, dict) and all(isinstance(k, str) and isinstance(v, (int, float))
                                                  for k, v in row.items()) for row in value):
                raise ValueError(f"history: {key!r} must be a list of {{name: number}} rows")
            return value
        if not isinstance(state, dict):
            raise ValueError(f"history: expected a dict, got {type(state).__name__}")
        seconds = state.get("seconds", 0.0)
        if not isinstance(seconds, (int, float)):
            raise ValueError(f"history: 'seconds' must be a number, got {seconds!r}")
        return cls(rows("train"), rows("val"), float(seconds))


class NonFiniteLossError(RuntimeError):
    """The loss became NaN or infinite: training stopped before the weights were ruined."""


def seed_everything(seed: int) -> None:
    """Seed Python, numpy and torch (CPU and GPU)."""
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)


def pick_device(device: str = "auto") -> torch.device:
    """``"auto"``: the first CUDA GPU if there is one, else the CPU."""
    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    return torch.device(device)
