"""The one training loop every model in motionlab uses, and its checkpoints.

A model is an ``nn.Module`` with a ``config`` (a dataclass) and a method
``loss(batch) -> dict`` that returns a scalar tensor under ``"loss"`` plus anything else
worth logging (reconstruction error, KL, ...). Everything else lives here, once::

    model = ConvAutoencoder(ConvAEConfig())
    history = train(model, prepared, TrainConfig(epochs=30))
    viz.plot_history(history)
    save_checkpoint("conv_ae.pt", model, prepared)

The loop: Adam (by default), a learning-rate schedule, gradient clipping, a progress bar
(``tqdm.auto``: a widget in notebooks, text in terminals), validation after every epoch,
seeding, a :class:`History` of every step, and a guard that stops with a clear message
the moment the loss stops being a finite number.
"""
from __future__ import annotations

import dataclasses
import importlib
import math
import pickle
import random
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn
from tqdm.auto import tqdm

CHECKPOINT_FORMAT = "motionlab-checkpoint-1"


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

    def __post_init__(self):
        if self.epochs < 1 or self.batch_size < 1 or self.lr <= 0:
            raise ValueError(f"epochs, batch_size and lr must be positive, got {self.epochs}, "
                             f"{self.batch_size}, {self.lr}")
        if self.schedule not in ("cosine", "constant"):
            raise ValueError(f"schedule: expected 'cosine' or 'constant', got {self.schedule!r}")


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
        return cls(list(state.get("train", [])), list(state.get("val", [])), float(state.get("seconds", 0.0)))


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


def _datasets(data) -> tuple[torch.utils.data.Dataset, torch.utils.data.Dataset | None]:
    if hasattr(data, "train"):
        return data.train, getattr(data, "val", None)
    if isinstance(data, (tuple, list)) and len(data) == 2:
        return data[0], data[1]
    return data, None


def _mean_terms(model: nn.Module, dataset, batch_size: int, device: torch.device) -> dict[str, float]:
    loader = torch.utils.data.DataLoader(dataset, batch_size=batch_size)
    totals: dict[str, float] = {}
    count = 0
    model.eval()
    with torch.no_grad():
        for batch in loader:
            terms = model.loss(batch.to(device))
            n = len(batch)
            for key, value in terms.items():
                totals[key] = totals.get(key, 0.0) + float(value) * n
            count += n
    model.train()
    return {key: value / count for key, value in totals.items()}


def train(model: nn.Module, data, config: TrainConfig | None = None,
          history: History | None = None) -> History:
    """Train ``model`` on ``data`` and return the :class:`History`.

    Args:
        model: an ``nn.Module`` with ``loss(batch) -> dict`` (``"loss"`` is minimised).
        data: a :class:`motionlab.data.MotionData` (its ``train`` and ``val`` sets), a
            ``(train, val)`` pair of datasets, or one training dataset.
        config: a :class:`TrainConfig` (default settings if ``None``).
        history: continue this history (training more epochs later).

    Training runs on ``config.device`` (``"auto"``: a GPU when there is one); when it ends
    the model goes back to the device it came on (normally the CPU, where the notebooks'
    tensors are), in eval mode.

    Raises:
        NonFiniteLossError: the loss became NaN or infinite (message says where and what to try).
    """
    config = config or TrainConfig()
    train_set, val_set = _datasets(data)
    if len(train_set) == 0:
        raise ValueError("data: the training set is empty")
    if config.num_threads:
        torch.set_num_threads(config.num_threads)
    seed_everything(config.seed)
    device = pick_device(config.device)
    home = next(model.parameters(), torch.empty(0)).device
    model.to(device).train()
    history = history or History()
    start_step = history.train[-1]["step"] + 1 if history.train else 0
    start_epoch = history.train[-1]["epoch"] + 1 if history.train else 0

    generator = torch.Generator().manual_seed(config.seed + start_epoch)
    loader = torch.utils.data.DataLoader(train_set, batch_size=config.batch_size, shuffle=True,
                                         drop_last=len(train_set) > config.batch_size,
                                         generator=generator)
    total = config.epochs * len(loader)
    if config.max_steps is not None:
        total = min(total, config.max_steps)
    optimizer = torch.optim.Adam([p for p in model.parameters() if p.requires_grad],
                                 lr=config.lr, weight_decay=config.weight_decay)

    def lr_factor(step: int) -> float:
        if step < config.warmup_steps:
            return (step + 1) / config.warmup_steps
        if config.schedule == "constant":
            return 1.0
        progress = (step - config.warmup_steps) / max(1, total - config.warmup_steps)
        return config.min_lr_ratio + (1 - config.min_lr_ratio) * 0.5 * (1 + math.cos(math.pi * progress))

    scheduler = torch.optim.lr_scheduler.LambdaLR(optimizer, lr_factor)
    bar = tqdm(total=total, disable=not config.progress, desc=type(model).__name__, unit="step")
    began = time.perf_counter()
    step, last_finite = 0, None
    try:
        for epoch in range(start_epoch, start_epoch + config.epochs):
            for batch in loader:
                terms = model.loss(batch.to(device))
                loss = terms["loss"]
                if not torch.isfinite(loss):
                    raise NonFiniteLossError(
                        f"the loss became {loss.item()} at epoch {epoch}, step {start_step + step} "
                        f"(last finite loss: {last_finite}). Try a lower learning rate "
                        f"(lr={config.lr:g}), gradient clipping (grad_clip={config.grad_clip}), or "
                        "check the data for NaNs.")
                optimizer.zero_grad(set_to_none=True)
                loss.backward()
                if config.grad_clip is not None:
                    nn.utils.clip_grad_norm_(model.parameters(), config.grad_clip)
                optimizer.step()
                scheduler.step()
                last_finite = loss.item()
                row = {"step": start_step + step, "epoch": epoch, "lr": optimizer.param_groups[0]["lr"]}
                row.update({key: float(value.detach()) for key, value in terms.items()})
                history.train.append(row)
                step += 1
                bar.update(1)
                if step >= total:
                    break
            if val_set is not None and len(val_set) > 0:
                val = _mean_terms(model, val_set, config.batch_size, device)
                history.val.append({"step": start_step + step - 1, "epoch": epoch, **val})
                bar.set_postfix(loss=f"{last_finite:.4f}", val=f"{val['loss']:.4f}")
            else:
                bar.set_postfix(loss=f"{last_finite:.4f}")
            if step >= total:
                break
    finally:
        bar.close()
        history.seconds += time.perf_counter() - began
        model.to(home).eval()
    return history


# ----------------------------------------------------------------------------------------
# Checkpoints
# ----------------------------------------------------------------------------------------

@dataclass
class Checkpoint:
    """A loaded checkpoint: the model with its weights, and what it was trained on.

    Attributes:
        model: the ``nn.Module``, in eval mode.
        normalizer: the :class:`motionlab.data.Normalizer` of its training data.
        description: how the data was made (``MotionData.description``).
        history: the training :class:`History`.
    """

    model: nn.Module
    normalizer: Any
    description: dict
    history: History


def _class_path(obj) -> str:
    return f"{type(obj).__module__}.{type(obj).__qualname__}"


def _import(path: str):
    module, _, name = path.rpartition(".")
    return getattr(importlib.import_module(module), name)


def save_checkpoint(path: str | Path, model: nn.Module, data=None, history: History | None = None,
                    normalizer=None, description: dict | None = None, half: bool = False) -> None:
    """Save weights, config, normaliser and data description in one file.

    ``data`` is the :class:`motionlab.data.MotionData` the model trained on (its normaliser
    and description are saved); or pass ``normalizer`` and ``description`` directly.
    ``half=True`` stores floating-point weights as float16 (half the size, for checkpoints
    shipped with the course); they load back into the float32 model.
    """
    if not dataclasses.is_dataclass(getattr(model, "config", None)):
        raise ValueError("model: needs a dataclass `config` attribute to be saved")
    normalizer = normalizer if normalizer is not None else getattr(data, "normalizer", None)
    description = description if description is not None else getattr(data, "description", {})
    state = {
        "format": CHECKPOINT_FORMAT,
        "model_class": _class_path(model),
        "config_class": _class_path(model.config),
        "config": dataclasses.asdict(model.config),
        "state_dict": {k: (v.detach().cpu().half() if half and v.is_floating_point() else v.detach().cpu())
                       for k, v in model.state_dict().items()},
        "normalizer": normalizer.state_dict() if normalizer is not None else None,
        "description": description,
        "history": history.to_dict() if history is not None else None,
    }
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save(state, path)


def load_checkpoint(path: str | Path, config=None, device: str = "cpu") -> Checkpoint:
    """Load a checkpoint saved by :func:`save_checkpoint`.

    With ``config``, the checkpoint must have been trained with exactly that config (same
    class and values); otherwise a ``ValueError`` names the fields that differ.
    """
    from .data import Normalizer
    path = Path(path)
    try:
        state = torch.load(path, map_location=device, weights_only=True)
    except (OSError, RuntimeError, EOFError, pickle.UnpicklingError) as err:
        raise ValueError(f"{path}: cannot read checkpoint ({err})") from None
    if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"{path}: not a motionlab checkpoint")
    config_class = _import(state["config_class"])
    saved = config_class(**state["config"])
    if config is not None:
        if type(config) is not config_class:
            raise ValueError(f"{path}: holds a {config_class.__name__}, not a {type(config).__name__}")
        different = [f"{f.name}: checkpoint {getattr(saved, f.name)!r} != requested {getattr(config, f.name)!r}"
                     for f in dataclasses.fields(saved) if getattr(saved, f.name) != getattr(config, f.name)]
        if different:
            raise ValueError(f"{path}: trained with another config; " + "; ".join(different))
    model = _import(state["model_class"])(saved)
    try:
        model.load_state_dict(state["state_dict"])
    except RuntimeError as err:
        raise ValueError(f"{path}: weights do not fit {state['model_class']} ({err})") from None
    model.to(device).eval()
    normalizer = Normalizer.from_state_dict(state["normalizer"]) if state["normalizer"] else None
    history = History.from_dict(state["history"]) if state["history"] else History()
    return Checkpoint(model, normalizer, state["description"], history)


_DATA_KEYS = ("source", "fps", "window_frames", "stride_frames", "augment", "clips")


def _matching_checkpoint(path: Path, model: nn.Module, data) -> Checkpoint | None:
    """The checkpoint at ``path`` if it holds ``model``'s class and config, trained on data
    made the same way as ``data``; else ``None``."""
    if not path.exists():
        return None
    try:
        checkpoint = load_checkpoint(path, config=model.config)
    except ValueError:
        return None                                # another model or config
    wanted = getattr(data, "description", {})
    if type(checkpoint.model) is not type(model) or \
            any(checkpoint.description.get(k) != wanted.get(k) for k in _DATA_KEYS):
        return None
    return checkpoint


def train_or_load(path: str | Path, model: nn.Module, data, config: TrainConfig | None = None,
                  retrain: bool = False, pretrained: str | Path | None = None) -> tuple[nn.Module, History]:
    """Load ``path`` if it holds this model with this config, else train and save it there.

    Notebooks use it so that a second run (or a later notebook that needs this model) skips
    training. ``pretrained`` is a checkpoint shipped with the course, tried first and never
    written: used when it holds this model and config trained on the same data, so a
    notebook can start from weights that took longer to train than it has. ``retrain=True``
    ignores both and trains. Returns the model (in eval mode) and its history.
    """
    if not retrain:
        for candidate in ([Path(pretrained)] if pretrained is not None else []) + [Path(path)]:
            checkpoint = _matching_checkpoint(candidate, model, data)
            if checkpoint is not None:
                model.load_state_dict(checkpoint.model.state_dict())
                return model.eval(), checkpoint.history
    history = train(model, data, config)
    save_checkpoint(path, model, data, history)
    return model.eval(), history
