"""One file per model, each readable top to bottom beside its paper.

Each model file ends with its :class:`~motionlab.models.modelcard.ModelCard` (``CARD``): the
name the command line knows it by, its classes, its paper's training schedule, its
augmentation and its stages. :data:`FILES` lists the files; the command line
(``python -m motionlab.train NAME``) and the checkpoint registry are built from their cards,
so adding a model is its file plus its name here.
"""
from __future__ import annotations

import importlib

from .modelcard import ModelCard

FILES = ("conv_ae", "vae", "vae_lstm", "lstm", "glow", "moglow", "dfn")
"""The model files, by name; each ends with ``CARD = ModelCard(<its name>, ...)``."""


def card(name: str) -> ModelCard:
    """The :class:`ModelCard` of the model file ``name`` (one of :data:`FILES`). Only names
    listed here are imported: a name given on a command line is never imported as it is."""
    if name not in FILES:
        raise ValueError(f"name: expected one of {', '.join(FILES)}, got {name!r}")
    found = getattr(importlib.import_module(f"{__name__}.{name}"), "CARD", None)
    if not isinstance(found, ModelCard) or found.name != name:
        raise ValueError(f"motionlab/models/{name}.py: expected it to end with CARD = ModelCard({name!r}, ...)")
    return found


def cards() -> dict[str, ModelCard]:
    """Every model's card, in the order of :data:`FILES`."""
    return {name: card(name) for name in FILES}
