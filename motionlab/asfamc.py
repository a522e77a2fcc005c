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

The parsers are :mod:`motionlab.asf` (the skeleton) and :mod:`motionlab.amc` (the motion);
their names are importable from here too. This module maps the ASF bones to the CMU joints,
runs forward kinematics and loads a trial as a :class:`~motionlab.clip.Clip`.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from . import checks
from .amc import AMC, AMC_KEYWORDS, MAX_FRAME_NUMBER_DIGITS, read_amc
from .asf import (ASF, ASF_SECTIONS, DOF_NAMES, ROOT_CHANNELS, ROTATION_DOFS, TRANSLATION_DOFS, Bone,
                  _dof_columns, read_asf)
from .clip import INCH_M, Clip
from .rotations import euler_to_matrix, forward_kinematics
from .skeleton import LOCOMOTION

__all__ = ["AMC", "AMC_KEYWORDS", "ASF", "ASF_SECTIONS", "Bone", "CMU_FROM_ASF", "DOF_NAMES", "INCH_M",
           "LOCOMOTION_BELOW_THORAX", "LOCOMOTION_FROM_ASF", "MAX_FRAME_NUMBER_DIGITS", "ROOT_CHANNELS",
           "ROTATION_DOFS", "TRANSLATION_DOFS", "load_clip", "load_locomotion", "metres_per_unit", "read_amc",
           "read_asf", "skeleton_path", "world_positions", "world_transforms"]

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
