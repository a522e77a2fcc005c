"""CMU's Acclaim motion files (``.amc``): the parser (:func:`read_amc`, vectorised per bone)
and what it returns (:class:`AMC`).

A motion file is read for its skeleton (:func:`motionlab.asf.read_asf`); the format is
described in :mod:`motionlab.asfamc`. A malformed file raises ``ValueError`` whose message
starts with ``"<file>:<line>:"``; a file cut short inside its last frame loses that frame,
with a warning.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .asf import ASF, ROTATION_DOFS, _dof_columns, _Source

AMC_KEYWORDS = (":FULLY-SPECIFIED", ":DEGREES", ":RADIANS")


@dataclass
class AMC:
    """A motion file in memory.

    Attributes:
        values: bone name -> ``(frames, len(dof))`` values in the ASF's dof order (the
            root: ``(frames, len(root_order))`` in ``root_order``). Rotations are degrees even
            when the file says ``:RADIANS``; translations are file length units. A bone
            missing from a frame (or from the whole file) has zeros there: its rest pose.
        first_frame: the number of the first frame (CMU files start at 1).
        angle: ``"deg"`` or ``"rad"``, as the file stated it.
        fully_specified: whether the file said ``:FULLY-SPECIFIED``.
        path: the file it was read from, if any.
    """

    values: dict[str, np.ndarray]
    first_frame: int = 1
    angle: str = "deg"
    fully_specified: bool = True
    path: str | None = None

    @property
    def n_frames(self) -> int:
        return next(iter(self.values.values())).shape[0] if self.values else 0


# --------------------------------------------------------------------------- AMC

_AMC_LINE = re.compile(r"^[ \t]*([^#\s]\S*)[ \t]*([^\n]*)", re.MULTILINE)
"""A non-blank, non-comment line: its first word and the rest of the line."""

_EMPTY_FRAME = re.compile(r"^[ \t]*(\d+)[ \t]*\n(?:[ \t]*(?:#[^\n]*)?\n)*[ \t]*(\d+)[ \t]*$", re.MULTILINE)
"""A frame number line followed by another (blank and comment lines between): a frame
that gives no bone."""

MAX_FRAME_NUMBER_DIGITS = 9
"""Frame numbers have at most this many digits (10**9 frames: 96 days at 120 fps)."""


def _is_frame_number(word: str) -> bool:
    """Whether ``word`` is a frame number: ASCII digits only."""
    return word.isascii() and word.isdigit()


def _amc_header(source: _Source) -> tuple[int, str | None, bool]:
    """Read the keywords before the first frame: returns the first frame's line index
    (0-based), the angle unit (``None`` if not stated) and ``:FULLY-SPECIFIED``."""
    angle, fully_specified = None, False
    for i, line in enumerate(source.lines):
        if not line or line.isspace():              # skipped without splitting: fast on huge files
            continue
        words = line.split()
        if words[0].startswith("#"):
            continue
        if words[0].startswith(":"):
            keyword = words[0].upper()
            if keyword not in AMC_KEYWORDS:
                raise source.error(i + 1, f"unknown keyword {words[0]!r}; expected "
                                          f"{', '.join(AMC_KEYWORDS)}")
            if keyword == ":FULLY-SPECIFIED":
                fully_specified = True
            else:
                angle = "deg" if keyword == ":DEGREES" else "rad"
            continue
        if len(words) != 1 or not _is_frame_number(words[0]):
            raise source.error(i + 1, f"expected a frame number, found {line.strip()[:40]!r}")
        return i, angle, fully_specified
    if all(not line or line.isspace() for line in source.lines):
        raise ValueError(f"{source.path}: no frames: the file is empty")
    raise source.error(source.n_lines, "no frames: the file has only a header")


def _line_numbers(source: _Source, first: int) -> list[int]:
    """1-based line numbers of the non-blank, non-comment lines from index ``first`` on."""
    return [n + 1 for n in range(first, source.n_lines)
            if source.lines[n].strip() and not source.lines[n].lstrip().startswith("#")]


def _bone_values(source: _Source, first: int, bone: str, n_dof: int, rows: np.ndarray,
                 texts: list[str]) -> np.ndarray:
    """Parse one bone's value text, ``texts[r]`` for ``r`` in ``rows``: ``(len(rows), n_dof)``.

    Fast path: join all rows with a ``|`` between them, split once, and check that the
    ``|`` words sit exactly every ``n_dof + 1`` words (so every row has ``n_dof`` values).
    Only when that fails are the rows looked at one by one, to name the offending line.
    """
    if len(rows) == 0:
        return np.zeros((0, n_dof))
    words = " | ".join([texts[r] for r in rows.tolist()]).split()
    separators = words[n_dof::n_dof + 1]
    if len(words) == len(rows) * (n_dof + 1) - 1 and separators.count("|") == len(rows) - 1:
        del words[n_dof::n_dof + 1]
        try:
            values = np.array(words, dtype=np.float64).reshape(len(rows), n_dof)
        except ValueError:
            values = None
        if values is not None and np.isfinite(values).all():
            return values
    line_of = _line_numbers(source, first)                    # slow path: find the culprit
    for r in rows:
        values = texts[r].split()
        if len(values) != n_dof:
            raise source.error(line_of[r], f"bone {bone} has {n_dof} dofs, found {len(values)} values")
        for word in values:
            source.number(word, line_of[r], f"bone {bone}")       # refuses nan, inf, 1e400
    raise AssertionError("unreachable: every row has n_dof finite numbers")


def _frame_of_each_line(source: _Source, first: int, heads: list[str],
                        texts: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Which frame each line belongs to ``(lines,)``, and where frames start ``(frames,)``.

    Checks that frame number lines hold only the number, that the numbers have at most
    :data:`MAX_FRAME_NUMBER_DIGITS` digits and that they are contiguous.
    """
    is_frame = np.array([_is_frame_number(head) for head in heads], dtype=bool)
    frame_rows = np.flatnonzero(is_frame)
    too_long = [r for r in frame_rows if len(heads[r]) > MAX_FRAME_NUMBER_DIGITS]
    if too_long:
        line = _line_numbers(source, first)[too_long[0]]
        number = heads[too_long[0]]
        shown = number if len(number) <= 30 else f"{number[:20]}... ({len(number)} digits)"
        raise source.error(line, f"frame number {shown} is too large "
                                 f"(more than {MAX_FRAME_NUMBER_DIGITS} digits)")
    frame_numbers = np.array([int(heads[r]) for r in frame_rows], dtype=np.int64)
    with_values = [r for r in frame_rows if texts[r]]
    jumps = np.flatnonzero(np.diff(frame_numbers) != 1)
    if with_values:
        line = _line_numbers(source, first)[with_values[0]]
        raise source.error(line, "a frame number line must hold only the number")
    if len(jumps):
        line = _line_numbers(source, first)[frame_rows[jumps[0] + 1]]
        raise source.error(line, f"frame {frame_numbers[jumps[0] + 1]} follows frame "
                                 f"{frame_numbers[jumps[0]]}; frames must be contiguous")
    return np.cumsum(is_frame) - 1, frame_rows


def _last_frame_cut_short(heads: list[str], texts: list[str], frame_rows: np.ndarray,
                          bone_of: np.ndarray, n_dofs: list[int]) -> str:
    """Why the last frame looks cut short (the file ends inside it), or ``""`` if it does not.

    It is cut short when the file ends right after its frame number, when it lacks a bone
    that the frame before it has, or when the file's last line names no known bone
    (``bone_of`` -1) or has fewer values than that bone's ``n_dofs``.
    """
    last, final = frame_rows[-1], len(heads) - 1
    if final == last:
        return "the file ends after its frame number"
    if len(frame_rows) > 1:
        before = set(bone_of[frame_rows[-2] + 1:last].tolist()) - {-1}
        missing = before - set(bone_of[last + 1:].tolist())
        if missing:
            return f"{len(missing)} bone(s) of the frame before it are missing"
    if bone_of[final] < 0:
        return f"its last line starts with {heads[final]!r}, not a bone"
    found = len(texts[final].split())
    if found < n_dofs[bone_of[final]]:
        return f"its last line has {found} of bone {heads[final]}'s {n_dofs[bone_of[final]]} values"
    return ""


def read_amc(path: str | Path, asf: ASF) -> AMC:
    """Read an Acclaim motion (``.amc``) file for skeleton ``asf``.

    Frames must be numbered contiguously. A bone missing from a frame gets zeros (its rest
    pose relative to its parent) in that frame, except in the last frame: a file that ends
    inside its last frame (it was cut short, see :func:`_last_frame_cut_short`) loses that
    frame, with a warning naming the file. A file without frames, a frame that gives no
    bone at all (so a file of bare frame numbers cannot make arrays of millions of rest
    poses), a bone given twice in a
    frame, a bone the ASF does not have, the wrong number of values for a bone's dofs or a
    value that is not a finite number (``nan``, ``inf``, ``1e400``) raises ``ValueError``
    starting ``"<file>:<line>:"``. Parsing is vectorised per bone, not per frame. Angles are
    converted to degrees when the file says ``:RADIANS`` (without ``:DEGREES``/``:RADIANS``,
    the ASF's angle unit applies).
    """
    source = _Source(str(path), "AMC")
    first, angle, fully_specified = _amc_header(source)
    angle = angle or asf.angle
    body = "\n".join(source.lines[first:])
    # every frame but a cut-short last one gives at least one bone, so the frames' arrays
    # are bounded by the values found, not by how many frame numbers the file lists; looked
    # for before any per-line work (a file of bare frame numbers is refused at once)
    empty = _EMPTY_FRAME.search(body)
    if empty:
        line = first + body.count("\n", 0, empty.start()) + 1
        raise source.error(line, f"frame {empty.group(1)} gives no bone (the next line is frame "
                                 f"{empty.group(2)}): every frame must list its bones")
    entries = _AMC_LINE.findall(body)                                  # (first word, the rest)
    heads = [head for head, _ in entries]
    texts = [text for _, text in entries]
    frame_of, frame_rows = _frame_of_each_line(source, first, heads, texts)

    dofs = {"root": asf.root_order} | {bone.name: bone.dof for bone in asf.bones}
    bone_ids = {name: i for i, name in enumerate(dofs)}
    bone_of = np.array([bone_ids.get(head, -1) for head in heads], dtype=np.int64)
    bone_of[frame_rows] = len(bone_ids)                                # frame number lines
    cut = _last_frame_cut_short(heads, texts, frame_rows, bone_of, [len(d) for d in dofs.values()])
    if cut:
        line = _line_numbers(source, first)[frame_rows[-1]]
        warnings.warn(f"{path}:{line}: the last frame ({heads[frame_rows[-1]]}) is incomplete "
                      f"({cut}); the file looks cut short, so that frame is dropped", stacklevel=2)
        keep = frame_rows[-1]
        heads, texts, bone_of, frame_of = heads[:keep], texts[:keep], bone_of[:keep], frame_of[:keep]
        frame_rows = frame_rows[:-1]
        if len(frame_rows) == 0:
            raise source.error(line, "no complete frame: the file ends inside its first frame")
    unknown = np.flatnonzero(bone_of < 0)
    if len(unknown):
        line = _line_numbers(source, first)[unknown[0]]
        raise source.error(line, f"bone {heads[unknown[0]]!r} is not in the skeleton {asf.path}")

    to_degrees = np.rad2deg(1.0) if angle == "rad" else 1.0
    values = {}
    for name, i in bone_ids.items():
        rows = np.flatnonzero(bone_of == i)
        frames = frame_of[rows]
        twice = np.flatnonzero(np.diff(frames) == 0)
        if len(twice):
            line = _line_numbers(source, first)[rows[twice[0] + 1]]
            frame_number = heads[frame_rows[frames[twice[0]]]]
            raise source.error(line, f"bone {name} given twice in frame {frame_number}")
        per_frame = np.zeros((len(frame_rows), len(dofs[name])))
        per_frame[frames] = _bone_values(source, first, name, len(dofs[name]), rows, texts)
        per_frame[:, _dof_columns(dofs[name], ROTATION_DOFS)] *= to_degrees
        values[name] = per_frame
    first_frame = int(heads[frame_rows[0]])
    return AMC(values, first_frame, angle, fully_specified, str(path))
