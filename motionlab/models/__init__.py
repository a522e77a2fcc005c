"""One file per model, each readable top to bottom beside its paper.

Each model file ends with its :class:`~motionlab.models.modelcard.ModelCard` (``CARD``): the
name the command line knows it by, its classes, its paper's training schedule, its
augmentation and its stages. :data:`FILES` lists the files; the command line
(``python -m motionlab.train NAME``) and the checkpoint registry are built from their cards,
so adding a model is its file plus its name here, twice: in the import line and in the
line that makes :data:`FILES`.
"""
from __future__ import annotations

from .modelcard import ModelCard

# Every model file, imported here by name: nothing else is ever imported as a model.
from . import conv_ae, dfn, glow, lstm, moglow, vae, vae_lstm  # noqa: E402  (after ModelCard)

FILES = tuple(file.__name__.rpartition(".")[2] for file in (conv_ae, vae, vae_lstm, lstm, glow, moglow, dfn))
"""The model files, by name, in the course's order; each ends with ``CARD = ModelCard(<its name>, ...)``."""


def card(name: str) -> ModelCard:
    """The :class:`ModelCard` of the model file ``name`` (one of :data:`FILES`). The files are
    imported above, by the statement that names them: a name given on a command line only
    picks one of them, and is never imported."""
    if name not in FILES:
        raise ValueError(f"name: expected one of {', '.join(FILES)}, got {name!r}")
    found = getattr(globals().get(name), "CARD", None)
    if not isinstance(found, ModelCard) or found.name != name:
        raise ValueError(f"motionlab/models/{name}.py: expected it to end with CARD = ModelCard({name!r}, ...)")
    return found


def cards() -> dict[str, ModelCard]:
    """Every model's card, in the order of :data:`FILES`."""
    return {name: card(name) for name in FILES}
