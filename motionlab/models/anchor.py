"""Feet anchored where they were planted: the shift both flows can make (``foot_anchor``).

In the root-local representation a planted foot must sweep back by exactly the root's
step every frame, and any error in that sweep is sliding. With ``foot_anchor`` a flow
models, for the ``x`` and ``z`` of each ankle and toe, the frame's value less ``m``: where
that joint would be had it stayed put in the world since the previous frame, computed
from the previous frame's foot and its control (:meth:`FootAnchor.anchor`). A planted foot
is then 0, whatever the speed.

The shift keeps maximum likelihood exact (its log-determinant is 0):

* MoGlow (:mod:`motionlab.models.moglow`): the previous pose and the control are the
  conditioning, so ``x_t - m(x_{t-1}, c_{t-1})`` is a shift by a constant of the flow;
* Glow (:mod:`motionlab.models.glow`): the previous frame is part of the window the flow
  models, so the map ``y_t = x_t - m(x_{t-1}, c_{t-1})`` (``y_0 = x_0``) over the window is
  triangular with ones on its diagonal: volume-preserving, and inverted frame by frame,
  ``x_t = y_t + m(x_{t-1}, c_{t-1})`` (:meth:`FootAnchor.anchor_window`).

Anchored feet alone, the legs stretch to hold them (docs/feet.md has the
measurements): a held foot stays put while the knee goes on with the body, and the shin
lengthens through each stance. In a laptop-size anchored Glow the window sums the steps,
every error in a step stays in the sum, and the shins grow over the window.

**The rest of the leg** (``leg_anchor``, with ``foot_anchor``): each toe's ``x, z`` is
modelled less its ankle's in the same frame, and each knee's ``x, y, z`` less the midpoint
of its hip and ankle. The flow then models the foot bone and where the knee bends, not
where the toe and the knee are, and a leg whose ankle is held keeps its length. These
shifts are by hips and ankles of the same frame, which are not shifted by them: the map is
triangular with ones on its diagonal (log-determinant 0), inverted by placing the ankles
first (:meth:`FootAnchor._anchored`).
"""
from __future__ import annotations

import numpy as np
import torch

from ..contacts import LEGS
from ..skeleton import FEET, LOCOMOTION
from .base import normalizer_for

FOOT_XZ = tuple(3 * j + axis for axis in (0, 2) for j in FEET)
"""The root-local ``x`` then ``z`` features of the ankles and toes (:data:`FEET` order)."""

ANKLE_SLOTS = tuple(k for k, feature in enumerate(FOOT_XZ) if feature // 3 in {leg[2] for leg in LEGS})
"""Where the ankles' ``x, z`` are in :data:`FOOT_XZ` and in ``m`` (with ``leg_anchor`` only
they take ``m``; the toes are placed from their ankles)."""

LEG_SOURCES = tuple(3 * j + axis for hip, _, ankle, _ in LEGS for j in (hip, ankle) for axis in range(3))
"""``leg_anchor``'s inputs: each leg's hip ``x, y, z`` then ankle ``x, y, z`` (left leg first)."""

LEG_TARGETS = tuple(f for _, knee, _, toe in LEGS for f in (3 * toe, 3 * toe + 2, 3 * knee, 3 * knee + 1, 3 * knee + 2))
"""``leg_anchor``'s outputs: each leg's toe ``x, z`` then knee ``x, y, z`` (left leg first)."""


def stayed_put(feet: torch.Tensor, control: torch.Tensor, fps: float) -> torch.Tensor:
    """Where each ankle and toe is in this frame's root frame had it stayed put in the world
    since the previous frame, in metres: ``feet`` ``(..., 8)`` the previous frame's root-local
    ``x`` then ``z`` (:data:`FOOT_XZ` order, metres), ``control`` ``(..., 3)`` its control
    (sideways and forward m/s, turning rad/s). With ``θ = turning / fps`` and ``s =
    (sideways, forward) / fps`` (:func:`motionlab.contacts.foot_velocity` inverted, world
    velocity 0): ``R(θ)^-1 (p - s)``, ``R(θ)^-1 = [[cos θ, -sin θ], [sin θ, cos θ]]`` on ``(x, z)``."""
    theta = control[..., 2:3] / fps
    x, z = feet[..., :len(FEET)] - control[..., 1:2] / fps, feet[..., len(FEET):] - control[..., 0:1] / fps
    cos, sin = torch.cos(theta), torch.sin(theta)
    return torch.cat([cos * x - sin * z, sin * x + cos * z], dim=-1)


def _leg_matrix() -> np.ndarray:
    """``A`` ``(10, 12)``: the shift of :data:`LEG_TARGETS` from :data:`LEG_SOURCES` in metres,
    toe ``x, z`` ← its ankle's, knee ← half its hip plus half its ankle."""
    a = np.zeros((len(LEG_TARGETS), len(LEG_SOURCES)))
    for leg in range(len(LEGS)):
        row, col = 5 * leg, 6 * leg                     # rows: toe x, z, knee x, y, z; cols: hip, ankle
        a[row, col + 3] = a[row + 1, col + 5] = 1.0
        for axis in range(3):
            a[row + 2 + axis, col + axis] = a[row + 2 + axis, col + 3 + axis] = 0.5
    return a


def check_config(config) -> None:
    """``ValueError`` naming ``foot_anchor`` where a config cannot anchor the feet: they need
    the locomotion features (63 pose values, 3 controls) with the feet's ``x, z`` modelled."""
    if not config.foot_anchor:
        return
    n_pose = config.n_features - config.n_control
    if (n_pose, config.n_control) != (3 * LOCOMOTION.n_joints, 3):
        raise ValueError(f"foot_anchor: needs the locomotion features ({3 * LOCOMOTION.n_joints} pose values "
                         f"and 3 controls), got {n_pose} and {config.n_control}")
    if set(config.constant_features) & set(FOOT_XZ):
        raise ValueError("foot_anchor: the feet's x and z cannot be constant_features")
    if config.leg_anchor and set(config.constant_features) & set(LEG_SOURCES + LEG_TARGETS):
        raise ValueError("leg_anchor: the hips', knees', ankles' and toes' values cannot be constant_features")


def check_leg_config(config) -> None:
    """``ValueError`` naming ``leg_anchor`` where it is set without ``foot_anchor``."""
    if config.leg_anchor and not config.foot_anchor:
        raise ValueError("leg_anchor: anchors the toes and knees to the ankles that foot_anchor places; "
                         "needs foot_anchor=True")


class FootAnchor:
    """The shift, for a flow whose ``config`` has ``foot_anchor``, ``n_features``,
    ``n_control``, ``constant_features`` and ``fps`` and which models the pose given the
    control (``modelled``, ``control`` and ``normalizer`` as :class:`~motionlab.models.flows.MotionFlow`)."""

    def _init_foot_anchor(self, config) -> None:
        """Register the feet's ``x`` then ``z`` columns among the modelled values."""
        if config.foot_anchor:
            modelled = [i for i in range(config.n_features - config.n_control) if i not in config.constant_features]
            self.register_buffer("foot_columns", torch.tensor([modelled.index(i) for i in FOOT_XZ]),
                                 persistent=False)
        if config.leg_anchor:
            ankles = [FOOT_XZ[k] for k in ANKLE_SLOTS]
            columns = (("ankle_columns", ankles), ("leg_sources", LEG_SOURCES), ("leg_targets", LEG_TARGETS))
            for name, features in columns:
                self.register_buffer(name, torch.tensor([modelled.index(i) for i in features]), persistent=False)

    def anchor_units(self) -> tuple[torch.Tensor, ...]:
        """The model's normaliser where :meth:`anchor` needs it, float32 on the model's
        device: the mean and std of the feet's ``x, z`` features (``(8,)``, :data:`FOOT_XZ`
        order) and of the control (``(3,)``); with ``leg_anchor`` also ``W`` ``(12, 10)`` and
        ``b`` ``(10,)``, the legs' shift in normalised units (``sources @ W + b``)."""
        normalizer = normalizer_for(self, "foot_anchor", "the shift is measured")
        columns = list(FOOT_XZ) + list(range(self.config.n_features)[self.control])
        legs = self.config.leg_anchor
        columns += list(LEG_SOURCES + LEG_TARGETS) if legs else []
        mean, std = (torch.as_tensor(np.asarray(values)[columns], dtype=torch.float32, device=self.modelled.device)
                     for values in (normalizer.mean, normalizer.std))
        n, c = len(FOOT_XZ), len(FOOT_XZ) + self.config.n_control
        units = (mean[:n], std[:n], mean[n:c], std[n:c])
        if not legs:
            return units
        k = c + len(LEG_SOURCES)
        source_mean, source_std, target_std = mean[c:k], std[c:k], std[k:]
        a = torch.as_tensor(_leg_matrix(), dtype=torch.float32, device=self.modelled.device)
        # metres: target shift = A (source_std * s + source_mean); normalised: divided by target_std
        return units + ((source_std[:, None] * a.T) / target_std, (a @ source_mean) / target_std)

    def anchor(self, previous: torch.Tensor, control: torch.Tensor, units=None) -> torch.Tensor:
        """``m``: where each ankle and toe would be in this frame's root frame had it stayed
        planted in the world since the previous frame, ``(..., 8)`` normalised (the feet's
        ``x`` then ``z``, :data:`FEET` order), from the previous frame's modelled pose
        ``(..., n_modelled)`` and its control ``(..., n_control)`` (normalised).

        In the data's units, :func:`stayed_put` of the previous frame's feet and control:
        ``m = R(θ)^-1 (p_{t-1} - s)``. ``units``: :meth:`anchor_units`, if already at hand."""
        foot_mean, foot_std, control_mean, control_std = (self.anchor_units() if units is None else units)[:4]
        p = previous[..., self.foot_columns].float() * foot_std + foot_mean               # metres
        c = control.float() * control_std + control_mean                                  # m/s, rad/s
        return ((stayed_put(p, c, self.config.fps) - foot_mean) / foot_std).to(previous.dtype)

    def _anchored(self, poses: torch.Tensor, previous: torch.Tensor, control: torch.Tensor,
                  sign: float, units=None) -> torch.Tensor:
        """``poses`` with ``sign · m`` added to the feet's ``x, z`` (-1: the flow's values
        from the poses; +1: the poses from the flow's values). With ``leg_anchor`` only the
        ankles take ``m``; the toes and knees then take ``sign`` times their shift from this
        frame's hips and ankles, as placed (the poses' own: the input for -1, the ankles just
        restored for +1)."""
        units = self.anchor_units() if units is None else units
        out = poses.clone()
        m = self.anchor(previous, control, units)
        if not self.config.leg_anchor:
            out[..., self.foot_columns] += sign * m
            return out
        out[..., self.ankle_columns] += sign * m[..., ANKLE_SLOTS]
        placed = poses if sign < 0 else out                              # hips and ankles, as in the pose
        weight, bias = units[4:]
        shift = placed[..., self.leg_sources].float() @ weight + bias
        out[..., self.leg_targets] += (sign * shift).to(out.dtype)
        return out

    def anchor_window(self, x: torch.Tensor, control: torch.Tensor, sign: float) -> torch.Tensor:
        """The triangular map over whole windows ``x`` ``(batch, frames, n_modelled)`` given
        their control ``(batch, frames, n_control)``: ``sign = -1`` gives the flow's values
        ``y_t = x_t - m(x_{t-1}, c_{t-1})`` (all frames at once), ``sign = +1`` inverts it
        frame by frame, ``x_t = y_t + m(x_{t-1}, c_{t-1})``. The first frame is kept as it is.
        Either way the Jacobian is triangular with ones on its diagonal: log-determinant 0."""
        units = self.anchor_units()
        if sign < 0:
            out = x.clone()
            out[:, 1:] = self._anchored(x[:, 1:], x[:, :-1], control[:, :-1], -1.0, units)
            return out
        frames = [x[:, :1]]
        for t in range(1, x.shape[1]):
            frames.append(self._anchored(x[:, t:t + 1], frames[-1], control[:, t - 1:t], 1.0, units))
        return torch.cat(frames, dim=1)
