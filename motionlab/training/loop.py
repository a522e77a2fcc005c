"""The training loop: :func:`train` and :func:`train_stages` (a model trained in stages),
the optimiser they use and the timing and summary they print."""
from __future__ import annotations

import contextlib
import time
from pathlib import Path

import numpy as np
import torch
from torch import nn

from .. import progress
from .config import PRECISIONS, History, NonFiniteLossError, TrainConfig, pick_device, seed_everything
from .parallel import _Loss, distributed
from .schedule import lr_factor
from .state import RunState, _random_states, _set_random_states, restore_state, save_state


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
    scheduler = torch.optim.lr_scheduler.LambdaLR(    # a lambda: LambdaLR saves nothing of a function
        optimizer, lambda step: lr_factor(step, total, config.warmup_steps, config.schedule, config.min_lr_ratio))
    low_precision = PRECISIONS[config.precision]
    scaler = torch.amp.GradScaler(device.type, enabled=config.precision == "fp16")   # fp16 gradients underflow

    def mixed_precision():
        if low_precision is None:
            return contextlib.nullcontext()
        return torch.autocast(device.type, dtype=low_precision)

    run = RunState(epoch=start_epoch, epoch_generator=generator.get_state(), start_step=start_step,
                   start_epoch=start_epoch)
    if resume and Path(state_file).exists():
        history = restore_state(state_file, model, optimizer, scheduler, config, run, scaler)
        start_step, start_epoch = run.start_step, run.start_epoch
        generator.set_state(run.epoch_generator)
    if config.estimate and rank == 0 and run.step < total:
        batch = next(iter(torch.utils.data.DataLoader(train_set, batch_size=config.batch_size // world)))
        seconds = seconds_per_step(model, batch.to(device), config)
        print(f"expected: {seconds:.3g} s per step on {device}, {_duration((total - run.step) * seconds)} "
              f"for {total - run.step} steps")
    bar = progress.bar(total, initial=run.step, desc=type(model).__name__, unit="step",
                       disable=not config.progress or rank > 0)
    began = last_save = time.perf_counter()
    seconds_before = history.seconds
    step, last_finite = run.step, None

    def save() -> None:
        history.seconds = seconds_before + time.perf_counter() - began
        run.step = step
        generators = _random_states()
        if world > 1:                     # every process's generators, so that each resumes its own
            everyone = [None] * world
            torch.distributed.all_gather_object(everyone, generators)
            generators = everyone
        if rank == 0:
            save_state(state_file, model, optimizer, scheduler, config, history, run, generators, scaler)

    try:
        for epoch in range(run.epoch, start_epoch + config.epochs):
            if step >= total:
                break
            if epoch != run.epoch:                      # a new epoch (not the one being resumed)
                run.begin_epoch(epoch, generator)
            if sampler is not None:
                sampler.set_epoch(epoch)                # each epoch's shuffle, the same in every process
            batches = iter(loader)
            for _ in range(run.position):               # resuming mid-epoch: the same shuffle, skipped
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
                run.position += 1
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
            run.begin_epoch(epoch + 1, generator)
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
