"""Normalising-flow building blocks: Glow for sequences (Henter et al. 2020, §3).

A normalising flow turns motion ``x`` into a standard-normal latent ``z`` through a chain
of invertible maps ``f_n^{-1}`` (eqs. 1-4), and scores ``x`` exactly with the change of
variables (eq. 5)::

    ln p(x) = ln N(z(x); 0, I) + Σ_n ln |det ∂z_n / ∂z_{n-1}|

Every block here is an :class:`InvertibleModule` over sequences ``(batch, time, channels)``:

* ``forward(x, cond=None) -> (z, logdet)`` is the *inference* direction of the paper's
  Fig. 1 (data -> latent, ``f_n^{-1}``); ``logdet`` is ``ln |det ∂z/∂x|`` per example,
  shape ``(batch,)``, summed over time and channels;
* ``inverse(z, cond=None) -> x`` is the *generation* direction (``f_n``).

``cond`` is an optional conditioning sequence ``(batch, time, cond_channels)`` that only
the coupling networks see (eq. 10: the control signal; MoGlow eq. 18: control and pose
history). The blocks:

* :class:`ActNorm` (§3.3.1): a per-channel affine map, initialised from the first batch;
* :class:`InvertibleLinear` (§3.3.2): a learned ``D x D`` mixing of channels, in LU form;
* :class:`AffineCoupling` (§3.3.3, eqs. 6-8, 10): half the channels shifted and scaled
  by a network of the other half (and of ``cond``);
* :class:`FlowStep` (Fig. 1): ActNorm -> InvertibleLinear -> AffineCoupling;
* :class:`FlowSequence` (eqs. 2-5): blocks in a chain, log-determinants added up;
* :func:`squeeze` / :func:`unsqueeze` (§3.3.4): half the frames, twice the channels;
* :class:`MultiScaleFlow` (§3.3.4): ``L`` levels of ``K`` steps, split and squeeze between;
* :class:`GaussianPrior` (eq. 1): ``N(0, I)``, sampled with a temperature.

The coupling network is pluggable: :class:`AffineCoupling` takes a *factory*
``make_network(in_channels, cond_channels, out_channels) -> nn.Module``, and calls the
network as ``network(lo, cond)`` with ``lo`` ``(batch, time, in_channels)`` and ``cond``
``(batch, time, cond_channels)`` or ``None``; it must return ``(batch, time,
out_channels)`` and have a zero-initialised output layer (run through :func:`output_layer`, so
that it computes in float32 under mixed precision). :class:`ConvCouplingNet`
(Glow for fixed-length sequences, eqs. 8 and 10) and :class:`MLPCouplingNet` (one frame
at a time) are provided; MoGlow (§4.2) plugs in a recurrent one. The network is called
exactly once per ``forward`` and once per ``inverse``, so a recurrent network may carry
its state from one call to the next (MoGlow generates one frame per call).

Glow for fixed-length windows (:mod:`motionlab.models.glow`) is a :class:`MultiScaleFlow`
of :class:`ConvCouplingNet` couplings. A per-frame flow as in MoGlow (``L = 1``, no
squeeze, couplings conditioned on an external sequence) is a plain chain of steps::

    flow = FlowSequence([FlowStep(channels, make_network, cond_channels) for _ in range(K)])
    z, logdet = flow(x, cond)                   # (batch, frames, channels), (batch,)
    log_likelihood = GaussianPrior().log_prob(z) + logdet
    x = flow.inverse(GaussianPrior().sample(z.shape, temperature=0.7), cond)
"""
from __future__ import annotations

import abc

import math
from typing import Callable, Iterable

import torch
import torch.nn.functional as F
from torch import nn

from .base import GenerativeModel
from .modelcard import NO_CLIP, choice, paper

NetworkFactory = Callable[[int, int, int], nn.Module]
"""``make_network(in_channels, cond_channels, out_channels) -> nn.Module``."""


def _check_sequence(name: str, x: torch.Tensor, channels: int) -> None:
    if not isinstance(x, torch.Tensor) or x.ndim != 3 or x.shape[-1] != channels:
        shape = tuple(x.shape) if isinstance(x, torch.Tensor) else type(x).__name__
        raise ValueError(f"{name}: expected (batch, time, {channels}), got {shape}")


def _check_cond(cond: torch.Tensor | None, cond_channels: int, x: torch.Tensor) -> None:
    if cond_channels == 0:
        if cond is not None:
            raise ValueError("cond: this block has no conditioning input (cond_channels=0), got a tensor")
        return
    if cond is None:
        raise ValueError(f"cond: this block is conditioned; expected (batch, time, {cond_channels}), got None")
    _check_sequence("cond", cond, cond_channels)
    if cond.shape[:2] != x.shape[:2]:
        raise ValueError(f"cond: expected batch and time {tuple(x.shape[:2])} like the input, "
                         f"got {tuple(cond.shape)}")


class InvertibleModule(nn.Module, abc.ABC):
    """A bijection on ``(batch, time, channels)`` sequences with a tractable log-determinant.

    Subclasses implement ``forward(x, cond=None) -> (z, logdet)`` (data -> latent, with
    ``logdet = ln |det ∂z/∂x|`` of shape ``(batch,)``) and ``inverse(z, cond=None) -> x``.
    """

    @abc.abstractmethod
    def forward(self, x: torch.Tensor, cond: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """Data -> latent: ``(z, logdet)``."""

    @abc.abstractmethod
    def inverse(self, z: torch.Tensor, cond: torch.Tensor | None = None) -> torch.Tensor:
        """Latent -> data."""


# ----------------------------------------------------------------------------------------
# §3.3.1 Actnorm
# ----------------------------------------------------------------------------------------

class ActNorm(InvertibleModule):
    """``a = s ⊙ x + t`` per channel, with ``s = exp(log_scale) > 0`` (§3.3.1).

    Data-dependent initialisation: the first batch that passes through ``forward`` sets
    ``s = 1 / std`` and ``t = -mean / std`` (statistics over batch and time), so that
    batch comes out with zero mean and unit variance, as batchnorm would give; from then on
    ``s`` and ``t`` are ordinary trainable parameters. Until then the block is the
    identity. The ``initialized`` flag is saved with the weights, so a loaded model is not
    initialised again.

    ``logdet = T · Σ_d ln s_d`` (the ``ln s_nd`` terms of eq. 9).

    Args:
        channels: ``D``, channels per frame.
        eps: added to the standard deviation at initialisation, so a channel that is
            constant in the first batch gets a large but finite scale.
    """

    def __init__(self, channels: int, eps: float = 1e-6):
        super().__init__()
        self.channels, self.eps = channels, eps
        self.log_scale = nn.Parameter(torch.zeros(channels))
        self.bias = nn.Parameter(torch.zeros(channels))
        self.register_buffer("initialized", torch.tensor(False))

    @torch.no_grad()
    def initialize(self, x: torch.Tensor) -> None:
        """Set ``s`` and ``t`` so that ``x`` ``(batch, time, channels)`` is standardised."""
        _check_sequence("x", x, self.channels)
        mean = x.mean(dim=(0, 1))
        std = x.std(dim=(0, 1), unbiased=False) + self.eps
        self.log_scale.copy_(-torch.log(std))
        self.bias.copy_(-mean / std)
        self.initialized.fill_(True)

    def forward(self, x, cond=None):
        _check_sequence("x", x, self.channels)
        if not self.initialized:
            self.initialize(x)
        z = x * self.log_scale.exp() + self.bias
        logdet = (x.shape[1] * self.log_scale.sum()).expand(x.shape[0])
        return z, logdet

    def inverse(self, z, cond=None):
        _check_sequence("z", z, self.channels)
        return (z - self.bias) * torch.exp(-self.log_scale)


# ----------------------------------------------------------------------------------------
# §3.3.2 Linear transformation: an invertible 1x1 convolution in LU form
# ----------------------------------------------------------------------------------------

class InvertibleLinear(InvertibleModule):
    """``b_t = W a_t`` for every frame: a convolution of width one (§3.3.2).

    ``W = P L U`` is stored in LU form: ``P`` a fixed permutation (the pivoting an LU
    decomposition needs), ``L`` lower triangular with ones on the diagonal, ``U`` upper
    triangular with diagonal ``u_dd = sign_d · exp(log_diag_d)``. Then
    ``ln |det W| = Σ_d ln |u_dd|`` in linear time (the ``ln u_nd`` terms of eq. 9), and
    ``logdet = T · Σ_d ln |u_dd|`` for a sequence of ``T`` frames. ``W`` starts as a random
    orthogonal matrix (drawn from torch's random generator): a learnable generalisation of
    a permutation that mixes the channels before each coupling.
    """

    def __init__(self, channels: int):
        super().__init__()
        self.channels = channels
        w = torch.linalg.qr(torch.randn(channels, channels, dtype=torch.float64))[0]   # orthogonal
        p, lower, upper = torch.linalg.lu(w)
        diagonal = torch.diagonal(upper)
        self.register_buffer("permutation", p.float())
        self.register_buffer("sign_diag", torch.sign(diagonal).float())
        self.register_buffer("lower_mask", torch.tril(torch.ones(channels, channels), -1))
        self.lower = nn.Parameter(lower.float())
        self.upper = nn.Parameter(torch.triu(upper, 1).float())
        self.log_diag = nn.Parameter(torch.log(diagonal.abs()).float())

    def factors(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """``(P, L, U)`` with ``W = P @ L @ U``."""
        eye = torch.eye(self.channels, dtype=self.lower.dtype, device=self.lower.device)
        lower = self.lower * self.lower_mask + eye
        upper = self.upper * self.lower_mask.T + torch.diag(self.sign_diag * self.log_diag.exp())
        return self.permutation, lower, upper

    def weight(self) -> torch.Tensor:
        """``W`` ``(channels, channels)``."""
        p, lower, upper = self.factors()
        return p @ lower @ upper

    def forward(self, x, cond=None):
        _check_sequence("x", x, self.channels)
        with full_precision(x):
            z = x @ self.weight().to(x.dtype).T
        logdet = (x.shape[1] * self.log_diag.sum()).expand(x.shape[0])
        return z, logdet

    def inverse(self, z, cond=None):
        """``a_t = W^-1 b_t`` by two triangular solves, ``W^-1 = U^-1 L^-1 P^T``. They run in
        float64: in float32 they are the least precise step of a whole flow's inverse."""
        _check_sequence("z", z, self.channels)
        p, lower, upper = (factor.double() for factor in self.factors())
        columns = p.T @ z.reshape(-1, self.channels).T.double()
        columns = torch.linalg.solve_triangular(lower, columns, upper=False, unitriangular=True)
        columns = torch.linalg.solve_triangular(upper, columns, upper=True)
        return columns.T.reshape(z.shape).to(z.dtype)


def full_precision(x: torch.Tensor):
    """A block where autocast (mixed-precision training, ``TrainConfig.precision``) is off:
    the flow's own arithmetic (the 1x1 mixing, the affine transform, every log-determinant
    and the prior) stays float32; only the coupling networks' hidden layers run in low
    precision (see :func:`output_layer`)."""
    return torch.autocast(x.device.type, enabled=False)


def output_layer(layer: nn.Module, hidden: torch.Tensor, like: torch.Tensor) -> torch.Tensor:
    """``layer(hidden)`` in ``like``'s dtype, with autocast off: a coupling network's output
    layer gives the shift ``t'`` and the raw scale ``h_s'``, and the coupling's
    log-determinant is ``Σ ln s' = Σ [ln σ(h_s' + 2) - ln σ(2)]`` (eq. 9), so under mixed
    precision this layer computes in float32 (a small product: ``2 x n_hi`` outputs) on the
    hidden layers' low-precision activations."""
    with full_precision(like):
        return layer(hidden.to(like.dtype))


# ----------------------------------------------------------------------------------------
# §3.3.3 Affine coupling, with pluggable networks A_n
# ----------------------------------------------------------------------------------------

class ConvCouplingNet(nn.Module):
    """``A_n`` of a fixed-length sequence Glow (eq. 8; with control, eq. 10).

    A convolution over ``width`` frames (3: frames ``t-1 .. t+1``) of the lower half and
    the conditioning, ReLU, a hidden width-one convolution, ReLU, and a zero-initialised
    width-one output convolution (§3.3.3: every coupling starts as the identity). The
    receptive field is exactly ``width`` frames, as in eq. 8. The window's ends are padded
    by repeating the first and last frames.

    Args:
        in_channels: channels of ``lo``.
        cond_channels: channels of ``cond`` (0: unconditioned).
        out_channels: ``2 x`` the channels of ``hi`` (a shift and a scale for each).
        hidden: channels of the two hidden layers (the paper: 512).
        width: frames seen by the first convolution (odd).
    """

    def __init__(self, in_channels: int, cond_channels: int, out_channels: int,
                 hidden: int = 512, width: int = 3):
        super().__init__()
        if width < 1 or width % 2 == 0:
            raise ValueError(f"width: must be odd and positive so the output keeps its length, got {width}")
        self.cond_channels = cond_channels
        self.layers = nn.Sequential(
            nn.Conv1d(in_channels + cond_channels, hidden, width, padding=width // 2, padding_mode="replicate"),
            nn.ReLU(),
            nn.Conv1d(hidden, hidden, 1),
            nn.ReLU(),
            nn.Conv1d(hidden, out_channels, 1))
        nn.init.zeros_(self.layers[-1].weight)
        nn.init.zeros_(self.layers[-1].bias)

    def forward(self, lo: torch.Tensor, cond: torch.Tensor | None = None) -> torch.Tensor:
        """``lo`` ``(batch, time, in)``, ``cond`` ``(batch, time, cond)`` -> ``(batch, time, out)``."""
        inputs = lo if cond is None else torch.cat([lo, cond], dim=-1)
        hidden = inputs.transpose(1, 2)
        *hidden_layers, last = self.layers
        for layer in hidden_layers:
            hidden = layer(hidden)
        return output_layer(last, hidden, lo).transpose(1, 2)


class MLPCouplingNet(nn.Module):
    """``A_n`` that sees one frame at a time: two hidden layers with ReLU, zero-initialised
    output. For flows over single frames whose context comes in through ``cond`` (a
    Markovian MoGlow, §4.2, where ``cond`` holds the pose history and control)."""

    def __init__(self, in_channels: int, cond_channels: int, out_channels: int, hidden: int = 512):
        super().__init__()
        self.layers = nn.Sequential(
            nn.Linear(in_channels + cond_channels, hidden), nn.ReLU(),
            nn.Linear(hidden, hidden), nn.ReLU(),
            nn.Linear(hidden, out_channels))
        nn.init.zeros_(self.layers[-1].weight)
        nn.init.zeros_(self.layers[-1].bias)

    def forward(self, lo: torch.Tensor, cond: torch.Tensor | None = None) -> torch.Tensor:
        """``lo`` ``(batch, time, in)``, ``cond`` ``(batch, time, cond)`` -> ``(batch, time, out)``."""
        hidden = lo if cond is None else torch.cat([lo, cond], dim=-1)
        *hidden_layers, last = self.layers
        for layer in hidden_layers:
            hidden = layer(hidden)
        return output_layer(last, hidden, lo)


SCALE_SHIFT = 2.0
"""The scale is ``s' = σ(h + 2) / σ(2)`` (Glow's ``σ(h + 2)``, divided so that ``h = 0``
gives exactly ``s' = 1``): positive, at most ``1 / σ(2) ≈ 1.14``."""
_LOG_SIGMOID_SHIFT = -math.log1p(math.exp(-SCALE_SHIFT))          # ln σ(2)


class AffineCoupling(InvertibleModule):
    """Glow's affine coupling (§3.3.3, eqs. 6-7; with conditioning, eq. 10).

    The channels are split into ``b = [b_lo, b_hi]`` (``lo``: the first ``channels // 2``).
    ``b_lo`` passes through unchanged; ``b_hi`` is shifted and scaled by values that a
    network ``A`` computes from ``b_lo`` (and ``cond``)::

        [h_t', h_s'] = A(b_lo, cond)                               eq. 7 / 8 / 10
        s' = σ(h_s' + 2) / σ(2) > 0                                sigmoid-constrained scale
        z  = [b_lo, (b_hi + t') ⊙ s']                              eq. 6

    Inverting needs only ``z_lo = b_lo`` to recompute ``s'`` and ``t'``:
    ``b_hi = z_hi / s' - t'``. ``logdet = Σ_{t,d} ln s'_{t,d}`` (eq. 9). With ``A``'s output
    layer at zero, ``s' = 1`` and ``t' = 0``: the block starts as the identity.

    Args:
        channels: ``D`` (at least 2).
        make_network: ``make_network(in_channels, cond_channels, out_channels) -> nn.Module``
            called once with ``(channels // 2, cond_channels, 2 * (channels - channels // 2))``;
            the module maps ``(lo, cond)`` to ``(batch, time, out_channels)`` and must
            start with a zero output layer.
        cond_channels: channels of the conditioning input (0: none).
    """

    def __init__(self, channels: int, make_network: NetworkFactory, cond_channels: int = 0):
        super().__init__()
        if channels < 2:
            raise ValueError(f"channels: a coupling needs at least 2 channels, got {channels}")
        self.channels, self.cond_channels = channels, cond_channels
        self.n_lo = channels // 2
        self.n_hi = channels - self.n_lo
        self.network = make_network(self.n_lo, cond_channels, 2 * self.n_hi)

    def _shift_and_log_scale(self, lo: torch.Tensor, cond: torch.Tensor | None):
        # under mixed precision A_n's hidden layers may compute in bfloat16; its output layer
        # (output_layer), the transform and its log-det do not
        h = self.network(lo, cond).to(lo.dtype)
        if h.shape != lo.shape[:2] + (2 * self.n_hi,):
            raise ValueError(f"make_network: the network returned {tuple(h.shape)}, expected "
                             f"{tuple(lo.shape[:2]) + (2 * self.n_hi,)}")
        shift, raw_scale = h[..., :self.n_hi], h[..., self.n_hi:]
        log_scale = F.logsigmoid(raw_scale + SCALE_SHIFT) - _LOG_SIGMOID_SHIFT
        return shift, log_scale

    def forward(self, x, cond=None):
        _check_sequence("x", x, self.channels)
        _check_cond(cond, self.cond_channels, x)
        lo, hi = x[..., :self.n_lo], x[..., self.n_lo:]
        shift, log_scale = self._shift_and_log_scale(lo, cond)
        z_hi = (hi + shift) * log_scale.exp()                     # eq. 6
        return torch.cat([lo, z_hi], dim=-1), log_scale.sum(dim=(1, 2))

    def inverse(self, z, cond=None):
        _check_sequence("z", z, self.channels)
        _check_cond(cond, self.cond_channels, z)
        lo, z_hi = z[..., :self.n_lo], z[..., self.n_lo:]
        shift, log_scale = self._shift_and_log_scale(lo, cond)
        return torch.cat([lo, z_hi * torch.exp(-log_scale) - shift], dim=-1)


# ----------------------------------------------------------------------------------------
# Chaining: a step of flow, and sequences of blocks (eqs. 2-5)
# ----------------------------------------------------------------------------------------

class FlowSequence(InvertibleModule):
    """Blocks applied one after another; ``forward`` sums their log-determinants (eq. 5),
    ``inverse`` undoes them in reverse order. Every block gets the same ``cond``."""

    def __init__(self, blocks: Iterable[InvertibleModule]):
        super().__init__()
        self.blocks = nn.ModuleList(blocks)

    def forward(self, x, cond=None):
        logdet = x.new_zeros(x.shape[0])
        for block in self.blocks:
            x, block_logdet = block(x, cond)
            logdet = logdet + block_logdet
        return x, logdet

    def inverse(self, z, cond=None):
        for block in reversed(self.blocks):
            z = block.inverse(z, cond)
        return z

    def __len__(self) -> int:
        return len(self.blocks)


class FlowStep(FlowSequence):
    """One step of flow (Fig. 1): :class:`ActNorm` -> :class:`InvertibleLinear` ->
    :class:`AffineCoupling`, over ``channels`` channels, conditioned on ``cond_channels``."""

    def __init__(self, channels: int, make_network: NetworkFactory, cond_channels: int = 0):
        super().__init__([ActNorm(channels), InvertibleLinear(channels),
                          AffineCoupling(channels, make_network, cond_channels)])

    @property
    def actnorm(self) -> ActNorm:
        return self.blocks[0]

    @property
    def linear(self) -> InvertibleLinear:
        return self.blocks[1]

    @property
    def coupling(self) -> AffineCoupling:
        return self.blocks[2]


# ----------------------------------------------------------------------------------------
# §3.3.4 Hierarchical decomposition: squeeze and split
# ----------------------------------------------------------------------------------------

def squeeze(x: torch.Tensor) -> torch.Tensor:
    """Half the frames, twice the channels: ``(batch, T, C) -> (batch, T/2, 2C)``; frames
    ``2k`` and ``2k + 1`` side by side (§3.3.4). A reshape: log-determinant 0."""
    if x.ndim != 3 or x.shape[1] % 2:
        raise ValueError(f"x: expected (batch, even time, channels), got {tuple(x.shape)}")
    return x.reshape(x.shape[0], x.shape[1] // 2, 2 * x.shape[2])


def unsqueeze(x: torch.Tensor) -> torch.Tensor:
    """The inverse of :func:`squeeze`: ``(batch, T, 2C) -> (batch, 2T, C)``."""
    if x.ndim != 3 or x.shape[2] % 2:
        raise ValueError(f"x: expected (batch, time, even channels), got {tuple(x.shape)}")
    return x.reshape(x.shape[0], x.shape[1] * 2, x.shape[2] // 2)


class MultiScaleFlow(InvertibleModule):
    """Glow's hierarchy (§3.3.4, Fig. 1): ``levels`` blocks of ``steps`` :class:`FlowStep`.

    After every level but the last, the first ``⌊D/2⌋`` channels are *split* off and go
    straight to the latent, and the other ``⌈D/2⌉`` are *squeezed* to half the frames and
    twice the channels, ``(T/2, 2⌈D/2⌉)``, for the next level. The conditioning sequence
    is squeezed alongside but never split (§5.2), so level ``l`` (from 0) sees
    ``cond_channels · 2^l`` conditioning channels at ``T / 2^l`` frames.

    ``forward(x, cond)`` maps ``x`` ``(batch, T, channels)`` to ``z``
    ``(batch, T · channels)``: ``z_N`` of eq. 9, the split-off parts of every level and the
    output of the last, each flattened (time-major) and concatenated. ``T`` must be a
    multiple of ``2^(levels - 1)``.

    Args:
        channels: ``D``, channels per frame of ``x``.
        levels: ``L``.
        steps: ``K``, steps of flow per level.
        make_network: the coupling networks' factory (see :class:`AffineCoupling`).
        cond_channels: channels per frame of ``cond`` (0: unconditioned).
    """

    def __init__(self, channels: int, levels: int, steps: int, make_network: NetworkFactory,
                 cond_channels: int = 0):
        super().__init__()
        if levels < 1 or steps < 1:
            raise ValueError(f"levels and steps: need at least 1 each, got levels={levels}, steps={steps}")
        self.channels, self.n_levels, self.cond_channels = channels, levels, cond_channels
        self.level_channels, self.split_channels = [], []
        width = channels
        for level in range(levels):
            self.level_channels.append(width)
            if level < levels - 1:
                self.split_channels.append(width // 2)
                width = 2 * (width - width // 2)
        self.levels = nn.ModuleList(
            FlowSequence(FlowStep(c, make_network, cond_channels * 2 ** level) for _ in range(steps))
            for level, c in enumerate(self.level_channels))

    def _check_frames(self, name: str, frames: int) -> None:
        multiple = 2 ** (self.n_levels - 1)
        if frames < multiple or frames % multiple:
            raise ValueError(f"{name}: {frames} frames is not a multiple of 2^(levels - 1) = {multiple}")

    def level_shapes(self, frames: int) -> list[dict[str, int]]:
        """For each level: its ``frames``, ``channels``, ``cond_channels`` and the channels
        ``split`` off after it (0 for the last), for a sequence of ``frames`` frames."""
        self._check_frames("frames", frames)
        return [{"frames": frames // 2 ** level, "channels": c, "cond_channels": self.cond_channels * 2 ** level,
                 "split": self.split_channels[level] if level < self.n_levels - 1 else 0}
                for level, c in enumerate(self.level_channels)]

    def _conds(self, cond: torch.Tensor | None) -> list[torch.Tensor | None]:
        conds = [cond]
        for _ in range(self.n_levels - 1):
            conds.append(None if cond is None else squeeze(conds[-1]))
        return conds

    def forward(self, x, cond=None):
        _check_sequence("x", x, self.channels)
        self._check_frames("x", x.shape[1])
        _check_cond(cond, self.cond_channels, x)
        parts, logdet = [], x.new_zeros(x.shape[0])
        for level, (flow, level_cond) in enumerate(zip(self.levels, self._conds(cond))):
            x, level_logdet = flow(x, level_cond)
            logdet = logdet + level_logdet
            if level < self.n_levels - 1:
                split = self.split_channels[level]
                parts.append(x[..., :split].reshape(x.shape[0], -1))       # to z_N
                x = squeeze(x[..., split:])
        parts.append(x.reshape(x.shape[0], -1))
        return torch.cat(parts, dim=1), logdet

    def inverse(self, z, cond=None):
        if z.ndim != 2 or z.shape[1] % self.channels:
            raise ValueError(f"z: expected (batch, frames * {self.channels}), got {tuple(z.shape)}")
        frames = z.shape[1] // self.channels
        shapes = self.level_shapes(frames)
        _check_cond(cond, self.cond_channels, z.reshape(z.shape[0], frames, self.channels))
        sizes = [s["frames"] * s["split"] for s in shapes[:-1]] + [shapes[-1]["frames"] * shapes[-1]["channels"]]
        parts = torch.split(z, sizes, dim=1)
        conds = self._conds(cond)
        last = shapes[-1]
        x = parts[-1].reshape(z.shape[0], last["frames"], last["channels"])
        for level in reversed(range(self.n_levels)):
            if level < self.n_levels - 1:
                shape = shapes[level]
                split_off = parts[level].reshape(z.shape[0], shape["frames"], shape["split"])
                x = torch.cat([split_off, unsqueeze(x)], dim=-1)
            x = self.levels[level].inverse(x, conds[level])
        return x


# ----------------------------------------------------------------------------------------
# eq. 1: the prior
# ----------------------------------------------------------------------------------------

class GaussianPrior(nn.Module):
    """``Z ~ N(0, I)`` (eq. 1), over latents of any shape ``(batch, ...)``."""

    LOG_2PI = math.log(2 * math.pi)

    def log_prob(self, z: torch.Tensor) -> torch.Tensor:
        """``ln N(z; 0, I)`` per example, summed over everything but the batch: ``(batch,)``."""
        return -0.5 * (z ** 2 + self.LOG_2PI).reshape(z.shape[0], -1).sum(dim=1)

    def sample(self, shape: tuple[int, ...], temperature: float = 1.0, generator: torch.Generator | None = None,
               device=None, dtype=torch.float32) -> torch.Tensor:
        """``temperature · ε`` with ``ε ~ N(0, I)`` of ``shape``.

        Temperature scales the prior's standard deviation: 1 samples the model, lower
        values trade diversity for typicality, and 0 gives the prior's mode, ``z = 0``.
        """
        temperature = float(temperature)
        if not (math.isfinite(temperature) and temperature >= 0):
            raise ValueError(f"temperature: expected a finite number >= 0, got {temperature}")
        noise = torch.randn(shape, generator=generator, device=device, dtype=dtype)
        return temperature * noise


class MotionFlow(GenerativeModel, nn.Module):
    """What Glow and MoGlow share: the layout of a frame's features inside the flow.

    The flow models the pose (the whole frame for an unconditional model) less the
    ``constant_features`` (the hips' root-local ``x`` and ``z``, always 0): ``n_modelled``
    values per frame, at the feature indices ``modelled``; the control columns are
    ``control``.
    """

    def _set_layout(self, config, described: int) -> None:
        modelled = [i for i in range(described) if i not in config.constant_features]
        self.register_buffer("modelled", torch.tensor(modelled), persistent=False)
        self.register_buffer("constant", torch.tensor(sorted(set(config.constant_features)), dtype=torch.long),
                             persistent=False)
        self.control = slice(config.n_features - config.n_control, config.n_features)
        self.n_modelled = len(modelled)

    def join_features(self, x: torch.Tensor, control: torch.Tensor | None) -> torch.Tensor:
        """Modelled values ``(batch, frames, n_modelled)`` and the control ``(batch, frames,
        n_control)`` (or ``None``: the flow models it too, or it is unknown) -> features
        ``(batch, frames, n_features)``, constant features 0."""
        features = x.new_zeros(x.shape[:2] + (self.config.n_features,))
        features[..., self.modelled] = x
        if control is not None:
            features[..., self.control] = control
        return features


# ------------------------------------------------------------------------ training, as the paper says

MOGLOW_CODE = ("not in the paper: the authors' released config, github.com/simonalexanderson/"
               "StyleGestures hparams/paper_version/locomotion.json")


def henter_schedule(steps: int, which: str) -> dict:
    """Henter et al. 2020 §5.2 gives the optimiser and the number of steps only (Glow and MoGlow)."""
    return {
        "optimizer": paper("Adam", "Henter 2020 §5.2: 'using Adam'"),
        "max_steps": paper(steps, f"§5.2: the {which} model, '{steps // 1000}k steps'"),
        "batch_size": choice(100, MOGLOW_CODE),
        "lr": choice(1e-4, MOGLOW_CODE),
        "warmup_steps": choice(1000, MOGLOW_CODE + " (its Noam decay has a floor at the peak "
                                     "learning rate: constant after the warm-up)"),
        "schedule": choice("constant", MOGLOW_CODE),
        "grad_clip": choice(1.0, NO_CLIP + "; the authors' code clips the norm at 100"),
    }
