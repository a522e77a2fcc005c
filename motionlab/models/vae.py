"""A variational autoencoder over motion features (Motegi et al. 2018, §IV-V).

The convolutional autoencoder of notebook 02 turns a window of motion into a feature map
``y`` (``window/2 x filters``: 60 x 32 = 1920 numbers in the paper). This VAE gives those
features a probability density over a small latent space ``z`` (32 dimensions):

    encoder  q_φ(z|y) = N(z | μ_φ(y), diag σ_φ²(y))      one hidden layer of 256, ReLU (§IV-A)
    decoder  p_θ(y|z) = N(y | μ_θ(z), diag σ_θ²(z))      one hidden layer of 256, ReLU
    cost     C = E + D                                    (§IV-B)
             E = -E_q[log p_θ(y|z)]                       Gaussian reconstruction term
             D = KL(q_φ(z|y) || N(0, I))                  = -½ Σ_m (1 + log σ_m² - μ_m² - σ_m²)

``-C`` is the evidence lower bound (ELBO) on ``log p(y)``. Sampling ``z ~ N(0, I)`` and
decoding ``μ_θ(z)`` through the frozen convolutional decoder gives a new motion (§V);
moving one coordinate of ``z`` while keeping the rest shows what that axis controls
(§V, Figs. 8-9).

Two options the paper does not have, because students meet *posterior collapse* here: a
weight ``beta`` on the KL term (β-VAE), and KL annealing (``kl_warmup_steps``: the weight
rises from 0 to ``beta`` over the first training steps).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import torch
from torch import nn

from .. import checks
from . import gaussian
from .base import Generated, GenerativeModel, generator_for, per_frame_nll
from .conv_ae import motegi_schedule
from .modelcard import ModelCard


@dataclass(frozen=True)
class VAEConfig:
    """Sizes and options. Defaults: the laptop conv autoencoder's 40 x 32 feature maps.

    Attributes:
        n_inputs: size of one flattened feature map (``window / 2 * filters``).
        hidden: units of the one hidden layer in encoder and decoder.
        latent: dimensions of ``z``.
        beta: weight of the KL term (1: the ELBO of §IV-B; > 1: a β-VAE).
        kl_warmup_steps: training steps over which the KL weight rises from 0 to ``beta``.
        min_log_var: lower bound on the decoder's log σ_θ² (features that are often exactly
            zero, after the ReLU, would otherwise drive σ_θ to 0 and the likelihood to infinity).
    """

    n_inputs: int = 1280
    hidden: int = 256
    latent: int = 32
    beta: float = 1.0
    kl_warmup_steps: int = 0
    min_log_var: float = -6.0

    def __post_init__(self):
        checks.config(self, non_negative_fields=("beta",), zero_allowed=("kl_warmup_steps",))
        if min(self.n_inputs, self.hidden, self.latent) < 1:
            raise ValueError(f"n_inputs, hidden and latent must be >= 1, got {self.n_inputs}, "
                             f"{self.hidden}, {self.latent}")
        if self.beta < 0 or self.kl_warmup_steps < 0:
            raise ValueError(f"beta and kl_warmup_steps must be >= 0, got {self.beta}, {self.kl_warmup_steps}")

    @classmethod
    def paper(cls, **changes) -> "VAEConfig":
        """Motegi §IV-A: 1920 inputs (60 x 32 conv features), 256 hidden units, 32 latents."""
        return replace(cls(n_inputs=1920, hidden=256, latent=32), **changes)


class FeatureVAE(nn.Module):
    """Motegi's VAE on flattened conv-autoencoder features ``(batch, n_inputs)``."""

    def __init__(self, config: VAEConfig = VAEConfig()):
        super().__init__()
        self.config = config
        c = config
        self.encoder = nn.Sequential(nn.Linear(c.n_inputs, c.hidden), nn.ReLU(),
                                     nn.Linear(c.hidden, 2 * c.latent))      # μ_φ, log σ_φ²
        self.decoder = nn.Sequential(nn.Linear(c.latent, c.hidden), nn.ReLU(),
                                     nn.Linear(c.hidden, 2 * c.n_inputs))    # μ_θ, log σ_θ²
        self.register_buffer("steps_seen", torch.zeros((), dtype=torch.long))

    def _check(self, y: torch.Tensor) -> None:
        if y.ndim != 2 or y.shape[1] != self.config.n_inputs:
            raise ValueError(f"y: expected (batch, {self.config.n_inputs}), got {tuple(y.shape)}")

    def encode(self, y: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """q_φ(z|y): ``(batch, n_inputs)`` -> mean and log-variance, each ``(batch, latent)``."""
        self._check(y)
        mu, log_var = self.encoder(y).chunk(2, dim=-1)
        return mu, log_var

    def decode(self, z: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """p_θ(y|z): ``(batch, latent)`` -> mean and log-variance, each ``(batch, n_inputs)``."""
        if z.ndim != 2 or z.shape[1] != self.config.latent:
            raise ValueError(f"z: expected (batch, {self.config.latent}), got {tuple(z.shape)}")
        mu, log_var = self.decoder(z).chunk(2, dim=-1)
        return mu, log_var.clamp(min=self.config.min_log_var)

    def kl_weight(self) -> float:
        """β, ramped up linearly over the first ``kl_warmup_steps`` training steps."""
        if self.config.kl_warmup_steps == 0:
            return self.config.beta
        return self.config.beta * min(1.0, float(self.steps_seen) / self.config.kl_warmup_steps)

    def loss(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        """The cost C = E + β D of §IV-B, averaged over the batch and divided by ``n_inputs``
        (so the learning rate does not depend on the feature size). Logged per example:
        ``reconstruction`` (E, nats), ``kl`` (D, nats) and ``elbo`` (-(E + D), nats)."""
        mu, log_var = self.encode(batch)
        # z = μ + σ ⊙ ε, ε ~ N(0, I) (§IV-B, Fig. 6). The paper writes ε ⊙ σ²; σ is what turns
        # a standard normal ε into a sample of N(μ, σ²).
        z = gaussian.sample(mu, log_var)
        y_mu, y_log_var = self.decode(z)
        reconstruction = gaussian.negative_log_likelihood(batch, y_mu, y_log_var).sum(-1).mean()    # E
        kl = gaussian.kl_divergence(mu, log_var).sum(-1).mean()                                    # D
        weight = self.kl_weight()
        if self.training:
            self.steps_seen += 1
        return {"loss": (reconstruction + weight * kl) / self.config.n_inputs,
                "reconstruction": reconstruction, "kl": kl, "elbo": -(reconstruction + kl),
                "kl_weight": torch.tensor(weight)}

    @torch.no_grad()
    def kl_per_dimension(self, y: torch.Tensor) -> torch.Tensor:
        """Mean KL of each latent dimension over the examples ``y``, ``(latent,)`` nats.

        A dimension whose KL is near 0 is *inactive*: the encoder ignores it and the prior
        fills it with noise the decoder has learned to ignore (posterior collapse).
        """
        mu, log_var = self.encode(y)
        return gaussian.kl_divergence(mu, log_var).mean(0)

    @torch.no_grad()
    def sample_latents(self, n: int, generator: torch.Generator | None = None) -> torch.Tensor:
        """``n`` latents from the prior N(0, I), ``(n, latent)`` (§V)."""
        return torch.randn(n, self.config.latent, generator=generator)


def traversal(z: torch.Tensor, axis: int, probabilities=np.linspace(0.1, 0.9, 9)) -> torch.Tensor:
    """Latents that walk one axis through the prior's quantiles (§V, Figs. 8-9).

    ``z`` ``(latent,)`` is the starting point; coordinate ``axis`` is replaced by the value
    whose cumulative probability under N(0, 1) is each of ``probabilities`` (the inverse
    normal CDF: 0.1 -> -1.28, 0.5 -> 0, 0.9 -> +1.28). Returns ``(len(probabilities), latent)``.
    """
    z = torch.as_tensor(z, dtype=torch.float32)
    if z.ndim != 1 or not 0 <= axis < len(z):
        raise ValueError(f"z: expected (latent,) and 0 <= axis < latent, got {tuple(z.shape)} and {axis}")
    p = torch.as_tensor(np.asarray(probabilities, dtype=np.float32))
    if (p <= 0).any() or (p >= 1).any():
        raise ValueError("probabilities: must lie strictly between 0 and 1")
    out = z.repeat(len(p), 1)
    out[:, axis] = torch.distributions.Normal(0.0, 1.0).icdf(p)
    return out


class MotionVAE(GenerativeModel):
    """The generative model of §V: the VAE stacked under the frozen convolutional decoder.

    Args:
        vae: a trained :class:`FeatureVAE`.
        conv_ae: the trained (frozen) ``ConvAutoencoder`` whose features the VAE models.
        feature_normalizer: standardises the flattened conv features for the VAE.
        motion_normalizer: the normaliser of the motion windows the conv AE was trained on
            (``self.normalizer``, so :meth:`generate` works in the data's units).

    ``decode(z)`` -> motion features ``(n, window, 66)`` in data units (metres, m/s, rad/s),
    ready for ``representation.to_positions``.
    """

    def __init__(self, vae: FeatureVAE, conv_ae, feature_normalizer, motion_normalizer):
        self.vae, self.conv_ae = vae.eval(), conv_ae.eval()
        self.feature_normalizer, self.normalizer = feature_normalizer, motion_normalizer
        cfg = conv_ae.config
        if vae.config.n_inputs != cfg.window // 2 * cfg.filters:
            raise ValueError(f"vae: n_inputs {vae.config.n_inputs} does not match the conv AE's "
                             f"{cfg.window // 2} x {cfg.filters} features")

    @property
    def fps(self) -> float:
        return self.conv_ae.config.fps

    @torch.no_grad()
    def features(self, windows: torch.Tensor) -> torch.Tensor:
        """Flattened, standardised conv features ``(n, n_inputs)`` of normalised motion windows."""
        y = self.conv_ae.encode(windows).flatten(1)
        return self.feature_normalizer.normalize(y)

    @torch.no_grad()
    def decode_normalized(self, z: torch.Tensor) -> torch.Tensor:
        """x̃ = Φ'(μ_θ(z)) (§V): latents ``(n, latent)`` -> normalised motion ``(n, window, 66)``."""
        y_mu, _ = self.vae.decode(torch.as_tensor(z, dtype=torch.float32))
        y = self.feature_normalizer.denormalize(y_mu)
        cfg = self.conv_ae.config
        return self.conv_ae.decode(y.reshape(len(y), cfg.window // 2, cfg.filters))

    def decode(self, z: torch.Tensor) -> np.ndarray:
        """Latents ``(n, latent)`` -> motion features ``(n, window, 66)`` in the data's units."""
        return self.normalizer.denormalize(self.decode_normalized(z).numpy())

    @torch.no_grad()
    def reconstruct(self, windows: torch.Tensor) -> np.ndarray:
        """Motion -> posterior mean -> motion: ``(n, window, 66)`` normalised in, data units out."""
        mu, _ = self.vae.encode(self.features(windows))
        return self.decode(mu)

    @torch.no_grad()
    def nll_bound(self, windows: torch.Tensor, samples: int = 8, seed: int = 0) -> dict[str, float]:
        """The negative ELBO ``E + D`` of §IV-B on the windows' conv features, per frame.

        It bounds ``-log p(y)`` of the standardised conv features ``y`` (:meth:`features`),
        not of the frames: the frozen conv decoder is deterministic, so the model has no
        density over frames at all. ``windows``: normalised motion ``(n, window, 66)``. ``E``
        is a mean over ``samples`` draws of ``z`` (``seed``), ``D`` exact. Returns
        ``{"nats/frame", "bits/frame"}``: the mean bound per window divided by its frames.
        """
        windows = torch.as_tensor(windows, dtype=torch.float32)
        if not torch.isfinite(windows).all():
            raise ValueError("windows: contains NaN or inf")
        if not (isinstance(samples, int) and samples >= 1):
            raise ValueError(f"samples: expected an int >= 1, got {samples!r}")
        y = self.features(windows)
        mu, log_var = self.vae.encode(y)
        generator = generator_for(seed)
        reconstruction = y.new_zeros(len(y))
        for _ in range(samples):
            y_mu, y_log_var = self.vae.decode(gaussian.sample(mu, log_var, generator=generator))
            reconstruction += gaussian.negative_log_likelihood(y, y_mu, y_log_var).sum(-1) / samples    # E
        kl = gaussian.kl_divergence(mu, log_var).sum(-1)                                                  # D
        return per_frame_nll(float((reconstruction + kl).mean()) / windows.shape[1])

    def sample(self, n: int, temperature: float = 1.0, generator: torch.Generator | None = None) -> torch.Tensor:
        """``n`` motions from the prior ``z ~ N(0, temperature² I)``: normalised ``(n, window, 66)``."""
        return self.decode_normalized(temperature * self.vae.sample_latents(n, generator))

    def generate(self, control=None, *, frames=None, prefix=None, n=1, temperature=1.0, seed=0) -> Generated:
        """``n`` new windows from the prior (§V); see :mod:`motionlab.models.base`.

        Motegi's VAE has no control input: ``control`` is ignored. It draws whole windows of
        ``conv_ae.config.window`` frames (``frames`` must be that or ``None``) and does not
        continue a ``prefix``.
        """
        n, temperature = self._check_common(n, temperature, seed)
        self._refuse_prefix(prefix)
        window = self.conv_ae.config.window
        if frames is not None and frames != window:
            raise ValueError(f"frames: this VAE draws windows of {window} frames, got {frames!r}")
        return self._result(self.sample(n, temperature, generator_for(seed)))


def axis_effects(decode: Callable[[torch.Tensor], np.ndarray], latent: int,
                 describe: Callable[[np.ndarray], dict[str, np.ndarray]], n_bases: int = 16,
                 low: float = 0.1, high: float = 0.9, seed: int = 0) -> dict[str, np.ndarray]:
    """How much each latent axis changes each motion descriptor (Motegi §V, made measurable).

    For ``n_bases`` random starting latents and every axis, decode the latent with that
    axis at the prior's ``low`` and ``high`` quantiles and take the mean difference of each
    descriptor (``describe(features) -> {name: (n,) values}``). Returns ``{name: (latent,)}``.
    """
    bases = torch.randn(n_bases, latent, generator=torch.Generator().manual_seed(seed))
    normal = torch.distributions.Normal(0.0, 1.0)
    lo, hi = normal.icdf(torch.tensor(low)), normal.icdf(torch.tensor(high))
    effects: dict[str, list[float]] = {}
    for axis in range(latent):
        z_lo, z_hi = bases.clone(), bases.clone()
        z_lo[:, axis], z_hi[:, axis] = lo, hi
        d_lo, d_hi = describe(decode(z_lo)), describe(decode(z_hi))
        for name in d_lo:
            effects.setdefault(name, []).append(float(np.mean(d_hi[name] - d_lo[name])))
    return {name: np.array(values) for name, values in effects.items()}


CARD = ModelCard("vae", FeatureVAE, VAEConfig, schedule=motegi_schedule("IV-B"))   # on a conv AE's features
