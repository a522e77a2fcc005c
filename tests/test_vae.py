"""Motegi's VAE over conv features: formulas, traversal, training, the stacked generator."""
import numpy as np
import pytest
import torch

from motionlab import data, metrics, training
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder
from motionlab.models.vae import FeatureVAE, MotionVAE, VAEConfig, axis_effects, traversal


def test_shapes_and_paper_size():
    paper = VAEConfig.paper()
    assert (paper.n_inputs, paper.hidden, paper.latent) == (1920, 256, 32)
    vae = FeatureVAE(VAEConfig(n_inputs=40, hidden=16, latent=4))
    mu, log_var = vae.encode(torch.randn(5, 40))
    assert mu.shape == log_var.shape == (5, 4)
    y_mu, y_log_var = vae.decode(mu)
    assert y_mu.shape == (5, 40) and (y_log_var >= vae.config.min_log_var).all()
    with pytest.raises(ValueError, match=r"y: expected \(batch, 40\)"):
        vae.encode(torch.randn(5, 41))
    with pytest.raises(ValueError, match=r"z: expected \(batch, 4\)"):
        vae.decode(torch.randn(5, 3))
    with pytest.raises(ValueError, match="beta"):
        VAEConfig(beta=-1)


def test_traversal_maps_probabilities_through_the_inverse_normal_cdf():
    z = torch.zeros(5)
    out = traversal(z, axis=2)
    assert out.shape == (9, 5)
    assert torch.allclose(out[[0, 4, 8], 2], torch.tensor([-1.2816, 0.0, 1.2816]), atol=1e-4)
    assert torch.equal(out[:, [0, 1, 3, 4]], torch.zeros(9, 4))
    with pytest.raises(ValueError, match="between 0 and 1"):
        traversal(z, 0, [0.0, 0.5])
    with pytest.raises(ValueError, match="axis"):
        traversal(z, 5)


def test_kl_warmup_and_beta():
    vae = FeatureVAE(VAEConfig(n_inputs=8, hidden=8, latent=2, beta=2.0, kl_warmup_steps=10))
    assert vae.kl_weight() == 0.0
    vae.train()
    for _ in range(5):
        vae.loss(torch.randn(4, 8))
    assert vae.kl_weight() == pytest.approx(1.0)
    for _ in range(10):
        vae.loss(torch.randn(4, 8))
    assert vae.kl_weight() == pytest.approx(2.0)


def test_training_improves_the_elbo_and_the_generator_decodes_motion():
    prepared = data.prepare(data.load("synthetic", fps=20, n_clips=10, duration_s=6), window_s=2.0,
                            stride_s=0.5, normalization="shared_pose")
    torch.manual_seed(0)
    conv_ae = ConvAutoencoder(ConvAEConfig(window=40, filters=8))
    training.train(conv_ae, prepared, training.TrainConfig(epochs=5, progress=False))
    with torch.no_grad():
        train_features = conv_ae.encode(prepared.train.windows).flatten(1).numpy()
    normalizer = data.Normalizer.fit(train_features)
    features = torch.as_tensor(normalizer.normalize(train_features), dtype=torch.float32)
    vae = FeatureVAE(VAEConfig(n_inputs=160, hidden=64, latent=4))
    with torch.no_grad():
        before = vae.eval().loss(features)["elbo"].item()
    training.train(vae, data.MotionDataset(features.numpy()), training.TrainConfig(epochs=20, progress=False))
    with torch.no_grad():
        after = vae.loss(features)["elbo"].item()
    assert after > before + 50                              # the bound rises
    assert vae.kl_per_dimension(features).shape == (4,)

    model = MotionVAE(vae, conv_ae, normalizer, prepared.normalizer)
    samples = model.generate(n=3, seed=1).features
    assert samples.shape == (3, 40, 66) and np.isfinite(samples).all()
    assert np.array_equal(samples, model.generate(n=3, seed=1).features)
    assert np.allclose(samples, model.decode(model.vae.sample_latents(3, torch.Generator().manual_seed(1))))
    assert model.reconstruct(prepared.test.windows[:2]).shape == (2, 40, 66)
    effects = axis_effects(model.decode, 4, metrics.describe_motion, n_bases=2)
    assert set(effects) == set(metrics.describe_motion(samples)) and effects["knee bend (deg)"].shape == (4,)
    with pytest.raises(ValueError, match="does not match the conv AE"):
        MotionVAE(FeatureVAE(VAEConfig(n_inputs=99)), conv_ae, normalizer, prepared.normalizer)


def test_describe_motion_units():
    clip = data.load("synthetic", fps=20, n_clips=1, duration_s=4)[0]
    d = metrics.describe_motion(clip.features()[None])
    assert 0.6 < d["hand height (m)"][0] < 1.1 and 0 <= d["knee bend (deg)"][0] < 60
    with pytest.raises(ValueError, match="features"):
        metrics.describe_motion(clip.features())
