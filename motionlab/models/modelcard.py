"""What the course knows about a model, written once, at the end of the model's own file.

Every model file ends with a ``CARD = ModelCard(...)``: the name the command line knows it
by, its model and config classes, what its paper says about training (and what we chose
where the paper is silent, with the reason), how its training clips are augmented and, for
a model trained stage by stage, its stages. :func:`motionlab.models.card` reads it;
the command line (:mod:`motionlab.train`) and the checkpoint registry
(:func:`motionlab.training.registered_models`) are built from the cards, so adding a model
is its file plus its name in ``motionlab/models/__init__.py``: in the line that imports the
model files and in :data:`motionlab.models.FILES`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, NamedTuple

from torch import nn

AUGMENTATIONS = ("mirror", "reverse")
"""What :func:`motionlab.data.augment` can do to a training clip (MoGlow §5.1)."""

SCHEDULE_KEYS = ("optimizer", "stages", "epochs", "stage_epochs", "batch_size", "lr", "schedule",
                 "warmup_steps", "grad_clip", "max_steps")
"""What a schedule may state: the command line's training options (:class:`motionlab.train.Plan`),
plus ``optimizer`` and ``stages``, which only document (motionlab always trains with Adam, and
a staged model always in its stages' order)."""


class Setting(NamedTuple):
    """One training setting: its value and where it comes from."""

    value: Any
    source: str          # the paper's section, or why we chose it
    from_paper: bool


def paper(value, where: str) -> Setting:
    """A setting the paper gives; ``where`` quotes it with its section."""
    return Setting(value, where, True)


def choice(value, why: str) -> Setting:
    """A setting the paper does not give; ``why`` says what we took instead and why."""
    return Setting(value, why, False)


NO_CLIP = "motionlab's default gradient-norm clipping (no paper mentions clipping)"


@dataclass(frozen=True)
class ModelCard:
    """One model's facts, kept beside the model.

    Attributes:
        name: the command line's name (``python -m motionlab.train NAME``), the file's name.
        model: the ``nn.Module`` class; built as ``model(config())``.
        config: its config dataclass (with a ``paper()`` classmethod for the paper's sizes).
        schedule: what the paper says about training, ``{option: paper(...) or choice(...)}``
            with keys from :data:`SCHEDULE_KEYS`; ``--paper`` applies it.
        augment: what is done to the training clips (:data:`AUGMENTATIONS`).
        stages: the stages a staged model trains in, in order (empty: trained in one go).
    """

    name: str
    model: type
    config: type
    schedule: dict[str, Setting]
    augment: tuple[str, ...] = AUGMENTATIONS
    stages: tuple[str, ...] = ()

    def __post_init__(self):
        if not (isinstance(self.name, str) and self.name.isidentifier() and self.name.islower()):
            raise ValueError(f"name: expected a lower-case Python identifier, got {self.name!r}")
        if not (isinstance(self.model, type) and issubclass(self.model, nn.Module)):
            raise ValueError(f"model: expected an nn.Module subclass, got {self.model!r}")
        if not (isinstance(self.config, type) and dataclasses.is_dataclass(self.config)):
            raise ValueError(f"config: expected a dataclass, got {self.config!r}")
        if not isinstance(self.schedule, dict) or not all(isinstance(s, Setting) for s in self.schedule.values()):
            raise ValueError("schedule: expected {option: paper(...) or choice(...)}")
        unknown = sorted(set(self.schedule) - set(SCHEDULE_KEYS))
        if unknown:
            raise ValueError(f"schedule: unknown options {unknown}; expected some of {', '.join(SCHEDULE_KEYS)}")
        if not all(setting.source for setting in self.schedule.values()):
            raise ValueError("schedule: every setting says where it comes from")
        if not (isinstance(self.augment, tuple) and set(self.augment) <= set(AUGMENTATIONS)):
            raise ValueError(f"augment: expected a tuple of {', '.join(AUGMENTATIONS)}, got {self.augment!r}")
        if not (isinstance(self.stages, tuple) and all(isinstance(s, str) and s for s in self.stages)
                and len(set(self.stages)) == len(self.stages)):
            raise ValueError(f"stages: expected a tuple of distinct stage names, got {self.stages!r}")
        if ("stage_epochs" in self.schedule) != bool(self.stages):
            raise ValueError("schedule: stage_epochs belongs to a staged model (stages=...), and only there")
