"""Files, written once: where the course's files live, a file's SHA-256, and writing a file
whole or not at all.

The shipped checkpoints are package data (``motionlab/checkpoints``), so an installed
motionlab finds them wherever it is installed; what the course trains or downloads goes to
a cache (:func:`cache`): the repository's ``data/cache`` when motionlab runs from a checkout,
else the user's cache folder. ``MOTIONLAB_CHECKPOINTS`` and ``MOTIONLAB_CACHE`` move either.

Every file motionlab writes that another run reads back (checkpoints, training states, the
clip cache, the download manifest) is written through :func:`replacing`: to a temporary
file beside it, then renamed over the old one, so a run stopped half-way leaves the old
file, never half a new one.
"""
from __future__ import annotations

import hashlib
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

PACKAGE = Path(__file__).resolve().parent


def checkpoints() -> Path:
    """The folder of the shipped checkpoints: ``$MOTIONLAB_CHECKPOINTS``, else the package's
    own ``checkpoints`` folder (installed with it)."""
    given = os.environ.get("MOTIONLAB_CHECKPOINTS")
    return Path(given).expanduser() if given else PACKAGE / "checkpoints"


def cache() -> Path:
    """Where the course keeps what it trains, loads and downloads: ``$MOTIONLAB_CACHE``; else,
    run from a checkout of the repository (its ``pyproject.toml`` beside the package), the
    repository's ``data/cache`` (ignored by git); else ``$XDG_CACHE_HOME/motionlab`` or
    ``~/.cache/motionlab``. Nothing is created until something is written there."""
    given = os.environ.get("MOTIONLAB_CACHE")
    if given:
        return Path(given).expanduser()
    if (PACKAGE.parent / "pyproject.toml").is_file() and (PACKAGE.parent / "notebooks").is_dir():
        return PACKAGE.parent / "data" / "cache"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "motionlab"


def sha256_of(path: str | Path) -> str:
    """The SHA-256 of a file, as hex (read in 1 MB blocks: any size in little memory)."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(1 << 20):
            digest.update(block)
    return digest.hexdigest()


@contextmanager
def replacing(path: str | Path, suffix: str = "") -> Iterator[Path]:
    """Write ``path`` whole or not at all::

        with files.replacing("model.pt") as partial:
            torch.save(state, partial)

    The block writes the temporary file ``partial`` (beside ``path``, ending in ``suffix``
    where a writer insists on one, e.g. ``".npz"`` for ``np.savez``); when the block ends
    without an error it replaces ``path`` in one step (``os.replace``), and when it raises,
    the temporary file is removed and ``path`` is left as it was.
    """
    path = Path(path)
    partial = path.with_name(f"{path.name}.partial{suffix}")
    try:
        yield partial
        os.replace(partial, path)
    finally:
        if partial.exists():
            partial.unlink()
