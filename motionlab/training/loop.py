"""The training loop: :func:`train` and :func:`train_stages` (a model trained in stages),
the optimiser they use and the timing and summary they print."""
from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from .. import progress
from . import parallel
from .config import PRECISIONS, History, NonFiniteLossError, TrainConfig, pick_device, seed_everything
from .parallel import distributed
from .schedule import lr_factor
from .state import RunState, _random_states, _set_random_states, restore_state, save_state


def _datasets(data) -> tuple[torch.utils.data.Dataset, torch.utils.data.Dataset | None]:
    """``(train, val)`` of what :func:`train` accepts as ``data`` (``val`` may be ``None``)."""
    if hasattr(data, "train"):
        return data.train, getattr(data, "val", None)
    if isinstance(data, (tuple, list)) and len(data) == 2:
        return data[0], data[1]
    return data, None


def _mean_terms(model: nn.Module, dataset, batch_size: int, device: torch.device) -> dict[str, float]:
    """The mean of each of the model's loss terms over ``dataset``, in eval mode, without gradients."""
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
    rank, world = _prepare(model, data, train_set, config, state_file, resume)
    home = next(model.parameters(), torch.empty(0)).device
    run = _setup(model, train_set, config, history or History(), state_file, rank, world)
    if resume and Path(state_file).exists():
        _resume(run)
    if config.estimate and rank == 0 and run.state.step < run.total:
        _print_estimate(run, train_set)
    _start_clock(run)
    try:
        for epoch in range(run.state.epoch, run.state.start_epoch + config.epochs):
            if run.state.step >= run.total:
                break
            _epoch(run, epoch, val_set)
    finally:
        _stop_clock(run)
    if state_file is not None:
        _save(run)
    model.to(home).eval()
    _print_summary(run, val_set)
    return run.history


@dataclass
class _Run:
    """What the steps of one :func:`train` call share: the model and what it trains with,
    built by :func:`_setup`; where the run is (``state``, what a state file keeps); and the
    progress bar, the clock and the last finite loss, kept up to date as it goes."""

    model: nn.Module
    config: TrainConfig
    history: History
    state: RunState
    state_file: str | Path | None
    device: torch.device
    rank: int
    world: int
    generator: torch.Generator                       # the batches' shuffle (one process)
    loader: torch.utils.data.DataLoader
    sampler: torch.utils.data.DistributedSampler | None
    compute: Callable[[torch.Tensor], dict[str, torch.Tensor]]   # model.loss, or its DDP wrapper
    optimizer: torch.optim.Optimizer
    scheduler: torch.optim.lr_scheduler.LambdaLR
    scaler: torch.amp.GradScaler
    total: int                                       # steps this run makes in all
    bar: Any = None
    began: float = 0.0                               # time.perf_counter() at the first step
    last_save: float = 0.0
    seconds_before: float = 0.0                      # the history's training time before this run
    seconds: float = 0.0                             # this run's, once it has stopped
    last_finite: float | None = None


def _prepare(model: nn.Module, data, train_set, config: TrainConfig, state_file, resume: bool) -> tuple[int, int]:
    """Check the arguments, give the model the data's normaliser, set torch's threads and
    seed every generator; returns this process's ``(rank, world_size)``."""
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
    return rank, world


def _setup(model: nn.Module, train_set, config: TrainConfig, history: History, state_file,
           rank: int, world: int) -> _Run:
    """Put the model on its device and build what the steps use: the batches, Adam, the
    learning-rate schedule (:func:`lr_factor`), the gradient scaler, and where the run
    starts (after ``history``'s last step and epoch)."""
    device = pick_device(config.device)
    model.to(device).train()
    start_step = history.train[-1]["step"] + 1 if history.train else 0
    start_epoch = history.train[-1]["epoch"] + 1 if history.train else 0
    generator = torch.Generator().manual_seed(config.seed + start_epoch)
    if parallel.joined():
        loader, sampler = parallel.shard(train_set, config.batch_size, rank, world, config.seed)
        compute = parallel.data_parallel(model, device)
    else:
        loader = torch.utils.data.DataLoader(train_set, batch_size=config.batch_size, shuffle=True,
                                             drop_last=len(train_set) > config.batch_size, generator=generator)
        sampler, compute = None, model.loss
    total = config.epochs * len(loader)
    if config.max_steps is not None:
        total = min(total, config.max_steps)
    optimizer = adam(model.parameters(), config.lr, config.weight_decay)
    scheduler = torch.optim.lr_scheduler.LambdaLR(    # a lambda: LambdaLR saves nothing of a function
        optimizer, lambda step: lr_factor(step, total, config.warmup_steps, config.schedule, config.min_lr_ratio))
    scaler = torch.amp.GradScaler(device.type, enabled=config.precision == "fp16")   # fp16 gradients underflow
    state = RunState(epoch=start_epoch, epoch_generator=generator.get_state(), start_step=start_step,
                     start_epoch=start_epoch)
    return _Run(model, config, history, state, state_file, device, rank, world, generator, loader, sampler,
                compute, optimizer, scheduler, scaler, total)


def _resume(run: _Run) -> None:
    """Continue from the state file: weights, optimiser, schedule, scaler, history, where the
    run was and its random generators, the batches' shuffle included."""
    run.history = restore_state(run.state_file, run.model, run.optimizer, run.scheduler, run.config, run.state,
                                run.scaler)
    run.generator.set_state(run.state.epoch_generator)


def _print_estimate(run: _Run, train_set) -> None:
    """How long the steps left will take, timed on a copy of the model (:func:`seconds_per_step`)."""
    batch = next(iter(torch.utils.data.DataLoader(train_set, batch_size=run.config.batch_size // run.world)))
    seconds = seconds_per_step(run.model, batch.to(run.device), run.config)
    left = run.total - run.state.step
    print(f"expected: {seconds:.3g} s per step on {run.device}, {_duration(left * seconds)} for {left} steps")


def _start_clock(run: _Run) -> None:
    """The progress bar (rank 0 only) and the clock."""
    run.bar = progress.bar(run.total, initial=run.state.step, desc=type(run.model).__name__, unit="step",
                           disable=not run.config.progress or run.rank > 0)
    run.began = run.last_save = time.perf_counter()
    run.seconds_before = run.history.seconds


def _stop_clock(run: _Run) -> None:
    """Close the bar and add this run's time to the history's."""
    run.bar.close()
    run.seconds = time.perf_counter() - run.began
    run.history.seconds = run.seconds_before + run.seconds


def _epoch(run: _Run, epoch: int, val_set) -> None:
    """Train on epoch ``epoch`` (what is left of it when resuming), saving the state when
    due, until its batches or the run's steps run out; then validate."""
    state = run.state
    if epoch != state.epoch:                    # a new epoch (not the one being resumed)
        state.begin_epoch(epoch, run.generator)
    if run.sampler is not None:
        run.sampler.set_epoch(epoch)            # each epoch's shuffle, the same in every process
    batches = iter(run.loader)
    for _ in range(state.position):             # resuming mid-epoch: the same shuffle, skipped
        next(batches)
    for batch in batches:
        _step(run, batch, epoch)
        state.step += 1
        state.position += 1
        run.bar.update(1)
        if _save_due(run):
            _save(run)
            run.last_save = time.perf_counter()
        if state.step >= run.total:
            break
    _validate(run, val_set, epoch)
    state.begin_epoch(epoch + 1, run.generator)


def _step(run: _Run, batch: torch.Tensor, epoch: int) -> None:
    """One optimiser step on ``batch`` and its row of the history: the loss in the configured
    precision, checked to be finite before it reaches the weights, then backward (scaled
    for fp16), gradient clipping, Adam and the learning-rate schedule."""
    config = run.config
    with _autocast(run.device, config.precision):
        terms = run.compute(batch.to(run.device))
    loss = terms["loss"].float()
    logged = {key: value.detach().float().reshape(()) for key, value in terms.items()}
    if run.world > 1:                           # the global batch's mean, the same in every process
        logged = parallel.mean_over_processes(logged, run.world)
    _check_finite(run, logged["loss"], loss, epoch)
    run.optimizer.zero_grad(set_to_none=True)
    run.scaler.scale(loss).backward()
    if config.grad_clip is not None:
        run.scaler.unscale_(run.optimizer)      # clip the true gradients (a no-op without fp16)
        nn.utils.clip_grad_norm_(run.model.parameters(), config.grad_clip)
    run.scaler.step(run.optimizer)              # fp16: skips a step whose gradients overflowed
    run.scaler.update()
    run.scheduler.step()
    run.last_finite = float(logged["loss"])
    row = {"step": run.state.start_step + run.state.step, "epoch": epoch,
           "lr": run.optimizer.param_groups[0]["lr"]}
    row.update({key: float(value) for key, value in logged.items()})
    run.history.train.append(row)


def _autocast(device: torch.device, precision: str):
    """``torch.autocast`` to ``precision``'s dtype (:data:`PRECISIONS`); nothing for fp32."""
    dtype = PRECISIONS[precision]
    return contextlib.nullcontext() if dtype is None else torch.autocast(device.type, dtype=dtype)


def _check_finite(run: _Run, logged_loss: torch.Tensor, loss: torch.Tensor, epoch: int) -> None:
    """Stop with :class:`NonFiniteLossError`, before the step, when the (logged) loss is NaN
    or infinite."""
    if not torch.isfinite(logged_loss):
        raise NonFiniteLossError(
            f"the loss became {loss.item()} at epoch {epoch}, step {run.state.start_step + run.state.step} "
            f"(last finite loss: {run.last_finite}). Try a lower learning rate "
            f"(lr={run.config.lr:g}), gradient clipping (grad_clip={run.config.grad_clip}), or "
            "check the data for NaNs.")


def _validate(run: _Run, val_set, epoch: int) -> None:
    """The mean loss terms on the validation set, logged in the history and shown on the bar."""
    if val_set is not None and len(val_set) > 0:
        val = _mean_terms(run.model, val_set, run.config.batch_size, run.device)
        run.history.val.append({"step": run.state.start_step + run.state.step - 1, "epoch": epoch, **val})
        loss = run.last_finite
        run.bar.set_postfix(loss=f"{loss}" if loss is None else f"{loss:.4f}", val=f"{val['loss']:.4f}")
    elif run.last_finite is not None:
        run.bar.set_postfix(loss=f"{run.last_finite:.4f}")


def _save_due(run: _Run) -> bool:
    """Whether ``config.save_every_steps`` or ``config.save_every_s`` asks for a save now."""
    config = run.config
    return run.state_file is not None and bool(
        (config.save_every_steps and run.state.step % config.save_every_steps == 0) or
        (config.save_every_s and time.perf_counter() - run.last_save >= config.save_every_s))


def _save(run: _Run) -> None:
    """Write the state file (rank 0) with every process's random generators, so that each
    resumes its own."""
    run.history.seconds = run.seconds_before + time.perf_counter() - run.began
    generators = parallel.gathered(_random_states(), run.world)
    if run.rank == 0:
        save_state(run.state_file, run.model, run.optimizer, run.scheduler, run.config, run.history, run.state,
                   generators, run.scaler)


def _print_summary(run: _Run, val_set) -> None:
    """The run's :func:`summary_line` (rank 0, with progress on)."""
    history, last = run.history, run.last_finite
    if last is None and history.train:
        last = history.train[-1]["loss"]
    # a bar's saved state is its first; this line is what a saved notebook keeps
    if run.config.progress and run.rank == 0:
        print(summary_line(type(run.model).__name__, run.state.step, run.seconds, last,
                           history.val[-1]["loss"] if val_set is not None and history.val else None))


def adam(parameters, lr: float, weight_decay: float = 0.0) -> torch.optim.Adam:
    """Adam over the ``parameters`` that require gradients, with PyTorch's fused kernel where
    this PyTorch has one for their device, the ordinary one otherwise: the same update either
    way. The fused kernel updates all weights in one pass per step instead of a small
    operation per tensor, which saves time when a model has many small tensors
    (``benchmarks/training_speed.py`` measures it)."""
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
