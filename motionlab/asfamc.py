"""CMU's Acclaim ASF/AMC motion capture files: read them and run forward kinematics.

The CMU Graphics Lab Motion Capture Database (http://mocap.cs.cmu.edu) serves every trial
in the Acclaim format, two text files:

* an **ASF** (Acclaim Skeleton File), one per subject, e.g. ``16.asf``. Sections start
  with a keyword line: ``:units`` (``mass``, ``length`` and ``angle deg|rad``), ``:root``
  (``order TX TY TZ RX RY RZ``: which numbers the AMC gives the root; ``axis XYZ``;
  ``position`` and ``orientation`` at rest), ``:bonedata`` (one ``begin`` ... ``end``
  block per bone) and ``:hierarchy`` (lines ``parent child child ...``). A bone has a
  ``direction`` (unit vector, world axes, rest pose), a ``length``, an ``axis`` (three
  angles and their order: the bone's local frame), ``dof`` (the numbers the AMC gives it,
  a subset of ``rx ry rz``; ``tx ty tz l`` are allowed too) and ``limits``.
* an **AMC** (Acclaim Motion Capture) file, one per trial, e.g. ``16_15.amc``: after
  ``:FULLY-SPECIFIED`` and ``:DEGREES`` (or ``:RADIANS``), one block per frame: a line with
  the frame number, then one line per bone, ``name v1 v2 ...``, the values of its dofs in
  the ASF's order (the root's in ``order``). There is no frame rate in the file; CMU
  captured at 120 fps.

>>> asf = read_asf("../shared/mocap/cmu_asfamc/16.asf")
>>> amc = read_amc("../shared/mocap/cmu_asfamc/16_15.amc", asf)
>>> positions, names = world_positions(asf, amc)
>>> positions.shape                     # (frames, root + 30 bone ends, 3), file units
(471, 31, 3)

Forward kinematics (checked against the cgspeed BVH conversion of the same trials in
``../shared/mocap/cmu``: root, legs and spine agree to 1e-4 units, 0.006 mm): Euler
angles are applied in the order they are written, first letter first, so ``axis ... XYZ``
and ``dof rx ry rz`` both mean the matrix ``Rz @ Ry @ Rx``. For a bone with axis frame ``C`` and dof rotation ``M``::

    L = C @ M @ C.T                       # the dof rotation, turned into world rest axes
    W_bone = W_parent @ L                 # accumulated rotation
    end = parent_end + W_bone @ (direction * length)

The root is the same with ``C`` from ``orientation`` (in ``axis`` order), ``M`` from the
AMC's rotation numbers (in ``order``), and its position is ``position`` plus the AMC's
``TX TY TZ``. Bones without dofs never move relative to their parent.

Compared with those BVH files, everything above the thorax differs: cgspeed drops the
``thorax`` bone (and the wrists), so there the neck, head and arms sit one thorax vector
(11-13 cm) lower, the fingers also one wrist vector (about 10 cm) closer to the elbow.
:data:`CMU_FROM_ASF` maps the 31 BVH joints to ASF positions.

Lengths stay in file units. CMU's ASF says ``length 0.45``: one unit is 1/0.45 inch, so
metres per unit is ``0.0254 / length`` (:func:`metres_per_unit`). Y is up.

A malformed file raises ``ValueError`` whose message starts with ``"<file>:<line>:"``.
"""
from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import checks
from .bvh import read_text_lines
from .clip import INCH_M, Clip
from .rotations import euler_to_matrix, forward_kinematics
from .skeleton import LOCOMOTION

ROTATION_DOFS = ("rx", "ry", "rz")
TRANSLATION_DOFS = ("tx", "ty", "tz")
DOF_NAMES = ROTATION_DOFS + TRANSLATION_DOFS + ("l",)
"""Dof names a bone may list: rotations, translations in its axis frame, ``l`` (stretch)."""

ROOT_CHANNELS = ("TX", "TY", "TZ", "RX", "RY", "RZ")

ASF_SECTIONS = (":version", ":name", ":units", ":documentation", ":root", ":bonedata",
                ":hierarchy", ":skin")
"""Section keywords of an ASF file (``:skin``, naming display meshes, is skipped)."""

AMC_KEYWORDS = (":FULLY-SPECIFIED", ":DEGREES", ":RADIANS")

CMU_FROM_ASF = {
    "Hips": "root",
    "LHipJoint": "root", "LeftUpLeg": "lhipjoint", "LeftLeg": "lfemur",
    "LeftFoot": "ltibia", "LeftToeBase": "lfoot",
    "RHipJoint": "root", "RightUpLeg": "rhipjoint", "RightLeg": "rfemur",
    "RightFoot": "rtibia", "RightToeBase": "rfoot",
    "LowerBack": "root", "Spine": "lowerback", "Spine1": "upperback",
    "Neck": "thorax", "Neck1": "lowerneck", "Head": "upperneck",
    "LeftShoulder": "thorax", "LeftArm": "lclavicle", "LeftForeArm": "lhumerus",
    "LeftHand": "lradius", "LeftFingerBase": "lwrist", "LeftHandIndex1": "lhand",
    "LThumb": "lwrist",
    "RightShoulder": "thorax", "RightArm": "rclavicle", "RightForeArm": "rhumerus",
    "RightHand": "rradius", "RightFingerBase": "rwrist", "RightHandIndex1": "rhand",
    "RThumb": "rwrist",
}
"""Each of the 31 CMU BVH joints -> the ASF bone whose END it is (``"root"``: the root).

A BVH joint sits at the start of its ASF bone (``LeftLeg`` is where ``ltibia`` starts),
which is the end of that bone's parent (``lfemur``). The cgspeed BVH files drop the
``thorax`` and wrist lengths, so there ``Neck``, the shoulders and everything above them
sit one thorax vector lower, and the finger bases one wrist vector closer to the arm,
than the ASF skeleton puts them.
"""

LOCOMOTION_FROM_ASF = {name: CMU_FROM_ASF[name] for name in LOCOMOTION.names}
"""The 21 locomotion joints (``skeleton.LOCOMOTION`` order) -> the ASF position naming them."""

LOCOMOTION_BELOW_THORAX = ("Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase",
                           "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase", "Spine", "Spine1")
"""Locomotion joints below the thorax: at the same place in the ASF/AMC and the cgspeed BVH files."""


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


def _dof_columns(dof: tuple[str, ...], names: tuple[str, ...]) -> list[int]:
    """Columns of ``dof`` (e.g. ``("TX", ..., "RZ")`` or ``("rx", "rz")``) that are in ``names``."""
    return [k for k, d in enumerate(dof) if d.lower() in names]


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


# --------------------------------------------------------------------------- kinematics

def _root_transform(asf: ASF, amc: AMC) -> tuple[np.ndarray, np.ndarray]:
    """Root rotation ``(F, 3, 3)`` and position ``(F, 3)``."""
    values = amc.values["root"]
    rotation_columns = _dof_columns(asf.root_order, ROTATION_DOFS)
    rotation_order = "".join(asf.root_order[k][1] for k in rotation_columns)     # e.g. "XYZ"
    motion = euler_to_matrix(values[:, rotation_columns], rotation_order)
    axes = euler_to_matrix(asf.root_orientation, asf.root_axis)
    position = np.broadcast_to(asf.root_position, (amc.n_frames, 3)).copy()
    for k in _dof_columns(asf.root_order, TRANSLATION_DOFS):
        position[:, "XYZ".index(asf.root_order[k][1])] += values[:, k]
    return axes @ motion @ axes.T, position


def _bone_motion(bone: Bone, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A bone's dof rotation ``M`` ``(F, 3, 3)`` and translation ``(F, 3)`` in its axis frame.

    ``l`` stretches the bone along its own direction (expressed in the axis frame here).
    """
    rotation_columns = _dof_columns(bone.dof, ROTATION_DOFS)
    rotation_order = "".join(bone.dof[k][1] for k in rotation_columns).upper()  # "rx rz" -> "XZ"
    motion = euler_to_matrix(values[:, rotation_columns], rotation_order)
    translation = np.zeros((len(values), 3))
    for k in _dof_columns(bone.dof, TRANSLATION_DOFS):
        translation[:, "xyz".index(bone.dof[k][1])] += values[:, k]
    if "l" in bone.dof:
        local_direction = bone.axis_matrix.T @ bone.direction
        translation += values[:, [bone.dof.index("l")]] * local_direction
    return motion, translation


def world_transforms(asf: ASF, amc: AMC) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """World rotations ``(F, 1 + B, 3, 3)``, positions ``(F, 1 + B, 3)`` and their names.

    Index 0 is the root (its rotation and position); index ``1 + b`` is bone ``b`` of
    ``asf.bones``: its accumulated rotation and the position of its END, file units.
    Forward kinematics (:func:`motionlab.rotations.forward_kinematics`) with each bone's
    offset turned by its own rotation; bones without dofs keep their parent's rotation.
    """
    names = ["root"] + asf.bone_names
    index = {name: i for i, name in enumerate(names)}
    parents = np.array([-1] + [index[asf.parents[name]] for name in asf.bone_names])
    frames = amc.n_frames
    rotations = np.broadcast_to(np.eye(3), (frames, len(names), 3, 3)).copy()
    offsets = np.empty((frames, len(names), 3))
    rotations[:, 0], offsets[:, 0] = _root_transform(asf, amc)
    for i, bone in enumerate(asf.bones, start=1):
        offsets[:, i] = bone.offset
        if bone.dof:
            axes = bone.axis_matrix
            motion, translation = _bone_motion(bone, amc.values[bone.name])
            rotations[:, i] = axes @ motion @ axes.T
            offsets[:, i] += translation @ axes.T
    fixed = np.array([False] + [not bone.dof for bone in asf.bones])
    rotations, positions = forward_kinematics(parents, rotations, offsets, "own", fixed)
    return rotations, positions, names


def world_positions(asf: ASF, amc: AMC) -> tuple[np.ndarray, list[str]]:
    """The root and every bone END: positions ``(F, 1 + B, 3)`` in file units (y up), names.

    Names are ``"root"`` then ``asf.bone_names``.
    """
    _, positions, names = world_transforms(asf, amc)
    return positions, names


# --------------------------------------------------------------------------- loading

def metres_per_unit(asf: ASF) -> float:
    """Metres per file length unit: ``0.0254 / length`` (CMU, ``length 0.45``: 0.056444 m)."""
    return INCH_M / asf.length


_TRIAL_NAME = re.compile(r"^(\d+)_\d+$")


def skeleton_path(amc_path: str | Path) -> Path:
    """The subject's skeleton next to a CMU trial: ``.../16_15.amc`` -> ``.../16.asf``
    (or ``16.ASF``: the extension may be in any letter case)."""
    amc_path = Path(amc_path)
    match = _TRIAL_NAME.match(amc_path.stem)
    if not match:
        raise ValueError(f"{amc_path}: cannot tell the subject from the name (expected "
                         "<subject>_<trial>.amc, e.g. 16_15.amc); pass asf_path")
    asf_path = amc_path.with_name(f"{match.group(1)}.asf")
    if not asf_path.is_file() and amc_path.parent.is_dir():
        asf_path = next((p for p in sorted(amc_path.parent.iterdir())
                         if p.name.lower() == asf_path.name and p.is_file()), asf_path)
    if not asf_path.is_file():
        raise ValueError(f"{amc_path}: its skeleton {asf_path.name} is not in {asf_path.parent}; "
                         "fetch it (python -m motionlab.download) or pass asf_path")
    return asf_path


def load_locomotion(amc_path: str | Path, asf_path: str | Path | None = None,
                    fps: float = 120.0) -> tuple[np.ndarray, float]:
    """A CMU trial as the 21 locomotion joints: positions ``(F, 21, 3)`` in metres, and fps.

    Args:
        amc_path: the ``.amc`` file, e.g. ``16_15.amc``.
        asf_path: its skeleton; default the subject's ``16.asf`` next to it.
        fps: the capture frame rate (AMC files do not state it; CMU captured at 120 fps).

    Joints are :data:`LOCOMOTION_FROM_ASF` in ``skeleton.LOCOMOTION`` order, y up, every
    frame of the file (unlike cgspeed BVH files, no T-pose frame to drop).
    """
    fps = checks.rate(fps, "fps")
    asf = read_asf(asf_path if asf_path is not None else skeleton_path(amc_path))
    amc = read_amc(amc_path, asf)
    positions, names = world_positions(asf, amc)
    missing = [b for b in LOCOMOTION_FROM_ASF.values() if b not in names]
    if missing:
        raise ValueError(f"{asf.path}: not a CMU skeleton, missing bones {', '.join(sorted(set(missing)))}")
    index = [names.index(b) for b in LOCOMOTION_FROM_ASF.values()]
    return positions[:, index] * metres_per_unit(asf), float(fps)


def load_clip(amc_path: str | Path, asf_path: str | Path | None = None, fps: float | None = None,
              source_fps: float = 120.0) -> Clip:
    """A CMU trial as a :class:`motionlab.clip.Clip` (named like ``"16_15"``), resampled to
    ``fps`` if given; ``source_fps`` is the capture rate. Ready for ``data.prepare``."""
    if fps is not None:
        fps = checks.rate(fps, "fps")
    positions, rate = load_locomotion(amc_path, asf_path, checks.rate(source_fps, "source_fps"))
    clip = Clip(Path(amc_path).stem, positions, rate, str(amc_path))
    return clip.resampled(fps) if fps is not None else clip
