"""Files, written once: a file's SHA-256, and writing a file whole or not at all.

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
