"""BVH motion capture files: read, write, and forward kinematics.

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
from .clip import CMU_UNIT_M, Clip
from .skeleton import LOCOMOTION_JOINTS
from .rotations import axis_rotation, forward_kinematics, matrix_to_euler_zyx, y_rotation

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


# --------------------------------------------------------------------------- as a Clip

def has_tpose_frame(clip: BVH) -> bool:
    """Whether frame 0 is a hand-made T-pose, as cgspeed BVH files prepend.

    That frame's rotations are whole degrees (mostly zero), unlike captured frames.
    """
    if clip.n_frames < 2:
        return False
    rotation_columns = [column.start + k
                        for column, names in zip(clip.channel_columns(), clip.channels)
                        for k, name in enumerate(names) if name.endswith("rotation")]
    first = clip.motion[0, rotation_columns]
    return bool(np.all(first == np.round(first)) and np.mean(first == 0) > 0.5)


def locomotion_joints(clip: BVH) -> list[int]:
    """Indices into ``clip.joint_names`` of the 21 locomotion joints, in locomotion order.

    Joints are found by their CMU names (:data:`motionlab.skeleton.LOCOMOTION_JOINTS`); the hips are the
    joint named ``Hips`` or, when there is none, the root joint whatever its name (some
    exporters call it ``Root`` or ``pelvis``). Raises ``ValueError`` listing missing joints.
    """
    index = {name: j for j, name in enumerate(clip.joint_names)}
    index.setdefault("Hips", int(np.flatnonzero(np.asarray(clip.parents) < 0)[0]))
    missing = [n for n in LOCOMOTION_JOINTS if n not in index]
    if missing:
        raise ValueError(f"{clip.path}: not a CMU-style skeleton, missing joints {', '.join(missing)}")
    return [index[n] for n in LOCOMOTION_JOINTS]


def load_clip(path: str | Path, fps: float | None = None, unit_m: float = CMU_UNIT_M,
             drop_tpose: bool | str = "auto") -> Clip:
    """A BVH file with CMU joint names as a 21-joint :class:`~motionlab.clip.Clip`, as
    :func:`motionlab.asfamc.load_clip` reads a CMU trial: every reader returns a Clip.

    Args:
        path: the ``.bvh`` file.
        fps: resample to this frame rate (default: keep the file's).
        unit_m: metres per file length unit (default: CMU units).
        drop_tpose: drop frame 0 if it is a cgspeed T-pose; ``"auto"`` detects it
            (:func:`has_tpose_frame`), ``True``/``False`` force it.

    The root joint stands in for ``Hips`` when no joint has that name
    (:func:`locomotion_joints`). A malformed file raises ``ValueError`` naming it.
    """
    path = Path(path)
    if fps is not None:
        fps = checks.rate(fps, "fps")
    unit_m = checks.positive(unit_m, "unit_m")
    if drop_tpose not in ("auto", True, False):
        raise ValueError(f"drop_tpose: expected 'auto', True or False, got {drop_tpose!r}")
    clip = read(path)
    index = locomotion_joints(clip)
    drop = has_tpose_frame(clip) if drop_tpose == "auto" else bool(drop_tpose)
    if drop:
        clip.motion = clip.motion[1:]
    if clip.n_frames < 2:
        raise ValueError(f"{path}: needs at least 2 frames of motion, has {clip.n_frames}")
    positions = clip.world_positions()[:, index] * unit_m
    result = Clip(path.stem, positions, clip.fps, str(path))
    return result.resampled(fps) if fps is not None else result


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


def _swing(rest: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Smallest rotations ``(F, 3, 3)`` taking unit vector ``rest`` ``(3,)`` to ``current`` ``(F, 3)``."""
    axis = np.cross(rest, current)
    cos = current @ rest
    k = np.zeros(current.shape[:-1] + (3, 3))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -axis[..., 2], axis[..., 1], -axis[..., 0]
    k = k - np.swapaxes(k, -1, -2)
    out = np.eye(3) + k + (k @ k) / np.maximum(1.0 + cos, 1e-12)[..., None, None]
    flipped = cos < -1 + 1e-9                      # opposite: half a turn about any perpendicular
    if flipped.any():
        perp = np.cross(rest, [1.0, 0.0, 0.0] if abs(rest[0]) < 0.9 else [0.0, 1.0, 0.0])
        perp /= np.linalg.norm(perp)
        out[flipped] = 2 * np.outer(perp, perp) - np.eye(3)
    return out


END_SITE_M = 0.05
"""How far :func:`from_positions` puts each leaf's End Site beyond the leaf joint, metres."""


def from_positions(positions: np.ndarray, fps: float, skeleton=None, unit_m: float = 1.0) -> BVH:
    """Joint positions -> a BVH clip whose forward kinematics gives them back.

    Args:
        positions: ``(frames, joints, 3)`` world positions in metres (y up) of ``skeleton``
            (default: the 21-joint locomotion skeleton).
        fps: frames per second.
        unit_m: metres per file unit (``clip.CMU_UNIT_M`` writes CMU units).

    Each bone's rest offset has the bone's mean length, pointing as in frame 0. The root
    carries the position and the character's heading; every other joint turns its bone by
    the smallest rotation from the rest direction, so positions come back exactly when bone
    lengths are constant (and with the mean lengths when they are not). A joint with several
    children (the hips, the chest) gets one zero-length helper joint per child, named
    ``<child>_base``, as the CMU skeleton has ``LHipJoint``, ``LowerBack`` and so on. Each
    leaf joint (toes, fingers, head) turns with the bone that ends in it and carries an
    ``End Site`` :data:`END_SITE_M` further along that bone, so that animation tools draw
    the last bone of each chain as a continuation of the one before it.
    """
    from .representation import facing_angles
    from .skeleton import LOCOMOTION
    skeleton = skeleton or LOCOMOTION
    positions = np.asarray(positions, dtype=np.float64)
    if positions.ndim != 3 or positions.shape[1:] != (skeleton.n_joints, 3):
        raise ValueError(f"positions: expected shape (frames, {skeleton.n_joints}, 3), got {positions.shape}")
    frames = len(positions)
    heading = y_rotation(facing_angles(positions, fps, skeleton=skeleton))
    in_body = np.einsum("fba,fjb->fja", heading, positions)       # heading removed
    children = {j: [c for c, p in enumerate(skeleton.parents) if p == j] for j in range(skeleton.n_joints)}

    names, parents, offsets, body_rot = [], [], [], []

    def bone_rotation(parent: int, child: int) -> tuple[np.ndarray, np.ndarray]:
        vector = in_body[:, child] - in_body[:, parent]
        length = np.linalg.norm(vector, axis=-1)
        rest = vector[0] / max(length[0], 1e-12)
        current = vector / np.maximum(length, 1e-12)[:, None]
        return rest * length.mean(), _swing(rest, current)

    def add(name: str, parent: int, offset: np.ndarray, rotation: np.ndarray) -> int:
        names.append(name)
        parents.append(parent)
        offsets.append(offset)
        body_rot.append(rotation)
        return len(names) - 1

    end_sites: dict[int, np.ndarray] = {}

    def visit(joint: int, file_parent: int, offset: np.ndarray, rotation_in: np.ndarray | None,
              incoming: np.ndarray) -> None:
        """Add ``joint`` under ``file_parent``; ``incoming``: the rotation of the bone ending here."""
        kids = children[joint]
        if len(kids) == 1:
            kid_offset, rotation = bone_rotation(joint, kids[0])
        elif not kids:
            rotation = incoming           # a leaf turns with its bone, so its End Site extends it
        else:
            rotation = rotation_in if rotation_in is not None else np.broadcast_to(np.eye(3), (frames, 3, 3))
        index = add(skeleton.names[joint], file_parent, offset, rotation)
        if not kids:                      # End Site: END_SITE_M further along the bone's rest direction
            direction = offset / max(np.linalg.norm(offset), 1e-12)
            end_sites[index] = direction * END_SITE_M / unit_m
        elif len(kids) == 1:
            visit(kids[0], index, kid_offset, None, rotation)
        else:
            for kid in kids:
                kid_offset, kid_rotation = bone_rotation(joint, kid)
                helper = add(f"{skeleton.names[kid]}_base", index, np.zeros(3), kid_rotation)
                visit(kid, helper, kid_offset, None, kid_rotation)

    root = int(np.flatnonzero(skeleton.parents < 0)[0])
    identity = np.broadcast_to(np.eye(3), (frames, 3, 3))
    visit(root, -1, np.zeros(3), identity, identity)
    body_rot = np.stack(body_rot, axis=1)                           # (frames, J', 3, 3)
    world_rot = heading[:, None] @ body_rot
    parent_rot = np.stack([world_rot[:, p] if p >= 0 else np.broadcast_to(np.eye(3), (frames, 3, 3))
                           for p in parents], axis=1)
    local = np.swapaxes(parent_rot, -1, -2) @ world_rot
    angles = matrix_to_euler_zyx(local).reshape(frames, -1)
    motion = np.concatenate([positions[:, root] / unit_m, angles], axis=1)
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")] + \
        [("Zrotation", "Yrotation", "Xrotation")] * (len(names) - 1)
    return BVH(names, np.array(parents, dtype=np.int64), np.array(offsets) / unit_m, channels,
               motion, 1.0 / fps, end_sites)
