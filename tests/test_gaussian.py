"""The Gaussian helpers every latent-variable model uses, against torch.distributions."""
import math

import numpy as np
import pytest
import torch
from torch.distributions import Normal, kl_divergence as torch_kl

from motionlab.models import gaussian


def normal(mu, log_var):
    return Normal(mu, (0.5 * log_var).exp())


def test_kl_to_the_unit_gaussian_and_to_a_learned_prior_match_torch():
    g = torch.Generator().manual_seed(0)
    mu_q, mu_p, lv_q, lv_p = (torch.randn(5, 7, generator=g) for _ in range(4))
    unit = torch_kl(normal(mu_q, lv_q), Normal(0.0, 1.0))
    assert torch.allclose(gaussian.kl_divergence(mu_q, lv_q), unit, atol=1e-5)
    learned = torch_kl(normal(mu_q, lv_q), normal(mu_p, lv_p))
    assert torch.allclose(gaussian.kl_divergence(mu_q, lv_q, mu_p, lv_p), learned, atol=1e-5)
    assert torch.equal(gaussian.kl_divergence(mu_q, lv_q, mu_q, lv_q), torch.zeros(5, 7))   # KL(q || q) = 0
    with pytest.raises(ValueError, match="give both"):
        gaussian.kl_divergence(mu_q, lv_q, mu_p)


def test_negative_log_likelihood_with_a_predicted_or_a_fixed_sigma_matches_torch():
    g = torch.Generator().manual_seed(1)
    x, mu, lv = (torch.randn(4, 6, generator=g) for _ in range(3))
    assert torch.allclose(gaussian.negative_log_likelihood(x, mu, lv), -normal(mu, lv).log_prob(x), atol=1e-5)
    assert torch.allclose(gaussian.negative_log_likelihood(x, mu, std=0.3), -Normal(mu, 0.3).log_prob(x), atol=1e-5)
    with pytest.raises(ValueError, match="exactly one"):
        gaussian.negative_log_likelihood(x, mu)
    with pytest.raises(ValueError, match="exactly one"):
        gaussian.negative_log_likelihood(x, mu, lv, std=1.0)
    for bad in (0.0, -1.0, math.inf, math.nan):
        with pytest.raises(ValueError, match="std"):
            gaussian.negative_log_likelihood(x, mu, std=bad)


def test_sample_scales_by_sigma_not_the_variance_and_by_the_temperature():
    mu, log_var = torch.full((200000, 1), 2.0), torch.full((200000, 1), np.log(9.0))
    z = gaussian.sample(mu, log_var, generator=torch.Generator().manual_seed(0))
    assert abs(z.mean().item() - 2.0) < 0.03 and abs(z.std().item() - 3.0) < 0.03   # σ = 3, not σ² = 9
    half = gaussian.sample(mu, log_var, 0.5, torch.Generator().manual_seed(0))
    assert torch.allclose(half - 2.0, 0.5 * (z - 2.0), atol=1e-5)                    # same noise, half the step
    assert torch.equal(gaussian.sample(mu, log_var, 0.0), mu)                        # temperature 0: the mean


def test_sample_is_reproducible_with_a_generator_and_differentiable():
    mu = torch.zeros(3, 4, requires_grad=True)
    log_var = torch.zeros(3, 4, requires_grad=True)
    a = gaussian.sample(mu, log_var, generator=torch.Generator().manual_seed(7))
    b = gaussian.sample(mu, log_var, generator=torch.Generator().manual_seed(7))
    assert torch.equal(a, b)
    a.sum().backward()
    assert mu.grad is not None and log_var.grad is not None                          # the reparameterisation trick
