"""CMU's Acclaim skeleton files (``.asf``): the parser (:func:`read_asf`) and what it returns
(:class:`ASF`, its :class:`Bone` s).

The format, and how :mod:`motionlab.asfamc` turns a skeleton and a motion into joint
positions, are described there. Angles come back in degrees, lengths in file units. A
malformed file raises ``ValueError`` whose message starts with ``"<file>:<line>:"``; the
line-numbered text source (:class:`_Source`) is shared with the motion parser,
:mod:`motionlab.amc`.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .bvh_file import read_text_lines
from .rotations import euler_to_matrix

ROTATION_DOFS = ("rx", "ry", "rz")
TRANSLATION_DOFS = ("tx", "ty", "tz")
DOF_NAMES = ROTATION_DOFS + TRANSLATION_DOFS + ("l",)
"""Dof names a bone may list: rotations, translations in its axis frame, ``l`` (stretch)."""

ROOT_CHANNELS = ("TX", "TY", "TZ", "RX", "RY", "RZ")

ASF_SECTIONS = (":version", ":name", ":units", ":documentation", ":root", ":bonedata",
                ":hierarchy", ":skin")
"""Section keywords of an ASF file (``:skin``, naming display meshes, is skipped)."""


def _dof_columns(dof: tuple[str, ...], names: tuple[str, ...]) -> list[int]:
    """Columns of ``dof`` (e.g. ``("TX", ..., "RZ")`` or ``("rx", "rz")``) that are in ``names``."""
    return [k for k, d in enumerate(dof) if d.lower() in names]


# --------------------------------------------------------------------------- data classes

@dataclass
class Bone:
    """One ``begin`` ... ``end`` block of an ASF ``:bonedata`` section.

    Attributes:
        id: the bone's ``id``.
        name: the bone's name (CMU: lowercase, e.g. ``"lfemur"``).
        direction: ``(3,)`` direction from the bone's start to its end, world axes, rest pose.
        length: the bone's length, file length units.
        axis: ``(3,)`` angles of the bone's local frame, degrees, in the order of
            :attr:`axis_order` (``"XYZ"``: ``C = Rz @ Ry @ Rx``).
        axis_order: the order of :attr:`axis`, a permutation of ``"XYZ"``.
        dof: the numbers the AMC gives this bone, in file order (e.g. ``("rx", "rz")``).
        limits: ``(len(dof), 2)`` lower and upper limit per dof (degrees for rotations),
            ``-inf``/``inf`` where the file gives none.
    """

    id: int
    name: str
    direction: np.ndarray
    length: float
    axis: np.ndarray
    axis_order: str
    dof: tuple[str, ...] = ()
    limits: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    @property
    def offset(self) -> np.ndarray:
        """``(3,)`` vector from the bone's start to its end at rest, world axes, file units."""
        return self.direction * self.length

    @property
    def axis_matrix(self) -> np.ndarray:
        """``(3, 3)`` rotation ``C`` of the bone's local frame (columns: its axes in world)."""
        return euler_to_matrix(self.axis, self.axis_order)


@dataclass
class ASF:
    """A skeleton file in memory. All angles in degrees, lengths in file units.

    Attributes:
        name: the ``:name`` (CMU: ``"VICON"``).
        mass: ``:units mass``.
        length: ``:units length``, the length multiplier (CMU: 0.45, one unit = 1/0.45 inch).
        angle: ``:units angle`` as the file states it, ``"deg"`` or ``"rad"``.
        root_order: the numbers the AMC gives the root, e.g. ``("TX", "TY", "TZ", "RX", "RY", "RZ")``.
        root_axis: the order of :attr:`root_orientation`, e.g. ``"XYZ"``.
        root_position: ``(3,)`` root position at rest, added to the AMC's translation.
        root_orientation: ``(3,)`` root frame angles, degrees.
        bones: the bones in file order.
        children: the ``:hierarchy``: ``"root"`` or a bone name -> its children, in file order.
        path: the file it was read from, if any.
    """

    name: str
    mass: float
    length: float
    angle: str
    root_order: tuple[str, ...]
    root_axis: str
    root_position: np.ndarray
    root_orientation: np.ndarray
    bones: list[Bone]
    children: dict[str, tuple[str, ...]]
    path: str | None = None

    @property
    def bone_names(self) -> list[str]:
        return [bone.name for bone in self.bones]

    @property
    def parents(self) -> dict[str, str]:
        """Bone name -> its parent's name (``"root"`` for bones attached to the root)."""
        return {child: parent for parent, kids in self.children.items() for child in kids}

    def bone(self, name: str) -> Bone:
        """The bone called ``name``; ``ValueError`` naming it if there is none."""
        for bone in self.bones:
            if bone.name == name:
                return bone
        raise ValueError(f"{self.path}: no bone {name!r}; bones are {', '.join(self.bone_names)}")

    def topological_order(self) -> list[str]:
        """Bone names, each after its parent (breadth first from the root)."""
        order, queue = [], list(self.children.get("root", ()))
        while queue:
            name = queue.pop(0)
            order.append(name)
            queue.extend(self.children.get(name, ()))
        return order


# --------------------------------------------------------------------------- ASF

class _Source:
    """A text file's lines, and ``ValueError``s that name the file and a line number."""

    def __init__(self, path: str, what: str):
        self.path = path
        self.lines = read_text_lines(path, what)      # BOM, binary data and HTML handled there
        self.n_lines = len(self.lines)

    def error(self, line: int, message: str) -> ValueError:
        return ValueError(f"{self.path}:{line}: {message}")

    def number(self, word: str, line: int, what: str) -> float:
        """``word`` as a finite float (``nan``, ``inf`` and ``1e400`` are refused)."""
        try:
            value = float(word)
        except ValueError:
            raise self.error(line, f"bad number {word!r} for {what}") from None
        if not math.isfinite(value):
            raise self.error(line, f"bad number {word!r} for {what}: not a finite number")
        return value

    def numbers(self, words: list[str], count: int, line: int, what: str) -> np.ndarray:
        if len(words) != count:
            raise self.error(line, f"expected {count} numbers for {what}, found {len(words)}")
        return np.array([self.number(w, line, what) for w in words])


def _sections(source: _Source) -> dict[str, tuple[int, list[str], list[tuple[int, list[str]]]]]:
    """Split an ASF into its sections: keyword -> (line, words after the keyword, body).

    The body is the list of ``(line number, words)`` of the section's non-comment lines.
    Section keywords are read in any letter case (``:ROOT``) and returned in lower case.
    """
    sections: dict[str, tuple[int, list[str], list[tuple[int, list[str]]]]] = {}
    current = None
    for n, line in enumerate(source.lines, start=1):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if words[0].startswith(":"):
            keyword = words[0].lower()
            if keyword not in ASF_SECTIONS:
                raise source.error(n, f"unknown section {words[0]!r}; ASF sections are "
                                      f"{', '.join(ASF_SECTIONS)}")
            if keyword in sections:
                raise source.error(n, f"second {keyword} section")
            sections[keyword] = (n, words[1:], [])
            current = sections[keyword][2]
        elif current is None:
            raise source.error(n, f"expected a section keyword such as ':version', found {words[0]!r}")
        else:
            current.append((n, words))
    return sections


def _parse_units(source: _Source, body) -> tuple[float, float, str]:
    """``(mass, length, angle)`` from the ``:units`` lines; 1, 1 and ``"deg"`` if not given."""
    units: dict[str, object] = {"mass": 1.0, "length": 1.0, "angle": "deg"}
    for n, words in body:
        key, value = words[0].lower(), words[1:]
        if key in ("mass", "length"):
            units[key] = number = source.numbers(value, 1, n, f"units {key}")[0]
            if number <= 0:
                raise source.error(n, f"units {key} must be positive, got {number:g}")
        elif key == "angle":
            if [v.lower() for v in value] not in (["deg"], ["rad"]):
                raise source.error(n, f"units angle must be 'deg' or 'rad', got {' '.join(value)!r}")
            units[key] = value[0].lower()
        else:
            raise source.error(n, f"unknown unit {key!r}; expected mass, length or angle")
    return float(units["mass"]), float(units["length"]), str(units["angle"])


def _axis_order(source: _Source, word: str, n: int) -> str:
    order = word.upper()
    if sorted(order) != ["X", "Y", "Z"]:
        raise source.error(n, f"axis order must be a permutation of XYZ, got {word!r}")
    return order


def _parse_root(source: _Source, body, to_degrees: float):
    order, axis = ROOT_CHANNELS, "XYZ"
    position, orientation = np.zeros(3), np.zeros(3)
    for n, words in body:
        key, value = words[0].lower(), words[1:]
        if key == "order":
            order = tuple(w.upper() for w in value)
            unknown = [w for w in order if w not in ROOT_CHANNELS]
            if unknown or len(set(order)) != len(order):
                raise source.error(n, f"root order must list distinct channels from "
                                      f"{' '.join(ROOT_CHANNELS)}, got {' '.join(value)!r}")
        elif key == "axis":
            if len(value) != 1:
                raise source.error(n, "root axis needs one order such as XYZ")
            axis = _axis_order(source, value[0], n)
        elif key == "position":
            position = source.numbers(value, 3, n, "root position")
        elif key == "orientation":
            orientation = source.numbers(value, 3, n, "root orientation") * to_degrees
        else:
            raise source.error(n, f"unknown root keyword {key!r}; expected order, axis, "
                                  "position or orientation")
    return order, axis, position, orientation


_LIMIT = re.compile(r"\(\s*([^\s()]+)\s+([^\s()]+)\s*\)")


def _limit(source: _Source, word: str, n: int) -> float:
    """One limit: a finite number, or the word ``inf`` / ``-inf`` (no limit, as the
    Acclaim format allows: ``limits (-inf inf)``). ``nan`` and ``1e400`` are refused."""
    if word.lower() in ("inf", "+inf", "-inf"):
        return float(word)
    return source.number(word, n, "a limit")


def _parse_limits(source: _Source, lines: list[tuple[int, list[str]]]) -> list[tuple[float, float]]:
    """``limits (a b)`` pairs, one or more per line, over the lines given."""
    limits = []
    for n, words in lines:
        text = " ".join(words)
        pairs = _LIMIT.findall(text)
        if not pairs or _LIMIT.sub("", text).strip():
            raise source.error(n, f"bad limits {text!r}; expected pairs like (-160.0 20.0)")
        limits += [(_limit(source, a, n), _limit(source, b, n)) for a, b in pairs]
    return limits


def _direction(source: _Source, words: list[str], n: int) -> np.ndarray:
    """A bone's ``direction``: three finite numbers, not all zero."""
    direction = source.numbers(words, 3, n, "direction")
    if not np.linalg.norm(direction) > 1e-9:
        raise source.error(n, f"direction {' '.join(words)} has length zero; a bone needs a direction")
    return direction


def _length(source: _Source, words: list[str], n: int) -> float:
    """A bone's ``length``: a finite number >= 0, file length units."""
    length = float(source.numbers(words, 1, n, "length")[0])
    if length < 0:
        raise source.error(n, f"length must be >= 0, got {words[0]}")
    return length


def _parse_bone(source: _Source, begin_line: int, lines, index: int, to_degrees: float) -> Bone:
    """One bone from the lines between ``begin`` and ``end``."""
    fields: dict[str, object] = {}
    limit_lines: list[tuple[int, list[str]]] = []
    for n, words in lines:
        key, value = words[0].lower(), words[1:]
        if key.startswith("(") and limit_lines:
            limit_lines.append((n, words))
        elif key == "limits":
            limit_lines = [(n, value)]
        elif key == "id":
            fields["id"] = int(source.numbers(value, 1, n, "id")[0])
        elif key == "name":
            if len(value) != 1:
                raise source.error(n, "a bone needs exactly one name")
            fields["name"] = value[0]
        elif key == "direction":
            fields["direction"] = _direction(source, value, n)
        elif key == "length":
            fields["length"] = _length(source, value, n)
        elif key in ("bodymass", "cofmass"):            # optional in the Acclaim format, unused here
            source.numbers(value, 1, n, key)
        elif key == "axis":
            if len(value) != 4:
                raise source.error(n, "axis needs three angles and an order, e.g. 'axis 0 0 20 XYZ'")
            fields["axis"] = source.numbers(value[:3], 3, n, "axis") * to_degrees
            fields["axis_order"] = _axis_order(source, value[3], n)
        elif key == "dof":
            unknown = [w for w in value if w.lower() not in DOF_NAMES]
            if unknown:
                raise source.error(n, f"unknown dof {unknown[0]!r}; dofs are {' '.join(DOF_NAMES)}")
            fields["dof"] = tuple(w.lower() for w in value)
            if len(set(fields["dof"])) != len(value):
                raise source.error(n, f"a dof listed twice in {' '.join(value)!r}")
        else:
            raise source.error(n, f"unknown bone keyword {key!r}")
    missing = [k for k in ("name", "direction", "length", "axis") if k not in fields]
    if missing:
        raise source.error(begin_line, f"bone has no {', '.join(missing)}")
    dof = fields.get("dof", ())
    limits = np.full((len(dof), 2), [-np.inf, np.inf])
    if limit_lines:
        given = np.array(_parse_limits(source, limit_lines)).reshape(-1, 2)
        if len(given) != len(dof):
            raise source.error(limit_lines[0][0], f"bone {fields['name']} has {len(dof)} dofs "
                                                  f"but {len(given)} limits")
        rotational = np.array([d in ROTATION_DOFS for d in dof])
        limits = np.where(rotational[:, None], given * to_degrees, given)
    return Bone(fields.get("id", index + 1), fields["name"], fields["direction"], float(fields["length"]),
                fields["axis"], fields["axis_order"], dof, limits)


def _parse_bonedata(source: _Source, line: int, body, to_degrees: float) -> list[Bone]:
    bones, block, begin_line = [], None, line
    for n, words in body:
        keyword = words[0].lower() if len(words) == 1 else None
        if keyword == "begin":
            if block is not None:
                raise source.error(n, "'begin' inside a bone; missing 'end'")
            block, begin_line = [], n
        elif keyword == "end":
            if block is None:
                raise source.error(n, "'end' without 'begin'")
            bones.append(_parse_bone(source, begin_line, block, len(bones), to_degrees))
            block = None
        elif block is None:
            raise source.error(n, f"expected 'begin', found {words[0]!r}")
        else:
            block.append((n, words))
    if block is not None:
        raise source.error(begin_line, "bone has no 'end'")
    names = [b.name for b in bones]
    for bone in bones:
        if bone.name == "root" or names.count(bone.name) > 1:
            raise source.error(line, f"bone name {bone.name!r} is reserved or used twice")
    return bones


def _parse_hierarchy(source: _Source, line: int, body, bone_names: list[str]) -> dict[str, tuple[str, ...]]:
    """The ``:hierarchy`` lines ``parent child child ...`` -> ``{parent: (child, ...)}``.

    ``begin``, ``end`` and ``root`` may be in any letter case; bone names must match exactly.
    """
    children: dict[str, tuple[str, ...]] = {}
    parent_of: dict[str, str] = {}
    known = set(bone_names) | {"root"}
    rows = [(n, words) for n, words in body if [w.lower() for w in words] not in (["begin"], ["end"])]
    for n, words in rows:
        words = ["root" if w.lower() == "root" and w not in known else w for w in words]
        for name in words:
            if name not in known:
                raise source.error(n, f"unknown bone {name!r} in :hierarchy")
        parent, kids = words[0], words[1:]
        if parent in children:
            raise source.error(n, f"{parent!r} listed twice as a parent in :hierarchy")
        for kid in kids:
            if kid in parent_of or kid == "root":
                raise source.error(n, f"bone {kid!r} has two parents in :hierarchy")
            parent_of[kid] = parent
        children[parent] = tuple(kids)
    reached, queue = set(), list(children.get("root", ()))
    while queue:
        name = queue.pop()
        reached.add(name)
        queue.extend(children.get(name, ()))
    unreached = [b for b in bone_names if b not in reached]
    if unreached:
        raise source.error(line, f"bones not connected to the root in :hierarchy: {', '.join(unreached)}")
    return children


def read_asf(path: str | Path) -> ASF:
    """Read an Acclaim skeleton (``.asf``) file.

    Angles come back in degrees whatever ``:units angle`` says; lengths stay in file units.
    Section names and keywords may be in any letter case (``:BONEDATA``, ``LENGTH``), and
    the file may start with a UTF-8 byte order mark. Raises ``ValueError`` starting
    ``"<file>:<line>:"`` for an unknown section or keyword, a bad or non-finite number
    (``nan``, ``inf``, ``1e400``; only limits may say ``-inf``/``inf``), a direction of
    length zero, a negative length, an unknown dof, limits that do not match the dofs, or a
    missing, inconsistent or incomplete ``:hierarchy``; ``"<file>:"`` for binary data.
    """
    source = _Source(str(path), "ASF")
    sections = _sections(source)
    for required in (":root", ":bonedata", ":hierarchy"):
        if required not in sections:
            raise source.error(source.n_lines, f"no {required} section")
    mass, length, angle = _parse_units(source, sections.get(":units", (0, [], []))[2])
    to_degrees = np.rad2deg(1.0) if angle == "rad" else 1.0
    order, axis, position, orientation = _parse_root(source, sections[":root"][2], to_degrees)
    bonedata_line, _, bonedata = sections[":bonedata"]
    bones = _parse_bonedata(source, bonedata_line, bonedata, to_degrees)
    hierarchy_line, _, hierarchy = sections[":hierarchy"]
    children = _parse_hierarchy(source, hierarchy_line, hierarchy, [b.name for b in bones])
    name = " ".join(sections[":name"][1]) if ":name" in sections else ""
    return ASF(name, mass, length, angle, order, axis, position, orientation, bones, children,
               str(path))
