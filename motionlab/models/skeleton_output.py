"""A skeleton output layer: a decoder's joint coordinates put onto one body, inside the model.

A model that outputs 21 free joint positions per frame can stretch its bones, and does
(``benchmarks/feet.py``: 3-6 % for the VAE-LSTM). :func:`motionlab.contacts.fit_bones`
repairs that after the fact; this layer makes it the model's own output, as DFN's rotation
decoder does (Chen §4, forward kinematics over a skeleton). Walking down the tree from the
hips (which stay where the decoder put them), each joint is placed at its bone's length from
its already placed parent, along the direction the decoder gave that bone::

    p^_root = x_root,     p^_child = p^_parent + L_bone * (x_child - x_parent) / |x_child - x_parent|

except the legs below the hip joints: they reach the decoder's ankles by two-bone IK (the
law of cosines, the knee in the plane the decoder bent it in; an ankle out of reach is
drawn in along the hip-ankle line) and the foot points at the decoder's toe, as
:func:`motionlab.contacts.fit_bones` does. The decoder places the feet, which the contact
term trains; walked down bone by bone, a leg would move its foot by every bone's correction
above it, and the feet slid more (docs/feet.md).

Each sequence's lengths ``L`` are its own bones' mean length over its frames, as decoded: the
body keeps the size the model gives it (the data's bodies differ in size, and one latent
sets it for a whole window), and no bone stretches from frame to frame. With one skeleton
for every sequence instead (20 learned lengths), a window of a short or tall body could only
be matched by moving the hips, and after the recipe's training the reconstruction from
``z_1`` alone was worse (6.3 against 4.5 cm on notebook 04's test windows). The layer is
differentiable, so the likelihood and the contact term are measured on the body the model
will generate.
"""
from __future__ import annotations

import torch
from torch import nn

from ..contacts import LEGS
from ..representation import N_POSE
from ..skeleton import LOCOMOTION

EPS_M = 1e-6
"""A bone the decoder collapsed to a point keeps a direction of zero length, not NaN."""

STRAIGHT = 1e-3
"""How far short of straight (a fraction of its length) an IK leg may reach, and how near the
hip it may fold (at full extension the angle's derivative is infinite; at the hip, 0 / 0)."""


CHILDREN = [child for _, child in LOCOMOTION.bones]
PARENTS = [parent for parent, _ in LOCOMOTION.bones]


def bone_lengths(pose: torch.Tensor) -> torch.Tensor:
    """:meth:`Skeleton.bone_lengths` in torch: ``pose`` ``(..., 21, 3)`` -> ``(..., 20)``,
    ``LOCOMOTION.bones`` order, in the units of ``pose``."""
    return (pose[..., CHILDREN, :] - pose[..., PARENTS, :]).norm(dim=-1)


def _unit(v: torch.Tensor) -> torch.Tensor:
    return v / v.norm(dim=-1, keepdim=True).clamp_min(EPS_M)


def reach(hip, knee, target, thigh, shin) -> tuple[torch.Tensor, torch.Tensor]:
    """Two-bone IK in torch (differentiable): the knee and ankle ``(..., 3)`` of a leg from
    ``hip`` with bones ``thigh`` and ``shin`` ``(..., 1)`` long whose ankle is put on
    ``target``, or as near it as the leg reaches along the hip-target line, the knee towards
    ``knee`` (the side it bent to). :func:`motionlab.contacts.two_bone_ik`'s law of cosines."""
    to_target = target - hip
    direction = _unit(to_target)
    d = to_target.norm(dim=-1, keepdim=True)
    shortest = torch.maximum((thigh - shin).abs() * (1 + STRAIGHT), (thigh + shin) * STRAIGHT)
    d = torch.minimum(torch.maximum(d, shortest), (thigh + shin) * (1 - STRAIGHT))
    pole = knee - hip
    pole = _unit(pole - (pole * direction).sum(-1, keepdim=True) * direction)
    cos_a = ((thigh ** 2 + d ** 2 - shin ** 2) / (2 * thigh * d)).clamp(-1 + STRAIGHT, 1 - STRAIGHT)
    return hip + thigh * (cos_a * direction + (1 - cos_a ** 2).sqrt() * pole), hip + d * direction


def _in_metres(features: torch.Tensor, normalizer) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Normalised ``features`` ``(..., >= 63)`` -> the pose ``(..., 21, 3)`` in metres, and the
    pose's mean and standard deviation ``(63,)`` that undid the normalisation."""
    mean = torch.as_tensor(normalizer.mean[:N_POSE], dtype=features.dtype, device=features.device)
    std = torch.as_tensor(normalizer.std[:N_POSE], dtype=features.dtype, device=features.device)
    return (features[..., :N_POSE] * std + mean).unflatten(-1, (LOCOMOTION.n_joints, 3)), mean, std


class SkeletonOutput(nn.Module):
    """``forward(features, normalizer)``: normalised features ``(..., frames, 66)`` (pose,
    then control) with each sequence's pose put onto its own skeleton; the control passes
    through. No weights: a fixed function of the decoder's output."""

    def __init__(self):
        super().__init__()
        self.bone_of = {child: k for k, child in enumerate(CHILDREN)}
        self.by_ik = {j for leg in LEGS for j in leg[1:]}   # knees, ankles, toes: placed by the legs' IK

    @staticmethod
    def lengths(pose: torch.Tensor) -> torch.Tensor:
        """Each sequence's bone lengths: ``pose`` ``(..., frames, 21, 3)`` in metres ->
        ``(..., 1, 20)``, each bone's mean length over the frames, ``LOCOMOTION.bones`` order."""
        return bone_lengths(pose).mean(dim=-2, keepdim=True)

    @staticmethod
    def pose_lengths(features: torch.Tensor, normalizer) -> torch.Tensor:
        """The bone lengths ``(..., frames, 20)`` in metres of normalised ``features``
        ``(..., frames, >= 63)``, frame by frame."""
        return bone_lengths(_in_metres(features, normalizer)[0])

    def forward(self, features: torch.Tensor, normalizer, lengths: torch.Tensor | None = None) -> torch.Tensor:
        """``lengths`` ``(..., 1 or frames, 20)`` in metres: the bones to keep (an
        autoregressive model's, carried from the body it continues); ``None``: each
        sequence's own mean (:meth:`lengths`)."""
        if normalizer is None:
            raise ValueError("normalizer: the skeleton output layer measures bones in metres and needs the "
                             "model's normaliser (training.train sets model.normalizer)")
        pose, mean, std = _in_metres(features, normalizer)
        lengths = self.lengths(pose) if lengths is None else lengths.to(pose.dtype)
        placed = [pose[..., 0, :]] + [None] * (LOCOMOTION.n_joints - 1)
        for k, (parent, child) in enumerate(zip(PARENTS, CHILDREN)):   # parents come first
            if child not in self.by_ik:
                bone = pose[..., child, :] - pose[..., parent, :]
                placed[child] = placed[parent] + lengths[..., k, None] * _unit(bone)
        for hip, knee, ankle, toe in LEGS:
            thigh, shin, foot = (lengths[..., self.bone_of[j], None] for j in (knee, ankle, toe))
            placed[knee], placed[ankle] = reach(placed[hip], pose[..., knee, :], pose[..., ankle, :], thigh, shin)
            placed[toe] = placed[ankle] + foot * _unit(pose[..., toe, :] - placed[ankle])
        on_skeleton = (torch.stack(placed, dim=-2).flatten(-2) - mean) / std
        return torch.cat([on_skeleton, features[..., N_POSE:]], dim=-1)
