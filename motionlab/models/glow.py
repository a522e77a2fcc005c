"""Glow for fixed-length motion sequences (Henter et al. 2020, §3; Kingma & Dhariwal 2018).

A whole window of ``T`` frames is one point ``x ∈ R^{T x D}``, mapped to a Gaussian latent
``z`` of the same size by a normalising flow built from :mod:`motionlab.models.flows`:
``L`` levels of ``K`` steps (ActNorm -> invertible 1x1 -> affine coupling), with a split
and a squeeze over time between levels (§3.3.4). The coupling networks are convolutions
over ``t-1 .. t+1`` (eq. 8). The exact log-likelihood is eq. 9::

    ln p(x) = ln N(z_N(x); 0, I) + Σ_n Σ_d Σ_t (ln s_nd + ln |u_nd| + ln s'_tnd(x))

With ``conditional=True`` (§3.4, eq. 10) the model is ``p(pose | control)``: the 63 pose
values of each frame are the flow's data, and the 3 control values (forward, sideways and
turning velocity) are the coupling networks' conditioning input, squeezed with the data
but never split (§5.2). With ``conditional=False`` it models all 66 values: motion *and*
path, with no say over either.

Two pose values are zero by construction: the hips' ``x`` and ``z`` in the root frame,
whose origin is on the floor under the hips (:mod:`motionlab.representation`). A density
on a value that never varies is infinitely peaked, and a flow would chase it for ever
(its likelihood grows without bound as ActNorm scales the constant up); the model leaves
these ``constant_features`` out of the flow and puts the zeros back when sampling.

Units: the model works on the normalised features of :func:`motionlab.data.prepare`
(each feature divided by its standard deviation), and its ``loss`` is the negative
log-likelihood in nats per modelled value of those normalised features. :meth:`Glow.nll`
reports nats and bits per frame, in normalised units, or in the data's own units
(metres, m/s, rad/s) when given the normaliser: ``ln p_data(x) = ln p(x / σ) - Σ_d ln σ_d``
per frame (the normalisation's Jacobian).

**The control's range.** A conditional Glow records, while it trains, the range of each
control channel its coupling networks have seen (``control_range``); otherwise the control
they see is held within it (the output still follows the control given). Beyond that range
a convolutional coupling extrapolates, and the flow's inverse can overflow: on real CMU
windows, whose sideways and turning speeds reach twice the built-in data's, a Glow in bone
coordinates made samples that were not finite at every temperature without the limit, and
with it none at τ ≤ 0.5 (docs/feet.md, "Glow in bone coordinates"). A file saved before the
range was recorded loads without one (no limit).

**Feet anchored where they were planted** (``foot_anchor``, off by default; as
:class:`~motionlab.models.moglow.MoGlowConfig`'s). The flow models, for the ``x`` and ``z``
of each ankle and toe in every frame but the first, the value less where that joint would
be had it stayed put since the previous frame (:mod:`motionlab.models.anchor`). Here the
previous frame is part of the window the flow models, not conditioning: the map is
triangular over time with ones on its diagonal, so its log-determinant is 0 and the
likelihood stays exact; sampling inverts it frame by frame. With ``leg_anchor`` the toes and
knees are modelled relative to their ankles and hips too.

**A contact head** (``contact_head``, off by default; :mod:`motionlab.models.contact_head`).
The model becomes ``p(x, c | u) = p(c | u) p(x | c, u)``: a small autoregressive model of
the window's foot contacts ``c`` given the control, and the flow given both, its coupling
networks seeing the labels beside the control. Training labels come from the data
(:func:`motionlab.contacts.contact_labels`); sampling draws the contacts first, then the
pose. Both parts are exact, and at the data's own labels the joint likelihood bounds the
pose's from below (``p(x | u) ≥ p(x, c(x) | u)``).

**Bones as lengths and directions** (``bone_coordinates``, off by default, not in the paper;
:mod:`motionlab.models.bone_coordinates`, as MoGlow's). In every frame but the first, each
joint but the hips and ankles is modelled by its bone's change of log-length since the frame
before and its direction. As with the anchor, the frame before is in the window: the map
is block-triangular over time, its log-determinant the sum of the frames', and sampling
inverts it for the whole window at once (each bone's log-length a running sum over the
frames: :meth:`Glow.window_from_bones`). The first frame's bones are modelled against the data's mean
pose, each log-length in units of :data:`FIRST_FRAME_UNIT`, so that every frame's channels
hold lengths and directions (with the first frame's ``x, y, z`` in them instead, some
samples of held-out windows were not finite: docs/feet.md, "Glow in bone coordinates").
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial

import torch

from .. import checks
from .base import Generated, check_tensor, generator_for, per_frame_nll
from . import anchor
from .anchor import FootAnchor
from . import bone_coordinates
from .bone_coordinates import BoneCoordinates
from . import contact_head
from .contact_head import N_CONTACTS, ContactHead, DataContacts
from .flows import ConvCouplingNet, GaussianPrior, MotionFlow, MultiScaleFlow, henter_schedule
from .modelcard import ModelCard

FIRST_FRAME_UNIT = 0.05
"""The first frame's bones are modelled against the data's mean pose, each log-length in units
of 0.05 (bodies differ in their bones' lengths by several per cent)."""


@dataclass(frozen=True)
class GlowConfig:
    """Sizes and options. Defaults: a laptop-sized model (training on 4-second windows takes
    about a minute on 2 CPU cores); :meth:`paper` is §5.2's.

    Attributes:
        n_features: features per frame of the data (66: 63 pose + 3 control).
        n_control: the last ``n_control`` features are the control signal.
        window: frames per training window (a multiple of ``2^(levels - 1)``).
        fps: frames per second of the data the model expects.
        levels: ``L``, levels of the hierarchy (§3.3.4).
        steps: ``K``, steps of flow per level.
        hidden: channels of the coupling networks' two hidden layers.
        width: frames the coupling networks see (3: ``t-1 .. t+1``, eq. 8).
        conditional: model the pose given the control (eq. 10), else all features.
        constant_features: features that are 0 in every frame (after normalisation) and
            are left out of the flow: by default the hips' root-local ``x`` and ``z``.
        foot_anchor: model the feet's ``x`` and ``z`` less where they would be had they
            stayed planted since the previous frame (:mod:`motionlab.models.anchor`); needs
            ``conditional``, the locomotion features and the model's normaliser.
        leg_anchor: with ``foot_anchor``, each toe's ``x, z`` modelled less its ankle's and
            each knee less the midpoint of its hip and ankle, in the same frame, every frame
            but the first (:mod:`motionlab.models.anchor`).
        contact_head: model the feet's contacts beside the pose, ``p(c | u) p(x | c, u)``
            (:mod:`motionlab.models.contact_head`); needs ``conditional``, the locomotion
            features and, to train, the model's normaliser.
        bone_coordinates: model every joint but the hips and ankles (with ``foot_anchor``
            or ``leg_anchor``: the spine's, neck's, head's and arms') by its bone's change of
            length since the frame before and its direction (the first frame's: against the
            data's mean pose, :data:`FIRST_FRAME_UNIT`)
            (:mod:`motionlab.models.bone_coordinates`); needs ``conditional``, the locomotion
            features and the model's normaliser. Not in the paper.
    """

    n_features: int = 66
    n_control: int = 3
    window: int = 80
    fps: float = 20.0
    levels: int = 2
    steps: int = 8
    hidden: int = 64
    width: int = 3
    conditional: bool = True
    constant_features: tuple[int, ...] = (0, 2)
    foot_anchor: bool = False
    leg_anchor: bool = False
    contact_head: bool = False
    bone_coordinates: bool = False

    def __post_init__(self):
        checks.config(self)
        object.__setattr__(self, "constant_features", tuple(int(i) for i in self.constant_features))
        if self.levels < 1 or self.steps < 1 or self.hidden < 1:
            raise ValueError(f"levels, steps and hidden: need at least 1 each, got {self.levels}, "
                             f"{self.steps}, {self.hidden}")
        if self.window % 2 ** (self.levels - 1) or self.window < 1:
            raise ValueError(f"window: {self.window} frames is not a multiple of 2^(levels - 1) = "
                             f"{2 ** (self.levels - 1)} (each level but the last halves the frames)")
        if self.width < 1 or self.width % 2 == 0:
            raise ValueError(f"width: must be odd and positive, got {self.width}")
        if not 0 < self.n_control < self.n_features:
            raise ValueError(f"n_control: expected 1 .. {self.n_features - 1}, got {self.n_control}")
        described = self.n_features - (self.n_control if self.conditional else 0)
        bad = [i for i in self.constant_features if not 0 <= i < described]
        if bad:
            raise ValueError(f"constant_features: {bad} are not modelled features (0 .. {described - 1})")
        if described - len(set(self.constant_features)) < 2:
            raise ValueError("constant_features: fewer than 2 features would be left to model")
        if self.foot_anchor and not self.conditional:
            raise ValueError("foot_anchor: the shift is a function of the control; needs conditional=True")
        anchor.check_leg_config(self)
        anchor.check_config(self)
        contact_head.check_config(self)
        if self.bone_coordinates and not self.conditional:
            raise ValueError("bone_coordinates: models the pose given the control; needs conditional=True")
        bone_coordinates.check_config(self)

    @classmethod
    def paper(cls, **changes) -> "GlowConfig":
        """§5.2: ``L = 4`` levels of ``K = 32`` steps, coupling networks with two hidden
        layers of 512 channels, conditioned on the control; 4-s windows at 20 fps (§5.1)."""
        return replace(cls(levels=4, steps=32, hidden=512, window=80, fps=20.0, conditional=True), **changes)


class Glow(DataContacts, FootAnchor, BoneCoordinates, MotionFlow):
    """The fixed-length sequence Glow of §3.3-3.4.

    Batches are normalised feature windows ``(batch, frames, n_features)``, ``frames`` a
    multiple of ``2^(levels - 1)`` (the convolutions do not fix the length; ``window`` is
    what it is trained on). The flow sees ``x`` ``(batch, frames, n_modelled)``: the pose
    (conditional) or all features (unconditional), less the constant features; the latent
    ``z`` is ``(batch, frames * n_modelled)``.
    """

    optional_state = ("control_range",)     # checkpoints saved before it load without a limit

    def __init__(self, config: GlowConfig = GlowConfig()):
        super().__init__()
        self.config = config
        self._set_layout(config, config.n_features - (config.n_control if config.conditional else 0))
        self.follows_control = config.conditional
        cond_channels = (config.n_control + N_CONTACTS * config.contact_head) if config.conditional else 0
        self.flow = MultiScaleFlow(self.n_modelled, config.levels, config.steps,
                                   partial(ConvCouplingNet, hidden=config.hidden, width=config.width),
                                   cond_channels=cond_channels)
        self.prior = GaussianPrior()
        self._init_foot_anchor(config)
        self.contact_head = ContactHead(config.n_control, config.hidden) if config.contact_head else None
        self.nll_is = "bound, with contacts" if config.contact_head else "exact"
        if config.conditional:      # (low; high) per control channel, low > high until training sees one
            self.register_buffer("control_range", torch.tensor([[1.0], [-1.0]]).repeat(1, config.n_control))

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):
        if hasattr(self, "control_range") and prefix + "control_range" not in state_dict:
            state_dict[prefix + "control_range"] = self.control_range.clone()     # a file from before it: no limit
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)

    def seen_control(self, control: torch.Tensor | None, record: bool = False) -> torch.Tensor | None:
        """The control ``(batch, frames, n_control)`` as the coupling networks and the contact
        head see it: with ``record`` (training), it widens ``control_range`` and passes as it
        is; otherwise it is held within the range recorded (unchanged before any is)."""
        if control is None:
            return None
        low, high = self.control_range
        if record:
            with torch.no_grad():
                empty = low > high
                new_low = torch.where(empty, control.amin(dim=(0, 1)), torch.minimum(low, control.amin(dim=(0, 1))))
                new_high = torch.where(empty, control.amax(dim=(0, 1)), torch.maximum(high, control.amax(dim=(0, 1))))
                self.control_range.copy_(torch.stack([new_low, new_high]))
            return control
        if (low > high).any():
            return control
        return torch.maximum(torch.minimum(control, high), low)

    # -- data in and out -----------------------------------------------------------------

    def _check(self, batch: torch.Tensor) -> None:
        check_tensor(batch, "batch", self.config.n_features, multiple=2 ** (self.config.levels - 1), finite=False,
                     frames_text="frames")

    def split_features(self, batch: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
        """``(x, cond)``: the flow's data ``(batch, frames, n_modelled)`` and the control
        ``(batch, frames, n_control)`` (``None`` for an unconditional model)."""
        self._check(batch)
        if len(self.constant) and batch[..., self.constant].abs().max() > 1e-4:
            raise ValueError(f"batch: features {self.config.constant_features} should be 0 in every frame "
                             f"(constant_features), got values up to {batch[..., self.constant].abs().max():.3g}")
        x = batch[..., self.modelled]
        return x, (batch[..., self.control] if self.config.conditional else None)

    # -- likelihood (eq. 9) --------------------------------------------------------------

    def _encode(self, batch: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """``(z, logdet, ln p(c | u))``: the last is 0 without a contact head."""
        x, cond = self.split_features(batch)
        if self.config.foot_anchor:          # triangular, ones on the diagonal: log-determinant 0
            x = self.anchor_window(x, cond, -1.0)
        bones = x.new_zeros(x.shape[0])
        if self.config.bone_coordinates:     # block-triangular: the frames' log-determinants added
            x, bones = self.window_to_bones(x)
        cond = self.seen_control(cond, record=self.training)
        if self.contact_head is None:
            z, logdet = self.flow(x, cond)
            return z, logdet + bones, x.new_zeros(x.shape[0])
        labels = self.data_contacts(batch)
        z, logdet = self.flow(x, self.with_contacts(cond, labels))
        return z, logdet + bones, self.contact_head.log_prob(labels, cond)

    def window_to_bones(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(y, ln |det ∂y/∂x|)`` of windows ``x`` ``(batch, frames, n_modelled)``: every frame
        in bones (``bone_coordinates``), the first against the data's mean pose, the others given
        the frame before; in training each change of length between frames gets standard-normal
        noise (dequantisation, as MoGlow's)."""
        later, logdet = self.to_bones(x[:, 1:], x[:, :-1])
        if self.training:
            lengths = self._bone_units(x.device).columns[:, 0]
            later[..., lengths] = later[..., lengths] + torch.randn_like(later[..., lengths])
        first, first_logdet = self.to_bones(x[:, :1], torch.zeros_like(x[:, :1]), FIRST_FRAME_UNIT)
        return torch.cat([first, later], dim=1), logdet.sum(1) + first_logdet.sum(1)

    def window_from_bones(self, y: torch.Tensor) -> torch.Tensor:
        """:meth:`window_to_bones` inverted. Frame by frame, each bone's log-length is the one
        before it plus ``K ℓ_t``; so over the window it is the mean pose's plus a running sum,
        ``ln|o_t| = ln|m| + FIRST_FRAME_UNIT · ℓ_0 + K Σ_{s=1..t} ℓ_s``, and every frame's
        joints are placed at once."""
        units = self._bone_units(y.device)
        mean = self._joints(torch.zeros_like(y[:, :1]), units)                    # the data's mean pose
        mean_lengths = (mean[..., units.children, :] - mean[..., units.parents, :]).norm(dim=-1)
        ell = y[..., units.columns[:, 0]].float()                                 # (batch, frames, bones)
        steps = torch.cat([FIRST_FRAME_UNIT * ell[:, :1], bone_coordinates.LOG_LENGTH_UNIT * ell[:, 1:]], dim=1)
        return self.place_bones(y, torch.log(mean_lengths) + torch.cumsum(steps, dim=1))

    def encode(self, batch: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(z, logdet)``: the latent ``(batch, frames * n_modelled)`` and ``Σ ln|det J|`` ``(batch,)``
        (with a contact head: given the data's own contacts)."""
        return self._encode(batch)[:2]

    def log_likelihood(self, batch: torch.Tensor) -> torch.Tensor:
        """``ln p(x | c)`` (conditional) or ``ln p(x)`` of each window, nats, normalised
        units, ``(batch,)`` (eq. 9). With a contact head, ``ln p(x, c(x) | u)`` at the data's
        own contacts: a lower bound on ``ln p(x | u)``."""
        z, logdet, contact = self._encode(batch)
        return self.prior.log_prob(z) + logdet + contact

    def loss(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        """Negative log-likelihood in nats per modelled value (``"loss"``), and per frame in
        bits (``"bits_per_frame"``); with eq. 9's two parts, the prior term and the
        log-determinant, in nats per value. All in normalised units. With a contact head the
        loss is the joint one, and ``"contact_bits_per_frame"`` is the contacts' share."""
        z, logdet, contact = self._encode(batch)
        log_prior = self.prior.log_prob(z)
        frames = batch.shape[1]
        values = frames * self.n_modelled
        nll = -(log_prior + logdet + contact).mean()
        out = {"loss": nll / values, "bits_per_frame": nll / frames / math.log(2),
               "log_prior": log_prior.mean() / values, "logdet": logdet.mean() / values}
        if self.contact_head is not None:
            out["contact_bits_per_frame"] = -contact.mean() / frames / math.log(2)
        return out

    @torch.no_grad()
    def nll(self, windows: torch.Tensor, normalizer=None, batch_size: int = 64) -> dict[str, float]:
        """Mean negative log-likelihood of ``windows`` ``(n, frames, n_features)``, per frame.

        Returns ``"nats/frame"`` and ``"bits/frame"``: in normalised units, or, given the
        :class:`motionlab.data.Normalizer` of the data, in the data's units (metres, m/s,
        rad/s), adding ``Σ_d ln σ_d`` over the modelled features (the Jacobian of the
        normalisation) to every frame's NLL. With a contact head it is the joint NLL at the
        data's own contacts, an upper bound on the pose's (``nll_is``).
        """
        total = torch.cat([-self.log_likelihood(chunk) for chunk in torch.split(windows, batch_size)])
        return per_frame_nll(float(total.mean()) / windows.shape[1], normalizer, self.modelled)

    # -- sampling ------------------------------------------------------------------------

    @torch.no_grad()
    def decode(self, z: torch.Tensor, control: torch.Tensor | None = None, contacts: torch.Tensor | None = None,
               generator: torch.Generator | None = None) -> torch.Tensor:
        """Latents ``(n, frames * n_modelled)`` (and the control ``(n, frames, n_control)``)
        to normalised feature windows ``(n, frames, n_features)``. With a contact head, the
        pose is decoded given ``contacts`` ``(n, frames, 4)`` (0/1), drawn from the head
        (with ``generator``) when not given."""
        if z.ndim != 2 or z.shape[1] % self.n_modelled:
            raise ValueError(f"z: expected (n, frames * {self.n_modelled}), got {tuple(z.shape)}")
        frames = z.shape[1] // self.n_modelled
        control = self._check_control(control, z.shape[0], frames)
        return self.join_features(self._inverse(z, control, self._contacts(contacts, control, generator)), control)

    def _contacts(self, contacts, control, generator) -> torch.Tensor | None:
        """The contacts a contact head decodes with: given ``(n, frames, 4)`` 0/1, or drawn."""
        if self.contact_head is None:
            if contacts is not None:
                raise ValueError("contacts: this Glow has no contact head (contact_head=False)")
            return None
        if contacts is None:
            return self.contact_head.sample(self.seen_control(control), generator)
        contacts = torch.as_tensor(contacts, dtype=torch.float32, device=control.device)
        if contacts.shape != (*control.shape[:2], N_CONTACTS) or not ((contacts == 0) | (contacts == 1)).all():
            raise ValueError(f"contacts: expected 0/1 labels {(*control.shape[:2], N_CONTACTS)} (ankles and toes), "
                             f"got {tuple(contacts.shape)}")
        return contacts

    def _inverse(self, z: torch.Tensor, control: torch.Tensor | None, contacts: torch.Tensor | None = None) -> torch.Tensor:
        """The modelled values of latents ``z``: the flow inverted, the joints placed from
        their bones (``bone_coordinates``), then the anchoring."""
        x = self.flow.inverse(z, self.with_contacts(self.seen_control(control), contacts))
        if self.config.bone_coordinates:
            x = self.window_from_bones(x)
        return self.anchor_window(x, control, 1.0) if self.config.foot_anchor else x

    def _check_control(self, control, n: int, frames: int | None):
        c = self.config.n_control
        if not self.config.conditional:
            if control is not None:
                raise ValueError("control: this model is unconditional (conditional=False); it samples its own control")
            return None
        if control is None:
            raise ValueError(f"control: a conditional model needs the control, (n, frames, {c})")
        control = torch.as_tensor(control, dtype=torch.float32, device=self.modelled.device)
        if control.ndim != 3 or control.shape[0] != n or control.shape[2] != c \
                or (frames is not None and control.shape[1] != frames):
            want = f"({n}, {frames if frames is not None else 'frames'}, {c})"
            raise ValueError(f"control: expected {want} in normalised units, got {tuple(control.shape)}")
        return control

    @torch.no_grad()
    def sample(self, n: int, control: torch.Tensor | None = None, frames: int | None = None,
               temperature: float = 1.0, generator: torch.Generator | None = None,
               contacts: torch.Tensor | None = None) -> torch.Tensor:
        """Draw ``n`` windows ``(n, frames, n_features)`` in normalised units.

        Args:
            n: number of windows.
            control: the control to follow, normalised, ``(n, frames, n_control)``: required
                by a conditional model (it is copied into the output), refused by an
                unconditional one.
            frames: window length (a conditional model takes it from ``control``;
                default: ``config.window``).
            temperature: the prior's standard deviation (§3, after Kingma & Dhariwal):
                1 samples the model, 0 gives the image of the latent mode ``z = 0``.
            generator: a ``torch.Generator`` for reproducible samples.
            contacts: with a contact head, the contacts to draw the pose for, ``(n, frames,
                4)`` 0/1; by default the head draws them (always at its own temperature, 1:
                the temperature scales the flow's latent only).
        """
        if n < 1:
            raise ValueError(f"n: expected at least 1 sample, got {n}")
        if frames is None:
            given = control is not None and torch.as_tensor(control).ndim == 3
            frames = int(torch.as_tensor(control).shape[1]) if given else self.config.window
        control = self._check_control(control, n, frames)
        self.flow._check_frames("frames", frames)
        contacts = self._contacts(contacts, control, generator)
        z = self.prior.sample((n, frames * self.n_modelled), temperature, generator,
                              device=self.modelled.device)
        return self.join_features(self._inverse(z, control, contacts), control)

    def generate(self, control=None, *, frames=None, prefix=None, n=1, temperature=1.0, seed=0) -> Generated:
        """``n`` windows; see :mod:`motionlab.models.base`.

        A conditional Glow follows ``control`` (required; ``frames`` is its length). An
        unconditional one ignores ``control`` and draws ``frames`` frames (default
        ``config.window``). Either way ``frames`` must be a multiple of ``2^(levels - 1)``,
        and Glow draws whole windows: it does not continue a ``prefix``.
        """
        n, temperature = self._check_common(n, temperature, seed)
        self._refuse_prefix(prefix)
        if self.config.conditional:
            control = self._normalized_control(control, n, frames)
            frames = control.shape[1]
        else:
            control = None
            frames = self.config.window if frames is None else checks.whole(frames, "frames", 1)
        generator = generator_for(seed)
        if self.contact_head is None:
            return self._result(self.sample(n, control, frames, temperature, generator))
        contacts = self._contacts(None, torch.as_tensor(control, dtype=torch.float32, device=self.modelled.device),
                                  generator)                        # drawn first, as sample would draw them
        return self._result(self.sample(n, control, frames, temperature, generator, contacts=contacts), contacts)

    def describe(self, frames: int | None = None) -> list[str]:
        """One line per level of the hierarchy: frames, channels, conditioning, split."""
        frames = self.config.window if frames is None else frames
        lines = []
        for level, shape in enumerate(self.flow.level_shapes(frames)):
            line = (f"level {level + 1}: {self.config.steps} steps on {shape['frames']} frames x "
                    f"{shape['channels']} channels")
            if shape["cond_channels"]:
                line += f", conditioned on {shape['cond_channels']} control channels"
            line += f"; then {shape['split']} channels split off to z" if shape["split"] else "; all to z"
            lines.append(line)
        if self.config.foot_anchor:
            lines.append("before the flow: the feet's x, z less where they would be had they stayed planted "
                         "(foot_anchor: triangular over the window, log-determinant 0)")
        if self.config.leg_anchor:
            lines.append("and the toes less their ankles, the knees less the midpoint of hip and ankle (leg_anchor)")
        if self.config.bone_coordinates:
            lines.append(("the spine, neck, head and arms" if (self.config.foot_anchor or self.config.leg_anchor)
                          else "every joint but the hips and ankles") + " modelled by its bone's change of length "
                         "and its direction, the first frame's against the mean pose (bone_coordinates)")
        if self.config.contact_head:
            lines.append(f"beside the flow: p(contacts | control), {N_CONTACTS} labels per frame drawn frame by frame, "
                         f"which the coupling networks see beside the control (contact_head)")
        return lines


CARD = ModelCard("glow", Glow, GlowConfig, schedule=henter_schedule(20_000, "fixed-length"))
