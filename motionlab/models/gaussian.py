"""Diagonal Gaussians, once: the KL divergence, the negative log-likelihood and the
reparameterised sample that the VAE (Motegi §IV-B), the VAE-LSTM (Habibie eq. 3-5) and DFN
(Chen §5.5-5.6) are built from.

Every function works elementwise (same shape out as in); sum over the dimensions you mean
(``.sum(-1)``) where you use it. Variances are given as ``log_var = log σ²`` (the networks
predict it: any real number is a valid variance), except :func:`negative_log_likelihood`'s
fixed ``std`` for an observation model with one known σ.
"""
from __future__ import annotations

import math

import torch


def kl_divergence(mu_q: torch.Tensor, log_var_q: torch.Tensor,
                  mu_p: torch.Tensor | None = None, log_var_p: torch.Tensor | None = None) -> torch.Tensor:
    """``KL(N(mu_q, exp(log_var_q)) || N(mu_p, exp(log_var_p)))`` per dimension, nats.

    Without ``mu_p`` and ``log_var_p`` the prior is the unit Gaussian ``N(0, I)`` (Kingma &
    Welling's closed form; Motegi §IV-B, Habibie eq. 4); with them, any diagonal Gaussian
    (DFN's learned priors, §5.6).
    """
    if mu_p is None and log_var_p is None:
        return 0.5 * (mu_q.pow(2) + log_var_q.exp() - 1.0 - log_var_q)
    if mu_p is None or log_var_p is None:
        raise ValueError("mu_p, log_var_p: give both (a learned prior) or neither (N(0, I))")
    return 0.5 * (log_var_p - log_var_q + (log_var_q.exp() + (mu_q - mu_p).pow(2)) / log_var_p.exp() - 1.0)


def negative_log_likelihood(x: torch.Tensor, mu: torch.Tensor, log_var: torch.Tensor | None = None,
                            std: float | None = None) -> torch.Tensor:
    """``-log N(x | mu, σ²)`` per value, nats: with a predicted ``log_var`` (tensor, like
    ``mu``) or one fixed ``std`` (a number, e.g. an observation noise of 0.1 normalised units)."""
    if (log_var is None) == (std is None):
        raise ValueError("log_var, std: give exactly one (a predicted log-variance or a fixed standard deviation)")
    if std is not None:
        if not (math.isfinite(std) and std > 0):
            raise ValueError(f"std: expected a finite number > 0, got {std!r}")
        return 0.5 * ((x - mu) / std).pow(2) + math.log(std) + 0.5 * math.log(2 * math.pi)
    return 0.5 * (math.log(2 * math.pi) + log_var + (x - mu) ** 2 / log_var.exp())


def sample(mu: torch.Tensor, log_var: torch.Tensor, temperature: float = 1.0,
           generator: torch.Generator | None = None) -> torch.Tensor:
    """``mu + temperature · σ · ε`` with ``ε ~ N(0, I)``: the reparameterisation trick
    (gradients flow into ``mu`` and ``log_var``). Temperature 0 gives the mean.

    The noise is drawn on the ``generator``'s device and moved to ``mu``'s, so a CPU
    generator also seeds a model on a GPU (without a generator: torch's global one)."""
    if generator is None:
        noise = torch.randn_like(mu)
    else:
        noise = torch.randn(mu.shape, generator=generator, device=generator.device, dtype=mu.dtype).to(mu.device)
    return mu + temperature * (0.5 * log_var).exp() * noise
