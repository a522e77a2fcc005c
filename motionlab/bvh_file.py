"""BVH motion capture files: the format, read, write, and forward kinematics.

A BVH file has two parts. ``HIERARCHY`` declares a tree of joints: each joint has an
``OFFSET`` from its parent (in the file's length units) and a list of ``CHANNELS``, the
numbers each frame gives it, in the order they are applied (for example
``Zrotation Yrotation Xrotation`` means the local rotation is ``Rz @ Ry @ Rx``).
``MOTION`` gives the frame count, the frame time in seconds, and one line of numbers per
frame, all joints' channels concatenated in hierarchy order. Angles are degrees.

>>> clip = read("../shared/mocap/cmu/16_15.bvh")
>>> clip.world_positions().shape        # (frames, joints, 3), file units
(471, 31, 3)

Conventions used here (shared by :func:`read` and :func:`write`):

* A joint's local transform translates by its offset, except along axes that have a
  position channel, where the channel value replaces the offset component; it then
  rotates by the product of its rotation channels in file order.
* World transforms compose parent-first: ``x_world = R_parent_world @ x_local + t``.

A malformed file (a number that is not finite, a joint named twice, an absurd frame time,
binary data...) raises ``ValueError`` naming the file and, where there is one, the line:
``"<file>:<line>: <what is wrong>"``. Nothing here recurses, so any hierarchy depth works.

A BVH as a :class:`~motionlab.clip.Clip`, and positions as a BVH, are :mod:`motionlab.bvh`,
where these names are importable too.
"""
from __future__ import annotations

import io
import itertools
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import checks
from .rotations import axis_rotation, forward_kinematics

POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
ROTATION_CHANNELS = ("Xrotation", "Yrotation", "Zrotation")
_AXIS = {"X": 0, "Y": 1, "Z": 2}


@dataclass
class BVH:
    """One BVH file in memory.

    Attributes:
        joint_names: names of the ``J`` joints, parents before children.
        parents: ``(J,)`` int array, ``-1`` for the root.
        offsets: ``(J, 3)`` offset of each joint from its parent, file units.
        channels: per joint, the tuple of its channel names in file order.
        motion: ``(frames, channels)`` float array, all channel values per frame.
        frame_time: seconds per frame.
        end_sites: joint index -> ``(3,)`` offset of that joint's ``End Site``.
        path: the file it was read from, if any.
    """

    joint_names: list[str]
    parents: np.ndarray
    offsets: np.ndarray
    channels: list[tuple[str, ...]]
    motion: np.ndarray
    frame_time: float
    end_sites: dict[int, np.ndarray] = field(default_factory=dict)
    path: str | None = None

    @property
    def fps(self) -> float:
        """Frames per second, ``1 / frame_time``, snapped to a whole number when within
        0.01 % of one (files write 120 fps as ``0.0083333``, i.e. 120.0005)."""
        fps = 1.0 / self.frame_time
        return float(round(fps)) if abs(fps - round(fps)) < 1e-4 * fps else fps

    @property
    def n_frames(self) -> int:
        return self.motion.shape[0]

    def channel_columns(self) -> list[slice]:
        """Per joint, the slice of :attr:`motion` columns holding its channels."""
        starts = np.concatenate([[0], np.cumsum([len(c) for c in self.channels])])
        return [slice(int(a), int(b)) for a, b in zip(starts[:-1], starts[1:])]

    def local_transforms(self) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations ``(frames, J, 3, 3)`` and translations ``(frames, J, 3)``."""
        frames, n_joints = self.n_frames, len(self.joint_names)
        rotations = np.broadcast_to(np.eye(3), (frames, n_joints, 3, 3)).copy()
        translations = np.broadcast_to(self.offsets, (frames, n_joints, 3)).copy()
        for j, columns in enumerate(self.channel_columns()):
            values = self.motion[:, columns]
            for k, name in enumerate(self.channels[j]):
                axis = _AXIS[name[0]]
                if name.endswith("position"):
                    translations[:, j, axis] = values[:, k]
                else:
                    rotations[:, j] = rotations[:, j] @ axis_rotation(name[0], values[:, k])
        return rotations, translations

    def world_transforms(self) -> tuple[np.ndarray, np.ndarray]:
        """World rotations ``(frames, J, 3, 3)`` and positions ``(frames, J, 3)``.

        Forward kinematics (:func:`motionlab.rotations.forward_kinematics`), offsets in
        the parent's frame.
        """
        return forward_kinematics(self.parents, *self.local_transforms())

    def world_positions(self, include_end_sites: bool = False) -> np.ndarray:
        """World joint positions ``(frames, J, 3)`` in file units.

        With ``include_end_sites=True`` the End Sites follow the joints, in the order of
        :attr:`end_sites`, giving ``(frames, J + E, 3)``.
        """
        world_rot, world_pos = self.world_transforms()
        if not include_end_sites or not self.end_sites:
            return world_pos
        ends = [np.einsum("fab,b->fa", world_rot[:, j], off) + world_pos[:, j]
                for j, off in self.end_sites.items()]
        return np.concatenate([world_pos, np.stack(ends, axis=1)], axis=1)


def read_text_lines(path: str | Path, what: str) -> list[str]:
    """The lines of a motion capture text file (BVH, ASF, AMC), for the readers.

    Accepts UTF-8 with or without a byte order mark and any line endings; a byte that is
    not UTF-8 (a Latin-1 letter in a comment) becomes U+FFFD instead of stopping the read.
    Raises ``ValueError`` naming the file when it cannot be read, holds binary data (NUL
    bytes: random bytes, a compressed file, UTF-16 text) or is a web page (its first line
    that is not blank or a ``#`` comment starts with ``<``, as HTML and XML do).
    """
    try:
        raw = Path(path).read_bytes()
    except OSError as err:
        raise ValueError(f"{path}: cannot read {what} file ({err.strerror})") from None
    if b"\x00" in raw:
        raise ValueError(f"{path}: not text: it holds NUL bytes (binary data, a compressed file "
                         f"or UTF-16 text?); {what} files are plain text")
    lines = raw.decode("utf-8-sig", errors="replace").splitlines()
    for n, line in enumerate(lines, start=1):
        text = line.strip()
        if text and not text.startswith("#"):
            if text.startswith("<"):
                raise ValueError(f"{path}:{n}: this line starts like HTML or XML ({text[:40]!r}), "
                                 f"not {what}: a web page saved under the file's name?")
            break
    return lines


class _Tokens:
    """The hierarchy's whitespace-separated tokens, each with its line number."""

    def __init__(self, path: str, lines: list[str], end: int):
        self.path = path
        self.items = [(tok, n + 1) for n in range(end) for tok in lines[n].split()]
        self.i = 0
        self.last_line = end

    def error(self, message: str, line: int | None = None) -> ValueError:
        return ValueError(f"{self.path}:{line or self.current_line()}: {message}")

    def current_line(self) -> int:
        return self.items[self.i][1] if self.i < len(self.items) else self.last_line

    def next(self, what: str) -> tuple[str, int]:
        if self.i >= len(self.items):
            raise self.error(f"unexpected end of HIERARCHY, expected {what}")
        item = self.items[self.i]
        self.i += 1
        return item

    def expect(self, word: str) -> None:
        """The next token must be ``word``, in any letter case (``ROOT``, ``root``)."""
        tok, line = self.next(repr(word))
        if tok.upper() != word.upper():
            raise self.error(f"expected {word!r}, found {tok!r}", line)

    def number(self, what: str) -> float:
        """The next token as a finite float (``nan``, ``inf`` and ``1e400`` are refused)."""
        tok, line = self.next(what)
        try:
            value = float(tok)
        except ValueError:
            raise self.error(f"bad number {tok!r} for {what}", line) from None
        if not math.isfinite(value):
            raise self.error(f"bad number {tok!r} for {what}: not a finite number", line)
        return value


_CHANNEL_NAMES = {name.upper(): name for name in POSITION_CHANNELS + ROTATION_CHANNELS}
"""Channel names in any letter case (``XROTATION``, ``xrotation``) -> the spelling used here."""


@dataclass
class _Hierarchy:
    """What the ``HIERARCHY`` section declares; fields as in :class:`BVH`."""

    names: list[str] = field(default_factory=list)
    parents: list[int] = field(default_factory=list)
    offsets: list[list[float]] = field(default_factory=list)
    channels: list[tuple[str, ...]] = field(default_factory=list)
    end_sites: dict[int, np.ndarray] = field(default_factory=dict)
    declared_on: dict[str, int] = field(default_factory=dict)   # joint name -> its line

    def add_joint(self, tokens: _Tokens, parent: int) -> int:
        """Read ``<name> {`` and add the joint; returns its index."""
        name, line = tokens.next("a joint name")
        if name in ("{", "}"):
            raise tokens.error(f"expected a joint name, found {name!r}", line)
        if name in self.declared_on:
            raise tokens.error(f"joint name {name!r} is used twice (first on line "
                               f"{self.declared_on[name]}); joint names must be unique", line)
        self.declared_on[name] = line
        self.names.append(name)
        self.parents.append(parent)
        self.offsets.append([0.0, 0.0, 0.0])
        self.channels.append(())
        tokens.expect("{")
        return len(self.names) - 1

    def column_names(self) -> list[str]:
        """``"<joint> <channel>"`` for every column of the motion data."""
        return [f"{name} {channel}" for name, names in zip(self.names, self.channels)
                for channel in names]


def _read_channels(tokens: _Tokens, joint: str) -> tuple[str, ...]:
    """``<count> <name> ...`` after ``CHANNELS``."""
    count, count_line = tokens.next("a channel count")
    if not (count.isascii() and count.isdigit()):
        raise tokens.error(f"bad channel count {count!r} for {joint}", count_line)
    names = []
    for _ in range(int(count)):
        channel, channel_line = tokens.next("a channel name")
        if channel.upper() not in _CHANNEL_NAMES:
            raise tokens.error(f"unknown channel {channel!r} in joint {joint}", channel_line)
        names.append(_CHANNEL_NAMES[channel.upper()])
    return tuple(names)


def _read_end_site(tokens: _Tokens, joint: str) -> np.ndarray:
    """``Site { OFFSET x y z }`` after ``End``: the ``(3,)`` offset."""
    tokens.expect("Site")
    tokens.expect("{")
    tokens.expect("OFFSET")
    offset = np.array([tokens.number(f"the End Site OFFSET of {joint}") for _ in range(3)])
    tokens.expect("}")
    return offset


def _parse_hierarchy(tokens: _Tokens) -> _Hierarchy:
    """Parse ``HIERARCHY ROOT ...`` up to its last ``}``.

    Iterative, not recursive: ``open_joints`` holds the joints whose ``}`` is still to
    come, innermost last, so a chain thousands of joints deep parses like a short one.
    """
    hierarchy = _Hierarchy()
    tokens.expect("HIERARCHY")
    tokens.expect("ROOT")
    open_joints = [hierarchy.add_joint(tokens, -1)]
    while open_joints:
        joint = open_joints[-1]
        name = hierarchy.names[joint]
        tok, line = tokens.next("'}'")
        keyword = tok.upper()
        if tok == "}":
            open_joints.pop()
        elif keyword == "OFFSET":
            hierarchy.offsets[joint] = [tokens.number(f"the OFFSET of {name}") for _ in range(3)]
        elif keyword == "CHANNELS":
            hierarchy.channels[joint] = _read_channels(tokens, name)
        elif keyword == "JOINT":
            open_joints.append(hierarchy.add_joint(tokens, joint))
        elif keyword == "END":
            hierarchy.end_sites[joint] = _read_end_site(tokens, name)
        else:
            raise tokens.error(f"unexpected {tok!r} in joint {name}", line)
    if tokens.i < len(tokens.items):
        tok, line = tokens.items[tokens.i]
        raise tokens.error(f"unexpected {tok!r} after the ROOT joint", line)
    return hierarchy


def read(path: str | Path) -> BVH:
    """Read a BVH file.

    Accepts any channel order per joint, position channels on any joint, End Sites,
    CR-LF or LF line endings, a UTF-8 byte order mark, keywords and channel names in any
    letter case (``root``, ``xrotation``, ``frame time:``) and ``Frame Time: .0083333``.
    A hierarchy of any depth is fine.

    A malformed file raises ``ValueError`` whose message starts with ``"<file>:<line>:"``:
    among others a number that is not finite (``nan``, ``inf``, ``1e400``), a joint name
    used twice, a frame time outside ``[1 / checks.MAX_FPS, MAX_FRAME_TIME_S]`` seconds, or
    a ``Frames:`` count that differs from the number of frame lines. Nothing is allocated
    from the declared count, so a file that claims 10**12 frames fails at once.
    """
    path = str(path)
    lines = read_text_lines(path, "BVH")
    motion_line = next((n for n, line in enumerate(lines) if line.strip().upper() == "MOTION"), None)
    if motion_line is None:
        raise ValueError(f"{path}:{len(lines)}: no MOTION section")
    hierarchy = _parse_hierarchy(_Tokens(path, lines, motion_line))
    n_frames, frames_line, frame_time, first_data = _read_motion_header(path, lines, motion_line)
    motion = _read_motion_values(path, lines, first_data, n_frames, frames_line,
                                 hierarchy.column_names())
    return BVH(hierarchy.names, np.array(hierarchy.parents, dtype=np.int64),
               np.array(hierarchy.offsets, dtype=np.float64).reshape(-1, 3), hierarchy.channels,
               motion, frame_time, hierarchy.end_sites, path)


MAX_FRAME_TIME_S = 1.0
"""Longest frame time :func:`read` accepts, seconds (1 fps). Motion capture runs at 30-480
fps; a longer frame time is almost surely a unit error (milliseconds written as seconds)."""

_HEADER = {"Frames:": re.compile(r"frames\s*:(.*)", re.IGNORECASE),
           "Frame Time:": re.compile(r"frame\s+time\s*:(.*)", re.IGNORECASE)}
"""The two lines after ``MOTION``, in any letter case: the text after the colon."""


def _read_motion_header(path: str, lines: list[str], motion_line: int) -> tuple[int, int, float, int]:
    """Parse ``Frames:`` and ``Frame Time:``. Returns the frame count, the (1-based) line
    that states it, the frame time and the index of the first data line."""
    n = motion_line + 1
    words = {}
    for key, pattern in _HEADER.items():
        while n < len(lines) and not lines[n].strip():
            n += 1
        line = lines[n].strip() if n < len(lines) else ""
        match = pattern.fullmatch(line)
        if not match:
            raise ValueError(f"{path}:{n + 1}: expected '{key}', found {line[:40]!r}")
        words[key] = (match.group(1).strip(), n + 1)
        n += 1
    frames_word, frames_line = words["Frames:"]
    return (_frame_count(path, frames_word, frames_line), frames_line,
            _frame_time(path, *words["Frame Time:"]), n)


def _frame_count(path: str, word: str, line: int) -> int:
    """The ``Frames:`` count: a whole number >= 0, digits only."""
    if not (word.isascii() and word.isdigit()):
        raise ValueError(f"{path}:{line}: bad frame count {word!r} after 'Frames:' "
                         "(expected a whole number >= 0)")
    return int(word)


def _frame_time(path: str, word: str, line: int) -> float:
    """The ``Frame Time:`` in seconds, between ``1 / MAX_FPS`` and :data:`MAX_FRAME_TIME_S`."""
    try:
        value = float(word)
    except ValueError:
        raise ValueError(f"{path}:{line}: bad number {word!r} after 'Frame Time:'") from None
    shortest = 1.0 / checks.MAX_FPS
    if not (math.isfinite(value) and shortest <= value <= MAX_FRAME_TIME_S):
        raise ValueError(f"{path}:{line}: Frame Time must be between {shortest:g} s "
                         f"({checks.MAX_FPS:g} fps) and {MAX_FRAME_TIME_S:g} s, got {word!r}")
    return value


def _read_motion_values(path: str, lines: list[str], first: int, n_frames: int,
                        frames_line: int, columns: list[str]) -> np.ndarray:
    """The frame lines from index ``first`` on as ``(n_frames, len(columns))`` floats.

    ``columns`` names each channel (``"Hips Xposition"``) for the messages. Before anything
    is parsed, the non-blank lines are counted (they must be ``n_frames``, as the
    ``Frames:`` line ``frames_line`` says) and the first one must have one value per
    column; numpy's C parser then reads them all at once. Only when that fails, or gives
    a value that is not finite, are the lines looked at one by one, to name the offending
    line (:func:`_parse_motion_lines`).
    """
    rows = [line for line in itertools.islice(lines, first, None) if line.strip()]
    if len(rows) != n_frames:
        raise ValueError(f"{path}:{frames_line}: header says {n_frames} frames, file has {len(rows)}")
    if n_frames == 0:
        return np.zeros((0, len(columns)))
    if len(rows[0].split()) != len(columns):
        return _parse_motion_lines(path, lines, first, columns)        # raises, naming the line
    try:
        motion = np.loadtxt(io.StringIO("\n".join(rows)), dtype=np.float64, comments=None, ndmin=2)
    except ValueError:
        motion = None
    if motion is None or motion.shape != (n_frames, len(columns)) or not np.isfinite(motion).all():
        motion = _parse_motion_lines(path, lines, first, columns)
    return motion


def _parse_motion_lines(path: str, lines: list[str], first: int, columns: list[str]) -> np.ndarray:
    """The slow path of :func:`_read_motion_values`: line by line, raising ``ValueError``
    for the first line with the wrong number of values, a word that is not a number, or a
    number that is not finite."""
    rows = []
    for n in range(first, len(lines)):
        words = lines[n].split()
        if words and len(words) != len(columns):
            raise ValueError(f"{path}:{n + 1}: expected {len(columns)} values, found {len(words)}")
        for word, column in zip(words, columns):
            try:
                value = float(word)
            except ValueError:
                raise ValueError(f"{path}:{n + 1}: bad number {word!r} for {column}") from None
            if not math.isfinite(value):
                raise ValueError(f"{path}:{n + 1}: bad number {word!r} for {column}: "
                                 "not a finite number")
        if words:
            rows.append([float(word) for word in words])
    return np.array(rows, dtype=np.float64).reshape(len(rows), len(columns))


def write(path: str | Path, clip: BVH, decimals: int = 6) -> None:
    """Write ``clip`` as a BVH file that :func:`read` gives back unchanged.

    Numbers are written with ``decimals`` decimal places (round trip to ``0.5 * 10**-decimals``).
    """
    out = io.StringIO()
    fmt = f"%.{decimals}f"
    children: dict[int, list[int]] = {}
    for j, p in enumerate(clip.parents):
        children.setdefault(int(p), []).append(j)

    def open_joint(j: int, depth: int) -> None:
        pad = "\t" * depth
        keyword = "ROOT" if clip.parents[j] < 0 else "JOINT"
        out.write(f"{pad}{keyword} {clip.joint_names[j]}\n{pad}{{\n")
        out.write(f"{pad}\tOFFSET " + " ".join(fmt % v for v in clip.offsets[j]) + "\n")
        if clip.channels[j]:
            out.write(f"{pad}\tCHANNELS {len(clip.channels[j])} {' '.join(clip.channels[j])}\n")

    def close_joint(j: int, depth: int) -> None:
        pad = "\t" * depth
        if j in clip.end_sites:
            out.write(f"{pad}\tEnd Site\n{pad}\t{{\n{pad}\t\tOFFSET "
                      + " ".join(fmt % v for v in clip.end_sites[j]) + f"\n{pad}\t}}\n")
        out.write(f"{pad}}}\n")

    roots = children.get(-1, [])
    if len(roots) != 1:
        raise ValueError(f"clip: a BVH needs exactly one root joint, found {len(roots)}")
    if any(children.get(j, []) and min(children[j]) <= j for j in range(len(clip.parents))):
        raise ValueError("clip: parents must come before their children")
    if len(set(clip.joint_names)) != len(clip.joint_names):
        raise ValueError("clip: joint names must be unique")
    expected = sum(len(c) for c in clip.channels)
    if clip.motion.ndim != 2 or clip.motion.shape[1] != expected:
        raise ValueError(f"clip: motion must be (frames, {expected}), got {clip.motion.shape}")
    if not (np.isfinite(clip.motion).all() and np.isfinite(clip.offsets).all()):
        raise ValueError("clip: motion and offsets must be finite (no NaN or inf)")
    out.write("HIERARCHY\n")
    # Depth first without recursion (any depth works): a stack of (joint, depth, opening?).
    stack = [(roots[0], 0, True)]
    while stack:
        j, depth, opening = stack.pop()
        if opening:
            open_joint(j, depth)
            stack.append((j, depth, False))
            stack.extend((child, depth + 1, True) for child in reversed(children.get(j, [])))
        else:
            close_joint(j, depth)
    out.write(f"MOTION\nFrames: {clip.n_frames}\nFrame Time: {clip.frame_time:.7f}\n")
    np.savetxt(out, clip.motion, fmt=fmt, delimiter=" ")
    Path(path).write_text(out.getvalue(), encoding="utf-8")
