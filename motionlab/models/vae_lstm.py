"""The control-conditioned recurrent VAE, "VAE-LSTM" (Habibie et al. 2017).

A window of motion is split into its pose ``X`` (63 root-local joint coordinates per frame)
and its control ``C`` (forward, sideways and turning velocity). Two convolutional encoders
(§3.2, eq. 6) summarise both at a quarter of the frame rate: the *inference network* gives
a Gaussian posterior ``q(z_s | X)`` per step ``s``, the *control encoder* a deterministic
code ``h_s``. A modified LSTM cell (§3.3, eqs. 7-9) combines them into a sequence of cell
states, the *motion canvas*, and a decoder of upsampling and convolution (§3.3) paints the
canvas back into frames at the full rate::

    X (T x 63) --inference net: [conv, ELU, max-pool] x 2--> mu, log sigma^2 (T/4 x units)  eq. 6
    C (T x 3)  --control encoder: [conv, ELU, max-pool] x 2--> h (T/4 x code)                eq. 6
    z_s = mu_s + sigma_s * eps                                                               eq. 3
    training:  c_s = a(f_s * W_c z_s     + i_s * W_h h_s)    gates i, f from c_{s-1}, h_s   eqs. 7-9
    test time: c_s = a(f_s * W_c c_{s-1} + i_s * W_h h_s)    c_0 = z_1: one latent only
    canvas c_{1..T/4} --[upsample x2, conv] x 2--> X^ (T x 66)                              §3.3
    loss = -log N(X | X^, std^2) + sum_s KL(q(z_s | X) || N(0, I))                          eqs. 4-5
         + free_running * -log N(X | X^ decoded from z_1 alone, test-time cell, std^2)    (ours)
         + contact_weight * mean(planted in X * |world foot velocity in X^|^2)   (HuMoR, EDGE, MDM; off: 0)
         + bone_weight * mean((bone length in X^ - in X)^2, cm^2)                    (ours; off: 0)
    skeleton=True: X^'s bones each one length per sequence (skeleton_output.py)    (ours; off)
    foot_gate=True: 4 more decoder channels, g_t = P(ankle / toe planted since t-1); each  (ours; off)
         foot joint's x, z = g_t * where it stayed put + (1 - g_t) * as decoded (a released
         foot eased back); loss + BCE(g, the data's contact labels)

Generation (§3.4, Algorithm 1) needs only a control signal: ``z_1`` comes from the prior
(no frames) or from the posterior of the first 4 frames (§4.3), and the cell runs in its
test-time form for every later step. The paper's objective never trains that test-time
form; the ``free_running`` term (our addition, see :meth:`VAELSTM.loss`) does, and without
it the generated motion is barely better than the average pose (notebook 04).

Where the paper leaves a choice open, this file makes one and says so in a comment marked
*Choice*. All tensors are ``(batch, frames, features)`` in the normalised units of
:class:`motionlab.data.Normalizer`; the convolutions transpose to ``(batch, channels,
frames)`` inside.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from .. import checks, contacts
from ..representation import N_POSE
from ..skeleton import FEET
from . import gaussian
from .anchor import FOOT_XZ, stayed_put
from .base import (Generated, GenerativeModel, check_tensor, eval_mode, generator_for, normalizer_for,
                   per_frame_nll)
from .modelcard import NO_CLIP, ModelCard, choice, paper
from .skeleton_output import SkeletonOutput

POOLING = 4
"""Frames per canvas step: two max-pooling layers, each halving the frame rate (§4.2)."""

N_FEET = len(FEET)
"""The gate's channels (``foot_gate``): the ankles and toes."""


@dataclass(frozen=True)
class VAELSTMConfig:
    """Sizes and options. Defaults: a laptop-sized model at 20 fps; :meth:`paper` is §4.2.

    Attributes:
        n_pose: pose features per frame (63: 21 joints x 3).
        n_control: control features per frame (3: forward, sideways, turning velocity).
        window: frames per training window (any length works: sequences are padded to a
            multiple of 4 with their last frame, and cropped back).
        fps: frames per second of the data the model expects.
        width: temporal filter width of every convolution, in frames (odd).
        control_filters, control_code: filters of the control encoder's two blocks; the
            second is the size of the control code ``h`` per step.
        inference_filters: filters of the inference network's first block (its second
            block has ``2 * units`` filters: ``mu`` and ``log sigma^2``).
        units: LSTM cell size, which is also the latent size (eq. 9 feeds ``z_t`` where
            the test-time cell feeds ``c_{t-1}``, through one matrix ``W_c``).
        decoder_filters: filters of the decoder's hidden convolution.
        observation_std: standard deviation of the Gaussian likelihood ``p(X | z)`` in
            normalised units (eq. 5, ``L_x``).
        dropout: probability that a joint (its three coordinates) or a control channel is
            zeroed at the encoders' input while training (§4.2).
        l1: weight of the L1 penalty on the mean absolute weight (§4.2: "l1 = 0.1").
        free_running: weight of a second reconstruction term in which the cell runs in its
            test-time form from ``z_1`` (our addition, see :meth:`loss`; 0 = the paper's
            objective exactly).
        control_smoothing_s: standard deviation (seconds) of a Gaussian that smooths the
            control before the control encoder sees it (an experiment, see
            :meth:`smooth_control`; 0 = the raw control, as in the paper).
        upsample: how the decoder doubles the frame rate: ``"linear"`` or ``"nearest"``.
        contact_weight: weight of the foot-contact velocity term (HuMoR, EDGE, MDM; see
            :meth:`loss`): nats per frame per (m/s)² of planted-foot velocity; 0 = off (the
            shipped models).
        bone_weight: weight of the bone-length term (:meth:`loss`): nats per frame per cm²
            of squared bone-length error; 0 = off (the shipped models).
        skeleton: each bone of the decoder's pose keeps one length (:class:`SkeletonOutput`; ours).
        foot_gate: the decoder also gives, per frame, the probability that each ankle and toe
            has stayed planted since the previous frame, trained on the data's contact labels;
            each foot joint's ``x, z`` is then that share of where it would be had it stayed
            put in the world and the rest where the decoder put it (:meth:`gate_feet`; ours). In
            training the share is the probability; at generation a foot is held or not.
        gate_release_s: with ``foot_gate``, how fast a released foot eases back to where the
            decoder puts it: the critically damped offset's rate ``y = 2 ln 2 / gate_release_s``
            (from rest, at 0.1 s half the offset is left after about 0.14 s and almost none
            after 0.35 s; 0: it jumps there in one frame).
    """

    n_pose: int = 63
    n_control: int = 3
    window: int = 80
    fps: float = 20.0
    width: int = 9
    control_filters: int = 16
    control_code: int = 32
    inference_filters: int = 32
    units: int = 32
    decoder_filters: int = 64
    observation_std: float = 1.0
    dropout: float = 0.1
    l1: float = 0.1
    free_running: float = 1.0
    control_smoothing_s: float = 0.0
    upsample: str = "linear"
    contact_weight: float = 0.0
    bone_weight: float = 0.0
    skeleton: bool = False
    foot_gate: bool = False
    gate_release_s: float = 0.1

    def __post_init__(self):
        checks.config(self, positive_fields=("observation_std",), probability_fields=("dropout",),
                      non_negative_fields=("l1", "free_running", "control_smoothing_s", "contact_weight",
                                           "bone_weight", "gate_release_s"))
        for name in ("n_pose", "n_control", "window", "control_filters", "control_code",
                     "inference_filters", "units", "decoder_filters"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name}: must be >= 1, got {getattr(self, name)}")
        if self.width < 1 or self.width % 2 == 0:
            raise ValueError(f"width: must be odd and >= 1 so a convolution keeps the length, got {self.width}")
        if not 0 <= self.dropout < 1:
            raise ValueError(f"dropout: expected 0 <= p < 1, got {self.dropout}")
        if self.upsample not in ("linear", "nearest"):
            raise ValueError(f"upsample: expected 'linear' or 'nearest', got {self.upsample!r}")
        if self.foot_gate and (self.n_pose, self.n_control) != (N_POSE, 3):
            raise ValueError(f"foot_gate: needs the locomotion features ({N_POSE} pose values and 3 controls), "
                             f"got {self.n_pose} and {self.n_control}")

    @property
    def n_features(self) -> int:
        return self.n_pose + self.n_control

    @classmethod
    def paper(cls, **changes) -> "VAELSTMConfig":
        """§4.2: 240-frame windows at 60 fps; filters 25 frames wide (0.4 s); control
        encoder 64 and 128 filters, inference network 64 and 256 (= mu and log sigma^2 of
        128 latents), 128 LSTM units (a 128 x 60 canvas), decoder 128 filters back to 66.
        The paper's objective exactly (eq. 5): ``free_running=0``; our free-running term is
        a separate, stated option (``paper(free_running=1.0)``). §4.2 gives no dropout rate
        (we keep 0.1)."""
        return replace(cls(window=240, fps=60.0, width=25, control_filters=64, control_code=128,
                           inference_filters=64, units=128, decoder_filters=128, free_running=0.0), **changes)


# ----------------------------------------------------------------------------------------
# Building blocks
# ----------------------------------------------------------------------------------------

def pad_to_canvas(x: torch.Tensor) -> torch.Tensor:
    """Pad ``(batch, frames, features)`` at the end to a multiple of 4 frames by repeating
    the last frame (§4.1 pads sequences with their final pose the same way)."""
    extra = -x.shape[1] % POOLING
    if extra == 0:
        return x
    return torch.cat([x, x[:, -1:].expand(-1, extra, -1)], dim=1)


class ConvEncoder(nn.Module):
    """Eq. 6: ``Psi(a(Psi(a(X * W_0 + b_0)) * W_1 + b_1))``, a = ELU, Psi = max-pool by 2.

    ``(batch, frames, in_channels)`` -> ``(batch, frames // 4, filters[1])``; frames must
    be a multiple of 4. With ``last_activation=False`` the second block has no ELU, so that
    it can output unbounded posterior parameters.
    """

    def __init__(self, in_channels: int, filters: tuple[int, int], width: int,
                 last_activation: bool = True):
        super().__init__()
        # Choice: convolutions pad by repeating the edge frames, as the data are padded
        # (§4.1); zero padding would look like a sudden stop at both ends.
        self.conv0 = nn.Conv1d(in_channels, filters[0], width, padding=width // 2, padding_mode="replicate")
        self.conv1 = nn.Conv1d(filters[0], filters[1], width, padding=width // 2, padding_mode="replicate")
        self.last_activation = last_activation

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = F.max_pool1d(F.elu(self.conv0(x.transpose(1, 2))), 2)
        h = self.conv1(h)
        if self.last_activation:
            h = F.elu(h)
        return F.max_pool1d(h, 2).transpose(1, 2)


class ControlledLSTMCell(nn.Module):
    """The modified LSTM cell of eqs. 7-9 (no output gate; the cell state is the output).

    ``i = s(W_ic c_prev + b_ic + W_ih h + b_ih)``                      (eq. 7)
    ``f = s(W_fc c_prev + b_fc + W_fh h + b_fh)``                      (eq. 8)
    ``c = tanh(f * W_c drive + i * W_h h)``                             (eq. 9)

    where ``drive`` is the latent ``z_t`` while training and ``c_prev`` at test time.
    """

    def __init__(self, units: int, control_code: int):
        super().__init__()
        self.W_ic = nn.Linear(units, units)          # weights and bias b_ic
        self.W_ih = nn.Linear(control_code, units)
        self.W_fc = nn.Linear(units, units)
        self.W_fh = nn.Linear(control_code, units)
        # Choice: eq. 9 writes W_c[.] and W_h[.] without biases; we keep them without.
        self.W_c = nn.Linear(units, units, bias=False)
        self.W_h = nn.Linear(control_code, units, bias=False)

    def forward(self, previous: torch.Tensor, drive: torch.Tensor, control_code: torch.Tensor) -> torch.Tensor:
        """One step. ``previous`` ``c_{t-1}`` and ``drive`` ``(batch, units)``,
        ``control_code`` ``h_t`` ``(batch, control_code)`` -> ``c_t`` ``(batch, units)``."""
        return self.step(previous, self.W_c(drive), *self.control_terms(control_code))

    def control_terms(self, control_code: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """What the control adds to eqs. 7, 8 and 9, ``W_ih h + b_ih``, ``W_fh h + b_fh``
        and ``W_h h``: ``control_code`` ``(..., control_code)`` -> three ``(..., units)``.
        They do not depend on ``c_{t-1}``, so a sequence computes them for every step at once."""
        return self.W_ih(control_code), self.W_fh(control_code), self.W_h(control_code)

    def step(self, previous: torch.Tensor, driven: torch.Tensor, input_from_control: torch.Tensor,
             forget_from_control: torch.Tensor, candidate_from_control: torch.Tensor) -> torch.Tensor:
        """Eqs. 7-9 given ``driven = W_c drive`` and :meth:`control_terms`, each ``(batch, units)``."""
        input_gate = torch.sigmoid(self.W_ic(previous) + input_from_control)       # eq. 7
        forget_gate = torch.sigmoid(self.W_fc(previous) + forget_from_control)     # eq. 8
        # Choice: the paper's activation "alpha" in eq. 9 is ELU everywhere else (§4.2);
        # we use the LSTM's tanh, which keeps the test-time recursion c_{t-1} -> c_t bounded.
        return torch.tanh(forget_gate * driven + input_gate * candidate_from_control)   # eq. 9


class CanvasDecoder(nn.Module):
    """CNN^dec (§3.3): ``[upsample x2, conv, ELU, upsample x2, conv]`` from the canvas
    ``(batch, steps, units)`` to frames ``(batch, 4 * steps, n_features)``; the inverse of
    the encoders, interpolating between canvas steps."""

    def __init__(self, units: int, filters: int, n_features: int, width: int, upsample: str):
        super().__init__()
        self.conv0 = nn.Conv1d(units, filters, width, padding=width // 2, padding_mode="replicate")
        self.conv1 = nn.Conv1d(filters, n_features, width, padding=width // 2, padding_mode="replicate")
        self.upsample = upsample

    def _up(self, h: torch.Tensor) -> torch.Tensor:
        if self.upsample == "linear":
            return F.interpolate(h, scale_factor=2, mode="linear", align_corners=False)
        return F.interpolate(h, scale_factor=2, mode="nearest")

    def forward(self, canvas: torch.Tensor) -> torch.Tensor:
        h = F.elu(self.conv0(self._up(canvas.transpose(1, 2))))
        return self.conv1(self._up(h)).transpose(1, 2)


# ----------------------------------------------------------------------------------------
# The model
# ----------------------------------------------------------------------------------------

class VAELSTM(GenerativeModel, nn.Module):
    """Habibie et al.'s VAE-LSTM: control signal in, full-body motion out.

    Training: ``loss(batch)`` on windows ``(batch, frames, n_pose + n_control)``.
    Generation: :meth:`generate` from a control path in the data's units (or the low-level
    :meth:`sample` on normalised tensors), from the prior (Algorithm 1) or primed with 4
    frames (§4.3).
    """

    follows_control = True
    continues_motion = True

    def __init__(self, config: VAELSTMConfig = VAELSTMConfig()):
        super().__init__()
        self.config = config
        c = config
        self.control_encoder = ConvEncoder(c.n_control, (c.control_filters, c.control_code), c.width)
        # The inference network's 2 * units filters are mu and log sigma^2 (§4.2: 256 = 2 x 128).
        # Choice: no ELU on that last block: eq. 6 would bound mu >= -1 and sigma^2 >= 1/e.
        self.inference = ConvEncoder(c.n_pose, (c.inference_filters, 2 * c.units), c.width,
                                     last_activation=False)
        self.cell = ControlledLSTMCell(c.units, c.control_code)
        self.decoder = CanvasDecoder(c.units, c.decoder_filters, c.n_features + N_FEET * c.foot_gate,
                                     c.width, c.upsample)
        self.skeleton = SkeletonOutput() if c.skeleton else None

    # -- checks --------------------------------------------------------------------------

    def _check(self, x: torch.Tensor, name: str, features: int | tuple[int, ...], min_frames: int = 1,
               finite: bool = True) -> None:
        check_tensor(x, name, features, min_frames, finite=finite)

    # -- the parts -----------------------------------------------------------------------

    def corrupt(self, x: torch.Tensor) -> torch.Tensor:
        """Dropout on the joints and the control (§4.2): each joint (its three coordinates)
        and each control channel of each window is zeroed (set to the data's mean) with
        probability ``dropout``; the rest is scaled by ``1 / (1 - dropout)``. Works on the
        pose ``(..., n_pose)``, the control ``(..., n_control)`` or both together."""
        p, n_pose = self.config.dropout, self.config.n_pose
        if p == 0:
            return x
        groups = []
        if x.shape[-1] in (n_pose, self.config.n_features):
            groups += [3] * (n_pose // 3)
        if x.shape[-1] in (self.config.n_control, self.config.n_features):
            groups += [1] * self.config.n_control
        keep = (torch.rand(x.shape[0], 1, len(groups), device=x.device) >= p).to(x.dtype)
        keep = keep.repeat_interleave(torch.tensor(groups, device=x.device), dim=-1)
        return x * keep / (1 - p)

    def smooth_control(self, control: torch.Tensor) -> torch.Tensor:
        """Gaussian smoothing over time of ``(batch, frames, n_control)``, standard deviation
        ``control_smoothing_s`` (edges repeat the first and last value).

        An experiment, off by default: the control of captured motion is the velocity of
        the hips projected on the floor (§4.1), so it wobbles with every step (the pelvis
        sways and surges) and tells the model when each foot lands. A path drawn by an
        animator has no such wobble. Smoothing over about a stride (0.5 s) removes it and
        keeps what an animator gives (speed, direction, turns, starts, stops): the model
        must then keep the rhythm of the steps itself, from ``z_1``.
        """
        sigma = self.config.control_smoothing_s * self.config.fps
        if sigma < 0.1:
            return control
        radius = int(math.ceil(3 * sigma))
        offsets = torch.arange(-radius, radius + 1, dtype=control.dtype, device=control.device)
        kernel = torch.exp(-0.5 * (offsets / sigma) ** 2)
        kernel = (kernel / kernel.sum()).expand(control.shape[-1], 1, -1)
        padded = F.pad(control.transpose(1, 2), (radius, radius), mode="replicate")
        return F.conv1d(padded, kernel, groups=control.shape[-1]).transpose(1, 2)

    def encode_control(self, control: torch.Tensor) -> torch.Tensor:
        """Control encoder CNN^enc (eq. 6): ``(batch, frames, n_control)`` with frames a
        multiple of 4 -> control code ``h`` ``(batch, frames // 4, control_code)``. The
        control is smoothed first when ``control_smoothing_s > 0``."""
        return self.control_encoder(self.smooth_control(control))

    def posterior(self, pose: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Inference network (eq. 6): pose ``(batch, frames, n_pose)`` with frames a multiple
        of 4 -> ``mu`` and ``log sigma^2`` of ``q(z_s | X)``, each ``(batch, frames // 4, units)``."""
        mu, log_var = self.inference(pose).chunk(2, dim=-1)
        # Choice: log sigma^2 is kept within [-10, 5] so exp() can neither vanish nor overflow.
        return mu, log_var.clamp(-10.0, 5.0)

    def canvas(self, control_code: torch.Tensor, latents: torch.Tensor) -> torch.Tensor:
        """Run the cell over ``steps`` canvas steps -> the motion canvas ``(batch, steps, units)``.

        ``latents`` ``(batch, steps, units)``: training form, ``z_s`` drives every step
        (eq. 9, top). ``latents`` ``(batch, 1, units)``: test-time form, ``z_1`` drives the
        first step and ``c_{s-1}`` every later one (eq. 9, bottom; Algorithm 1). Either way
        the cell starts from ``c_0 = z_1`` (Algorithm 1 initialises the cell with ``z_1``).
        """
        steps = control_code.shape[1]
        if latents.shape[1] not in (1, steps):
            raise ValueError(f"latents: expected 1 or {steps} steps, got {latents.shape[1]}")
        # the terms that do not depend on c_{s-1} are computed for every step at once
        from_control = self.cell.control_terms(control_code)
        driven = self.cell.W_c(latents) if latents.shape[1] == steps else None
        previous = latents[:, 0]
        states = []
        for s in range(steps):
            # W_c drive: z_s in training; at test time c_{s-1}, and z_1 (= c_0) at the first step
            driven_now = driven[:, s] if driven is not None else self.cell.W_c(previous)
            previous = self.cell.step(previous, driven_now, *(term[:, s] for term in from_control))
            states.append(previous)
        return torch.stack(states, dim=1)                      # m_c = [c_1 || ... || c_S]

    def decode(self, canvas: torch.Tensor, control: torch.Tensor | None = None) -> torch.Tensor:
        """CNN^dec: canvas ``(batch, steps, units)`` -> frames ``(batch, 4 * steps, n_features)``.
        With ``foot_gate`` the feet are gated along ``control`` ``(batch, 4 * steps, n_control)``
        (normalised; the control the motion follows), which is then required."""
        return self._decode(canvas, control)[0]

    def _decode(self, canvas: torch.Tensor, control: torch.Tensor | None) -> tuple[torch.Tensor, torch.Tensor | None]:
        """:meth:`decode`, and with ``foot_gate`` the gate's logits ``(batch, 4 * steps, 4)`` (else None)."""
        if canvas.ndim != 3 or canvas.shape[-1] != self.config.units:
            raise ValueError(f"canvas: expected (batch, steps, {self.config.units}), got {tuple(canvas.shape)}")
        frames, logits = self.decoder(canvas), None
        if self.config.foot_gate:
            if control is None or control.shape[:2] != frames.shape[:2]:
                raise ValueError(f"control: foot_gate needs the control of the {frames.shape[1]} decoded frames, got "
                                 f"{None if control is None else tuple(control.shape)}")
            frames, logits = frames[..., :self.config.n_features], frames[..., self.config.n_features:]
            gate = torch.sigmoid(logits)
            # Choice: soft while training, so that the gradient reaches the gate through the
            # pose as well as through its labels; held or not at generation (above 1/2), as
            # sample(..., gate=True) reports it (measured: a soft gate leaks, and its feet creep)
            frames = self.gate_feet(frames, gate if self.training else (gate > 0.5).to(gate.dtype), control)
        return (frames if self.skeleton is None else self.skeleton(frames, self.normalizer)), logits

    def gate_feet(self, frames: torch.Tensor, gate: torch.Tensor, control: torch.Tensor) -> torch.Tensor:
        """Each ankle's and toe's ``x, z`` in ``frames`` ``(batch, T, n_features)``, frame by
        frame from the second::

            f_t = g_t · m(f_{t-1}, c_{t-1}) + (1 - g_t) · (d_t + o_t)

        with ``d_t`` where the decoder put it, ``m`` where it would be had it stayed put in the
        world since the previous frame (:func:`~motionlab.models.anchor.stayed_put`, the
        flows' foot anchor) and ``g_t`` ``gate`` ``(batch, T, 4)``, the probability that it
        did (:data:`~motionlab.skeleton.FEET` order). ``control`` ``(batch, T, n_control)``.
        All normalised; the gate is computed in metres through ``model.normalizer``.

        A planted foot (``g = 1``) then stays where it landed whatever the decoder does, and a
        swinging one (``g = 0``) is the decoder's, once the offset ``o`` it had from the
        decoder's foot when released has faded. The offset fades as a critically damped
        spring (inertialisation, as in motion matching): from ``o`` and its rate ``v`` in the
        previous frame, ``o(dt) = (o + (v + y o) dt) e^(-y dt)``, ``y = 2 ln 2 /
        gate_release_s``, so the foot leaves its spot with neither a jump in position nor one
        in velocity. A hold starts where the foot already is, so the landing has no jump either.
        Only the ``x, z`` are gated: the decoder keeps the foot's height and the rest of the leg
        (``skeleton=True`` makes the leg reach the gated ankle). The flows' anchor (``foot_anchor``) holds every frame and lets the
        flow model the difference; a decoder that is not told where the foot got to would
        drift by the sum of its errors, so here the hold lasts only as long as the contact."""
        normalizer = normalizer_for(self, "foot_gate", "the feet are gated")
        columns = list(FOOT_XZ) + list(range(N_POSE, N_POSE + 3))
        mean, std = (torch.as_tensor(np.asarray(v)[columns], dtype=torch.float32, device=frames.device)
                     for v in (normalizer.mean, normalizer.std))
        n = len(FOOT_XZ)
        decoded = frames[..., list(FOOT_XZ)].float() * std[:n] + mean[:n]                # metres
        moving = control.float() * std[n:] + mean[n:]                                      # m/s, rad/s
        g = gate.float().repeat(1, 1, 2)                                                   # x then z
        dt, release = 1 / self.config.fps, self.config.gate_release_s
        y = 2 * math.log(2) / release if release > 0 else math.inf
        decay = math.exp(-y * dt)
        feet, offsets = [decoded[:, 0]], [torch.zeros_like(decoded[:, 0])] * 2
        for t in range(1, frames.shape[1]):
            held = stayed_put(feet[-1], moving[:, t - 1], self.config.fps)
            o, v = offsets[-1], (offsets[-1] - offsets[-2]) / dt
            offset = decay * (o + (v + y * o) * dt) if release > 0 else torch.zeros_like(o)
            feet.append(g[:, t] * held + (1 - g[:, t]) * (decoded[:, t] + offset))
            offsets = [offsets[-1], feet[-1] - decoded[:, t]]
        gated = ((torch.stack(feet, dim=1) - mean[:n]) / std[:n]).to(frames.dtype)
        out = frames.clone()
        out[..., list(FOOT_XZ)] = gated
        return out

    def contact_nats(self, logits: torch.Tensor, batch: torch.Tensor) -> torch.Tensor:
        """The gate's negative log-likelihood of the data's contact labels
        (:func:`motionlab.contacts.contact_labels`, frame pairs ``t-1, t``), nats per frame
        summed over the four foot joints: ``logits`` ``(batch, frames, 4)``, ``batch`` the
        windows ``(batch, frames, n_features)`` (normalised)."""
        with torch.no_grad():
            labels = contacts.contact_labels(normalizer_for(self, "foot_gate", "the contact labels are measured")
                                             .denormalize(batch.float()),
                                             self.config.fps)
        return F.binary_cross_entropy_with_logits(logits[:, 1:].float(), labels, reduction="none").sum(-1).mean()

    # -- training ------------------------------------------------------------------------

    def forward(self, x: torch.Tensor, sample: bool = True) -> dict[str, torch.Tensor]:
        """The training pass on windows ``x`` ``(batch, frames, n_features)``.

        Returns ``reconstruction`` ``(batch, frames, n_features)``, ``mu``, ``log_var``,
        ``z`` and ``canvas`` ``(batch, ceil(frames / 4), units)``. ``sample=False`` uses
        the posterior means instead of samples (a deterministic reconstruction).
        """
        self._check(x, "x", self.config.n_features)
        return self._forward(x, sample)

    def _forward(self, x: torch.Tensor, sample: bool = True) -> dict[str, torch.Tensor]:
        # unchecked: forward() checks its input, loss() only its shape
        frames = x.shape[1]
        padded = pad_to_canvas(x)
        given = padded[..., self.config.n_pose:]          # the control the motion follows (the gate's)
        if self.training:
            padded = self.corrupt(padded)
        pose, control = padded[..., :self.config.n_pose], padded[..., self.config.n_pose:]
        code = self.encode_control(control)
        mu, log_var = self.posterior(pose)
        z = gaussian.sample(mu, log_var) if sample else mu                           # eq. 3
        canvas = self.canvas(code, z)
        reconstruction, logits = self._decode(canvas, given)
        return {"reconstruction": reconstruction[:, :frames], "mu": mu, "log_var": log_var,
                "z": z, "canvas": canvas, "control_code": code, "given_control": given,
                "gate_logits": None if logits is None else logits[:, :frames]}

    def _neg_log_likelihood(self, prediction: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        """``-log N(target | prediction, std^2 I)`` summed over features: ``(batch, frames)`` nats."""
        return gaussian.negative_log_likelihood(target, prediction, std=self.config.observation_std).sum(-1)

    def l1_penalty(self) -> torch.Tensor:
        """Mean absolute value of every weight matrix and filter (not the biases)."""
        weights = [p for name, p in self.named_parameters() if not name.endswith("bias")]
        return torch.cat([w.abs().flatten() for w in weights]).mean()

    def loss(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        """Eq. 5 per frame: ``(-log p(X | z) + sum_s KL(q(z_s | X) || N(0, I))) / frames``,
        plus ``l1`` times the mean absolute weight (§4.2).

        With ``free_running > 0`` a second reconstruction term (times ``free_running``)
        decodes the same window with the cell in its test-time form from the sampled
        ``z_1`` only: the path that generation takes, which the paper's objective never
        trains. Logged: ``nll`` and ``kl`` (nats per frame), ``mse`` (normalised units),
        and ``free_mse`` when used.

        With ``contact_weight > 0`` the foot-contact velocity term of HuMoR (Rempe et al.
        2021), EDGE (Tseng et al. 2023) and MDM (Tevet et al. 2023) is added, times
        ``contact_weight``: where the window's feet are planted, their squared world velocity
        in the reconstruction, (m/s)² (:meth:`contact_term`, in the data's units through
        ``model.normalizer``). The reconstruction's pose moves along the window's own control,
        as generation moves the pose along the control it is given (the decoded control is
        only a training target). Applied to each reconstruction the loss has, with its weight
        there: the training form, and the free-running one times ``free_running`` (the path
        that generates, and whose feet slide). Logged: ``contact`` and ``free_contact``.
        With ``bone_weight > 0``, the same for the bone-length term (:meth:`bone_term`, cm²):
        logged ``bone`` and ``free_bone``. With ``foot_gate``, the gate's negative
        log-likelihood of the data's contact labels (:meth:`contact_nats`, nats per frame) on
        each reconstruction, with its weight there: logged ``contacts`` and ``free_contacts``.
        """
        self._check(batch, "x", self.config.n_features, finite=False)   # NaN: the training loop's guard
        out = self._forward(batch)
        frames = batch.shape[1]
        nll = self._neg_log_likelihood(out["reconstruction"], batch).sum(1) / frames     # L_x
        kl = gaussian.kl_divergence(out["mu"], out["log_var"]).sum(-1).sum(1) / frames    # L_z, eq. 4
        total = (nll + kl).mean() + self.config.l1 * self.l1_penalty()
        terms = {"nll": nll.mean(), "kl": kl.mean(),
                 "mse": F.mse_loss(out["reconstruction"], batch).detach()}
        n_pose, paths = self.config.n_pose, [("", out["reconstruction"], 1.0)]
        gates = [("", out["gate_logits"], 1.0)]
        if self.config.free_running > 0:
            free, free_logits = self._decode(self.canvas(out["control_code"], out["z"][:, :1]), out["given_control"])
            free = free[:, :frames]
            free_nll = self._neg_log_likelihood(free, batch).sum(1) / frames
            total = total + self.config.free_running * free_nll.mean()
            terms["free_mse"] = F.mse_loss(free, batch).detach()
            paths.append(("free_", free, self.config.free_running))
            gates.append(("free_", None if free_logits is None else free_logits[:, :frames], self.config.free_running))
        for prefix, logits, scale in gates if self.config.foot_gate else ():
            value = self.contact_nats(logits, batch)
            total = total + scale * value
            terms[prefix + "contacts"] = value.detach()
        for name, weight, term in (("contact", self.config.contact_weight, self.contact_term),
                                   ("bone", self.config.bone_weight, self.bone_term)):
            for prefix, reconstruction, scale in paths if weight > 0 else ():
                value = term(torch.cat([reconstruction[..., :n_pose], batch[..., n_pose:]], -1), batch)
                total = total + weight * scale * value
                terms[prefix + name] = value.detach()
        return {"loss": total, **terms}

    # -- generation ----------------------------------------------------------------------

    @torch.no_grad()
    def sample(self, control: torch.Tensor, prefix: torch.Tensor | None = None, temperature: float = 1.0,
               generator: torch.Generator | None = None, gate: bool = False):
        """Motion for a control signal: Algorithm 1, or primed with initial frames (§4.3).

        Args:
            control: ``(batch, frames, n_control)``, normalised, for the whole sequence;
                any number of frames (padded to a multiple of 4 with the last value).
            prefix: ``None``: ``z_1`` is drawn from the prior ``N(0, I)`` (Algorithm 1).
                Or ``(batch, k >= 4, n_pose or n_features)`` first frames: ``z_1`` is drawn
                from the posterior of its first canvas step (4 frames = one step, §4.3).
            temperature: scales ``z_1``'s standard deviation (0: the mean).
            generator: a ``torch.Generator`` for reproducible samples.
            gate: with ``foot_gate``, also return each frame's probability that each ankle and
                toe is planted, ``(batch, frames, 4)`` (:data:`~motionlab.skeleton.FEET`
                order; a foot is held where it is above one half; the first frame's is the second's).

        Returns ``(batch, frames, n_features)`` normalised features for the control's
        frames (with a prefix, the first ``k`` are the model's rendering of it); the control
        columns are the given ``control`` (the model follows it; its own reconstruction of
        the control is only a training target). With ``gate=True``, ``(features, planted)``.
        """
        if gate and not self.config.foot_gate:
            raise ValueError("gate: this VAE-LSTM has no gated feet (VAELSTMConfig.foot_gate)")
        features, planted = self._sample(control, prefix, temperature, generator)
        return (features, planted) if gate else features

    @torch.no_grad()
    def _sample(self, control, prefix, temperature, generator) -> tuple[torch.Tensor, torch.Tensor | None]:
        """:meth:`sample`, and with ``foot_gate`` its planted probabilities (else None)."""
        self._check(control, "control", self.config.n_control)
        batch, frames = control.shape[:2]
        with eval_mode(self):
            code = self.encode_control(pad_to_canvas(control))
            if prefix is None:
                mu = log_var = torch.zeros(batch, 1, self.config.units, device=control.device)
            else:
                self._check(prefix, "prefix", (self.config.n_pose, self.config.n_features), min_frames=POOLING)
                if prefix.shape[0] != batch:
                    raise ValueError(f"prefix: expected {batch} sequences like control, got {prefix.shape[0]}")
                mu, log_var = self.posterior(pad_to_canvas(prefix[..., :self.config.n_pose]))
                mu, log_var = mu[:, :1], log_var[:, :1]
            z1 = gaussian.sample(mu, log_var, temperature, generator)
            motion, logits = self._decode(self.canvas(code, z1), pad_to_canvas(control))
        planted = None
        if logits is not None:
            planted = torch.sigmoid(logits[:, :frames])
            planted = torch.cat([planted[:, 1:2], planted[:, 1:]], dim=1) if frames > 1 else planted
        return torch.cat([motion[:, :frames, :self.config.n_pose], control], dim=-1), planted

    def generate(self, control=None, *, frames=None, prefix=None, n=1, temperature=1.0, seed=0) -> Generated:
        """Follow the ``control`` path (required); see :mod:`motionlab.models.base`.

        The output has the control's frames. Without a ``prefix`` the first latent comes from
        the prior (Algorithm 1); with one (``k >= 4`` real frames) from its posterior (§4.3),
        and the first ``k`` frames of the result are the model's rendering of the prefix.
        With ``foot_gate`` the model holds its planted feet itself, so ``contacts`` stays None
        (``contacts`` is what a lock would hold beyond what it detects; this model has held
        them already); ``sample(..., gate=True)`` gives the gate's probabilities.
        """
        n, temperature = self._check_common(n, temperature, seed)
        control = self._normalized_control(control, n, frames)
        if prefix is not None:
            prefix = self._normalized_prefix(prefix, n, min_frames=POOLING)
        device = next(self.parameters()).device
        return self._result(self.sample(control.to(device), None if prefix is None else prefix.to(device),
                                        temperature, generator_for(seed)))

    @torch.no_grad()
    def reconstruct(self, x: torch.Tensor, free_running: bool = False) -> torch.Tensor:
        """Deterministic reconstruction of windows ``x`` ``(batch, frames, n_features)``
        from the posterior means: every ``mu_s`` driving the cell (the training form), or
        only ``mu_1`` (``free_running=True``, the test-time form). Control columns are
        returned as decoded."""
        self._check(x, "x", self.config.n_features)
        padded = pad_to_canvas(x)
        with eval_mode(self):
            code = self.encode_control(padded[..., self.config.n_pose:])
            mu, _ = self.posterior(padded[..., :self.config.n_pose])
            return self.decode(self.canvas(code, mu[:, :1] if free_running else mu),
                               padded[..., self.config.n_pose:])[:, :x.shape[1]]

    # -- likelihood ----------------------------------------------------------------------

    @torch.no_grad()
    def nll_bound(self, windows: torch.Tensor, normalizer=None, scored=None, samples: int = 8,
                  seed: int = 0) -> dict[str, float]:
        """An upper bound on ``-log p(pose | control)`` of the model that *generates*.

        Generation (Algorithm 1) is a latent-variable model with one latent: ``z_1 ~ N(0, I)``,
        the cell in its test-time form, ``X ~ N(decoder, observation_std² I)``. Its evidence
        lower bound with ``q(z_1 | X)`` (the inference network's first step, eq. 6) as the
        proposal is ``E_q[log p(X | z_1, C)] - KL(q(z_1 | X) || N(0, I))`` (eq. 3-5 with
        one latent); the negative ELBO is an upper bound on the negative log-likelihood. The
        expectation is a mean over ``samples`` draws of ``z_1`` (``seed``), the KL exact.

        Args:
            windows: normalised features ``(n, frames, n_features)``; the control columns
                are the condition.
            normalizer: given, the bound is in the data's units (metres), adding ``Σ_d ln σ_d``
                over the scored features to every frame, as the flows' ``nll`` does.
            scored: the pose features the bound is on (default: all ``n_pose``). A subset
                bounds their marginal likelihood (the Gaussian factorises over features).

        Returns ``{"nats/frame", "bits/frame"}``: the mean bound per frame.
        """
        self._check(windows, "windows", self.config.n_features, min_frames=POOLING)
        if not torch.isfinite(windows).all():
            raise ValueError("windows: contains NaN or inf")
        if not (isinstance(samples, int) and samples >= 1):
            raise ValueError(f"samples: expected an int >= 1, got {samples!r}")
        scored = self._scored(scored)
        frames = windows.shape[1]
        padded = pad_to_canvas(windows)
        pose = windows[..., scored]
        generator = generator_for(seed)
        with eval_mode(self):
            code = self.encode_control(padded[..., self.config.n_pose:])
            mu, log_var = self.posterior(padded[..., :self.config.n_pose])
            mu, log_var = mu[:, :1], log_var[:, :1]                                   # q(z_1 | X)
            kl = gaussian.kl_divergence(mu, log_var).sum((1, 2))                        # eq. 4
            reconstruction = windows.new_zeros(len(windows))
            for _ in range(samples):
                z1 = gaussian.sample(mu, log_var, generator=generator)                  # eq. 3
                motion = self.decode(self.canvas(code, z1), padded[..., self.config.n_pose:])   # test-time form
                motion = motion[:, :frames, scored]
                reconstruction += self._neg_log_likelihood(motion, pose).sum(1) / samples
        return per_frame_nll(float((reconstruction + kl).mean()) / frames, normalizer, scored)

    def nll_bound_floor(self, normalizer=None, scored=None) -> dict[str, float]:
        """The lowest value :meth:`nll_bound` can take, whatever the data and the weights:
        every scored value reconstructed exactly and nothing paid for the latent (KL 0).
        A fixed ``observation_std`` charges each value ``ln(σ √(2π))`` nats even then.
        Arguments and units as for :meth:`nll_bound`."""
        scored = self._scored(scored)
        exact = torch.zeros(len(scored))
        return per_frame_nll(float(self._neg_log_likelihood(exact, exact)), normalizer, scored)

    def _scored(self, scored) -> torch.Tensor:
        """The pose feature indices a likelihood is on, checked (default: all)."""
        scored = torch.arange(self.config.n_pose) if scored is None else torch.as_tensor(scored, dtype=torch.long)
        if scored.ndim != 1 or len(scored) == 0 or scored.min() < 0 or scored.max() >= self.config.n_pose \
                or len(set(scored.tolist())) != len(scored):
            raise ValueError(f"scored: expected distinct pose feature indices in 0 .. {self.config.n_pose - 1}")
        return scored


    def trace(self, x: torch.Tensor) -> list[tuple[str, tuple[int, ...]]]:
        """The shape of a window ``x`` at every stage, for a walk-through of the model."""
        self._check(x, "x", self.config.n_features)
        with torch.no_grad(), eval_mode(self):
            out = self(x, sample=False)
        padded = pad_to_canvas(x)
        c = self.config
        return [("window (batch, frames, pose + control)", tuple(x.shape)),
                ("padded to a multiple of 4 frames", tuple(padded.shape)),
                (f"pose X -> inference net, {c.inference_filters} then {2 * c.units} filters, 2 pools",
                 tuple(out["mu"].shape[:2]) + (2 * c.units,)),
                ("  = mu and log sigma^2 of q(z_s | X), each", tuple(out["mu"].shape)),
                (f"control C -> control encoder, {c.control_filters} then {c.control_code} filters",
                 tuple(out["control_code"].shape)),
                (f"LSTM cell over {out['canvas'].shape[1]} steps: the motion canvas",
                 tuple(out["canvas"].shape)),
                (f"decoder: upsample, conv, ELU, upsample, conv (then cropped{', feet gated' * c.foot_gate}"
                 f"{', skeleton layer' * c.skeleton})",
                 tuple(out["reconstruction"].shape))]


# ------------------------------------------------------------------------ training, as the paper says

HABIBIE = "Habibie 2017 §4.2"

CARD = ModelCard("vae_lstm", VAELSTM, VAELSTMConfig, schedule={
    "optimizer": paper("Adam", f"{HABIBIE}: 'using the Adam optimizer'"),
    "lr": paper(5e-4, f"{HABIBIE}: 'a learning rate of 5x10^-4'"),
    "epochs": paper(5000, f"{HABIBIE}: 'for 5000 epochs'"),
    "batch_size": choice(32, "§4.2 gives no batch size: motionlab's default"),
    "schedule": choice("constant", "§4.2 names one learning rate and no decay"),
    "grad_clip": choice(1.0, NO_CLIP),
})
