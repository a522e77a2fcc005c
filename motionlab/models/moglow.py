"""MoGlow: autoregressive, controllable Glow for motion (Henter et al. 2020, §4-5).

The fixed-length Glow of :mod:`motionlab.models.glow` draws a whole window at once. MoGlow
draws *one frame at a time*: a Glow flow over the pose of frame ``t`` alone (``L = 1``, no
squeeze, §4.2), whose affine couplings see

* the ``τ`` previous poses ``x_{t-τ:t-1}`` (the autoregressive history, eq. 16),
* the control of frames ``t-τ .. t`` (forward, sideways and turning velocity; never the
  future's, so control has zero latency),
* and, inside each coupling network, an LSTM state ``h_t`` carried through time (eq. 17)::

    p(x | c) = p(x_{1:τ} | c_{1:τ}) · Π_{t>τ} p(x_t | x_{t-τ:t-1}, c_{t-τ:t}, h_t)     eq. 16
    h_{t+1}  = g(x_{t-τ:t-1}, c_{t-τ:t}, h_t)                                         eq. 17
    [s'_t, t'_t] = A_n(b_lo_t, x_{t-τ:t-1}, c_{t-τ:t}, h_t)                           eq. 18

Training sees whole windows: the history of every frame is the *true* one (teacher
forcing), so the LSTMs run over all ``T - τ`` predicted frames in one call, from a zero
state (footnote 2: the first ``τ`` frames are given, not modelled). Sampling starts from
``τ`` given frames and generates one frame per step, feeding each back as history and
carrying the LSTM states (:class:`~motionlab.engine.stream.MoGlowStream`, the real-time API).

**Dropout on the history (§5.3).** During training each history frame is dropped (set to
0, the data mean in normalised units) with probability ``dropout`` (0.95 in the paper),
independently for every predicted frame and lag, and kept frames are passed on as they
are, as in the authors' code. The control is never dropped. Without dropout the model
learns to continue the motion in its history and ignores the control (notebook 06).

**The history at generation.** The paper (Fig. 3) drops nothing at generation: every
history frame is there. But networks trained with dropout ``p`` have seen, on average,
only ``1 - p`` of each history frame; given all of it they are outside what they were
trained on. At laptop size their samples then fade or never step: told to walk at
1.3 m/s from standing, the shipped model (``p`` = 0.95) steps at 0.19-0.29 m/s with the
full history and at 1.08-1.23 m/s with it scaled (the data: 1.20-1.30; notebook 06,
section 7). So, by default, the history is multiplied by ``1 - p`` wherever the model is
evaluated or sampled (the weight-scaling rule of ordinary dropout, Srivastava et al.
2014): the networks see the history's expected training value. ``scale_history=False``
(:meth:`MoGlow.with_full_history`) gives the paper's rule. Training is the same either
way.

Like :class:`~motionlab.models.glow.Glow` the model works on normalised features
``(batch, frames, 66)`` (63 pose + 3 control, :func:`motionlab.data.prepare`) and leaves
the hips' root-local ``x`` and ``z`` (always 0) out of the flow: 61 modelled values per
frame. ``loss`` is the NLL in nats per modelled value; :meth:`MoGlow.nll` reports bits per
predicted frame.

**Feet anchored where they were planted** (``foot_anchor``, off by default). A planted
foot must, in the root frame, sweep back by exactly the root's step every frame, and any
error in that is sliding. With ``foot_anchor`` the flow models, for the ``x`` and ``z`` of
each ankle and toe, the frame's value less where that joint would be had it stayed put in
the world since the previous frame (:meth:`MoGlow.anchor`): a function of the previous
pose and the control, which are conditioning, so the shift's log-determinant is 0 and the
likelihood stays exact (``m`` takes the true previous pose, whether or not dropout hides it
from the networks). Sampling adds it back frame by frame,
:class:`~motionlab.engine.stream.MoGlowStream` too. With ``anchor_conditioning`` (not in
the paper either) ``m`` is also part of every coupling's conditioning, never dropped; with
``leg_anchor`` the toes and knees are modelled relative to the ankles and hips of their
frame, so that a held foot does not stretch the leg.

**A contact head** (``contact_head``, off by default, not in the paper;
:mod:`motionlab.models.contact_head`). Each frame's foot contacts ``c_t`` are modelled
beside its pose, ``p(c_t | c_{<t}, cond_t) p(x_t | c_t, cond_t)``: the head reads the
frame's conditioning (eq. 18's history and controls), the coupling networks also read the
labels. Both factors are exact; at the data's own labels the joint likelihood bounds eq. 16
from below. Sampling, and :class:`~motionlab.engine.stream.MoGlowStream`, draw the contacts
first, frame by frame (:meth:`MoGlow.draw_contacts`).

**Bones as lengths and directions** (``bone_coordinates``, off by default, not in the paper;
:mod:`motionlab.models.bone_coordinates`). Every joint but the hips and ankles (with the
feet or legs anchored: the spine's, neck's, head's and arms') is
modelled by its bone's change of length since the previous frame and its direction, a
smooth bijection given the conditioning whose log-determinant is added: the likelihood stays
exact, and the flow's mode keeps each of those bones at its length.

Everything here reuses :mod:`motionlab.models.flows` unchanged: the coupling network is
the pluggable part (:class:`LSTMCouplingNet` here; the Markovian variant of §4.2 uses
:class:`~motionlab.models.flows.MLPCouplingNet`).
"""
from __future__ import annotations

import copy
import math
from contextlib import contextmanager
from dataclasses import dataclass, replace
from functools import partial

import torch
from torch import nn

from ..engine import recurrent
from .. import checks
from .base import Generated, eval_mode, generator_for, per_frame_nll
from .flows import (FlowSequence, FlowStep, GaussianPrior, MLPCouplingNet, MotionFlow, henter_schedule,
                    output_layer)
from . import anchor, bone_coordinates
from .anchor import FootAnchor
from .bone_coordinates import BoneCoordinates
from . import contact_head
from .contact_head import N_CONTACTS, ContactHead, DataContacts, labels_of
from .modelcard import ModelCard


@dataclass(frozen=True)
class MoGlowConfig:
    """Sizes and options. Defaults: a laptop model (60 epochs on 200 built-in clips take
    15 minutes on 2 CPU cores): ``K = 4`` steps, one LSTM layer of 64 units per coupling,
    the paper's 4-s training windows and its history dropout 0.95, with the history scaled
    by ``1 - dropout`` at generation (``scale_history``). :meth:`paper` is §5.1-5.3's.

    Attributes:
        n_features: features per frame (66: 63 pose + 3 control).
        n_control: the last ``n_control`` features are the control ``c_t``.
        window: frames per training window (80 = 4 s at 20 fps, §5.1): ``history`` given
            frames, then ``window - history`` predicted ones.
        fps: frames per second of the data the model expects.
        history: ``τ``, previous poses each frame is conditioned on (§5.2: 10 = 0.5 s).
        steps: ``K``, steps of flow (§5.2: 16).
        hidden: units of each coupling network's LSTM layers (§5.2: 512).
        lstm_layers: LSTM layers per coupling network (§5.2: 2).
        recurrent: LSTM couplings (MoGlow) or feed-forward ones (the Markov model of
            eq. 12, two hidden layers of ``hidden`` units).
        dropout: probability of dropping a history frame during training (§5.3: 0.95).
        scale_history: when evaluating and sampling, multiply the history by
            ``1 - dropout`` (its expected value in training); ``False``: the paper's full
            history (Fig. 3), whose samples fade at laptop size.
        constant_features: pose features that are 0 in every frame and are left out of
            the flow (the hips' root-local ``x`` and ``z``).
        foot_anchor: model the feet's ``x`` and ``z`` less where they would be had they
            stayed planted since the previous frame (:meth:`MoGlow.anchor`); needs the
            model's normaliser (``model.normalizer``, set by :func:`motionlab.training.train`).
        anchor_conditioning: with ``foot_anchor``, the coupling networks also see ``m``
            (where each foot would be had it stayed planted: where it is), never dropped:
            the history, dropped, rarely shows them where a foot is relative to the body.
            Not in the paper; measured in docs/feet.md.
        leg_anchor: with ``foot_anchor``, each toe's ``x, z`` is modelled less its ankle's
            and each knee less the midpoint of its hip and ankle, in the same frame
            (:mod:`motionlab.models.anchor`): the legs keep their length. Not in the paper.
        contact_head: model each frame's foot contacts beside its pose, ``p(c_t | c_<t,
            cond_t) p(x_t | c_t, cond_t)`` (:mod:`motionlab.models.contact_head`: the head
            sees the frame's conditioning, the coupling networks also the frame's labels);
            needs the locomotion features and, to train, the model's normaliser. Not in the paper.
        bone_coordinates: model every joint but the hips and ankles (with ``foot_anchor`` or
            ``leg_anchor``: the spine's, neck's, head's and arms') by its bone's change of
            length and its direction (:mod:`motionlab.models.bone_coordinates`), so that
            those bones keep their length; needs the model's normaliser. Not in the paper.
    """

    n_features: int = 66
    n_control: int = 3
    window: int = 80
    fps: float = 20.0
    history: int = 10
    steps: int = 4
    hidden: int = 64
    lstm_layers: int = 1
    recurrent: bool = True
    dropout: float = 0.95
    scale_history: bool = True
    constant_features: tuple[int, ...] = (0, 2)
    foot_anchor: bool = False
    anchor_conditioning: bool = False
    leg_anchor: bool = False
    contact_head: bool = False
    bone_coordinates: bool = False

    def __post_init__(self):
        checks.config(self, probability_fields=("dropout",))
        object.__setattr__(self, "constant_features", tuple(int(i) for i in self.constant_features))
        if min(self.history, self.steps, self.hidden, self.lstm_layers) < 1:
            raise ValueError(f"history, steps, hidden and lstm_layers: need at least 1 each, got {self.history}, "
                             f"{self.steps}, {self.hidden}, {self.lstm_layers}")
        if self.window <= self.history:
            raise ValueError(f"window: {self.window} frames leaves nothing to predict after history={self.history}")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"dropout: expected a probability in [0, 1), got {self.dropout}")
        if not 0 < self.n_control < self.n_features:
            raise ValueError(f"n_control: expected 1 .. {self.n_features - 1}, got {self.n_control}")
        n_pose = self.n_features - self.n_control
        bad = [i for i in self.constant_features if not 0 <= i < n_pose]
        if bad:
            raise ValueError(f"constant_features: {bad} are not pose features (0 .. {n_pose - 1})")
        anchor.check_leg_config(self)
        anchor.check_config(self)
        if self.anchor_conditioning and not self.foot_anchor:
            raise ValueError("anchor_conditioning: the networks see the feet's anchor m; needs foot_anchor=True")
        contact_head.check_config(self)
        bone_coordinates.check_config(self)

    @classmethod
    def paper(cls, **changes) -> "MoGlowConfig":
        """§5.2: ``K = 16`` steps, ``L = 1``, couplings with 2 LSTM layers of 512 units,
        ``τ = 10``; §5.1: 4-s windows at 20 fps; §5.3: dropout 0.95. The history is scaled
        at generation as in the default config; ``scale_history=False`` gives Fig. 3's rule."""
        return replace(cls(steps=16, hidden=512, lstm_layers=2, history=10, window=80, fps=20.0, dropout=0.95),
                       **changes)


class LSTMCouplingNet(nn.Module):
    """``A_n`` of eq. 18: an LSTM over ``[b_lo_t, conditioning_t]``, then a zero-initialised
    linear layer to the shift and scale (so each coupling starts as the identity).

    ``forward(lo, cond)`` takes ``(batch, frames, in)`` and ``(batch, frames, cond)`` and
    returns ``(batch, frames, out)``. It starts from a zero state, unless the network is
    :attr:`carrying` (sampling): then it starts from the state the previous call left, and
    stores the new one, so one call per frame runs the LSTM through time (eq. 17). From a
    zero state it runs the same LSTM through :func:`recurrent.from_zero_state`, which on the
    CPU uses the written-out LSTM where that is measured faster (it skips the
    conditioning's gradient).
    """

    def __init__(self, in_channels: int, cond_channels: int, out_channels: int,
                 hidden: int = 128, layers: int = 1):
        super().__init__()
        self.lstm = nn.LSTM(in_channels + cond_channels, hidden, num_layers=layers, batch_first=True)
        self.output = nn.Linear(hidden, out_channels)
        nn.init.zeros_(self.output.weight)
        nn.init.zeros_(self.output.bias)
        self.carrying = False
        self.state: tuple[torch.Tensor, torch.Tensor] | None = None
        self.written_out = True           # recurrent.from_zero_state where it pays off (False: nn.LSTM always)

    def forward(self, lo: torch.Tensor, cond: torch.Tensor | None = None) -> torch.Tensor:
        if self.written_out and not self.carrying:
            hidden = recurrent.from_zero_state(self.lstm, lo, cond)
        else:
            inputs = lo if cond is None else torch.cat([lo, cond], dim=-1)
            hidden, state = recurrent.run(self.lstm, inputs, self.state if self.carrying else None)
            if self.carrying:
                self.state = state
        return output_layer(self.output, hidden, lo)            # float32 under mixed precision


class MoGlow(DataContacts, FootAnchor, BoneCoordinates, MotionFlow):
    """The autoregressive MoGlow of §4.2 (or its Markov variant, ``recurrent=False``).

    Batches are normalised feature windows ``(batch, frames, n_features)`` with
    ``frames > history``; the first ``history`` frames are conditioning only.
    """

    follows_control = True
    continues_motion = True

    def __init__(self, config: MoGlowConfig = MoGlowConfig()):
        super().__init__()
        self.config = config
        self._set_layout(config, config.n_features - config.n_control)
        # the conditioning of frame t: τ previous poses, then the control of frames t-τ .. t
        self.cond_channels = config.history * self.n_modelled + (config.history + 1) * config.n_control
        if config.anchor_conditioning:      # ... then m, where the feet would be had they stayed planted
            self.cond_channels += len(anchor.FOOT_XZ)
        if config.recurrent:
            network = partial(LSTMCouplingNet, hidden=config.hidden, layers=config.lstm_layers)
        else:
            network = partial(MLPCouplingNet, hidden=config.hidden)
        self.flow = FlowSequence(FlowStep(self.n_modelled, network, self.cond_channels + N_CONTACTS * config.contact_head)
                                 for _ in range(config.steps))
        self.prior = GaussianPrior()
        self._init_foot_anchor(config)
        # p(c_t | c_<t, cond_t): per frame (width 1), so it streams with the flow
        self.contact_head = ContactHead(self.cond_channels, config.hidden, width=1) if config.contact_head else None
        self.nll_is = "bound, with contacts" if config.contact_head else "exact"

    # -- data in and out -----------------------------------------------------------------

    def check_features(self, batch: torch.Tensor, name: str = "batch", min_frames: int | None = None) -> None:
        n = self.config.n_features
        min_frames = self.config.history + 1 if min_frames is None else min_frames
        if not isinstance(batch, torch.Tensor) or batch.ndim != 3 or batch.shape[-1] != n \
                or batch.shape[1] < min_frames:
            shape = tuple(batch.shape) if isinstance(batch, torch.Tensor) else type(batch).__name__
            raise ValueError(f"{name}: expected (batch, frames >= {min_frames}, {n}) normalised features, got {shape}")
        if len(self.constant) and batch[..., self.constant].abs().max() > 1e-4:
            raise ValueError(f"{name}: features {self.config.constant_features} should be 0 in every frame "
                             f"(constant_features), got values up to {batch[..., self.constant].abs().max():.3g}")

    def conditioning(self, poses: torch.Tensor, control: torch.Tensor, drop: bool = False) -> torch.Tensor:
        """The conditioning of every predicted frame (eq. 18), ``(batch, frames - τ, cond_channels)``.

        Args:
            poses: modelled poses ``(batch, frames, n_modelled)``.
            control: ``(batch, frames, n_control)``.
            drop: apply the history dropout of §5.3 (training).

        Frame ``t = τ .. frames-1`` gets ``[x_{t-τ}, ..., x_{t-1}, c_{t-τ}, ..., c_t]`` flattened;
        without ``drop`` the poses are multiplied by :attr:`history_scale`.
        """
        tau = self.config.history
        history = poses[:, :-1].unfold(1, tau, 1)                 # (batch, frames-τ, n_modelled, τ)
        if drop and self.config.dropout > 0:
            keep = 1.0 - self.config.dropout
            mask = torch.bernoulli(history.new_full(history.shape[:2] + (1, tau), keep))
            history = history * mask                             # per frame: all of its values or none
        elif self.history_scale != 1.0:
            history = history * self.history_scale               # evaluation: the expected kept value
        controls = control.unfold(1, tau + 1, 1)                  # (batch, frames-τ, n_control, τ+1)
        parts = [history.transpose(2, 3).flatten(2), controls.transpose(2, 3).flatten(2)]
        if self.config.anchor_conditioning:                      # m from the true x_{t-1}, c_{t-1}
            parts.append(self.anchor(poses[:, tau - 1:-1], control[:, tau - 1:-1]))
        return torch.cat(parts, dim=-1)

    @property
    def history_scale(self) -> float:
        """What the history is multiplied by when the model is evaluated or sampled:
        ``1 - dropout`` with ``scale_history`` (the default), else 1 (the paper's Fig. 3)."""
        return 1.0 - self.config.dropout if self.config.scale_history else 1.0

    def with_full_history(self) -> "MoGlow":
        """A copy of this model, same weights (and normaliser), that is evaluated and sampled
        with the paper's full history (Fig. 3: ``scale_history=False``), to compare the two
        rules."""
        other = copy.deepcopy(self)
        other.config = replace(self.config, scale_history=False)
        return other

    def frame_conditioning(self, history: torch.Tensor, controls: torch.Tensor,
                           previous: torch.Tensor | None = None, units=None) -> torch.Tensor:
        """The conditioning of one new frame, ``(batch, 1, cond_channels)``, from the ``τ``
        previous modelled poses ``(batch, τ, n_modelled)`` and the controls of those frames
        and the new one ``(batch, τ + 1, n_control)``; laid out as :meth:`conditioning`
        (the caller scales the history by :attr:`history_scale`). With
        ``anchor_conditioning``, ``previous``: the last pose unscaled ``(batch, n_modelled)``,
        for ``m`` (``units``: :meth:`anchor_units`, if at hand)."""
        parts = [history.flatten(1), controls.flatten(1)]
        if self.config.anchor_conditioning:
            if previous is None:
                raise ValueError("previous: an anchor_conditioning model needs the last pose, unscaled, for m")
            parts.append(self.anchor(previous, controls[:, -2], units))
        return torch.cat(parts, dim=1)[:, None]

    # -- likelihood (eq. 16) -------------------------------------------------------------

    def log_likelihood(self, batch: torch.Tensor) -> torch.Tensor:
        """``Σ_{t>τ} ln p(x_t | x_{t-τ:t-1}, c_{t-τ:t}, h_t)`` of each window, nats,
        normalised units, ``(batch,)``. The first ``τ`` frames are given (footnote 2). With a
        contact head, the joint ``ln p(x, c(x))`` at the data's own contacts (a lower bound)."""
        self.check_features(batch)
        poses, control = batch[..., self.modelled], batch[..., self.control]
        cond = self.conditioning(poses, control, drop=self.training)
        tau = self.config.history
        target, bones = poses[:, tau:], 0.0
        if self.config.bone_coordinates:     # lengths and directions: its log-determinant added
            target, bones = self.to_bones(target, poses[:, tau - 1:-1])
            bones = bones.sum(1)
            if self.training:                # dequantisation: the data's bones never change length
                lengths = self._bone_units(target.device).columns[:, 0]
                target[..., lengths] = target[..., lengths] + torch.randn_like(target[..., lengths])
        if self.config.foot_anchor:          # a shift by the conditioning: log-determinant 0
            target = self._anchored(target, poses[:, tau - 1:-1], control[:, tau - 1:-1], -1.0)
        if self.contact_head is None:
            z, logdet = self.flow(target, cond)
            return self.prior.log_prob(z) + logdet + bones
        labels = self.data_contacts(batch)[:, tau:]      # ln p(x, c(x)): a lower bound on ln p(x)
        z, logdet = self.flow(target, self.with_contacts(cond, labels))
        return self.prior.log_prob(z) + logdet + bones + self.contact_head.log_prob(labels, cond)

    def loss(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        """NLL in nats per modelled value (``"loss"``) and in bits per predicted frame."""
        frames = batch.shape[1] - self.config.history
        nll = -self.log_likelihood(batch).mean()
        return {"loss": nll / (frames * self.n_modelled), "bits_per_frame": nll / frames / math.log(2)}

    @torch.no_grad()
    def nll(self, windows: torch.Tensor, normalizer=None, batch_size: int = 64) -> dict[str, float]:
        """Mean NLL of the predicted frames of ``windows`` ``(n, frames, n_features)``.

        ``"nats/frame"`` and ``"bits/frame"``: normalised units, or, given the
        :class:`motionlab.data.Normalizer`, the data's units (metres), adding ``Σ_d ln σ_d``
        over the modelled features to every frame. Evaluated without dropout.
        """
        with eval_mode(self):
            total = torch.cat([-self.log_likelihood(chunk) for chunk in torch.split(windows, batch_size)])
        return per_frame_nll(float(total.mean()) / (windows.shape[1] - self.config.history), normalizer, self.modelled)

    # -- sampling ------------------------------------------------------------------------

    @contextmanager
    def carrying_state(self):
        """Within this block the LSTM couplings carry their state from call to call,
        starting from zero (``h_{τ+1} = 0``, footnote 2)."""
        networks = [m for m in self.modules() if isinstance(m, LSTMCouplingNet)]
        for network in networks:
            network.carrying, network.state = True, None
        try:
            yield
        finally:
            for network in networks:
                network.carrying, network.state = False, None

    def check_history(self, history) -> torch.Tensor:
        """``history`` as a float tensor on the model's device, checked to be ``(batch, τ,
        n_features)`` (normalised or in data units: the constant features are not checked)."""
        history = torch.as_tensor(history, dtype=torch.float32, device=self.modelled.device)
        tau, n = self.config.history, self.config.n_features
        if history.ndim != 3 or history.shape[1] != tau or history.shape[2] != n:
            raise ValueError(f"history: expected the {tau} frames before the first generated one, "
                             f"(batch, {tau}, {n}), got {tuple(history.shape)}")
        return history

    def _check_sampling(self, control: torch.Tensor, history: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        history = self.check_history(history)
        self.check_features(history, "history", min_frames=self.config.history)
        control = torch.as_tensor(control, dtype=torch.float32, device=self.modelled.device)
        c = self.config.n_control
        if control.ndim != 3 or control.shape[0] != history.shape[0] or control.shape[2] != c or control.shape[1] < 1:
            raise ValueError(f"control: expected ({history.shape[0]}, frames, {c}) normalised, one row per frame "
                             f"to generate, got {tuple(control.shape)}")
        return control, history

    @torch.no_grad()
    def sample(self, control: torch.Tensor, history: torch.Tensor, temperature: float = 1.0,
               noise: torch.Tensor | None = None, generator: torch.Generator | None = None) -> torch.Tensor:
        """Generate ``frames`` new frames, one at a time (Fig. 3), through the flow's own
        inverse. This is the reference sampler; :class:`~motionlab.engine.stream.MoGlowStream` is the fast one.

        Args:
            control: the control of the frames to generate, normalised, ``(batch, frames, n_control)``.
            history: the ``τ`` frames before them, normalised features ``(batch, τ, n_features)``.
            temperature: the prior's standard deviation (1: the model; 0: the mode ``z = 0``).
            noise: standard-normal ``ε`` ``(batch, frames, n_modelled)``; ``z = temperature · ε``
                (default: drawn with ``generator``).
            generator: a ``torch.Generator`` for reproducible samples.

        Returns:
            The generated frames, normalised features ``(batch, frames, n_features)``, with
            the given control copied in.
        """
        return self._sample(control, history, temperature, noise, generator)[0]

    def _sample(self, control, history, temperature, noise, generator):
        """:meth:`sample`'s work: the frames, and with a contact head the contacts drawn for
        them ``(batch, frames, 4)`` (else None)."""
        control, history = self._check_sampling(control, history)
        batch, frames = control.shape[:2]
        noise = self._noise(noise, (batch, frames, self.n_modelled), generator)
        tau = self.config.history
        poses = history[..., self.modelled]
        controls = torch.cat([history[..., self.control], control], dim=1)
        units = self.anchor_units() if self.config.foot_anchor else None       # once, not every frame
        carried = self.contact_head.start(batch, history.device) if self.contact_head is not None else None
        drawn = []
        with eval_mode(self), self.carrying_state():
            for t in range(frames):
                cond = self.frame_conditioning(self.history_scale * poses[:, -tau:], controls[:, t:t + tau + 1],
                                               poses[:, -1], units)
                cond, carried = self.draw_contacts(cond, carried, generator)
                if carried is not None:
                    drawn.append(carried[0])                              # the state the head drew
                x = self.flow.inverse(temperature * noise[:, t:t + 1], cond)
                x = self.restore(x, poses[:, -1:], controls[:, t + tau - 1:t + tau], units)
                poses = torch.cat([poses, x], dim=1)
        contacts = None if carried is None else (labels_of(torch.stack(drawn, 1)) if drawn
                                                 else control.new_zeros(batch, 0, N_CONTACTS))
        return self.join_features(poses[:, tau:], control), contacts

    def restore(self, x: torch.Tensor, previous: torch.Tensor, control: torch.Tensor, units=None) -> torch.Tensor:
        """The new poses ``(..., n_modelled)`` from the flow's values ``x``, given the frame
        before and its control (``previous``, ``control``: the same leading shape): the feet
        anchored back (``foot_anchor``), then the upper body's joints from their bones
        (``bone_coordinates``). For :meth:`sample` and :class:`~motionlab.engine.stream.MoGlowStream`."""
        if self.config.foot_anchor:
            x = self._anchored(x, previous, control, 1.0, units)
        if self.config.bone_coordinates:
            x = self.from_bones(x, previous)
        return x

    def draw_contacts(self, cond: torch.Tensor, carried, generator: torch.Generator | None = None):
        """With a contact head, one frame's contacts drawn from ``p(c_t | c_<t, cond_t)`` and
        appended to its conditioning ``(batch, 1, cond_channels)`` as ``±1``; ``carried``: the
        head's state (:meth:`ContactHead.start`). Returns ``(conditioning, carried)``;
        without a head, both unchanged."""
        if self.contact_head is None:
            return cond, carried
        context = self.contact_head.context_of(cond)[:, 0]
        labels, carried = self.contact_head.step(context, carried, generator)
        return self.with_contacts(cond, labels[:, None]), carried

    def _noise(self, noise, shape, generator) -> torch.Tensor:
        """Standard-normal ``ε`` of ``shape``: ``noise`` checked, or drawn with ``generator``."""
        if noise is None:
            return self.prior.sample(shape, 1.0, generator, device=self.modelled.device)
        epsilon = torch.as_tensor(noise, dtype=torch.float32, device=self.modelled.device)
        if tuple(epsilon.shape) != tuple(shape):
            raise ValueError(f"noise: expected {tuple(shape)}, got {tuple(epsilon.shape)}")
        return epsilon

    def generate(self, control=None, *, frames=None, prefix=None, n=1, temperature=1.0, seed=0) -> Generated:
        """Follow ``control`` (required) from ``prefix`` (required, at least ``τ`` real
        frames; the last ``τ`` are the history); see :mod:`motionlab.models.base`.

        A recurrent model runs as a :class:`~motionlab.engine.stream.MoGlowStream` (the real-time path; ``n``
        streams as one batch), a Markov one through :meth:`sample`. With a contact head, the result
        holds the contacts the model drew (``Generated.contacts``).
        """
        n, temperature = self._check_common(n, temperature, seed)
        control = self._control_array(control, n, frames)
        history = self._prefix_array(prefix, n, min_frames=self.config.history)[:, -self.config.history:]
        if not self.config.recurrent:
            norm = self._normalizer()
            control = torch.tensor((control - norm.mean[self.control]) / norm.std[self.control], dtype=torch.float32)
            history = torch.tensor(norm.normalize(history), dtype=torch.float32)
            history[..., self.constant] = 0.0
            return self._result(*self._sample(control, history, temperature, None, generator_for(seed)))
        stream = self.stream(torch.tensor(history, dtype=torch.float32), temperature, generator_for(seed),
                             self._normalizer())
        control = torch.tensor(control, dtype=torch.float32)
        if self.contact_head is None:
            return self._result_in_data_units(stream.run(control).cpu().numpy())
        frames, drawn = [], []                                    # a contact head's: keep what it drew
        for t in range(control.shape[1]):
            frames.append(stream.step(control[:, t]))
            drawn.append(stream.contacts)
        return self._result_in_data_units(torch.stack(frames, 1).cpu().numpy(), torch.stack(drawn, 1))

    def stream(self, history: torch.Tensor, temperature: float = 1.0, generator: torch.Generator | None = None,
               normalizer=None, weights: torch.dtype = torch.float32):
        """A :class:`~motionlab.engine.stream.MoGlowStream` that continues ``history`` one
        control frame at a time (the real-time sampler of §4.2, in the engine's own module)."""
        from ..engine.stream import MoGlowStream
        return MoGlowStream(self, history, temperature=temperature, generator=generator, normalizer=normalizer,
                            weights=weights)

    def describe(self) -> list[str]:
        """What the model conditions on, and its size."""
        c = self.config
        kind = (f"LSTM {c.lstm_layers} x {c.hidden}" if c.recurrent else f"feed-forward 2 x {c.hidden} (Markov)")
        weights = sum(p.numel() for p in self.parameters())
        return [f"{c.steps} steps of flow over one frame: {self.n_modelled} pose values (L = 1, no squeeze)",
                f"coupling networks: {kind}, each sees b_lo ({self.n_modelled // 2}) + conditioning "
                f"({self.cond_channels} = {c.history} poses x {self.n_modelled} + {c.history + 1} controls x "
                f"{c.n_control})",
                f"parameters: {weights:,} ({4 * weights / 1e6:.1f} MB as float32)"] + \
            (["feet's x, z modelled less where they would be had they stayed planted (foot_anchor)"]
             if c.foot_anchor else []) + \
            ([f"the conditioning also holds m, where the feet would be had they stayed planted "
              f"({len(anchor.FOOT_XZ)} values, anchor_conditioning)"] if c.anchor_conditioning else []) + \
            (["toes modelled less their ankles, knees less the midpoint of hip and ankle (leg_anchor)"]
             if c.leg_anchor else []) + \
            ([f"beside the flow: p(contacts | earlier contacts, conditioning), {N_CONTACTS} labels per frame, "
              "which the coupling networks see beside the conditioning (contact_head)"] if c.contact_head else []) + \
            ([("spine, neck, head and arms" if (c.foot_anchor or c.leg_anchor)
               else "every joint but the hips and ankles")
              + " modelled by each bone's change of length and its direction (bone_coordinates)"]
             if c.bone_coordinates else [])


CARD = ModelCard("moglow", MoGlow, MoGlowConfig, schedule=henter_schedule(80_000, "autoregressive"))
