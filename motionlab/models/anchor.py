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

The legs then stretch to hold the feet (the README's feet section has the measurements). In
the shipped anchored MoGlow a held foot stays put while the knee goes on with the body, and
the shin lengthens through each stance (notebook 06 draws it). In a laptop-size anchored
Glow the window sums the steps, every error in a step stays in the sum, and the shins grow
over the window.
"""
from __future__ import annotations

import numpy as np
import torch

from ..skeleton import FEET, LOCOMOTION

FOOT_XZ = tuple(3 * j + axis for axis in (0, 2) for j in FEET)
"""The root-local ``x`` then ``z`` features of the ankles and toes (:data:`FEET` order)."""


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

    def anchor_units(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """The model's normaliser where :meth:`anchor` needs it, float32 on the model's
        device: the mean and std of the feet's ``x, z`` features (``(8,)``, :data:`FOOT_XZ`
        order) and of the control (``(3,)``)."""
        if self.normalizer is None:
            raise ValueError("foot_anchor: the shift is measured in the data's units and needs the model's "
                             "normaliser; train with training.train on a MotionData (it sets model.normalizer) "
                             "or set model.normalizer")
        columns = list(FOOT_XZ) + list(range(self.config.n_features)[self.control])
        mean, std = (torch.as_tensor(np.asarray(values)[columns], dtype=torch.float32, device=self.modelled.device)
                     for values in (self.normalizer.mean, self.normalizer.std))
        n = len(FOOT_XZ)
        return mean[:n], std[:n], mean[n:], std[n:]

    def anchor(self, previous: torch.Tensor, control: torch.Tensor, units=None) -> torch.Tensor:
        """``m``: where each ankle and toe would be in this frame's root frame had it stayed
        planted in the world since the previous frame, ``(..., 8)`` normalised (the feet's
        ``x`` then ``z``, :data:`FEET` order), from the previous frame's modelled pose
        ``(..., n_modelled)`` and its control ``(..., n_control)`` (normalised).

        In the data's units, with ``θ = turning / fps`` and ``s = (sideways, forward) / fps``
        the previous frame's step (:func:`motionlab.contacts.foot_velocity` inverted, world
        velocity 0): ``m = R(θ)^-1 (p_{t-1} - s)``, ``R(θ)^-1 = [[cos θ, -sin θ], [sin θ, cos θ]]``
        on ``(x, z)``. ``units``: :meth:`anchor_units`, if already at hand."""
        foot_mean, foot_std, control_mean, control_std = self.anchor_units() if units is None else units
        p = previous[..., self.foot_columns].float() * foot_std + foot_mean               # metres
        c = control.float() * control_std + control_mean                                  # m/s, rad/s
        fps = self.config.fps
        theta = c[..., 2:3] / fps
        x, z = p[..., :len(FEET)] - c[..., 1:2] / fps, p[..., len(FEET):] - c[..., 0:1] / fps
        cos, sin = torch.cos(theta), torch.sin(theta)
        m = torch.cat([cos * x - sin * z, sin * x + cos * z], dim=-1)
        return ((m - foot_mean) / foot_std).to(previous.dtype)

    def _anchored(self, poses: torch.Tensor, previous: torch.Tensor, control: torch.Tensor,
                  sign: float, units=None) -> torch.Tensor:
        """``poses`` with ``sign · m`` added to the feet's ``x, z`` (-1: the flow's values
        from the poses; +1: the poses from the flow's values)."""
        out = poses.clone()
        out[..., self.foot_columns] += sign * self.anchor(previous, control, units)
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
