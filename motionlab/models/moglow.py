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
carrying the LSTM states (:class:`MoGlowStream`, the real-time API).

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
from the networks). Sampling adds it back frame by frame, :class:`MoGlowStream` too.

Everything here reuses :mod:`motionlab.models.flows` unchanged: the coupling network is
the pluggable part (:class:`LSTMCouplingNet` here; the Markovian variant of §4.2 uses
:class:`~motionlab.models.flows.MLPCouplingNet`).
"""
from __future__ import annotations

import copy
import math
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, replace
from functools import partial

import numpy as np
import torch
from torch import nn

from . import recurrent
from .. import checks, cpu
from .base import Generated, eval_mode, generator_for
from .flows import (_LOG_SIGMOID_SHIFT, SCALE_SHIFT, FlowSequence, FlowStep, GaussianPrior, MLPCouplingNet,
                    output_layer)
from .glow import MotionFlow
from ..skeleton import FEET, LOCOMOTION

# the root-local x and z features of the ankles and toes (FEET order), which foot_anchor shifts
_FOOT_XZ = tuple(3 * j + axis for axis in (0, 2) for j in FEET)


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
        if self.foot_anchor and (n_pose, self.n_control) != (3 * LOCOMOTION.n_joints, 3):
            raise ValueError(f"foot_anchor: needs the locomotion features ({3 * LOCOMOTION.n_joints} pose values "
                             f"and 3 controls), got {n_pose} and {self.n_control}")
        if self.foot_anchor and set(self.constant_features) & set(_FOOT_XZ):
            raise ValueError("foot_anchor: the feet's x and z cannot be constant_features")

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


class MoGlow(MotionFlow):
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
        if config.recurrent:
            network = partial(LSTMCouplingNet, hidden=config.hidden, layers=config.lstm_layers)
        else:
            network = partial(MLPCouplingNet, hidden=config.hidden)
        self.flow = FlowSequence(FlowStep(self.n_modelled, network, self.cond_channels)
                                 for _ in range(config.steps))
        self.prior = GaussianPrior()
        if config.foot_anchor:              # the feet's x then z columns among the modelled values
            modelled = [i for i in range(config.n_features - config.n_control) if i not in config.constant_features]
            self.register_buffer("foot_columns", torch.tensor([modelled.index(i) for i in _FOOT_XZ]),
                                 persistent=False)

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
        return torch.cat([history.transpose(2, 3).flatten(2), controls.transpose(2, 3).flatten(2)], dim=-1)

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

    @staticmethod
    def frame_conditioning(history: torch.Tensor, controls: torch.Tensor) -> torch.Tensor:
        """The conditioning of one new frame, ``(batch, 1, cond_channels)``, from the ``τ``
        previous modelled poses ``(batch, τ, n_modelled)`` and the controls of those frames
        and the new one ``(batch, τ + 1, n_control)``; laid out as :meth:`conditioning`
        (the caller scales the history by :attr:`history_scale`)."""
        return torch.cat([history.flatten(1), controls.flatten(1)], dim=1)[:, None]

    # -- feet anchored where they were planted (foot_anchor) ----------------------------

    def anchor_units(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """The model's normaliser where :meth:`anchor` needs it, float32 on the model's
        device: the mean and std of the feet's ``x, z`` features (``(8,)``, :data:`_FOOT_XZ`
        order) and of the control (``(3,)``)."""
        if self.normalizer is None:
            raise ValueError("foot_anchor: the shift is measured in the data's units and needs the model's "
                             "normaliser; train with training.train on a MotionData (it sets model.normalizer) "
                             "or set model.normalizer")
        columns = list(_FOOT_XZ) + list(range(self.config.n_features)[self.control])
        mean, std = (torch.as_tensor(np.asarray(values)[columns], dtype=torch.float32, device=self.modelled.device)
                     for values in (self.normalizer.mean, self.normalizer.std))
        n = len(_FOOT_XZ)
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

    # -- likelihood (eq. 16) -------------------------------------------------------------

    def log_likelihood(self, batch: torch.Tensor) -> torch.Tensor:
        """``Σ_{t>τ} ln p(x_t | x_{t-τ:t-1}, c_{t-τ:t}, h_t)`` of each window, nats,
        normalised units, ``(batch,)``. The first ``τ`` frames are given (footnote 2)."""
        self.check_features(batch)
        poses, control = batch[..., self.modelled], batch[..., self.control]
        cond = self.conditioning(poses, control, drop=self.training)
        tau = self.config.history
        target = poses[:, tau:]
        if self.config.foot_anchor:          # a shift by the conditioning: log-determinant 0
            target = self._anchored(target, poses[:, tau - 1:-1], control[:, tau - 1:-1], -1.0)
        z, logdet = self.flow(target, cond)
        return self.prior.log_prob(z) + logdet

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
        per_frame = float(total.mean()) / (windows.shape[1] - self.config.history)
        if normalizer is not None:
            per_frame += float(np.log(np.asarray(normalizer.std)[self.modelled.cpu().numpy()]).sum())
        return {"nats/frame": per_frame, "bits/frame": per_frame / math.log(2)}

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
        inverse. This is the reference sampler; :class:`MoGlowStream` is the fast one.

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
        control, history = self._check_sampling(control, history)
        batch, frames = control.shape[:2]
        noise = self._noise(noise, (batch, frames, self.n_modelled), generator)
        tau = self.config.history
        poses = history[..., self.modelled]
        controls = torch.cat([history[..., self.control], control], dim=1)
        with eval_mode(self), self.carrying_state():
            for t in range(frames):
                cond = self.frame_conditioning(self.history_scale * poses[:, -tau:], controls[:, t:t + tau + 1])
                x = self.flow.inverse(temperature * noise[:, t:t + 1], cond)
                if self.config.foot_anchor:
                    x = self._anchored(x, poses[:, -1:], controls[:, t + tau - 1:t + tau], 1.0)
                poses = torch.cat([poses, x], dim=1)
        return self.join_features(poses[:, tau:], control)

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

        A recurrent model runs as a :class:`MoGlowStream` (the real-time path; ``n``
        streams as one batch), a Markov one through :meth:`sample`.
        """
        n, temperature = self._check_common(n, temperature, seed)
        control = self._control_array(control, n, frames)
        history = self._prefix_array(prefix, n, min_frames=self.config.history)[:, -self.config.history:]
        if not self.config.recurrent:
            norm = self._normaliser()
            control = torch.tensor((control - norm.mean[self.control]) / norm.std[self.control], dtype=torch.float32)
            history = torch.tensor(norm.normalize(history), dtype=torch.float32)
            history[..., self.constant] = 0.0
            return self._result(self.sample(control, history, temperature, generator=generator_for(seed)))
        stream = self.stream(torch.tensor(history, dtype=torch.float32), temperature, generator_for(seed),
                             self._normaliser())
        return self._result_in_data_units(stream.run(torch.tensor(control, dtype=torch.float32)).cpu().numpy())

    def stream(self, history: torch.Tensor, temperature: float = 1.0, generator: torch.Generator | None = None,
               normalizer=None, weights: torch.dtype = torch.float32) -> "MoGlowStream":
        """A :class:`MoGlowStream` that continues ``history`` one control frame at a time."""
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
             if c.foot_anchor else [])


@dataclass(eq=False)
class _StreamCoupling:
    """One coupling as :class:`MoGlowStream` runs it: its weights, laid out for the stream's
    product kernel, and the buffers each frame overwrites in place (``B`` streams, ``L``
    LSTM layers of ``H`` units, ``D = n_lo + n_hi`` modelled values).

    The LSTM's input and hidden states share one ``(B, n_lo + L·H)`` buffer
    ``[b_lo, h_1, ..., h_L]`` in the weights' dtype: ``lo`` is this frame's ``b_lo``,
    ``layer_inputs[l]`` the slice layer ``l`` multiplies (``[b_lo, h_1]`` for the first,
    ``[h_{l-1}, h_l]`` after it), and ``hidden[l]`` where it writes its new ``h_l``.
    """

    lo: torch.Tensor                     # (B, n_lo), a view of the buffer
    layer_inputs: list[torch.Tensor]     # per layer, a view of the buffer
    hidden: list[torch.Tensor]           # per layer, (B, H), a view of the buffer
    cells: list[torch.Tensor]            # per layer, c_l, (B, H) float32
    operands: list[torch.Tensor]         # per layer, [W_ih W_hh] as (in, 4H); the first's without the conditioning
    biases: list[torch.Tensor | None]    # per layer, (4H,) float32; the first's is in cond_gates
    cond_gates: torch.Tensor             # (B, 4H) float32: the conditioning's part of the first layer's gates
    output: torch.Tensor                 # (H, 2 n_hi): the output layer, giving [t' / σ(2), -h_s' - 2]
    output_bias: torch.Tensor            # (2 n_hi,)
    output_out: torch.Tensor             # (B, 2 n_hi) float32: the output layer's result, [shift, exponent]
    shift: torch.Tensor                  # (B, n_hi), a view of output_out: t' / σ(2)
    exponent: torch.Tensor               # (B, n_hi), a view of output_out: -h_s' - 2 (exp'd in place)
    unmix: torch.Tensor                  # (D, D): W^-1 and ActNorm^-1 as one affine map, σ(2) in the hi rows
    unmix_bias: torch.Tensor             # (D,)


class MoGlowStream:
    """Real-time MoGlow: feed one control frame, get one pose back (§4.2, Fig. 3).

    Holds the last ``τ`` poses and controls and every coupling's LSTM state, and runs the
    flow backwards (coupling inverse -> ``W^-1`` -> ActNorm inverse, step ``K`` to 1) in
    inference mode, one frame per :meth:`step`. Several streams (characters) run at once as
    a batch.

    Generating one frame reads every weight once, so one stream is limited by how fast its
    products read the weights, and then by the hundreds of small operations beside them.
    So at creation the stream precomputes, once, what does not change from frame to frame,
    and keeps the couplings' work in buffers made once, which every frame overwrites in
    place (:class:`_StreamCoupling`):

    * each step's ``W^-1`` joined with its ActNorm inverse into one affine map (matrix
      products, not triangular solves);
    * the first LSTM layer's weights on the conditioning, of all ``K`` couplings, stacked
      into one matrix: the conditioning is the same for every coupling, so one product per
      frame gives that part of every coupling's gates (one product per coupling for several
      streams on a CPU, measured faster there);
    * each layer's remaining weights joined, ``[W_ih W_hh]`` on ``[input, h_{t-1}]``, and
      every coupling's input and hidden states kept side by side in one buffer
      ``[b_lo, h_1, h_2, ...]``, so each layer is one product on a slice of it, and writes
      its new ``h`` into it in place (``nn.LSTM``, called one frame at a time, would repack
      its weights on every call);
    * the output layer's rows rearranged so that the coupling's inverse scale
      ``1 / s' = σ(2) (1 + exp(-h_s' - 2))`` (:data:`~motionlab.models.flows.SCALE_SHIFT`)
      is one exponential, with ``σ(2)`` moved into the next affine map;
    * the weights laid out for the fastest product kernel of this CPU (``_kernel``).

    ``weights=torch.bfloat16`` halves the bytes read per frame: the LSTM products run in
    bfloat16 (the conditioning's part and the rest of each first layer's gates are each
    rounded to bfloat16 before they are added in float32), everything else in float32;
    frames then differ from the float32 ones by about 1e-3 to 1e-2 in normalised units.

    A ``foot_anchor`` model's stream adds each frame's ``m`` (:meth:`MoGlow.anchor`, from
    the frame before and its control) to the flow's output, as :meth:`MoGlow.sample` does.

    >>> stream = model.stream(history)            # (batch, τ, 66) normalised features
    >>> frame = stream.step(control)              # (batch, 3) -> (batch, 66)

    Args:
        model: a trained :class:`MoGlow` with recurrent couplings.
        history: the ``τ`` frames to start from ``(batch, τ, n_features)`` (normalised, or
            in the data's units when ``normalizer`` is given).
        temperature: the prior's standard deviation.
        generator: a ``torch.Generator`` for the noise.
        normalizer: a :class:`motionlab.data.Normalizer`: take and return features in the
            data's units (metres, m/s, rad/s) instead of normalised ones.
        weights: dtype of the LSTM weights during streaming (``torch.float32`` or
            ``torch.bfloat16``).
    """

    def __init__(self, model: MoGlow, history, temperature: float = 1.0,
                 generator: torch.Generator | None = None, normalizer=None, weights: torch.dtype = torch.float32):
        if weights not in (torch.float32, torch.bfloat16):
            raise ValueError(f"weights: expected torch.float32 or torch.bfloat16, got {weights}")
        self.weights = weights
        if not model.config.recurrent:
            raise ValueError("model: the stream needs recurrent (LSTM) couplings; use MoGlow.sample for a Markov model")
        self.model, self.normalizer, self.generator = model, normalizer, generator
        self.temperature = float(temperature)
        if not (math.isfinite(self.temperature) and self.temperature >= 0):
            raise ValueError(f"temperature: expected a finite number >= 0, got {temperature}")
        device = model.modelled.device
        history = model.check_history(history)
        if normalizer is not None:
            self._mean = torch.as_tensor(np.asarray(normalizer.mean), dtype=torch.float32, device=device)
            self._std = torch.as_tensor(np.asarray(normalizer.std), dtype=torch.float32, device=device)
            history = (history - self._mean) / self._std
            history[..., model.constant] = 0.0
        model.check_features(history, "history", min_frames=model.config.history)
        self.batch = history.shape[0]
        self.poses = history[..., model.modelled].clone()               # (batch, τ, n_modelled)
        self.controls = history[..., model.control].clone()             # (batch, τ, n_control)
        self.frames = 0
        self._history_scale = model.history_scale                        # fixed for the stream's life
        self._anchor_units = model.anchor_units() if model.config.foot_anchor else None
        # How one frame's LSTM products run on a CPU (measured over paper-size layers, see
        # benchmarks/moglow_speed.py). One stream only reads weights, and the kernels differ:
        # * bfloat16, native arithmetic (AVX512-BF16, AMX) for both kernel families
        #   (motionlab.cpu: oneDNN's instruction set and ATen's, each capped by its variable):
        #   PyTorch's own matrix product, not oneDNN's, reads them at about the memory
        #   bandwidth (~22-32 against ~14-17 GB/s);
        # * bfloat16, emulated (AVX2 laptops, or capped): the matrix-vector kernel reads them
        #   faster than a product;
        # * float32: oneDNN's product of the row with the weights stored transposed,
        #   ``(in, 4H)``, reads them faster (~17-21 GB/s) than against ``(4H, in)`` (~14).
        # Several streams are arithmetic: oneDNN's product against ``(4H, in)``.
        one_cpu_stream = self.batch == 1 and device.type == "cpu"
        self._kernel = "product"
        if one_cpu_stream and weights == torch.bfloat16:
            native = cpu.native_bfloat16() and cpu.aten_capability().startswith("AVX512")
            self._kernel = "own product" if native else "matrix-vector"
        elif one_cpu_stream:
            self._kernel = "transposed"
        with torch.inference_mode():
            self._precompute(device)

    def _operand(self, weight: torch.Tensor) -> torch.Tensor:
        """``weight`` ``(out, in)`` as the right-hand operand ``(in, out)`` of this stream's
        products: stored transposed for the ``"transposed"`` kernel, else a view of the
        ``(out, in)`` matrix."""
        weight = weight.to(self.weights)
        return weight.T.contiguous() if self._kernel == "transposed" else weight.contiguous().T

    def _multiply(self, inputs: torch.Tensor, operand: torch.Tensor, out: torch.Tensor) -> None:
        """``out = inputs @ operand`` with this stream's kernel, written into ``out``."""
        if self._kernel == "matrix-vector":                     # one stream: its only row
            torch.mv(operand.T, inputs[0], out=out[0])
        else:
            torch.mm(inputs, operand, out=out)

    def _precompute(self, device: torch.device) -> None:
        """Lay out every coupling's weights and buffers (see the class docstring); the LSTM
        states start at zero (footnote 2)."""
        model, batch = self.model, self.batch
        hidden, layers, n_steps = model.config.hidden, model.config.lstm_layers, model.config.steps
        gates = 4 * hidden
        new = partial(torch.zeros, device=device)
        # torch stores the gates as rows i, f, g, o; reordered to i, f, o, g, the three
        # sigmoid gates are one slice (one sigmoid per layer and frame)
        order = torch.cat([torch.arange(0, 2 * hidden), torch.arange(3 * hidden, 4 * hidden),
                           torch.arange(2 * hidden, 3 * hidden)]).to(device)
        sigma_2 = math.exp(_LOG_SIGMOID_SHIFT)                            # σ(2)
        # scratch shared by every layer: the product, the gates (float32) and views of them,
        # tanh(c), and the last layer's h in float32 for the output layer
        self._product_out = new(batch, gates, dtype=self.weights)
        self._gates = new(batch, gates)
        self._sigmoid_gates, self._cell_gate = self._gates[:, :3 * hidden], self._gates[:, 3 * hidden:]
        self._input_gate, self._forget_gate, self._output_gate = self._gates[:, :3 * hidden].split(hidden, dim=1)
        self._tanh_cell, self._last_hidden = new(batch, hidden), new(batch, hidden)
        # the poses between steps (float32): z in, the coupling's output, then the next z;
        # every step splits them alike (n_lo, n_hi)
        self._z, self._coupled = new(batch, model.n_modelled), new(batch, model.n_modelled)
        n_lo = model.flow.blocks[0].coupling.n_lo
        self._halves = (self._z[:, :n_lo], self._z[:, n_lo:], self._coupled[:, :n_lo], self._coupled[:, n_lo:])
        # the conditioning's part of every coupling's first-layer gates, one frame's worth
        self._cond_product = new(batch, n_steps * gates, dtype=self.weights)
        self._cond_gates = new(batch, n_steps * gates)
        self._couplings, cond_weights, cond_biases = [], [], []
        for k, step in enumerate(model.flow.blocks):
            actnorm, linear, coupling = step.actnorm, step.linear, step.coupling
            lstm, output = coupling.network.lstm, coupling.network.output
            n_lo, n_hi = coupling.n_lo, coupling.n_hi
            weight_ih = lstm.weight_ih_l0[order]                          # (4H, n_lo + cond)
            cond_weights.append(weight_ih[:, n_lo:])
            cond_biases.append((lstm.bias_ih_l0 + lstm.bias_hh_l0)[order])
            operands = [self._operand(torch.cat([weight_ih[:, :n_lo], lstm.weight_hh_l0[order]], dim=1))]
            biases = [None]
            for layer in range(1, layers):
                operands.append(self._operand(torch.cat([getattr(lstm, f"weight_ih_l{layer}")[order],
                                                         getattr(lstm, f"weight_hh_l{layer}")[order]], dim=1)))
                biases.append((getattr(lstm, f"bias_ih_l{layer}") + getattr(lstm, f"bias_hh_l{layer}"))[order])
            buffer = new(batch, n_lo + layers * hidden, dtype=self.weights)      # [b_lo, h_1, ..., h_L]
            state = [buffer[:, n_lo + layer * hidden:n_lo + (layer + 1) * hidden] for layer in range(layers)]
            inputs = [buffer[:, :n_lo + hidden]] + [buffer[:, n_lo + (layer - 1) * hidden:n_lo + (layer + 1) * hidden]
                                                    for layer in range(1, layers)]
            # the output layer's rows: the shift divided by σ(2), and -h_s' - 2 for the scale
            rows = torch.cat([output.weight[:n_hi] / sigma_2, -output.weight[n_hi:]])
            bias = torch.cat([output.bias[:n_hi] / sigma_2, -output.bias[n_hi:] - SCALE_SHIFT])
            # W^-1 then ActNorm^-1 is one affine map: (x W^-T - b) s = x (W^-T s) - b s; the
            # rows that take the coupled half also take the σ(2) of its inverse scale
            scale = torch.exp(-actnorm.log_scale)
            unmix = torch.linalg.inv(linear.weight().double()).T.float() * scale
            unmix[n_lo:] *= sigma_2
            output_out = new(batch, 2 * n_hi)
            self._couplings.append(_StreamCoupling(
                layer_inputs=inputs, hidden=state, lo=buffer[:, :n_lo],
                cells=[new(batch, hidden) for _ in range(layers)], operands=operands, biases=biases,
                cond_gates=self._cond_gates[:, k * gates:(k + 1) * gates],
                output=rows.T.contiguous(), output_bias=bias, shift=output_out[:, :n_hi],
                exponent=output_out[:, n_hi:], output_out=output_out, unmix=unmix.contiguous(),
                unmix_bias=-actnorm.bias * scale))
        self._cond_operand = self._operand(torch.cat(cond_weights))                 # (cond, K·4H)
        self._cond_bias = torch.cat(cond_biases)
        # several streams on a CPU: one product per coupling (64 float32 rows: 90 GFLOP/s,
        # against 65 for one product over all couplings' columns); else one product
        chunk = gates if batch > 1 and device.type == "cpu" else n_steps * gates
        self._cond_chunks = [(self._cond_operand[:, start:start + chunk], self._cond_product[:, start:start + chunk])
                             for start in range(0, n_steps * gates, chunk)]

    def _coupling_network(self, coupling: _StreamCoupling) -> None:
        """One coupling's network on this frame's ``b_lo`` (already in its buffer): the LSTM
        layers (eq. 17, carrying their state; gates reordered i, f, o, g), then the output
        layer, into ``coupling.output_out``: ``[t' / σ(2), -h_s' - 2]``."""
        last = len(coupling.cells) - 1
        for layer, (inputs, operand, bias, cell) in enumerate(zip(coupling.layer_inputs, coupling.operands,
                                                                   coupling.biases, coupling.cells)):
            self._multiply(inputs, operand, self._product_out)
            torch.add(self._product_out, coupling.cond_gates if bias is None else bias, out=self._gates)
            self._sigmoid_gates.sigmoid_()
            self._cell_gate.tanh_()
            cell.mul_(self._forget_gate).addcmul_(self._input_gate, self._cell_gate)    # c_t = f c_{t-1} + i g
            torch.tanh(cell, out=self._tanh_cell)
            if layer < last:                                                       # h_t = o tanh(c_t)
                torch.mul(self._output_gate, self._tanh_cell, out=coupling.hidden[layer])
            else:
                torch.mul(self._output_gate, self._tanh_cell, out=self._last_hidden)
                coupling.hidden[layer].copy_(self._last_hidden)
        torch.addmm(coupling.output_bias, self._last_hidden, coupling.output, out=coupling.output_out)

    def _normalised_control(self, control) -> torch.Tensor:
        c = self.model.config.n_control
        control = torch.as_tensor(control, dtype=torch.float32, device=self.poses.device)
        if control.ndim == 1:
            control = control.expand(self.batch, -1)
        if control.shape != (self.batch, c):
            raise ValueError(f"control: expected ({self.batch}, {c}) (or ({c},) for every stream), "
                             f"got {tuple(control.shape)}")
        if not torch.isfinite(control).all():
            raise ValueError("control: contains NaN or infinite values")
        if self.normalizer is not None:
            control = (control - self._mean[self.model.control]) / self._std[self.model.control]
        return control

    def step(self, control, noise: torch.Tensor | None = None) -> torch.Tensor:
        """The next frame for ``control`` ``(batch, n_control)`` (or ``(n_control,)``).

        Args:
            control: this frame's control (normalised, or data units with a normaliser).
            noise: standard-normal ``ε`` ``(batch, n_modelled)`` (default: drawn).

        Returns:
            The new frame's features ``(batch, n_features)``, normalised or in data units.
        """
        model = self.model
        own_products = cpu.onednn_disabled() if self._kernel == "own product" else nullcontext()
        with torch.inference_mode(), own_products:
            control = self._normalised_control(control)
            shape = (self.batch, model.n_modelled)
            if noise is None:
                device = self.generator.device if self.generator is not None else self.poses.device
                noise = torch.randn(shape, generator=self.generator, device=device).to(self.poses.device)
            elif tuple(noise.shape) != shape:
                raise ValueError(f"noise: expected {shape}, got {tuple(noise.shape)}")
            controls = torch.cat([self.controls, control[:, None]], dim=1)       # c_{t-τ .. t}
            cond = MoGlow.frame_conditioning(self._history_scale * self.poses, controls)[:, 0]
            # the conditioning's part of every coupling's first-layer gates, in one product
            # (one per coupling for several streams on a CPU)
            cond = cond.to(self.weights)
            for operand, out in self._cond_chunks:
                self._multiply(cond, operand, out)
            torch.add(self._cond_product, self._cond_bias, out=self._cond_gates)
            torch.mul(noise, self.temperature, out=self._z)
            z_lo, z_hi, coupled_lo, coupled_hi = self._halves
            for coupling in reversed(self._couplings):                           # f_K^-1 ... f_1^-1 undone
                coupling.lo.copy_(z_lo)
                self._coupling_network(coupling)
                # eq. 6 inverted, b_hi = z_hi / s' - t', divided by σ(2) (the unmix multiplies it back):
                # z_hi (1 + e) - t' / σ(2), with e = exp(-h_s' - 2) = 1 / (σ(2) s') - 1
                torch.addcmul(z_hi, z_hi, coupling.exponent.exp_(), out=coupled_hi)
                coupled_hi.sub_(coupling.shift)
                coupled_lo.copy_(z_lo)
                torch.addmm(coupling.unmix_bias, self._coupled, coupling.unmix, out=self._z)   # W^-1, ActNorm^-1
            x = self._z.clone()
            if self._anchor_units is not None:                               # m from x_{t-1} and c_{t-1}
                x = model._anchored(x, self.poses[:, -1], self.controls[:, -1], 1.0, self._anchor_units)
            self.poses = torch.cat([self.poses[:, 1:], x[:, None]], dim=1)
            self.controls = controls[:, 1:]
            self.frames += 1
            frame = self.model.join_features(x[:, None], control[:, None])[:, 0]
            if self.normalizer is not None:
                frame = frame * self._std + self._mean
                frame[:, model.constant] = 0.0
        return frame.clone()

    def run(self, control, noise: torch.Tensor | None = None) -> torch.Tensor:
        """:meth:`step` over a whole control sequence ``(batch, frames, n_control)``:
        ``(batch, frames, n_features)``."""
        control = torch.as_tensor(control, dtype=torch.float32)
        if control.ndim != 3 or control.shape[0] != self.batch:
            raise ValueError(f"control: expected ({self.batch}, frames, {self.model.config.n_control}), "
                             f"got {tuple(control.shape)}")
        frames = [self.step(control[:, t], None if noise is None else noise[:, t]) for t in range(control.shape[1])]
        return torch.stack(frames, dim=1)
