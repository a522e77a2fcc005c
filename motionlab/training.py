"""The one training loop every model in motionlab uses, and its checkpoints.

A model is an ``nn.Module`` with a ``config`` (a dataclass) and a method
``loss(batch) -> dict`` that returns a scalar tensor under ``"loss"`` plus anything else
worth logging (reconstruction error, KL, ...). Everything else lives here, once::

    model = ConvAutoencoder(ConvAEConfig())
    history = train(model, prepared, TrainConfig(epochs=30))
    viz.plot_history(history)
    save_checkpoint("conv_ae.pt", model, prepared)

The loop: Adam (by default), a learning-rate schedule, gradient clipping, a progress bar
(:mod:`motionlab.progress`: one output redrawn in place in notebooks, tqdm in terminals),
validation after every epoch, seeding, a :class:`History` of every step, and a guard that stops with a clear message
the moment the loss stops being a finite number.
"""
from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import random
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from . import checks, progress

CHECKPOINT_FORMAT = "motionlab-checkpoint-1"

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


def distributed() -> tuple[int, int]:
    """``(rank, world_size)`` of this process: ``(0, 1)`` unless ``torch.distributed`` is
    initialised (:func:`init_distributed`, under ``torchrun``)."""
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        return torch.distributed.get_rank(), torch.distributed.get_world_size()
    return 0, 1


def init_distributed() -> bool:
    """Join the process group when this process was started by ``torchrun`` (``WORLD_SIZE``
    and ``LOCAL_RANK`` set): NCCL when there is a GPU (each process takes GPU
    ``LOCAL_RANK``), gloo on CPU. Returns whether it did; :func:`train` then trains with
    ``DistributedDataParallel``."""
    if "WORLD_SIZE" not in os.environ or torch.distributed.is_initialized():
        return torch.distributed.is_initialized()
    gpu = torch.cuda.is_available()
    if gpu:
        torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", 0)))
    torch.distributed.init_process_group("nccl" if gpu else "gloo")
    return True


class _Loss(nn.Module):
    """``model.loss`` as a forward pass: DistributedDataParallel averages the gradients of
    what its module's forward computes, and every motionlab model trains through ``loss``."""

    def __init__(self, model: nn.Module):
        super().__init__()
        self.model = model

    def forward(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        return self.model.loss(batch)


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
          history: History | None = None, *, state_file: str | Path | None = None,
          resume: bool = False) -> History:
    """Train ``model`` on ``data`` and return the :class:`History`.

    Args:
        model: an ``nn.Module`` with ``loss(batch) -> dict`` (``"loss"`` is minimised).
        data: a :class:`motionlab.data.MotionData` (its ``train`` and ``val`` sets), a
            ``(train, val)`` pair of datasets, or one training dataset.
        config: a :class:`TrainConfig` (default settings if ``None``).
        history: continue this history (training more epochs later).
        state_file: keep the run's state here (:func:`save_state`: weights, optimiser,
            schedule, step, random states, position in the data), every
            ``config.save_every_steps`` steps or ``config.save_every_s`` seconds and at the end.
        resume: continue from ``state_file`` when it exists: the run then ends exactly as
            if it had never stopped (same batches, same random draws, same weights; the
            config must be the one the state was saved with).

    Under ``torchrun`` (after :func:`init_distributed`) every process runs this with the same
    arguments: ``config.batch_size`` is the *global* batch, split evenly over the processes
    (a ``DistributedSampler`` gives each its share of every epoch's shuffle), the model is
    wrapped in ``DistributedDataParallel``, the logged terms are averaged over the processes,
    and only rank 0 shows progress and writes ``state_file``.

    Training runs on ``config.device`` (``"auto"``: a GPU when there is one); when it ends
    the model goes back to the device it came on (normally the CPU, where the notebooks'
    tensors are), in eval mode. When ``data`` has a ``normalizer`` the model keeps it as
    ``model.normalizer``, so its ``generate`` works in the data's units.

    Raises:
        NonFiniteLossError: the loss became NaN or infinite (message says where and what to try).
    """
    config = config or TrainConfig()
    train_set, val_set = _datasets(data)
    if len(train_set) == 0:
        raise ValueError("data: the training set is empty")
    if resume and state_file is None:
        raise ValueError("resume: needs a state_file to resume from")
    if getattr(data, "normalizer", None) is not None:
        model.normalizer = data.normalizer
    if config.num_threads:
        torch.set_num_threads(config.num_threads)
    rank, world = distributed()
    if config.batch_size % world:
        raise ValueError(f"batch_size: {config.batch_size} windows do not split over {world} processes; "
                         f"give a multiple of {world}")
    seed_everything(config.seed + rank)        # each process its own noise (dropout, sampling)
    device = pick_device(config.device)
    home = next(model.parameters(), torch.empty(0)).device
    model.to(device).train()
    history = history or History()
    start_step = history.train[-1]["step"] + 1 if history.train else 0
    start_epoch = history.train[-1]["epoch"] + 1 if history.train else 0

    generator = torch.Generator().manual_seed(config.seed + start_epoch)
    sampler = None
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        sampler = torch.utils.data.DistributedSampler(train_set, num_replicas=world, rank=rank, shuffle=True,
                                                      seed=config.seed, drop_last=True)
        share = len(sampler)
        loader = torch.utils.data.DataLoader(train_set, batch_size=config.batch_size // world, sampler=sampler,
                                             drop_last=share > config.batch_size // world)
        compute = torch.nn.parallel.DistributedDataParallel(
            _Loss(model), device_ids=[device.index or torch.cuda.current_device()] if device.type == "cuda" else None)
    else:
        loader = torch.utils.data.DataLoader(train_set, batch_size=config.batch_size, shuffle=True,
                                             drop_last=len(train_set) > config.batch_size,
                                             generator=generator)
        compute = model.loss
    total = config.epochs * len(loader)
    if config.max_steps is not None:
        total = min(total, config.max_steps)
    optimizer = adam(model.parameters(), config.lr, config.weight_decay)

    def lr_factor(step: int) -> float:
        if step < config.warmup_steps:
            return (step + 1) / config.warmup_steps
        if config.schedule == "constant":
            return 1.0
        progress = (step - config.warmup_steps) / max(1, total - config.warmup_steps)
        return config.min_lr_ratio + (1 - config.min_lr_ratio) * 0.5 * (1 + math.cos(math.pi * progress))

    scheduler = torch.optim.lr_scheduler.LambdaLR(optimizer, lr_factor)
    low_precision = PRECISIONS[config.precision]
    scaler = torch.amp.GradScaler(device.type, enabled=config.precision == "fp16")   # fp16 gradients underflow

    def mixed_precision():
        if low_precision is None:
            return contextlib.nullcontext()
        return torch.autocast(device.type, dtype=low_precision)

    # where the run is: steps done, the epoch and the batches done in it, and the batch
    # generator's state when that epoch began (its shuffle is drawn from it)
    run = {"step": 0, "epoch": start_epoch, "position": 0, "epoch_generator": generator.get_state(),
           "start_step": start_step, "start_epoch": start_epoch}
    if resume and Path(state_file).exists():
        history = _restore_state(state_file, model, optimizer, scheduler, config, run, scaler)
        start_step, start_epoch = run["start_step"], run["start_epoch"]
        generator.set_state(run["epoch_generator"])
    if config.estimate and rank == 0 and run["step"] < total:
        batch = next(iter(torch.utils.data.DataLoader(train_set, batch_size=config.batch_size // world)))
        seconds = seconds_per_step(model, batch.to(device), config)
        print(f"expected: {seconds:.3g} s per step on {device}, {_duration((total - run['step']) * seconds)} "
              f"for {total - run['step']} steps")
    bar = progress.bar(total, initial=run["step"], desc=type(model).__name__, unit="step",
                       disable=not config.progress or rank > 0)
    began = last_save = time.perf_counter()
    seconds_before = history.seconds
    step, last_finite = run["step"], None

    def save() -> None:
        history.seconds = seconds_before + time.perf_counter() - began
        run.update(step=step)
        generators = _random_states()
        if world > 1:                     # every process's generators, so that each resumes its own
            everyone = [None] * world
            torch.distributed.all_gather_object(everyone, generators)
            generators = everyone
        if rank == 0:
            save_state(state_file, model, optimizer, scheduler, config, history, run, generators, scaler)

    try:
        for epoch in range(run["epoch"], start_epoch + config.epochs):
            if step >= total:
                break
            if epoch != run["epoch"]:                   # a new epoch (not the one being resumed)
                run.update(epoch=epoch, position=0, epoch_generator=generator.get_state())
            if sampler is not None:
                sampler.set_epoch(epoch)                # each epoch's shuffle, the same in every process
            batches = iter(loader)
            for _ in range(run["position"]):            # resuming mid-epoch: the same shuffle, skipped
                next(batches)
            for batch in batches:
                with mixed_precision():
                    terms = compute(batch.to(device))
                loss = terms["loss"].float()
                logged = {key: value.detach().float().reshape(()) for key, value in terms.items()}
                if world > 1:                           # the global batch's mean, the same in every process
                    values = torch.stack(list(logged.values()))
                    torch.distributed.all_reduce(values)
                    logged = dict(zip(logged, values / world))
                if not torch.isfinite(logged["loss"]):
                    raise NonFiniteLossError(
                        f"the loss became {loss.item()} at epoch {epoch}, step {start_step + step} "
                        f"(last finite loss: {last_finite}). Try a lower learning rate "
                        f"(lr={config.lr:g}), gradient clipping (grad_clip={config.grad_clip}), or "
                        "check the data for NaNs.")
                optimizer.zero_grad(set_to_none=True)
                scaler.scale(loss).backward()
                if config.grad_clip is not None:
                    scaler.unscale_(optimizer)          # clip the true gradients (a no-op without fp16)
                    nn.utils.clip_grad_norm_(model.parameters(), config.grad_clip)
                scaler.step(optimizer)                  # fp16: skips a step whose gradients overflowed
                scaler.update()
                scheduler.step()
                last_finite = float(logged["loss"])
                row = {"step": start_step + step, "epoch": epoch, "lr": optimizer.param_groups[0]["lr"]}
                row.update({key: float(value) for key, value in logged.items()})
                history.train.append(row)
                step += 1
                run["position"] += 1
                bar.update(1)
                if state_file is not None and (
                        (config.save_every_steps and step % config.save_every_steps == 0) or
                        (config.save_every_s and time.perf_counter() - last_save >= config.save_every_s)):
                    save()
                    last_save = time.perf_counter()
                if step >= total:
                    break
            if val_set is not None and len(val_set) > 0:
                val = _mean_terms(model, val_set, config.batch_size, device)
                history.val.append({"step": start_step + step - 1, "epoch": epoch, **val})
                bar.set_postfix(loss=f"{last_finite}" if last_finite is None else f"{last_finite:.4f}",
                                val=f"{val['loss']:.4f}")
            elif last_finite is not None:
                bar.set_postfix(loss=f"{last_finite:.4f}")
            run.update(epoch=epoch + 1, position=0, epoch_generator=generator.get_state())
    finally:
        bar.close()
        seconds = time.perf_counter() - began
        history.seconds = seconds_before + seconds
    if state_file is not None:
        save()
    model.to(home).eval()
    if last_finite is None and history.train:
        last_finite = history.train[-1]["loss"]
    if config.progress and rank == 0:   # a bar's saved state is its first; this line is what a saved notebook keeps
        print(summary_line(type(model).__name__, step, seconds, last_finite,
                           history.val[-1]["loss"] if val_set is not None and history.val else None))
    return history


def adam(parameters, lr: float, weight_decay: float = 0.0) -> torch.optim.Adam:
    """Adam over the ``parameters`` that require gradients, with PyTorch's fused kernel (one
    pass over all weights per step instead of one small operation per tensor) where this
    PyTorch has one for their device, the ordinary one otherwise: the same update either way.
    Measured on 2 CPU cores at laptop size, batch 32 (``benchmarks/training_speed.py``): the
    VAE makes 1.55x as many steps per second, Glow, MoGlow and the VAE-LSTM about 1.1x; the
    other models' steps change by less than the run-to-run noise."""
    parameters = [p for p in parameters if p.requires_grad]
    try:
        return torch.optim.Adam(parameters, lr=lr, weight_decay=weight_decay, fused=True)
    except (RuntimeError, ValueError):             # no fused kernel in this PyTorch for this device
        return torch.optim.Adam(parameters, lr=lr, weight_decay=weight_decay)


def seconds_per_step(model: nn.Module, batch: torch.Tensor, config: TrainConfig | None = None,
                     repeats: int = 3) -> float:
    """Seconds one training step of ``model`` takes on ``batch`` (loss, backward, clipping,
    Adam), the median of ``repeats`` after one warm-up step, measured on a copy: the model,
    its optimiser and every random generator are left as they were."""
    import copy
    config = config or TrainConfig()
    saved = _random_states()
    twin = copy.deepcopy(model).train()
    optimizer = adam(twin.parameters(), config.lr, config.weight_decay)
    times = []
    for k in range(repeats + 1):
        began = time.perf_counter()
        loss = twin.loss(batch)["loss"]
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        if config.grad_clip is not None:
            nn.utils.clip_grad_norm_(twin.parameters(), config.grad_clip)
        optimizer.step()
        if batch.is_cuda:
            torch.cuda.synchronize()
        if k:
            times.append(time.perf_counter() - began)
    _set_random_states(saved)
    return float(np.median(times))


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"about {seconds:.0f} s"
    if seconds < 2 * 3600:
        return f"about {seconds / 60:.0f} min"
    return f"about {seconds / 3600:.1f} h"


STATE_FORMAT = "motionlab-train-state-1"
_RESUME_FREE = ("device", "num_threads", "progress", "save_every_steps", "save_every_s", "estimate")
"""TrainConfig fields a resumed run may change: they do not change what is computed."""


def _random_states() -> dict:
    """This process's random generators (torch, Python, numpy, CUDA) as plain values."""
    np_state = np.random.get_state()        # plain lists of ints: they also travel between processes
    return {"torch": torch.get_rng_state().tolist(), "python": _plain(random.getstate()),
            "numpy": [np_state[0], np_state[1].tolist(), *map(float, np_state[2:])],
            "cuda": [s.tolist() for s in torch.cuda.get_rng_state_all()] if torch.cuda.is_available() else []}


def save_state(path: str | Path, model: nn.Module, optimizer, scheduler, config: TrainConfig,
               history: History, run: dict, generators: dict | list | None = None, scaler=None) -> None:
    """Write everything a run needs to continue exactly (see :func:`train`): the weights
    and buffers, Adam's moments, the schedule, the history, where the run is in the data
    and every random generator's state (``generators``: this process's by default, or a
    list with one per process of a distributed run). Plain tensors and values only; the
    file is replaced atomically, so a crash while saving leaves the previous state."""
    generators = _random_states() if generators is None else generators
    state = {"format": STATE_FORMAT, "model": type(model).__name__,
             "model_config": dataclasses.asdict(model.config) if dataclasses.is_dataclass(getattr(model, "config", None)) else {},
             "config": dataclasses.asdict(config),
             "weights": {k: v.detach().cpu() for k, v in model.state_dict().items()},
             "optimizer": optimizer.state_dict(), "scheduler": scheduler.state_dict(),
             "scaler": scaler.state_dict() if scaler is not None and scaler.is_enabled() else {},
             "history": history.to_dict(),
             "run": {k: (v.clone() if isinstance(v, torch.Tensor) else int(v)) for k, v in run.items()},
             "rng": generators if isinstance(generators, list) else [generators]}
    path = Path(path)
    partial = path.with_name(path.name + ".partial")
    torch.save(state, partial)
    os.replace(partial, path)


def _set_random_states(rng: dict) -> None:
    """The inverse of :func:`_random_states`."""
    torch.set_rng_state(torch.tensor(rng["torch"], dtype=torch.uint8))
    random.setstate(_tuples(rng["python"]))
    np.random.set_state((rng["numpy"][0], np.array(rng["numpy"][1], dtype=np.uint32), int(rng["numpy"][2]),
                         int(rng["numpy"][3]), float(rng["numpy"][4])))
    if rng["cuda"] and torch.cuda.is_available():
        torch.cuda.set_rng_state_all([torch.tensor(s, dtype=torch.uint8) for s in rng["cuda"]])


def _plain(value):
    """Python's random state (nested tuples of ints) as lists, which a weights-only load reads."""
    return [_plain(v) for v in value] if isinstance(value, (tuple, list)) else value


def _tuples(value):
    return tuple(_tuples(v) for v in value) if isinstance(value, list) else value


def _restore_state(path, model, optimizer, scheduler, config: TrainConfig, run: dict, scaler=None) -> History:
    """Load :func:`save_state`'s file into the run; ``ValueError`` naming the file when it is
    not such a file or was saved by a different model or config."""
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:        # a damaged file, or one that is not a torch file at all
        raise ValueError(f"{path}: not a training state ({type(err).__name__}: {err})") from None
    if not isinstance(state, dict) or state.get("format") != STATE_FORMAT:
        raise ValueError(f"{path}: not a motionlab training state (format {STATE_FORMAT!r})")
    if state["model"] != type(model).__name__:
        raise ValueError(f"{path}: saved while training {state['model']}, not {type(model).__name__}")
    ours = dataclasses.asdict(config)
    changed = sorted(k for k in ours if k not in _RESUME_FREE and state["config"].get(k) != ours[k])
    if dataclasses.is_dataclass(getattr(model, "config", None)) and state["model_config"] != dataclasses.asdict(model.config):
        changed.append("the model's config")
    if changed:
        raise ValueError(f"{path}: saved with a different {', '.join(changed)}; resume with the same "
                         "settings, or start afresh without --resume")
    try:
        model.load_state_dict(state["weights"])
        optimizer.load_state_dict(state["optimizer"])
        scheduler.load_state_dict(state["scheduler"])
        if scaler is not None and scaler.is_enabled() and state.get("scaler"):
            scaler.load_state_dict(state["scaler"])
        history = History.from_dict(state["history"])
        run.update(state["run"])
        rank, world = distributed()
        if len(state["rng"]) != world:
            raise ValueError(f"{path}: saved by {len(state['rng'])} process(es), resumed by {world}; "
                             "resume with as many")
        _set_random_states(state["rng"][rank])
    except (KeyError, RuntimeError, TypeError, IndexError) as err:
        raise ValueError(f"{path}: damaged training state ({type(err).__name__}: {err})") from None
    return history


def summary_line(name: str, steps: int, seconds: float, loss: float | None, val_loss: float | None = None) -> str:
    """One line that says a training run finished: ``"VAELSTM: 1200 steps in 41.5 s, final
    loss 0.1234 (validation 0.1300)"``."""
    text = f"{name}: {steps} steps in {seconds:.1f} s"
    if loss is not None:
        text += f", final loss {loss:.4g}"
    if val_loss is not None:
        text += f" (validation {val_loss:.4g})"
    return text


def train_stages(model: nn.Module, data, configs, stages: tuple[str, ...] | None = None, *,
                 state_file: str | Path | None = None, resume: bool = False) -> dict:
    """Train a staged model (``model.stages``, e.g. DFN's §5.6: the frame autoencoder, then
    the sequence autoencoder with it frozen, then the dynamics model with both frozen), one
    stage after another with :func:`train`.

    Args:
        model: a model with a ``stages`` tuple and ``set_stage(name, windows)`` that freezes
            what the stage does not train.
        data: a :class:`motionlab.data.MotionData` (or what :func:`train` accepts with a
            ``.train`` set of windows).
        configs: one :class:`TrainConfig` for all stages, or a dict from stage name to its config.
        stages: which stages to run, in order (default: all; a later stage needs the earlier
            ones trained).
        state_file, resume: as for :func:`train`; each stage keeps its own state in
            ``<state_file>.<stage>``, so a resumed run skips the stages that finished.

    Returns ``{stage: History}``; afterwards every parameter is trainable again.
    """
    known = tuple(getattr(model, "stages", ()))
    if not known or not hasattr(model, "set_stage"):
        raise ValueError(f"model: {type(model).__name__} is not trained in stages (no stages / set_stage)")
    stages = known if stages is None else tuple(stages)
    unknown = [s for s in stages if s not in known]
    if unknown:
        raise ValueError(f"stages: unknown {unknown}; expected some of {known}")
    if isinstance(configs, dict):
        missing = [s for s in stages if s not in configs]
        if missing:
            raise ValueError(f"configs: no TrainConfig for stage(s) {missing}")
    windows = getattr(data, "train", data)
    windows = windows.windows if hasattr(windows, "windows") else torch.stack(list(windows))
    if getattr(data, "normalizer", None) is not None:
        model.normalizer = data.normalizer          # as train() does; set_stage may need the data's units
    histories = {}
    for stage in stages:
        model.set_stage(stage, windows)
        stage_state = None if state_file is None else Path(f"{state_file}.{stage}")
        histories[stage] = train(model, data, configs[stage] if isinstance(configs, dict) else configs,
                                 state_file=stage_state, resume=resume)
    for p in model.parameters():
        p.requires_grad_(True)
    return histories



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


class CheckpointMismatch(ValueError):
    """A sound checkpoint that holds another model, config or data than the one asked for
    (:func:`train_or_load` then trains instead). Every other problem with a checkpoint file
    is a plain ``ValueError``."""


_REGISTERED: dict[str, tuple[type, type]] = {}


def _class_path(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def register_model(model_class: type, config_class: type) -> None:
    """Let checkpoints hold ``model_class`` (built as ``model_class(config_class(**saved))``).

    motionlab's own models (:func:`registered_models`) are always registered.
    Loading never imports or calls a name read from the file: the file's class name is only
    looked up among the classes registered here, in code.
    """
    if not (isinstance(model_class, type) and issubclass(model_class, nn.Module)):
        raise ValueError(f"model_class: expected an nn.Module subclass, got {model_class!r}")
    if not (isinstance(config_class, type) and dataclasses.is_dataclass(config_class)):
        raise ValueError(f"config_class: expected a dataclass, got {config_class!r}")
    _REGISTERED[_class_path(model_class)] = (model_class, config_class)


def registered_models() -> dict[str, tuple[type, type]]:
    """``{"module.ModelClass": (model class, config class)}`` of every model a checkpoint may hold."""
    from . import models                       # the model cards (motionlab.models.FILES)
    known = {_class_path(card.model): (card.model, card.config) for card in models.cards().values()}
    known.update(_REGISTERED)
    return known


def save_checkpoint(path: str | Path, model: nn.Module, data=None, history: History | None = None,
                    normalizer=None, description: dict | None = None, half: bool = False) -> None:
    """Save weights, config, normaliser and data description in one file.

    ``data`` is the :class:`motionlab.data.MotionData` the model trained on (its normaliser
    and description are saved); or pass ``normalizer`` and ``description`` directly.
    ``half=True`` stores floating-point weights as float16 (half the size, for checkpoints
    shipped with the course); they load back into the float32 model. Buffers (fitted
    statistics such as a model's normalisation or skeleton) are kept in float32. The file is
    written under another name first and then renamed, so an interrupted save never leaves
    half a checkpoint behind.
    """
    if not dataclasses.is_dataclass(getattr(model, "config", None)):
        raise ValueError("model: needs a dataclass `config` attribute to be saved")
    if normalizer is None:
        normalizer = getattr(data, "normalizer", None) or getattr(model, "normalizer", None)
    description = description if description is not None else getattr(data, "description", {})
    weights = {name for name, _ in model.named_parameters()}     # buffers (statistics, a skeleton) stay float32
    state = {
        "format": CHECKPOINT_FORMAT,
        "model_class": _class_path(type(model)),
        "config_class": _class_path(type(model.config)),
        "config": dataclasses.asdict(model.config),
        "state_dict": {k: (v.detach().cpu().half() if half and k in weights and v.is_floating_point()
                           else v.detach().cpu()) for k, v in model.state_dict().items()},
        "normalizer": normalizer.state_dict() if normalizer is not None else None,
        "description": description,
        "history": history.to_dict() if history is not None else None,
    }
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".partial")
    torch.save(state, partial)
    os.replace(partial, path)


_CHECKPOINT_KEYS = {"model_class": str, "config_class": str, "config": dict, "state_dict": dict,
                    "normalizer": (dict, type(None)), "description": dict, "history": (dict, type(None))}


def _read_state(path: Path) -> dict:
    """The checkpoint's dict of plain data and tensors, every key present with its type."""
    if not path.is_file():
        raise ValueError(f"{path}: no such checkpoint file")
    try:   # weights_only: the unpickler builds tensors and plain containers, never a class from the file
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:         # torch raises many kinds on a damaged file; all mean "unreadable"
        raise ValueError(f"{path}: cannot read checkpoint ({type(err).__name__}: {err})") from None
    if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"{path}: not a motionlab checkpoint")
    for key, kind in _CHECKPOINT_KEYS.items():
        if key not in state:
            raise ValueError(f"{path}: checkpoint is missing {key!r}")
        if not isinstance(state[key], kind):
            raise ValueError(f"{path}: checkpoint's {key!r} is a {type(state[key]).__name__}")
    for name, tensor in state["state_dict"].items():
        if not isinstance(name, str) or not isinstance(tensor, torch.Tensor):
            raise ValueError(f"{path}: checkpoint's weights must map names to tensors ({name!r})")
        if tensor.is_floating_point() and not torch.isfinite(tensor).all():
            raise ValueError(f"{path}: weight {name!r} holds NaN or infinite values")
    return state


def _saved_config(path: Path, state: dict, config_class: type):
    """The config the checkpoint was trained with, built from plain values only."""
    fields = {f.name for f in dataclasses.fields(config_class)}
    unknown = sorted(set(map(str, state["config"])) - fields)
    if unknown:
        raise ValueError(f"{path}: config has fields {config_class.__name__} does not know: {', '.join(unknown)}")
    defaults = config_class()
    for name, value in state["config"].items():
        default = getattr(defaults, name)
        if not _same_kind(value, default):
            raise ValueError(f"{path}: config does not make a {config_class.__name__} "
                             f"({name} = {value!r}, expected a {type(default).__name__})")
    try:
        return config_class(**state["config"])
    except (TypeError, ValueError) as err:
        raise ValueError(f"{path}: config does not make a {config_class.__name__} ({err})") from None


def _same_kind(value, default) -> bool:
    """Whether a config value read from a file has the type of the field's default."""
    if default is None or value is None:
        return True                                      # optional fields
    if isinstance(default, bool) or isinstance(value, bool):
        return type(value) is type(default)
    if isinstance(default, float):
        return isinstance(value, (int, float))
    if isinstance(default, (tuple, list)):
        return isinstance(value, (tuple, list)) and all(
            _same_kind(item, default[0]) for item in value) if default else isinstance(value, (tuple, list))
    return isinstance(value, type(default))


def _meta_model(path: Path, model_class: type, config, state_dict: dict) -> None:
    """Build the model without memory (torch's meta device) and check that the file's
    weights fit it exactly, before anything real is allocated.

    A config read from a file could ask for any size; building it for real first could
    allocate gigabytes (or loop for ever). Here construction stops as soon as the model
    registers more tensors than the file holds, and the model's full size (buffers too)
    must be within reach of the weights' size in the file.
    """
    limit = 2 * len(state_dict) + 64                        # plus buffers that are not saved
    registered = 0

    def count(*_):
        nonlocal registered
        registered += 1
        if registered > limit:
            raise CheckpointMismatch(f"{path}: its config builds a model with more than {limit} tensors, "
                                     f"but the file holds {len(state_dict)}")

    hooks = [nn.modules.module.register_module_parameter_registration_hook(count),
             nn.modules.module.register_module_buffer_registration_hook(count)]
    try:
        with torch.random.fork_rng(devices=[]), torch.device("meta"):   # leave the caller's RNG alone
            model = model_class(config)
    except (TypeError, ValueError, RuntimeError, IndexError, ZeroDivisionError) as err:
        if isinstance(err, CheckpointMismatch):
            raise
        raise ValueError(f"{path}: its config does not build a {model_class.__name__} ({err})") from None
    finally:
        for hook in hooks:
            hook.remove()
    expected = model.state_dict()
    missing, unexpected = sorted(set(expected) - set(state_dict)), sorted(set(state_dict) - set(expected))
    wrong = [f"{k} {tuple(state_dict[k].shape)} != {tuple(v.shape)}" for k, v in expected.items()
             if k in state_dict and state_dict[k].shape != v.shape]
    if missing or unexpected or wrong:
        raise CheckpointMismatch(
            f"{path}: weights do not fit {model_class.__name__}: "
            + "; ".join(part for part in [f"missing {missing[:5]}" if missing else "",
                                          f"unexpected {unexpected[:5]}" if unexpected else "",
                                          f"shapes {wrong[:5]}" if wrong else ""] if part))
    in_file = sum(t.numel() * t.element_size() for t in state_dict.values())
    in_model = sum(t.numel() * t.element_size() for t in (*model.parameters(), *model.buffers()))
    if in_model > 4 * in_file + 2 ** 28:                   # 256 MB of unsaved buffers at most
        raise ValueError(f"{path}: its config builds a model of {in_model / 2 ** 30:.1f} GiB "
                         f"from {in_file / 2 ** 20:.1f} MiB of weights")


def _feature_count(config) -> int | None:
    """How many data features (columns of the normaliser) a model's config reads, if it says."""
    if hasattr(config, "n_features"):
        return config.n_features
    if hasattr(config, "n_pose") and hasattr(config, "n_control"):
        return config.n_pose + config.n_control
    return None


def load_checkpoint(path: str | Path, config=None, device: str = "cpu") -> Checkpoint:
    """Load a checkpoint saved by :func:`save_checkpoint`.

    With ``config``, the checkpoint must have been trained with exactly that config (same
    class and values); otherwise a :class:`CheckpointMismatch` (a ``ValueError``) names the
    fields that differ.

    Only registered model classes (:func:`registered_models`) are ever built, from plain
    values; nothing named in the file is imported or called. A file that cannot be read,
    is missing keys, names another class, holds NaN or infinite weights, weights that do
    not fit the model, or a normaliser of the wrong width raises ``ValueError`` naming it.
    """
    from .data import Normalizer
    path = Path(path)
    state = _read_state(path)
    classes = registered_models().get(state["model_class"])
    if classes is None:
        raise ValueError(f"{path}: holds a {state['model_class']!r}, which is not one of motionlab's "
                         "registered models (see motionlab.training.register_model)")
    model_class, config_class = classes
    if state["config_class"] != _class_path(config_class):
        raise ValueError(f"{path}: a {model_class.__name__} is configured by {config_class.__name__}, "
                         f"not {state['config_class']!r}")
    saved = _saved_config(path, state, config_class)
    if config is not None:
        if type(config) is not config_class:
            raise CheckpointMismatch(f"{path}: holds a {config_class.__name__}, not a {type(config).__name__}")
        different = [f"{f.name}: checkpoint {getattr(saved, f.name)!r} != requested {getattr(config, f.name)!r}"
                     for f in dataclasses.fields(saved) if getattr(saved, f.name) != getattr(config, f.name)]
        if different:
            raise CheckpointMismatch(f"{path}: trained with another config; " + "; ".join(different))
    _meta_model(path, model_class, saved, state["state_dict"])
    model = model_class(saved)
    model.load_state_dict(state["state_dict"])
    model.to(device).eval()
    normalizer = None
    if state["normalizer"] is not None:
        try:
            normalizer = Normalizer.from_state_dict(state["normalizer"])
        except (TypeError, ValueError) as err:
            raise ValueError(f"{path}: normaliser is not valid ({err})") from None
        width = _feature_count(saved)
        if width is not None and len(normalizer.mean) != width:
            raise ValueError(f"{path}: normaliser has {len(normalizer.mean)} features, "
                             f"the model reads {width}")
        model.normalizer = normalizer
    try:
        history = History.from_dict(state["history"]) if state["history"] else History()
    except (TypeError, ValueError) as err:
        raise ValueError(f"{path}: training history is not valid ({err})") from None
    return Checkpoint(model, normalizer, state["description"], history)


_DATA_KEYS = ("source", "fps", "window_frames", "stride_frames", "augment", "clips")


def _matching_checkpoint(path: Path, model: nn.Module, data) -> Checkpoint | None:
    """The checkpoint at ``path`` if it holds ``model``'s class and config, trained on data
    made the same way as ``data``; else ``None``."""
    if not path.exists():
        return None
    try:
        checkpoint = load_checkpoint(path, config=model.config)
    except CheckpointMismatch:
        return None                                # another model or config: train instead
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

    Only a :class:`CheckpointMismatch` (another model, config or data) means "train instead";
    a damaged or unsafe file raises its ``ValueError``, so nothing wrong passes unnoticed.
    """
    if not retrain:
        for candidate in ([Path(pretrained)] if pretrained is not None else []) + [Path(path)]:
            checkpoint = _matching_checkpoint(candidate, model, data)
            if checkpoint is not None:
                model.load_state_dict(checkpoint.model.state_dict())
                model.normalizer = checkpoint.normalizer
                return model.eval(), checkpoint.history
    history = train(model, data, config)
    save_checkpoint(path, model, data, history)
    return model.eval(), history
