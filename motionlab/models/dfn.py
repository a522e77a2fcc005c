"""Dynamic Future Net, "DFN" (Chen et al. 2020): diversified motion from a short prefix.

The current frame is a result of the past and a choice made for a planned future. DFN
models three latent states per frame ``t`` (§5.3): a deterministic *past* state ``h_t``
(a GRU over everything generated so far), a stochastic *future* state ``f_t`` (where the
motion is heading over the next ``horizon`` frames) and a stochastic *current* state
``z_t`` (this frame). Generation first imagines a future, then picks a current state that
leads there, then updates the past::

    frame y_t (66) --frame encoder (§5.1)--> x_t = [pose code | velocity code]
    x_t..x_{t+H-1} --GRU seq2seq (§5.2)----> s_t, a summary of the next H frames
    f_t ~ p(f_t | h_t)        = N(mu, sigma^2),  3-layer MLP, 256, LeakyReLU        eq. 5
    s^_t = MLP(f_t)           unrolled future summary, 2-layer MLP, 128              eq. 6
    z_t ~ p(z_t | h_t, s^_t)  = N(mu, sigma^2),  4-layer MLP, 128, LeakyReLU        eq. 7
    x^_t = MLP(z_t)           current feature, 3 hidden layers of 128                §5.3
    h_{t+1} = GRU(h_t, [z_t, f_t])               2 stacked layers of 128             eq. 8
    x^_t --frame decoders (§5.1)--> joint rotations --forward kinematics--> pose (63),
                                    and velocity (3)

Training infers ``f_t`` and ``z_t`` from the data (§5.4): ``q(f_t | h_t, s_t)`` from the
true future summary and ``q(z_t | x_t, h_t, s_t)`` from the true frame, and adds a
temporal-difference term (§5.5, after TD-VAE): a state ``z_t1`` inferred back from a later
``z_t2`` must predict ``z_t2`` over the skip ``t2 - t1``. The loss (§5.6) is the frame
reconstruction, the future-summary reconstruction, the two KL terms and the TD term.

**A contact head** (``contact_head``, off by default; not in the paper; after the flows'
:mod:`motionlab.models.contact_head`). Each frame's foot contacts ``c_t`` (ankles and toes, a
discrete state) are drawn after the future and before the current state, and the current
state and the past read them, as the flows' poses do::

    c_t ~ p(c_t | c_<t, h_t, f_t)      z_t ~ p(z_t | h_t, s^_t, c_t)      h_{t+1} = GRU(h_t, [z_t, f_t, c_t])

Trained in the dynamics stage at the data's own labels, so the dynamics loss stays an ELBO,
now of the frames and their contacts. The drawn contacts are what the foot lock holds
(``Generated.contacts``).

Training is staged as in the paper (§5.6): the frame autoencoder first (stage
``"frame"``), then, with it frozen, the dynamics embedding (``"sequence"``), then, with
both frozen, the dynamics model (``"dynamics"``). :func:`motionlab.training.train_stages`
runs the three with motionlab's one training loop.

This file follows the text of §5. Where the paper leaves a choice open (several sizes are
not given) it makes one and says so in a comment marked *Choice*. All
frame tensors are ``(batch, frames, 66)`` in the normalised units of
:class:`motionlab.data.Normalizer`; latents are ``(batch, frames, size)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import torch
import torch.nn.functional as F
from torch import nn

from .. import checks
from . import contact_head, gaussian
from ..skeleton import LOCOMOTION
from .base import GenerativeModel, eval_mode
from .contact_head import N_CONTACTS, ContactHead, DataContacts
from .dfn_parts import ForwardKinematics, GaussianHead, StagedTraining, mlp, quaternion_to_matrix
from .modelcard import NO_CLIP, ModelCard, choice, paper

STAGES = ("frame", "sequence", "dynamics")
"""The training stages, in order (§5.6)."""
POSE_DECODERS = ("rotations", "positions")
"""What the frame decoder outputs (§5.1): joint rotations through forward kinematics, or positions."""


@dataclass(frozen=True)
class DFNConfig:
    """Sizes and options. Defaults: a laptop-sized model at 20 fps; :meth:`paper` is §5.

    Attributes:
        n_pose, n_control: features per frame: 63 root-local joint coordinates and 3
            velocities (the paper: 72 + 4 for 24 joints, §4).
        fps: frames per second of the data the model expects.
        frame_hidden: width of the frame encoder's and pose decoder's two hidden layers.
        pose_code, velocity_code: sizes of the two parts of the frame code ``x_t`` (§5.1).
        horizon: ``H``, frames summarised by the future summary ``s_t`` (§5.2, §5.4).
        summary: size of the future summary ``s_t``; also the dynamics embedding's GRU size.
        past: size of each of the 2 layers of the past-state GRU ``h_t`` (eq. 8; paper 128).
        future: size of the future state ``f_t``.
        current: size of the current state ``z_t``.
        future_prior_hidden: hidden width of ``p(f | h)`` (eq. 5; paper 256).
        current_prior_hidden: hidden width of ``p(z | h, s^)`` (eq. 7) and of the current
            feature MLP ``x^ = MLP(z)`` (paper 128 both).
        summary_decoder_hidden: hidden width of ``s^ = MLP(f)`` (eq. 6; paper 128).
        current_posterior_hidden: hidden width of ``q(z | x, h, s)`` (eq. 10; paper 32).
        future_posterior_hidden: hidden width of ``q(f | h, s)`` (eq. 11; paper 512).
        td_hidden: hidden width of the TD posterior (eq. 13) and skip predictor (eq. 14),
            paper 32.
        td_max_skip: the largest ``t2 - t1`` of the temporal-difference term, frames.
        td_weight: weight of the temporal-difference term (0: off).
        observation_std: standard deviation of the Gaussian likelihood of the current
            feature ``x_t`` and of the future summary ``s_t``, in standardised units.
        velocity_weight: weight of the joint-velocity term of the dynamics embedding's loss
            (eq. 3).
        pose_decoder: ``"rotations"`` (§5.1: a rotation per joint, passed through forward
            kinematics over one fixed skeleton, so bone lengths cannot change) or
            ``"positions"`` (the 63 root-local coordinates directly; bones may stretch).
        contact_weight: weight of the foot-contact velocity term (HuMoR, EDGE, MDM) in the
            two stages whose loss is on decoded frames (eqs. 2 and 3; see :meth:`DFN.frame_loss`),
            per (m/s)² of planted-foot velocity; 0 = off (the shipped model).
        prior_feed: *not in the paper*: in training, the chance per step and window that the
            past-state GRU (eq. 8) reads a sample of the priors (eqs. 5-7) instead of the
            posteriors' (scheduled sampling, Bengio et al. 2015, on the latent states), so
            that ``h`` learns from the states generation gives it; 0 = the paper (shipped).
        contact_head: *not in the paper*: model each frame's foot contacts, ``p(c_t | c_<t,
            h_t, f_t)`` (:mod:`motionlab.models.contact_head`), and give them to the current
            prior and the past GRU; trained with the dynamics model; generation draws them
            (``Generated.contacts``).
    """

    n_pose: int = 63
    n_control: int = 3
    fps: float = 20.0
    frame_hidden: int = 256
    pose_code: int = 16
    velocity_code: int = 4
    horizon: int = 10
    summary: int = 32
    past: int = 64
    future: int = 16
    current: int = 16
    future_prior_hidden: int = 128
    current_prior_hidden: int = 64
    summary_decoder_hidden: int = 64
    current_posterior_hidden: int = 32
    future_posterior_hidden: int = 128
    td_hidden: int = 32
    td_max_skip: int = 4
    td_weight: float = 1.0
    observation_std: float = 0.1
    velocity_weight: float = 1.0
    pose_decoder: str = "rotations"
    contact_weight: float = 0.0
    prior_feed: float = 0.0
    contact_head: bool = False

    def __post_init__(self):
        checks.config(self, positive_fields=("observation_std",),
                      non_negative_fields=("td_weight", "velocity_weight", "contact_weight"),
                      probability_fields=("prior_feed",))
        if self.pose_decoder not in POSE_DECODERS:
            raise ValueError(f"pose_decoder: expected one of {', '.join(POSE_DECODERS)}, got {self.pose_decoder!r}")
        if self.pose_decoder == "rotations" and self.n_pose != 3 * LOCOMOTION.n_joints:
            raise ValueError(f"pose_decoder: 'rotations' decodes the {LOCOMOTION.n_joints}-joint locomotion "
                             f"skeleton ({3 * LOCOMOTION.n_joints} pose values), got n_pose={self.n_pose}")
        contact_head.check_config(self)

    @property
    def n_features(self) -> int:
        return self.n_pose + self.n_control

    @property
    def code(self) -> int:
        """Size of the frame code ``x_t``: pose code plus velocity code."""
        return self.pose_code + self.velocity_code

    @classmethod
    def paper(cls, **changes) -> "DFNConfig":
        """The sizes of §5: past GRU 2 x 128, future prior 256, current prior, current
        feature and summary decoder 128, current posterior 32, future posterior 512, TD
        networks 32; a 16-dimensional pose embedding (§6.3, Fig. 6). The paper gives no
        frame-autoencoder width, velocity-code size, state sizes, summary size, horizon or
        frame rate: *Choice*: 512, 8, 32 for ``f`` and ``z``, 64, and 20 frames (1 s at
        our 20 fps)."""
        return replace(cls(frame_hidden=512, pose_code=16, velocity_code=8, horizon=20, summary=64,
                           past=128, future=32, current=32, future_prior_hidden=256,
                           current_prior_hidden=128, summary_decoder_hidden=128,
                           current_posterior_hidden=32, future_posterior_hidden=512, td_hidden=32),
                       **changes)


# ----------------------------------------------------------------------------------------
# §5.1 Spatial embedding: the frame autoencoder
# ----------------------------------------------------------------------------------------

class FrameAutoencoder(nn.Module):
    """§5.1, Fig. 3: an MLP encoder whose code splits into a pose code and a velocity code,
    a pose decoder and a velocity decoder. ``(..., 66) <-> (..., pose_code + velocity_code)``.

    The pose decoder is the paper's by default (``pose_decoder="rotations"``): an MLP from
    the pose code to a quaternion for every joint with children plus the hips' position,
    then :class:`ForwardKinematics`. "Using joint rotations instead of joint positions
    maintains the bone lengths" (§5.1): ``metrics.bone_length_drift`` of anything decoded
    is zero up to float rounding. ``pose_decoder="positions"`` outputs the 63 root-local
    coordinates directly instead, and bones can stretch.

    Frames are in normalised units; forward kinematics works in metres, so the decoder
    keeps the pose columns' normalisation (``pose_mean``, ``pose_std``, set with the rest
    offsets by :meth:`fit_constants`).
    *Choice*: quaternions ``(w, x, y, z)``, each decoded as an offset from the identity and
    normalised, so an untrained decoder starts at the rest pose.
    *Choice*: the encoder sees the whole frame (pose and velocity); the pose decoder sees
    only the pose code and the velocity decoder only the velocity code.
    """

    def __init__(self, config: DFNConfig):
        super().__init__()
        c = config
        self.config = c
        self.encoder = mlp([c.n_features, c.frame_hidden, c.frame_hidden, c.code])
        self.rotations = c.pose_decoder == "rotations"
        if self.rotations:
            self.kinematics = ForwardKinematics()
            outputs = 4 * len(self.kinematics.rotated) + 3                     # quaternions, hips
        else:
            outputs = c.n_pose
        self.pose_decoder = mlp([c.pose_code, c.frame_hidden, c.frame_hidden, outputs])
        self.velocity_decoder = mlp([c.velocity_code, 64, c.n_control])
        # Features the training data never varies (the hips' root-local x and z are 0 by
        # definition) are decoded as that constant: a normalised error there costs almost
        # nothing in eq. 2 but would move the hips away from the root by centimetres.
        self.register_buffer("constant", torch.zeros(c.n_features, dtype=torch.bool))
        self.register_buffer("constant_value", torch.zeros(c.n_features))
        self.register_buffer("pose_mean", torch.zeros(c.n_pose))
        self.register_buffer("pose_std", torch.ones(c.n_pose))

    def fit_constants(self, frames: torch.Tensor, tolerance: float = 1e-6, pose_mean=None, pose_std=None) -> None:
        """Fit what the decoder takes from the training ``frames`` ``(..., 66)`` (normalised):
        the features that never vary and, for the rotation decoder, the rest offsets.
        ``pose_mean``, ``pose_std`` ``(63,)``: the pose columns' normalisation (metres), so
        that forward kinematics works in metres (default: the normalised units as they are)."""
        flat = frames.reshape(-1, frames.shape[-1])
        self.constant.copy_(flat.std(0) < tolerance if len(flat) > 1 else torch.zeros_like(self.constant))
        self.constant_value.copy_(flat.mean(0))
        if pose_mean is not None:
            self.pose_mean.copy_(torch.as_tensor(pose_mean, dtype=self.pose_mean.dtype))
            self.pose_std.copy_(torch.as_tensor(pose_std, dtype=self.pose_std.dtype))
        if self.rotations:
            metres = flat[:, :self.config.n_pose] * self.pose_std + self.pose_mean
            self.kinematics.fit(metres.reshape(len(flat), -1, 3))

    def encode(self, frames: torch.Tensor) -> torch.Tensor:
        return self.encoder(frames)

    def decode_pose(self, pose_code: torch.Tensor) -> torch.Tensor:
        """The pose decoder: ``(..., pose_code)`` -> normalised pose ``(..., 63)``."""
        out = self.pose_decoder(pose_code)
        if not self.rotations:
            return out
        n = len(self.kinematics.rotated)
        identity = out.new_tensor([1.0, 0.0, 0.0, 0.0])
        rotations = quaternion_to_matrix(out[..., :4 * n].unflatten(-1, (n, 4)) + identity)
        hips = torch.where(self.constant[:3], self.constant_value[:3], out[..., 4 * n:])  # joint 0: the hips
        hips = hips * self.pose_std[:3] + self.pose_mean[:3]                  # metres
        joints = self.kinematics(rotations, hips)                             # (..., 21, 3), metres
        return (joints.flatten(-2) - self.pose_mean) / self.pose_std

    def decode(self, code: torch.Tensor) -> torch.Tensor:
        pose_code, velocity_code = code.split([self.config.pose_code, self.config.velocity_code], -1)
        frames = torch.cat([self.decode_pose(pose_code), self.velocity_decoder(velocity_code)], -1)
        return torch.where(self.constant, self.constant_value, frames)


# ----------------------------------------------------------------------------------------
# §5.2 Dynamics embedding: the sequence autoencoder
# ----------------------------------------------------------------------------------------

class SequenceAutoencoder(nn.Module):
    """§5.2, Fig. 4: a GRU encodes ``H`` frame codes ``(n, H, code)`` into a future summary
    ``s`` ``(n, summary)``; a second GRU unrolls ``s`` back into ``H`` frame codes.

    *Choice*: the decoder GRU starts from ``s`` and is fed ``s`` at every step (the paper
    does not say what it is fed); a linear layer maps its states to frame codes.
    """

    def __init__(self, config: DFNConfig):
        super().__init__()
        c = config
        self.horizon = c.horizon
        self.encoder = nn.GRU(c.code, c.summary, batch_first=True)
        self.to_summary = nn.Linear(c.summary, c.summary)
        self.decoder = nn.GRU(c.summary, c.summary, batch_first=True)
        self.to_code = nn.Linear(c.summary, c.code)

    def encode(self, codes: torch.Tensor) -> torch.Tensor:
        _, last = self.encoder(codes)
        return self.to_summary(last[-1])

    def decode(self, summary: torch.Tensor) -> torch.Tensor:
        states, _ = self.decoder(summary[:, None].expand(-1, self.horizon, -1).contiguous(),
                                 summary[None].contiguous())
        return self.to_code(states)


# ----------------------------------------------------------------------------------------
# §5.3-5.5 Dynamics model
# ----------------------------------------------------------------------------------------

class DynamicsModel(nn.Module):
    """The generative networks of §5.3, the inference networks of §5.4 and the TD networks
    of §5.5, over standardised frame codes ``x`` and future summaries ``s``."""

    def __init__(self, config: DFNConfig):
        super().__init__()
        c = config
        contacts = N_CONTACTS if c.contact_head else 0            # not in the paper: see DFNConfig.contact_head
        # §5.3 generative model
        self.past = nn.ModuleList([nn.GRUCell(c.current + c.future + contacts, c.past),          # eq. 8: 2 layers
                                   nn.GRUCell(c.past, c.past)])
        self.future_prior = GaussianHead([c.past] + [c.future_prior_hidden] * 2 + [c.future])            # eq. 5
        self.summary_decoder = mlp([c.future, c.summary_decoder_hidden, c.summary])                      # eq. 6
        self.current_prior = GaussianHead([c.past + c.summary + contacts] + [c.current_prior_hidden] * 3
                                          + [c.current])                                                # eq. 7
        self.current_feature = mlp([c.current] + [c.current_prior_hidden] * 3 + [c.code])   # x = MLP(z)
        # §5.4 inference
        self.current_posterior = GaussianHead([c.code + c.past + c.summary] + [c.current_posterior_hidden] * 2
                                              + [c.current])                                            # eq. 10
        self.future_posterior = GaussianHead([c.past + c.summary] + [c.future_posterior_hidden] * 2
                                             + [c.future])                                              # eq. 11
        # §5.5 temporal difference
        self.td_posterior = GaussianHead([c.current + 2 * c.past + 1] + [c.td_hidden] * 2 + [c.current])  # eq. 13
        self.skip = mlp([c.current + 1] + [c.td_hidden] * 3 + [c.current])                              # eq. 14

    def initial_state(self, batch: int, size: int, device) -> list[torch.Tensor]:
        """``h_0``: zeros for both GRU layers."""
        return [torch.zeros(batch, size, device=device) for _ in self.past]

    def step_past(self, state: list[torch.Tensor], z: torch.Tensor, f: torch.Tensor,
                  c: torch.Tensor | None = None) -> list[torch.Tensor]:
        """Eq. 8: ``h_{t+1} = GRU(h_t, [z_t, f_t])``, two stacked layers (with a contact head,
        ``[z_t, f_t, c_t]``, the contacts as ``±1``).

        *Choice*: the GRU reads the current and the future state ("given the current and
        future state, the past state is updated"), not the frame itself: generation never
        feeds decoded frames back, so it cannot drift out of the frame autoencoder's range.
        """
        first = self.past[0](torch.cat([z, f] if c is None else [z, f, 2 * c - 1], -1), state[0])
        return [first, self.past[1](first, state[1])]


# ----------------------------------------------------------------------------------------
# The model
# ----------------------------------------------------------------------------------------

class DFN(DataContacts, StagedTraining, GenerativeModel, nn.Module):
    """Chen et al.'s Dynamic Future Net: staged training, stochastic generation from a prefix.

    Training: ``set_stage(name)`` then ``loss(batch)`` on windows ``(batch, frames, 66)``
    (:func:`motionlab.training.train_stages`); generation: :meth:`generate` from a prefix
    ``(batch, k, 66)``, any length. Those (:class:`~.dfn_parts.StagedTraining`) wrap the paper's.
    """

    stages = STAGES                                             # trained in this order (§5.6)
    continues_motion = True

    def __init__(self, config: DFNConfig = DFNConfig()):
        super().__init__()
        self.config = config
        self.frame = FrameAutoencoder(config)                   # §5.1
        self.sequence = SequenceAutoencoder(config)             # §5.2
        self.dynamics = DynamicsModel(config)                   # §5.3-5.5
        # Not in the paper: p(c_t | c_<t, h_t, f_t), per frame (width 1), trained with the dynamics
        self.contact_head = (ContactHead(config.past + config.future, width=1) if config.contact_head else None)
        # Choice: the dynamics model works on standardised frame codes and summaries, so
        # that its Gaussian likelihoods and KL terms do not depend on the arbitrary scale
        # the autoencoders happened to learn. Fitted when a stage is frozen (set_stage).
        self.register_buffer("code_mean", torch.zeros(config.code))
        self.register_buffer("code_std", torch.ones(config.code))
        self.register_buffer("summary_mean", torch.zeros(config.summary))
        self.register_buffer("summary_std", torch.ones(config.summary))
        self.stage = "frame"

    # -- the embeddings ------------------------------------------------------------------

    def codes(self, frames: torch.Tensor) -> torch.Tensor:
        """§5.1 encoder, standardised: ``(batch, frames, 66)`` -> ``x`` ``(batch, frames, code)``."""
        return (self.frame.encode(frames) - self.code_mean) / self.code_std

    def frames_from_codes(self, codes: torch.Tensor) -> torch.Tensor:
        """§5.1 decoders: standardised ``x`` ``(..., code)`` -> frames ``(..., 66)``."""
        return self.frame.decode(codes * self.code_std + self.code_mean)

    def summaries(self, codes: torch.Tensor) -> torch.Tensor:
        """§5.2 encoder over every window of ``horizon`` codes: ``x`` ``(batch, frames, code)``
        -> ``s`` ``(batch, frames - horizon + 1, summary)``, standardised; ``s_t`` summarises
        ``x_t .. x_{t+H-1}``.

        *Choice*: the summary of frame ``t`` includes frame ``t`` itself (the paper's index
        range was lost); the future posterior ``q(f_t | h_t, s_t)`` thus sees the frame
        being generated and the ``H - 1`` after it.
        """
        batch, frames, size = codes.shape
        H = self.config.horizon
        windows = codes.unfold(1, H, 1).permute(0, 1, 3, 2)          # (batch, steps, H, code)
        steps = windows.shape[1]
        s = self.sequence.encode(windows.reshape(batch * steps, H, size)).reshape(batch, steps, -1)
        return (s - self.summary_mean) / self.summary_std

    # -- the losses, one per stage -------------------------------------------------------

    def frame_loss(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        """Eq. 2: mean squared error of every frame's reconstruction through the frame
        autoencoder (normalised units); ``pose_mse`` and ``velocity_mse`` logged apart.

        With ``contact_weight > 0``, here and in :meth:`sequence_loss` (the two stages that
        decode frames; the dynamics model's loss is on codes, and it generates through the
        frame decoder these stages train), the foot-contact velocity term of HuMoR (Rempe et
        al. 2021), EDGE (Tseng et al. 2023) and MDM (Tevet et al. 2023) is added, times
        ``contact_weight``: where the data's feet are planted, their squared world velocity
        in the decoded frames, (m/s)², pose and decoded velocity together as DFN generates
        them (:meth:`contact_term`, in the data's units through ``model.normalizer``).
        Logged as ``contact``."""
        recon = self.frame.decode(self.frame.encode(batch))
        n = self.config.n_pose
        loss = F.mse_loss(recon, batch)
        return self._with_contact(recon, batch, {
            "loss": loss, "pose_mse": F.mse_loss(recon[..., :n], batch[..., :n]).detach(),
            "velocity_mse": F.mse_loss(recon[..., n:], batch[..., n:]).detach()})

    def sequence_loss(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        """Eq. 3 on ``horizon``-frame pieces of the windows: the frames decoded (through
        the frozen frame decoder) from the unrolled summary against the true frames, plus
        ``velocity_weight`` times the same for their frame-to-frame differences (joint
        velocities). Normalised units. With ``contact_weight > 0``, plus the contact term on
        the decoded pieces (see :meth:`frame_loss`)."""
        H = self.config.horizon
        # Choice: pieces start every H // 2 frames from a random offset, not at every frame:
        # neighbouring pieces overlap almost entirely, and this is several times faster.
        stride = max(1, H // 2)
        offset = int(torch.randint(0, stride, ())) if batch.shape[1] - H >= stride else 0
        batch = batch[:, offset:]
        with torch.no_grad():
            codes = self.codes(batch)
        pieces = codes.unfold(1, H, stride).permute(0, 1, 3, 2).reshape(-1, H, self.config.code)
        targets = batch.unfold(1, H, stride).permute(0, 1, 3, 2).reshape(-1, H, self.config.n_features)
        recon = self.frames_from_codes(self.sequence.decode(self.sequence.encode(pieces)))
        frame_mse = F.mse_loss(recon, targets)
        velocity_mse = F.mse_loss(recon.diff(dim=1), targets.diff(dim=1))
        return self._with_contact(recon, targets, {"loss": frame_mse + self.config.velocity_weight * velocity_mse,
                                                   "frame_mse": frame_mse.detach(),
                                                   "velocity_mse": velocity_mse.detach()})

    def infer(self, batch: torch.Tensor, generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        """The inference pass of §5.4 over windows ``(batch, frames, 66)``.

        For each of the ``steps = frames - horizon + 1`` frames with a full future summary:
        posterior and prior parameters of ``f`` and ``z``, their samples, the unrolled
        summary ``s^``, the current feature ``x^`` and the past states ``h``; all
        ``(batch, steps, size)``, plus the targets ``x`` and ``s``.
        """
        self._check(batch, "batch", min_frames=self.config.horizon)
        d, c = self.dynamics, self.config
        with torch.no_grad():                                     # frozen embeddings (§5.6)
            codes = self.codes(batch)
            s = self.summaries(codes)
        steps = s.shape[1]
        x = codes[:, :steps]
        labels = None if self.contact_head is None else self.data_contacts(batch)[:, :steps]   # contact head
        state = d.initial_state(batch.shape[0], c.past, batch.device)
        names = ("h", "qf_mu", "qf_log_var", "f", "qz_mu", "qz_log_var", "z")
        out: dict[str, list[torch.Tensor]] = {k: [] for k in names}
        # The recurrence runs through the posteriors and the GRU only; what the priors and
        # decoders make of h, f and z is computed for every step at once after the loop.
        for t in range(steps):
            h = state[-1]
            c_t = None if labels is None else labels[:, t]
            qf = d.future_posterior(h, s[:, t])                              # eq. 11
            f = gaussian.sample(*qf, generator=generator)
            qz = d.current_posterior(x[:, t], h, s[:, t])                    # eq. 10
            z = gaussian.sample(*qz, generator=generator)
            for key, value in zip(names, (h, *qf, f, *qz, z)):
                out[key].append(value)
            if self.training and c.prior_feed > 0:                           # see DFNConfig.prior_feed
                with torch.no_grad():
                    pf = gaussian.sample(*d.future_prior(h), generator=generator)                      # eq. 5
                    pz = gaussian.sample(*d.current_prior(h, d.summary_decoder(pf), *self._as_input(c_t)),
                                         generator=generator)                                  # eqs. 6-7
                feed = torch.rand(h.shape[0], 1, generator=generator, device=h.device) < c.prior_feed
                f, z = torch.where(feed, pf, f), torch.where(feed, pz, z)
            state = d.step_past(state, z, f, c_t)                            # eq. 8
        result = {k: torch.stack(v, 1) for k, v in out.items()}
        result["pf_mu"], result["pf_log_var"] = d.future_prior(result["h"])           # eq. 5
        result["s_hat"] = d.summary_decoder(result["f"])                               # eq. 6
        # Choice: the current prior is conditioned on the summary unrolled from the
        # posterior's f (as at generation, where it comes from the prior's f), not on
        # the true s, so that p(z | h, s^) is trained on the input it will get.
        result["pz_mu"], result["pz_log_var"] = d.current_prior(result["h"], result["s_hat"],
                                                                *self._as_input(labels))       # eq. 7
        result["x_hat"] = d.current_feature(result["z"])
        result.update(x=x, s=s)
        if labels is not None:
            result["contacts"] = labels
        return result

    def td_terms(self, out: dict[str, torch.Tensor], skip: int,
                 generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        """§5.5 for every pair ``(t1, t2 = t1 + skip)``: the TD posterior
        ``q(z_t1 | z_t2, h_t1, h_t2, skip)`` (eq. 13), its KL to the belief at ``t1``,
        ``q(z_t1 | x_t1, h_t1, s_t1)``, and the skip prediction of ``z_t2`` from a sample of
        it (eq. 14), as ``-log N(z_t2 | skip MLP, I)``. Each ``(batch, steps - skip)``.

        *Choice* (the equations were lost): TD-VAE's form (Gregor et al. 2019) with the
        belief at ``t1`` played by the current-state posterior; the skip enters both
        networks as ``skip / td_max_skip``.
        """
        d = self.dynamics
        steps = out["z"].shape[1]
        if not 1 <= skip < steps:
            raise ValueError(f"skip: expected 1 <= skip < {steps} steps, got {skip}")
        z2 = out["z"][:, skip:]
        h1, h2 = out["h"][:, :-skip], out["h"][:, skip:]
        dt = torch.full_like(z2[..., :1], skip / self.config.td_max_skip)
        mu, log_var = d.td_posterior(z2, h1, h2, dt)                              # eq. 13
        kl = gaussian.kl_divergence(mu, log_var, out["qz_mu"][:, :-skip], out["qz_log_var"][:, :-skip]).sum(-1)
        prediction = d.skip(torch.cat([gaussian.sample(mu, log_var, generator=generator), dt], -1))   # eq. 14
        return {"td_mu": mu, "td_log_var": log_var, "td_kl": kl,
                "td_nll": gaussian.negative_log_likelihood(z2, prediction, std=1.0).sum(-1)}

    def dynamics_loss(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        """Eq. 15 per step, averaged over steps and windows (nats):

        ``-log N(x_t | x^_t, std^2) - log N(s_t | s^_t, std^2)``
        ``+ KL(q(z_t | x_t, h_t, s_t) || p(z_t | h_t, s^_t)) + KL(q(f_t | h_t, s_t) || p(f_t | h_t))``
        ``+ td_weight * (KL(q_TD(z_t1 | ...) || q(z_t1 | ...)) - log p(z_t2 | z_t1, skip))``
        ``- log p(c_t | c_<t, h_t, f_t)`` with a contact head (the data's own contacts, which
        the current prior is then given too; logged as ``contacts``)

        The skip is drawn uniformly from ``1 .. td_max_skip`` per batch. Logged apart:
        ``x_nll``, ``s_nll``, ``kl_z``, ``kl_f``, ``td`` (nats per step), ``x_mse`` (standardised
        units).
        """
        out = self.infer(batch)
        std = self.config.observation_std
        x_nll = gaussian.negative_log_likelihood(out["x"], out["x_hat"], std=std).sum(-1).mean()
        s_nll = gaussian.negative_log_likelihood(out["s"], out["s_hat"], std=std).sum(-1).mean()
        kl_z = gaussian.kl_divergence(out["qz_mu"], out["qz_log_var"], out["pz_mu"], out["pz_log_var"]).sum(-1).mean()
        kl_f = gaussian.kl_divergence(out["qf_mu"], out["qf_log_var"], out["pf_mu"], out["pf_log_var"]).sum(-1).mean()
        total = x_nll + s_nll + kl_z + kl_f
        terms = {"x_nll": x_nll.detach(), "s_nll": s_nll.detach(), "kl_z": kl_z.detach(),
                 "kl_f": kl_f.detach(), "x_mse": F.mse_loss(out["x_hat"], out["x"]).detach()}
        steps = out["z"].shape[1]
        if self.config.td_weight > 0 and steps > 1:
            skip = int(torch.randint(1, min(self.config.td_max_skip, steps - 1) + 1, ()))
            td = self.td_terms(out, skip)
            td_loss = (td["td_kl"] + td["td_nll"]).mean()
            total = total + self.config.td_weight * td_loss
            terms["td"] = td_loss.detach()
        if self.contact_head is not None:
            contact_nll = -self.contact_head.log_prob(out["contacts"], torch.cat([out["h"], out["f"]], -1)).mean() / steps
            total = total + contact_nll
            terms["contacts"] = contact_nll.detach()
        return {"loss": total, **terms}

    @staticmethod
    def _as_input(labels: torch.Tensor | None) -> tuple[torch.Tensor, ...]:
        """Contacts (0/1) as an extra input of the current prior, ``±1``: none without a head."""
        return () if labels is None else (2 * labels - 1,)

    @torch.no_grad()
    def sample(self, prefix: torch.Tensor, frames: int, temperature: float = 1.0,
               generator: torch.Generator | None = None, latents: bool = False):
        """Open-loop generation from a motion prefix (§6.1): stochastic, any length.

        Args:
            prefix: ``(batch, k, 66)`` normalised frames (the paper: 8 to 20). Repeat one
                prefix along ``batch`` for several samples of one start.
            frames: total frames to return, ``>= k``: the prefix (as given) then
                ``frames - k`` generated ones.
            temperature: scales the standard deviation of both priors (1 = the model;
                0 = the mean path, deterministic).
            generator: a ``torch.Generator`` for reproducible samples; latents: also return the states.

        Returns ``(batch, frames, 66)`` normalised features; with ``latents=True`` a dict with ``"frames"``
        and ``"z"``, ``"f"``, ``"x"`` ``(batch, frames - k, size)`` (the current and future states and the
        standardised current feature of each generated frame), and with a contact head
        ``"contacts"`` ``(batch, frames - k, 4)``, the contacts drawn for the generated frames.

        The prefix drives the past state (*Choice*; the paper does not say how): read by the
        inference networks of §5.4 as training windows are, ``f_t``, ``z_t`` the means of
        ``q(f_t | h_t, s_t)``, ``q(z_t | x_t, h_t, s_t)`` while ``s_t`` lies within the prefix;
        for its last ``H - 1`` frames ``f_t`` is the prior's mean and ``s^_t = MLP(f_t)`` stands
        in for ``s_t``. (Holding the prefix's last frame as their future told the model the
        motion stops: from a steady walk or run its samples stepped 0.4-0.5 times as fast as
        the data in the first second, now 0.96-0.99, ``benchmarks/dfn_steps.py``.) Then, per
        new frame (§3, Fig. 5a): ``f_t ~ p(f | h_t)``, ``s^_t = MLP(f_t)``,
        ``z_t ~ p(z | h_t, s^_t)``, ``x^_t = MLP(z_t)``, ``h_{t+1} = GRU(h_t, [z_t, f_t])``.
        With a contact head, ``c_t ~ p(c_t | c_<t, h_t, f_t)`` after ``f_t``, and ``z_t`` and
        ``h_{t+1}`` are given it; over the prefix the head draws from the primed states too
        (*Choice*: so that sampling needs no normaliser), and those contacts are not returned.
        """
        self._check(prefix, "prefix")
        k = prefix.shape[1]
        if not isinstance(frames, int) or frames < k:
            raise ValueError(f"frames: expected an int >= the prefix's {k} frames, got {frames!r}")
        if not (isinstance(temperature, (int, float)) and math.isfinite(temperature) and temperature >= 0):
            raise ValueError(f"temperature: expected a finite number >= 0, got {temperature!r}")
        with eval_mode(self):
            return self._sample(prefix, frames, temperature, generator, latents)

    def _sample(self, prefix, frames, temperature, generator, latents):
        """:meth:`sample`'s work, with the model in evaluation mode."""
        d, c, k = self.dynamics, self.config, prefix.shape[1]
        given_on, prefix = prefix.device, prefix.to(self.code_mean.device)      # to the model's device
        state = d.initial_state(prefix.shape[0], c.past, prefix.device)
        carried = None if self.contact_head is None else self.contact_head.start(prefix.shape[0], prefix.device)
        # Priming (see sample): posteriors while s_t lies in the prefix, then the prior's f.
        codes = self.codes(prefix)
        summaries = self.summaries(codes) if k >= c.horizon else codes[:, :0]    # (n, k - H + 1, summary)
        for t, x in enumerate(codes.unbind(1)):
            h = state[-1]
            if t < summaries.shape[1]:
                s = summaries[:, t]
                f = d.future_posterior(h, s)[0]                                          # eq. 11
            else:
                f = d.future_prior(h)[0]                                                 # eq. 5
                s = d.summary_decoder(f)                                                 # eq. 6
            z = d.current_posterior(x, h, s)[0]                                          # eq. 10
            carried, labels = self._draw_contacts(h, f, carried, generator)
            state = d.step_past(state, z, f, labels)
        zs, fs, cs = [], [], []
        for _ in range(frames - k):
            h = state[-1]
            f = gaussian.sample(*d.future_prior(h), temperature, generator)             # eq. 5
            s_hat = d.summary_decoder(f)                                                  # eq. 6
            carried, labels = self._draw_contacts(h, f, carried, generator)
            z = gaussian.sample(*d.current_prior(h, s_hat, *self._as_input(labels)), temperature, generator)  # eq. 7
            zs.append(z), fs.append(f), cs.append(labels)
            state = d.step_past(state, z, f, labels)                             # eq. 8
        empty = prefix.new_zeros(prefix.shape[0], 0, 1)
        stack = lambda v, n: torch.stack(v, 1) if v else empty.expand(-1, -1, n)  # noqa: E731
        x = d.current_feature(stack(zs, c.current))                  # x = MLP(z), every frame at once
        motion = torch.cat([prefix, self.frames_from_codes(x)], 1)
        if latents:
            out = {"frames": motion.to(given_on), "z": stack(zs, c.current).to(given_on),
                   "f": stack(fs, c.future).to(given_on), "x": x.to(given_on)}
            if self.contact_head is not None:
                out["contacts"] = stack(cs, N_CONTACTS).to(given_on)
            return out
        return motion.to(given_on)

    def _draw_contacts(self, h, f, carried, generator):
        """With a contact head, the head's carried state and one frame's contacts ``(n, 4)``
        drawn from ``p(c_t | c_<t, h_t, f_t)``; without one, ``(None, None)``."""
        if self.contact_head is None:
            return None, None
        context = self.contact_head.context_of(torch.cat([h, f], -1)[:, None])[:, 0]
        labels, carried = self.contact_head.step(context, carried, generator)
        return carried, labels


# ------------------------------------------------------------------------ training

CARD = ModelCard("dfn", DFN, DFNConfig, stages=STAGES, augment=("mirror",), schedule={
    "stages": paper("frame, then sequence, then dynamics with both frozen", "Chen 2020 §5.1 and §5.6"),
    "optimizer": choice("Adam", "Chen 2020 names no optimiser, learning rate, batch size or epochs"),
    "stage_epochs": choice({"frame": 100, "sequence": 100, "dynamics": 200},
                           "not in the paper: notebook 07's PAPER setting"),
    "lr": choice(3e-3, "not in the paper: notebook 07's"),
    "batch_size": choice(64, "not in the paper: notebook 07's"),
    "schedule": choice("cosine", "not in the paper: notebook 07's, motionlab's default"),
    "grad_clip": choice(1.0, NO_CLIP),
})
"""DFN has no control, so time-reversed clips would teach it to walk backwards on its own
(notebook 07): its clips are only mirrored."""
