"""The VAEs' likelihood bounds (notebook 08's table): each is the negative ELBO of the model
that generates, checked against the exact NLL and the exact ELBO, both integrated on a grid
over a one-dimensional latent."""
import math

import numpy as np
import pytest
import torch

from motionlab import data
from motionlab.models import gaussian
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder
from motionlab.models.vae import FeatureVAE, MotionVAE, VAEConfig
from motionlab.models.vae_lstm import VAELSTM, VAELSTMConfig, pad_to_canvas

GRID = torch.linspace(-10.0, 10.0, 8001, dtype=torch.float64)                  # a one-dimensional latent, finely
LOG_DZ = math.log(float(GRID[1] - GRID[0]))


def exact_per_frame(log_likelihood, mu, log_var, frames):
    """``(-log p(x), -ELBO)`` per frame, averaged over windows, by quadrature over ``GRID``.

    ``log_likelihood(z)``: ``log p(x | z)`` of every window ``(windows,)`` for one latent value;
    ``mu``, ``log_var``: ``q(z | x)`` per window ``(windows,)``."""
    log_p_x_given_z = torch.stack([log_likelihood(float(z)) for z in GRID], dim=1)   # (windows, grid)
    log_prior = -0.5 * GRID ** 2 - 0.5 * math.log(2 * math.pi)
    nll = -torch.logsumexp(log_p_x_given_z + log_prior + LOG_DZ, dim=1)
    q = torch.exp(-0.5 * (GRID - mu[:, None]) ** 2 / log_var.exp()[:, None]) / torch.sqrt(2 * math.pi * log_var.exp())[:, None]
    log_q = torch.log(q.clamp_min(1e-300))
    elbo = (q * (log_p_x_given_z + log_prior - log_q)).sum(1) * math.exp(LOG_DZ)
    return float(nll.mean()) / frames, float(-elbo.mean()) / frames


@pytest.fixture(scope="module")
def vae_lstm():
    torch.manual_seed(0)
    config = VAELSTMConfig(window=16, width=5, control_filters=4, control_code=6, inference_filters=8,
                           units=1, decoder_filters=8, observation_std=0.5)
    model = VAELSTM(config).double().eval()
    with torch.no_grad():                               # let the latent matter to the decoder
        model.cell.W_c.weight.mul_(20.0)
        model.inference.conv1.bias[0] += 2.0            # and q(z_1 | X) differ from the prior
    return model, torch.randn(3, 16, 66, dtype=torch.float64)


@pytest.mark.slow
def test_the_vae_lstm_bound_is_the_negative_elbo_of_the_generating_model(vae_lstm):
    model, windows = vae_lstm
    scored = [1, 4, 7, 30, 62]
    padded = pad_to_canvas(windows)
    with torch.no_grad():
        code = model.encode_control(padded[..., 63:])
        mu, log_var = model.posterior(padded[..., :63])

        def log_likelihood(z):
            z1 = torch.full((len(windows), 1, 1), z, dtype=torch.float64)
            motion = model.decode(model.canvas(code, z1))[:, :16, scored]
            return -gaussian.negative_log_likelihood(windows[..., scored], motion, std=0.5).sum((1, 2))

        nll, negative_elbo = exact_per_frame(log_likelihood, mu[:, 0, 0], log_var[:, 0, 0], 16)
    bound = model.nll_bound(windows, scored=scored, samples=512)["nats/frame"]
    assert bound == pytest.approx(negative_elbo, abs=0.01)           # the estimate is the ELBO
    assert negative_elbo > nll + 0.05                                        # which bounds the NLL from above
    assert model.nll_bound(windows, scored=scored, samples=1)["nats/frame"] != bound
    assert model.nll_bound(windows, scored=scored, samples=1, seed=3) == \
        model.nll_bound(windows, scored=scored, samples=1, seed=3)


def test_the_bound_in_metres_adds_the_normalisation_jacobian(vae_lstm):
    model, windows = vae_lstm
    normalizer = data.Normalizer(mean=np.zeros(66), std=np.linspace(0.05, 2.0, 66))
    scored = list(range(2, 63))
    normalised = model.nll_bound(windows, scored=scored)
    in_metres = model.nll_bound(windows, normalizer, scored=scored)
    assert in_metres["nats/frame"] - normalised["nats/frame"] == pytest.approx(np.log(normalizer.std[2:63]).sum())
    assert in_metres["bits/frame"] == pytest.approx(in_metres["nats/frame"] / math.log(2))
    # every scored value costs at least ln(σ √(2π)) nats, whatever the decoder: the floor of
    # a fixed-variance decoder
    floor = model.nll_bound_floor(scored=scored)
    assert floor["nats/frame"] == pytest.approx(61 * math.log(0.5 * math.sqrt(2 * math.pi)))
    assert normalised["nats/frame"] > floor["nats/frame"]
    assert model.nll_bound_floor(normalizer, scored)["bits/frame"] < in_metres["bits/frame"]


@pytest.mark.parametrize("kwargs, message", [
    ({"scored": [63]}, "scored"), ({"scored": []}, "scored"), ({"scored": [1, 1]}, "scored"),
    ({"samples": 0}, "samples"), ({"samples": 2.5}, "samples")])
def test_the_vae_lstm_bound_refuses_bad_arguments(vae_lstm, kwargs, message):
    model, windows = vae_lstm
    with pytest.raises(ValueError, match=message):
        model.nll_bound(windows, **kwargs)


def test_the_vae_lstm_bound_refuses_bad_windows(vae_lstm):
    model, windows = vae_lstm
    broken = windows.clone()
    broken[0, 3, 5] = float("nan")
    with pytest.raises(ValueError, match="NaN"):
        model.nll_bound(broken)
    with pytest.raises(ValueError, match="windows"):
        model.nll_bound(windows[..., :60])


def test_motegis_bound_is_the_negative_elbo_of_the_conv_features():
    torch.manual_seed(0)
    conv_ae = ConvAutoencoder(ConvAEConfig(window=16, filters=4)).eval()
    windows = torch.randn(4, 16, 66)
    with torch.no_grad():
        raw = conv_ae.encode(windows).flatten(1).numpy()
    model = MotionVAE(FeatureVAE(VAEConfig(n_inputs=32, hidden=8, latent=1)).eval(), conv_ae,
                      data.Normalizer.fit(raw), data.Normalizer(mean=np.zeros(66), std=np.ones(66)))
    with torch.no_grad():
        model.vae.encoder[2].bias[0] += 2.0             # q(z | y) away from the prior
    y = model.features(windows)
    with torch.no_grad():
        mu, log_var = model.vae.encode(y)

        def log_likelihood(z):
            y_mu, y_log_var = model.vae.decode(torch.full((len(y), 1), z))
            return -gaussian.negative_log_likelihood(y, y_mu, y_log_var).sum(-1)

        nll, negative_elbo = exact_per_frame(log_likelihood, mu[:, 0].double(), log_var[:, 0].double(), 16)
    bound = model.nll_bound(windows, samples=512)
    assert bound["nats/frame"] == pytest.approx(negative_elbo, abs=0.01)
    assert negative_elbo > nll + 0.05
    assert bound["bits/frame"] == pytest.approx(bound["nats/frame"] / math.log(2))
    with torch.no_grad():                                # the same cost as training's (E + D of §IV-B)
        torch.manual_seed(1)
        trained_on = -float(model.vae.loss(y.repeat(2000, 1))["elbo"]) / 16      # 2,000 draws per window
    assert bound["nats/frame"] == pytest.approx(trained_on, abs=0.01)
    broken = windows.clone()
    broken[1, 2, 3] = float("inf")
    with pytest.raises(ValueError, match="NaN or inf"):
        model.nll_bound(broken)
    with pytest.raises(ValueError, match="samples"):
        model.nll_bound(windows, samples=0)
