"""What makes a downloaded CMU file trusted: its content and the folder's manifest.

* **Content.** A quick first look at a file's first bytes (:func:`looks_like_asf`,
  :func:`looks_like_amc`), then the real check: the file parsed in full by the reader
  (:func:`check_asf`, :func:`check_amc`), which must not warn, every AMC frame giving the
  root and every bone with dofs, the file ending with a line break.
* **The manifest.** ``manifest.json`` in the folder lists each file's URL, size, SHA-256 and
  when it was recorded (:func:`read_manifest`); a file already in the folder is trusted if
  it still matches its entry, or, when it has none, if it parses (then it is added).

How the files are fetched is :mod:`motionlab.download_http`; which trials, and the command
line, :mod:`motionlab.download`, where these names are importable too.
"""
from __future__ import annotations

import json
import os
import warnings
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

from . import asfamc, files
from .files import sha256_of

MANIFEST = "manifest.json"


class DownloadError(ValueError):
    """A file could not be fetched: no network, an HTTP error, a broken-off transfer, or
    the server sent something that is not a valid ASF/AMC file."""


class DownloadWarning(UserWarning):
    """A file in the destination folder changed since it was recorded, or does not parse,
    and is fetched again."""


# --------------------------------------------------------------------------- content checks

def _first_line(head: bytes) -> str:
    """The first line of ``head`` that is neither blank nor a ``#`` comment."""
    for line in head.decode("latin-1").splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            return line.strip()
    return ""


def looks_like_amc(head: bytes) -> bool:
    """Whether a file starting with ``head`` is an AMC: a keyword such as ``:FULLY-SPECIFIED``
    or a frame number first. A quick first look; :func:`check_amc` is the real check."""
    line = _first_line(head)
    return line.upper().startswith((":FULLY-SPECIFIED", ":DEGREES", ":RADIANS")) or line.isdigit()


def looks_like_asf(head: bytes) -> bool:
    """Whether a file starting with ``head`` is an ASF: a section keyword (``:version``) first.
    A quick first look; :func:`check_asf` is the real check."""
    return _first_line(head).startswith(":")


def _describe(head: bytes) -> str:
    text = head.decode("latin-1", errors="replace").lstrip()
    if text[:100].lower().startswith(("<!doctype", "<html", "<?xml", "<head")):
        return "an HTML page (an error page?)"
    return f"something else, starting {text[:40]!r}"


def _check_last_line(path: Path) -> None:
    """CMU's files end with a line break; a transfer cut short mid-line does not."""
    with open(path, "rb") as f:
        f.seek(0, os.SEEK_END)
        if f.tell() == 0:
            raise ValueError(f"{path}: the file is empty")
        f.seek(-1, os.SEEK_END)
        if f.read(1) != b"\n":
            raise ValueError(f"{path}: the last line has no line break: the file was cut short")


def _read_strictly(read: Callable, *args) -> tuple[object, list[str]]:
    """Call a reader; returns what it read and the warnings it gave (a reader that copes
    with a flaw, say by dropping an incomplete last frame, warns; a download must have none)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = read(*args)
    complaints = []
    for warning in caught:
        if issubclass(warning.category, UserWarning):
            complaints.append(str(warning.message))
        else:                                             # not about the file: pass it on
            warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    return result, complaints


def check_asf(path: str | Path) -> asfamc.ASF:
    """Parse a skeleton file in full (:func:`motionlab.asfamc.read_asf`); returns it.
    Raises ``ValueError`` naming the file (and line) if it is not a complete ASF, or if
    the reader warned about it."""
    _check_last_line(Path(path))
    asf, complaints = _read_strictly(asfamc.read_asf, path)
    if complaints:
        raise ValueError(complaints[0])
    return asf


def check_amc(path: str | Path, asf: asfamc.ASF | str | Path) -> asfamc.AMC:
    """Parse a motion file in full against its skeleton (an :class:`~motionlab.asfamc.ASF`
    or the path of one); returns it.

    :func:`motionlab.asfamc.read_amc` checks every line and that frame numbers are
    contiguous; on top of that every frame must give the root and every bone with dofs
    (what ``:FULLY-SPECIFIED`` promises, and what a frame cut short lacks), and the reader
    must not have warned. Raises ``ValueError`` naming the file (and line) otherwise.
    """
    path = Path(path)
    if not isinstance(asf, asfamc.ASF):
        asf = check_asf(asf)
    _check_last_line(path)
    amc, complaints = _read_strictly(asfamc.read_amc, path, asf)
    _check_frames_complete(path, asf)
    if complaints:
        raise ValueError(complaints[0])
    return amc


def _bones_per_frame(path: Path) -> list[tuple[str, int, set[str]]]:
    """``(frame number, its line number, the bones it gives)`` for each frame of an AMC."""
    frames: list[tuple[str, int, set[str]]] = []
    with open(path, encoding="utf-8", errors="replace") as f:
        for n, line in enumerate(f, start=1):
            words = line.split()
            if not words or words[0].startswith(("#", ":")):
                continue
            if len(words) == 1 and words[0].isdigit():          # a new frame
                frames.append((words[0], n, set()))
            elif frames:
                frames[-1][2].add(words[0])
    return frames


def _check_frames_complete(path: Path, asf: asfamc.ASF) -> None:
    """Every frame of the AMC at ``path`` gives the root and every bone with dofs."""
    needed = {"root"} | {bone.name for bone in asf.bones if bone.dof}
    frames = _bones_per_frame(path)
    if not frames:
        raise ValueError(f"{path}: no frames")
    for number, line, given in frames:
        missing = sorted(needed - given)
        if missing:
            shown = ", ".join(missing[:3]) + (", ..." if len(missing) > 3 else "")
            raise ValueError(f"{path}:{line}: frame {number} lacks {len(missing)} of {len(needed)} "
                             f"bones ({shown}): an incomplete frame")


# --------------------------------------------------------------------------- the manifest

def read_manifest(folder: str | Path) -> dict[str, dict]:
    """``<folder>/manifest.json``: file name -> ``{"url", "size", "sha256", "recorded",
    "origin"}``; empty if there is none (or it is unreadable: then every file gets parsed)."""
    path = Path(folder) / MANIFEST
    if not path.is_file():
        return {}
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        warnings.warn(f"{path}: unreadable ({err}); the files are checked by parsing them",
                      DownloadWarning, stacklevel=2)
        return {}
    return manifest if isinstance(manifest, dict) else {}


def _record(path: Path, url: str, origin: str) -> None:
    """Add (or replace) ``path``'s entry in its folder's manifest."""
    manifest = read_manifest(path.parent)
    manifest[path.name] = {"url": url, "size": path.stat().st_size, "sha256": sha256_of(path),
                           "recorded": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                           "origin": origin}
    _write_json(path.parent / MANIFEST, manifest)


def _write_json(path: Path, value: dict) -> None:
    """Write ``value`` to ``path`` at once (through a temporary file), never half."""
    with files.replacing(path) as partial:
        partial.write_text(json.dumps(value, indent=1, sort_keys=True) + "\n", encoding="utf-8")


def _problem_with(target: Path, url: str, kind: str,
                  validate: Callable[[Path], object] | None) -> str | None:
    """Why the file already at ``target`` cannot be trusted, or ``None`` if it can.

    A file in the manifest must still have its recorded size and SHA-256. A file not in it
    must parse (``validate``); it is then added to the manifest.
    """
    entry = read_manifest(target.parent).get(target.name)
    if isinstance(entry, dict) and "sha256" in entry:
        size = target.stat().st_size
        if size != entry.get("size"):
            return (f"its size changed since it was recorded in {MANIFEST} "
                    f"({size} bytes, not {entry.get('size')})")
        if sha256_of(target) != entry["sha256"]:
            return f"its content changed since it was recorded in {MANIFEST} (another SHA-256)"
        return None
    try:
        if validate is not None:
            validate(target)
    except ValueError as err:
        return f"it is not in {MANIFEST} and is not a valid {kind} file ({err})"
    _record(target, url, "found in the folder, parsed")
    return None
