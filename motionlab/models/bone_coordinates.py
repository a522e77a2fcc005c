"""Bones as a length and a direction: coordinates MoGlow and Glow can model (``bone_coordinates``).

In root-local positions a bone's length is a curved function of the two joints it joins,
and a flow that adds its noise coordinate by coordinate stretches bones, in its mode too
(docs/feet.md: the anchored MoGlow's shins and forearms vary by 5-10 % over a run at τ = 0).
With ``bone_coordinates`` MoGlow models every joint but the hips and the ankles (18 bones,
parents first; :func:`bones_of`) by three other numbers, in place of its ``x, y, z``: with
``o = p_child - p_parent`` (metres) and ``o'`` the same bone in the previous frame,

    l = (ln |o| - ln |o'|) / K            the bone's change of length since the previous frame
    s = stereographic(o / |o|)            its direction, projected from a pole it never points to

(``K`` = :data:`LOG_LENGTH_UNIT`; the pole is the opposite of the bone's mean direction in
the data, so ``s = 0`` is the bone pointing its usual way). The map is a smooth bijection
given the previous frame, which the model conditions on, so maximum likelihood stays exact:

    ln p(x) = ln p(y) + Σ_bones [Σ_axes ln σ_axis - 3 ln |o| - ln 4 + 2 ln(1 + |s|²) - ln K]

(``σ``: the normaliser's standard deviations; ``|o|³ · 4 / (1 + |s|²)²`` is the volume of
spherical coordinates with the stereographic sphere). The data's bones keep their length,
so every ``l`` of the data is 0 and its density could grow without bound; in training each
``l`` gets standard-normal noise (dequantisation: a length jitter of ``K``). A sample's
bone then changes its length by ``K`` times the flow's ``l`` per frame: the mode holds it, up
to the flow's error, and the noise adds up over a long run as a random walk.

The ankles keep their ``x, y, z``: a planted foot is placed where a flow models it best, and
with the ankles in bones too (the whole leg a chain from the hips) the samples' feet sank
3-4 cm into the floor and slid more (docs/feet.md, "Bones as lengths and directions, the legs too").
So each shin, knee to ankle, is the one bone of its leg left free. With ``foot_anchor`` or
``leg_anchor`` (:mod:`motionlab.models.anchor`), which place the feet, knees and toes, only
the spine's, neck's, head's and arms' 12 bones are modelled so (measured on the anchored
MoGlow and not shipped: one training of two drags its legs on the side-step).

Glow (:mod:`motionlab.models.glow`) uses the same map in every frame of its window, given the
frame before in the same window; the first frame's bones against the data's mean pose.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import torch

from ..representation import N_POSE
from ..skeleton import LOCOMOTION
from .base import normalizer_for

LOG_LENGTH_UNIT = 1e-4
"""``K``: one unit of ``l`` is a change of length by this fraction of the bone, per frame."""

FIRST_UPPER_JOINT = LOCOMOTION.names.index("Spine")
ALL_BONES = tuple((child, parent) for parent, child in LOCOMOTION.bones)
"""``(child, parent)`` of every bone, parents first (``LOCOMOTION`` order)."""
UPPER_BONES = tuple((child, parent) for child, parent in ALL_BONES if child >= FIRST_UPPER_JOINT)
"""The spine's, neck's, head's and arms' bones: those a model whose legs are anchored has in bones."""


ANKLES = (LOCOMOTION.names.index("LeftFoot"), LOCOMOTION.names.index("RightFoot"))
BUT_THE_ANKLES = tuple((child, parent) for child, parent in ALL_BONES if child not in ANKLES)
"""Every bone but the shins: the ankles keep their ``x, y, z``, where a planted foot is modelled best."""


def bones_of(config) -> tuple[tuple[int, int], ...]:
    """The bones ``config`` models as lengths and directions: every bone but the shins, or the
    upper body's where the feet or legs are anchored (:mod:`motionlab.models.anchor` places them)."""
    return UPPER_BONES if (config.foot_anchor or config.leg_anchor) else BUT_THE_ANKLES


def check_config(config) -> None:
    """``ValueError`` naming ``bone_coordinates`` where a config cannot model them: they need
    the locomotion features with every upper-body joint's ``x, y, z`` modelled."""
    if not config.bone_coordinates:
        return
    n_pose = config.n_features - config.n_control
    if (n_pose, config.n_control) != (N_POSE, 3):
        raise ValueError(f"bone_coordinates: needs the locomotion features ({N_POSE} pose values and 3 "
                         f"controls), got {n_pose} and {config.n_control}")
    children = {3 * child + axis for child, _ in bones_of(config) for axis in range(3)}
    if set(config.constant_features) & children:
        raise ValueError("bone_coordinates: the values of a joint modelled by its bone (every joint but the hips, "
                         "or the spine's, neck's, head's and arms' with anchored legs) cannot be constant_features")


class BoneUnits(NamedTuple):
    """What the map needs from a normaliser (:meth:`BoneCoordinates._bone_units`)."""

    children: torch.Tensor     # (bones,) each modelled bone's child joint, parents first
    parents: torch.Tensor      # (bones,) and its parent joint
    mean: torch.Tensor         # (63,) the pose's mean, metres
    std: torch.Tensor          # (63,) its standard deviation
    modelled: torch.Tensor     # the pose features the flow models, in its column order
    columns: torch.Tensor      # (bones, 3) each bone's child's columns: l, s1, s2 in the flow's values
    axes: torch.Tensor         # (bones, 3) and its x, y, z among the 63 pose values
    poles: torch.Tensor        # (bones, 3) each bone's pole: the opposite of its mean direction
    e1: torch.Tensor           # (bones, 3) and two orthonormal axes across it
    e2: torch.Tensor
    log_std: float             # Σ ln σ over the children's x, y, z: the log-determinant's constant
    tiers: list[tuple[torch.Tensor, torch.Tensor, torch.Tensor]]   # by depth from the joints the flow places:
    #                            each tier's (bones, their children, their parents), placed tier by tier


class BoneCoordinates:
    """The map, for a MoGlow whose ``config`` has ``bone_coordinates`` (``modelled`` and
    ``normalizer`` as :class:`~motionlab.models.moglow.MoGlow`)."""

    def _bone_units(self, device) -> BoneUnits:
        """What the map needs (:class:`BoneUnits`), computed once per normaliser and device."""
        normalizer = normalizer_for(self, "bone_coordinates", "the bones' lengths are measured")
        key = (id(normalizer), str(device))
        cached = getattr(self, "_bone_cache", None)
        if cached is not None and cached[0] == key:
            return cached[1]
        with torch.inference_mode(False):            # kept across calls: not inference tensors (a stream's)
            units = self._compute_bone_units(normalizer, device)
        self._bone_cache = (key, units)
        return units

    def _compute_bone_units(self, normalizer, device) -> BoneUnits:
        mean = torch.tensor(np.asarray(normalizer.mean[:N_POSE], dtype=np.float64), dtype=torch.float32, device=device)
        std = torch.tensor(np.asarray(normalizer.std[:N_POSE], dtype=np.float64), dtype=torch.float32, device=device)
        modelled = self.modelled.tolist()
        bones = bones_of(self.config)
        columns = torch.tensor([[modelled.index(3 * child + axis) for axis in range(3)] for child, _ in bones],
                               device=device)
        joints = mean.view(LOCOMOTION.n_joints, 3)
        poles, first, second = [], [], []
        for child, parent in bones:
            pole = -(joints[child] - joints[parent])
            pole = pole / pole.norm()
            helper = torch.tensor([1.0, 0.0, 0.0] if abs(float(pole[0])) < 0.9 else [0.0, 1.0, 0.0], device=device)
            e1 = torch.linalg.cross(pole, helper)
            e1 = e1 / e1.norm()
            poles.append(pole), first.append(e1), second.append(torch.linalg.cross(pole, e1))
        children, parents = [child for child, _ in bones], [parent for _, parent in bones]
        log_std = float(torch.log(std.view(-1, 3)[children]).sum())
        depth = {}
        for k, (child, parent) in enumerate(bones):          # parents first: a parent's depth is known
            depth[child] = depth.get(parent, 0) + 1
        tiers = []
        for d in range(1, max(depth.values()) + 1):
            tier = [k for k, (child, _) in enumerate(bones) if depth[child] == d]
            tiers.append(tuple(torch.tensor(index, device=device) for index in
                               (tier, [children[k] for k in tier], [parents[k] for k in tier])))
        axes = torch.tensor([[3 * child + axis for axis in range(3)] for child in children], device=device)
        return BoneUnits(torch.tensor(children, device=device), torch.tensor(parents, device=device), mean, std,
                         torch.tensor(modelled, device=device), columns, axes, torch.stack(poles),
                         torch.stack(first), torch.stack(second), log_std, tiers)

    @staticmethod
    def _joints(x: torch.Tensor, units: BoneUnits) -> torch.Tensor:
        """Modelled normalised values ``(..., n_modelled)`` -> joints ``(..., 21, 3)`` in metres
        (a constant feature at its mean)."""
        mean, std, modelled = units.mean, units.std, units.modelled
        pose = mean.expand(*x.shape[:-1], N_POSE).clone()
        pose[..., modelled] = x.float() * std[modelled] + mean[modelled]
        return pose.unflatten(-1, (LOCOMOTION.n_joints, 3))

    def to_bones(self, poses: torch.Tensor, previous: torch.Tensor,
                 unit: float = LOG_LENGTH_UNIT) -> tuple[torch.Tensor, torch.Tensor]:
        """The flow's values of ``poses`` ``(..., n_modelled)`` (normalised) given the frames
        before them ``previous`` (same shape): ``(y, ln |det ∂y/∂x|)``, the second ``(...)``."""
        units = self._bone_units(poses.device)
        now, before = self._joints(poses, units), self._joints(previous, units)
        children, parents = units.children, units.parents
        bone = now[..., children, :] - now[..., parents, :]                          # o, (..., bones, 3)
        length = bone.norm(dim=-1)                                                    # |o|
        u = bone / length[..., None]
        away = 1 - (u * units.poles).sum(-1)                                          # 1 - u·pole
        s1, s2 = (u * units.e1).sum(-1) / away, (u * units.e2).sum(-1) / away        # stereographic
        length_before = (before[..., children, :] - before[..., parents, :]).norm(dim=-1)
        ell = (torch.log(length) - torch.log(length_before)) / unit
        y = poses.clone()
        y[..., units.columns] = torch.stack([ell, s1, s2], dim=-1).to(y.dtype)
        logdet = units.log_std + (-3 * torch.log(length) + 2 * torch.log1p(s1 ** 2 + s2 ** 2)).sum(-1) \
            - len(children) * (math.log(4) + math.log(unit))
        return y, logdet

    def from_bones(self, y: torch.Tensor, previous: torch.Tensor, unit: float = LOG_LENGTH_UNIT) -> torch.Tensor:
        """:meth:`to_bones` inverted: the poses ``(..., n_modelled)`` whose flow's values are
        ``y``, given the frames before them; each joint placed from its parent, parents first (the
        bones of one depth in the tree at once: :attr:`BoneUnits.tiers`)."""
        units = self._bone_units(y.device)
        before = self._joints(previous, units)
        children, parents = units.children, units.parents
        lengths = (before[..., children, :] - before[..., parents, :]).norm(dim=-1)          # |o'|, (..., bones)
        return self.place_bones(y, torch.log(lengths) + unit * y[..., units.columns[:, 0]].float())

    def place_bones(self, y: torch.Tensor, log_lengths: torch.Tensor) -> torch.Tensor:
        """The poses ``(..., n_modelled)`` whose bones have the directions in ``y`` (the flow's
        values) and the lengths ``exp(log_lengths)`` ``(..., bones)``, in metres; the joints not
        in bones are ``y``'s. The last step of :meth:`from_bones`, and of a whole Glow window at
        once, whose log-lengths are a sum over its frames (``Glow.window_from_bones``)."""
        units = self._bone_units(y.device)
        joints = self._joints(y, units)                              # the joints not in bones are already y's
        s1, s2 = (y[..., units.columns[:, axis]].float() for axis in (1, 2))
        n2 = (s1 ** 2 + s2 ** 2)[..., None]                          # the stereographic projection inverted
        u = (2 * (s1[..., None] * units.e1 + s2[..., None] * units.e2) + (n2 - 1) * units.poles) / (n2 + 1)
        bone = torch.exp(log_lengths)[..., None] * u                                # o, (..., bones, 3)
        for tier, children, parents in units.tiers:
            joints[..., children, :] = joints[..., parents, :] + bone[..., tier, :]
        x = y.clone()
        placed = (joints[..., units.children, :] - units.mean[units.axes]) / units.std[units.axes]
        x[..., units.columns] = placed.to(x.dtype)
        return x
