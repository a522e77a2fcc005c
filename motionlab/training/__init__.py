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

Its parts: :mod:`.config` (:class:`TrainConfig`, :class:`History`), :mod:`.schedule` (the
learning rate), :mod:`.parallel` (several processes under ``torchrun``), :mod:`.state`
(exact resume), :mod:`.loop` (:func:`train`); checkpoints are :mod:`motionlab.checkpoints`,
whose names are here too.
"""
from __future__ import annotations

from .config import PRECISIONS, History, NonFiniteLossError, TrainConfig, pick_device, seed_everything
from .loop import adam, seconds_per_step, summary_line, train, train_stages
from .parallel import distributed, init_distributed
from .schedule import lr_factor
from .state import STATE_FORMAT, RunState, restore_state, save_state

# motionlab.checkpoints imports this package (History, train), so its names are looked up
# on first use rather than imported here, which would be a cycle
_CHECKPOINT_NAMES = ("CHECKPOINT_FORMAT", "Checkpoint", "CheckpointMismatch", "load_checkpoint", "register_model",
                     "registered_models", "save_checkpoint", "train_or_load")

__all__ = ["PRECISIONS", "STATE_FORMAT", "History", "NonFiniteLossError", "RunState", "TrainConfig", "adam",
           "distributed", "init_distributed", "lr_factor", "pick_device", "restore_state", "save_state",
           "seconds_per_step", "seed_everything", "summary_line", "train", "train_stages", *_CHECKPOINT_NAMES]


def __getattr__(name: str):
    if name in _CHECKPOINT_NAMES:
        from .. import checkpoints
        value = globals()[name] = getattr(checkpoints, name)
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
