"""The state a training run can resume from exactly: where the run is (:class:`RunState`),
:func:`save_state` to write it with the weights, optimiser, schedule, history and every
random generator, and :func:`restore_state` to read it back."""
from __future__ import annotations

import dataclasses
import os
import random
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch
from torch import nn

from .config import History, TrainConfig
from .parallel import distributed


STATE_FORMAT = "motionlab-train-state-1"
_RESUME_FREE = ("device", "num_threads", "progress", "save_every_steps", "save_every_s", "estimate")
"""TrainConfig fields a resumed run may change: they do not change what is computed."""


@dataclass
class RunState:
    """Where a run of :func:`motionlab.training.train` is, besides its weights, optimiser and
    history: what it needs to go on with the very batch it would have trained next.

    Attributes:
        step: steps done in this run.
        epoch: the epoch under way (numbered as in the history).
        position: batches of that epoch done.
        epoch_generator: the batch generator's state when that epoch began (its shuffle is
            drawn from it).
        start_step, start_epoch: the history's next step and epoch when the run began (a
            run that continues a history numbers its rows on from there).
    """

    step: int = 0
    epoch: int = 0
    position: int = 0
    epoch_generator: torch.Tensor = field(default_factory=lambda: torch.empty(0, dtype=torch.uint8))
    start_step: int = 0
    start_epoch: int = 0

    def begin_epoch(self, epoch: int, generator: torch.Generator) -> None:
        """Epoch ``epoch`` starts: no batch of it done, its shuffle drawn from ``generator`` as it is now."""
        self.epoch, self.position, self.epoch_generator = epoch, 0, generator.get_state()

    def to_dict(self) -> dict:
        """Plain values for a state file (ints and a copy of the generator's state), under
        the keys state files have always had."""
        return {f.name: (value.clone() if isinstance(value, torch.Tensor) else int(value))
                for f in dataclasses.fields(self) for value in [getattr(self, f.name)]}

    def update(self, saved: dict) -> None:
        """Take the values of a :meth:`to_dict` read back from a file (others are ignored)."""
        for f in dataclasses.fields(self):
            if f.name in saved:
                setattr(self, f.name, saved[f.name])


def _random_states() -> dict:
    """This process's random generators (torch, Python, numpy, CUDA) as plain values."""
    np_state = np.random.get_state()        # plain lists of ints: they also travel between processes
    return {"torch": torch.get_rng_state().tolist(), "python": _plain(random.getstate()),
            "numpy": [np_state[0], np_state[1].tolist(), *map(float, np_state[2:])],
            "cuda": [s.tolist() for s in torch.cuda.get_rng_state_all()] if torch.cuda.is_available() else []}


def save_state(path: str | Path, model: nn.Module, optimizer, scheduler, config: TrainConfig,
               history: History, run: RunState, generators: dict | list | None = None, scaler=None) -> None:
    """Write everything a run needs to continue exactly (see :func:`motionlab.training.train`):
    the weights and buffers, Adam's moments, the schedule, the history, where the run is
    (``run``) and every random generator's state (``generators``: this process's by default, or a
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
             "run": run.to_dict(),
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


def restore_state(path, model, optimizer, scheduler, config: TrainConfig, run: RunState, scaler=None) -> History:
    """Load :func:`save_state`'s file into the model, optimiser, schedule, gradient scaler,
    ``run`` and this process's random generators, and return the saved history.
    ``ValueError`` naming the file when it is not such a file, is damaged, or was saved by
    a different model or config or by another number of processes."""
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
