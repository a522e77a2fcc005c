"""Skeletons: joint names, parents, bones and the left/right mirror map.

Two skeletons matter in motionlab:

* the **31-joint CMU skeleton** of the cgspeed BVH release (what ``../shared/mocap/cmu``
  holds), and
* the **21-joint locomotion skeleton** used by Holden et al. and by MoGlow (Henter 2020,
  §5.1): the CMU skeleton without its zero-length helper joints (hip joints, lower back,
  neck, clavicles, finger bases and thumbs). Every model in the course works on it.

A hierarchy is a list of joint names plus ``parents``, an integer array where
``parents[j]`` is the index of joint ``j``'s parent and ``-1`` marks the root. Parents
always come before their children, so forward kinematics can run in index order.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CMU_JOINTS = (
    "Hips",
    "LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase",
    "RHipJoint", "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase",
    "LowerBack", "Spine", "Spine1", "Neck", "Neck1", "Head",
    "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand", "LeftFingerBase",
    "LeftHandIndex1", "LThumb",
    "RightShoulder", "RightArm", "RightForeArm", "RightHand", "RightFingerBase",
    "RightHandIndex1", "RThumb",
)
"""The 31 joints of the cgspeed CMU BVH files, in file order."""

CMU_PARENTS = np.array(
    [-1,
     0, 1, 2, 3, 4,
     0, 6, 7, 8, 9,
     0, 11, 12, 13, 14, 15,
     13, 17, 18, 19, 20, 21, 20,
     13, 24, 25, 26, 27, 28, 27],
    dtype=np.int64,
)
"""Parent index of each of :data:`CMU_JOINTS` (``-1`` for the root)."""

CMU_TO_LOCOMOTION = np.array(
    [0, 2, 3, 4, 5, 7, 8, 9, 10, 12, 13, 15, 16, 18, 19, 20, 22, 25, 26, 27, 29],
    dtype=np.int64,
)
"""Indices into :data:`CMU_JOINTS` of the 21 locomotion joints, in locomotion order."""


def _mirror_map(names: tuple[str, ...]) -> np.ndarray:
    """Index of each joint's left/right counterpart (itself for centre joints)."""
    swaps = (("Left", "Right"), ("LHip", "RHip"), ("LThumb", "RThumb"))
    index = {name: i for i, name in enumerate(names)}
    mirror = np.arange(len(names))
    for i, name in enumerate(names):
        for a, b in swaps:
            if name.startswith(a):
                mirror[i] = index[b + name[len(a):]]
            elif name.startswith(b):
                mirror[i] = index[a + name[len(b):]]
    return mirror


def reduce_hierarchy(parents: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Parents of a sub-skeleton that keeps joints ``keep`` (indices into ``parents``).

    Each kept joint's new parent is its nearest kept ancestor; the result indexes into
    ``keep``. Raises ``ValueError`` if a kept joint other than the first has no kept
    ancestor (the sub-skeleton would not be a tree).
    """
    parents = np.asarray(parents)
    keep = np.asarray(keep)
    position = {int(j): i for i, j in enumerate(keep)}
    reduced = np.full(len(keep), -1, dtype=np.int64)
    for i, j in enumerate(keep):
        p = parents[j]
        while p >= 0 and int(p) not in position:
            p = parents[p]
        if p < 0 and i > 0:
            raise ValueError(f"keep: joint {int(j)} has no kept ancestor")
        reduced[i] = position[int(p)] if p >= 0 else -1
    return reduced


@dataclass(frozen=True)
class Skeleton:
    """A joint hierarchy: names, parents, and left/right mirror map.

    Attributes:
        names: joint names, parents before children.
        parents: ``(joints,)`` int array, ``-1`` for the root.
        mirror: ``(joints,)`` int array, the left/right counterpart of each joint.
    """

    names: tuple[str, ...]
    parents: np.ndarray
    mirror: np.ndarray

    @property
    def n_joints(self) -> int:
        return len(self.names)

    @property
    def bones(self) -> list[tuple[int, int]]:
        """``(parent, child)`` index pairs, one per non-root joint."""
        return [(int(p), j) for j, p in enumerate(self.parents) if p >= 0]

    def index(self, name: str) -> int:
        """Index of joint ``name``; ``ValueError`` naming the joint if it is unknown."""
        try:
            return self.names.index(name)
        except ValueError:
            raise ValueError(f"unknown joint {name!r}; joints are {', '.join(self.names)}") from None

    def bone_lengths(self, positions: np.ndarray) -> np.ndarray:
        """Bone lengths ``(..., joints - 1)`` from positions ``(..., joints, 3)``.

        Bones are ordered as :attr:`bones`; units are those of ``positions``.
        """
        positions = np.asarray(positions)
        if positions.shape[-2:] != (self.n_joints, 3):
            raise ValueError(
                f"positions: expected shape (..., {self.n_joints}, 3), got {positions.shape}")
        child = np.array([j for _, j in self.bones])
        parent = self.parents[child]
        return np.linalg.norm(positions[..., child, :] - positions[..., parent, :], axis=-1)


CMU = Skeleton(CMU_JOINTS, CMU_PARENTS, _mirror_map(CMU_JOINTS))
"""The 31-joint CMU (cgspeed BVH) skeleton."""

LOCOMOTION_JOINTS = tuple(CMU_JOINTS[i] for i in CMU_TO_LOCOMOTION)
LOCOMOTION = Skeleton(
    LOCOMOTION_JOINTS,
    reduce_hierarchy(CMU_PARENTS, CMU_TO_LOCOMOTION),
    _mirror_map(LOCOMOTION_JOINTS),
)
"""The 21-joint locomotion skeleton of Holden et al. and MoGlow: every model uses it."""

FEET = tuple(LOCOMOTION.index(n) for n in ("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase"))
"""Locomotion-skeleton indices of the ankles and toes (the joints that touch the floor)."""


def cmu_to_locomotion(positions: np.ndarray) -> np.ndarray:
    """Select the 21 locomotion joints from 31-joint CMU positions ``(..., 31, 3)``."""
    positions = np.asarray(positions)
    if positions.shape[-2:] != (len(CMU_JOINTS), 3):
        raise ValueError(
            f"positions: expected shape (..., {len(CMU_JOINTS)}, 3), got {positions.shape}")
    return positions[..., CMU_TO_LOCOMOTION, :]
