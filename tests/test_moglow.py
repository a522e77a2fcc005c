"""MoGlow (Henter et al. 2020, §4-5): shapes, invertibility, conditioning, streaming, training."""
import math
from dataclasses import replace

import numpy as np
import pytest
import torch

from motionlab import data, training
from motionlab.models.flows import MLPCouplingNet
from motionlab.engine.stream import MoGlowStream
from motionlab.models.moglow import LSTMCouplingNet, MoGlow, MoGlowConfig

SMALL = MoGlowConfig(window=16, history=4, steps=3, hidden=16)


def features(n=5, frames=16, seed=0):
    """Random normalised feature windows with the hips' x, z at 0."""
    x = torch.randn(n, frames, 66, generator=torch.Generator().manual_seed(seed))
    x[..., [0, 2]] = 0.0
    return x


def trained_like(config=SMALL, seed=0):
    """A model whose couplings are no longer the identity (as if trained)."""
    torch.manual_seed(seed)
    model = MoGlow(config)
    model.loss(features(8, config.window))                 # ActNorm's data-dependent initialisation
    with torch.no_grad():
        for module in model.modules():
            if isinstance(module, (LSTMCouplingNet,)):
                module.output.weight.normal_(0, 0.05)
            if isinstance(module, MLPCouplingNet):
                module.layers[-1].weight.normal_(0, 0.05)
    return model.eval()


def test_config_paper_and_errors():
    paper = MoGlowConfig.paper()
    assert (paper.steps, paper.hidden, paper.lstm_layers, paper.history, paper.window, paper.dropout) == \
        (16, 512, 2, 10, 80, 0.95)
    with pytest.raises(ValueError, match="window"):
        MoGlowConfig(window=10, history=10)
    with pytest.raises(ValueError, match="dropout"):
        MoGlowConfig(dropout=1.0)
    with pytest.raises(ValueError, match="constant_features"):
        MoGlowConfig(constant_features=(64,))


def test_shapes_and_conditioning_layout():
    model = MoGlow(SMALL)
    assert model.n_modelled == 61
    assert model.cond_channels == 4 * 61 + 5 * 3
    x = features(2, 9)
    poses, control = x[..., model.modelled], x[..., model.control]
    cond = model.conditioning(poses, control)
    assert cond.shape == (2, 5, model.cond_channels)
    scale = model.history_scale
    assert scale == pytest.approx(1 - SMALL.dropout)
    # frame t = 4 + k sees poses k .. k+3 (oldest first, scaled), then controls k .. k+4
    for k in range(5):
        expected = model.frame_conditioning(scale * poses[:, k:k + 4], control[:, k:k + 5])[:, 0]
        assert torch.equal(cond[:, k], expected)
        assert torch.equal(cond[:, k, :61], scale * poses[:, k])
        assert torch.equal(cond[:, k, -3:], control[:, k + 4])          # the current frame's control


def test_loss_terms_and_units():
    model = MoGlow(SMALL)
    x = features(3, 16)
    terms = model.loss(x)
    assert set(terms) == {"loss", "bits_per_frame"}
    frames = 16 - SMALL.history
    # in nats per value; bits per frame is the same number rescaled
    assert math.isclose(terms["bits_per_frame"].item(), terms["loss"].item() * 61 / math.log(2), rel_tol=1e-5)
    nll = model.nll(x)
    assert math.isclose(nll["bits/frame"], nll["nats/frame"] / math.log(2), rel_tol=1e-6)
    assert math.isclose(nll["nats/frame"], -model.log_likelihood(x).mean().item() / frames, rel_tol=1e-5)


def test_nll_in_data_units_adds_the_normalisation_jacobian():
    model = trained_like()
    x = features(4, 16)
    std = np.full(66, 2.0)
    normalizer = data.Normalizer(np.zeros(66), std)
    assert math.isclose(model.nll(x, normalizer)["nats/frame"] - model.nll(x)["nats/frame"], 61 * math.log(2.0),
                        rel_tol=1e-5)


def test_one_frame_is_exactly_invertible_given_its_conditioning():
    model = trained_like()
    x = features(3, 5)                                          # τ = 4 history frames + 1 predicted
    poses, control = x[..., model.modelled], x[..., model.control]
    cond = model.conditioning(poses, control)
    with torch.no_grad():
        z, logdet = model.flow(poses[:, 4:], cond)
        back = model.flow.inverse(z, cond)
    assert not torch.equal(z, poses[:, 4:])
    assert torch.allclose(back, poses[:, 4:], atol=1e-5)


def test_log_likelihood_matches_frame_by_frame_with_carried_state():
    # Training runs the LSTMs over a whole window; generation one frame at a time with the
    # state carried: both must give the same density.
    model = trained_like()
    x = features(2, 12)
    poses, control = x[..., model.modelled], x[..., model.control]
    with torch.no_grad():
        whole = model.log_likelihood(x)
        cond = model.conditioning(poses, control)
        total = torch.zeros(2)
        with model.carrying_state():
            for t in range(cond.shape[1]):
                z, logdet = model.flow(poses[:, 4 + t:5 + t], cond[:, t:t + 1])
                total += model.prior.log_prob(z) + logdet
    assert torch.allclose(whole, total, atol=1e-3)


def test_the_future_does_not_leak_into_the_past():
    # Causality (eq. 16): changing frames after t leaves ln p(x_t | ...) of earlier frames alone.
    model = trained_like()
    x = features(1, 16)
    later = x.clone()
    later[:, 10:, 3:] += 1.0
    with torch.no_grad():
        z1, _ = model.flow(x[..., model.modelled][:, 4:], model.conditioning(x[..., model.modelled], x[..., model.control]))
        z2, _ = model.flow(later[..., model.modelled][:, 4:],
                           model.conditioning(later[..., model.modelled], later[..., model.control]))
    assert torch.allclose(z1[:, :6], z2[:, :6], atol=1e-6)
    assert not torch.allclose(z1[:, 6:], z2[:, 6:])


def test_history_dropout_drops_whole_frames_and_keeps_the_control():
    model = MoGlow(replace(SMALL, dropout=0.5))
    torch.manual_seed(0)
    x = features(64, 16)
    poses, control = x[..., model.modelled], x[..., model.control]
    clean = model.conditioning(poses, control) / model.history_scale   # the full history, unscaled
    dropped = model.conditioning(poses, control, drop=True)
    history = dropped[..., :4 * 61].reshape(64, 12, 4, 61)
    zero_frames = (history == 0).all(-1)
    assert 0.35 < zero_frames.float().mean() < 0.65                 # about half the frames, each whole
    kept = ~zero_frames
    assert torch.allclose(history[kept], clean[..., :4 * 61].reshape(64, 12, 4, 61)[kept])   # kept as they are
    assert torch.equal(dropped[..., 4 * 61:], model.conditioning(poses, control)[..., 4 * 61:])   # control kept
    # dropout only while training: evaluation is deterministic
    model.eval()
    assert torch.equal(model.log_likelihood(x), model.log_likelihood(x))


def test_evaluation_scales_the_history_by_its_expected_training_value():
    """With dropout p the networks saw, on average, 1 - p of each history frame; evaluation
    and sampling give them that (scale_history, the default), or the paper's full history."""
    x = features(2, 9)
    scaled, paper = MoGlow(replace(SMALL, dropout=0.8)), MoGlow(replace(SMALL, dropout=0.8, scale_history=False))
    poses, control = x[..., scaled.modelled], x[..., scaled.control]
    full = paper.conditioning(poses, control)
    assert paper.history_scale == 1.0 and MoGlow(replace(SMALL, dropout=0.0)).history_scale == 1.0
    assert torch.allclose(scaled.conditioning(poses, control)[..., :4 * 61], 0.2 * full[..., :4 * 61])
    assert torch.equal(scaled.conditioning(poses, control)[..., 4 * 61:], full[..., 4 * 61:])
    # the samplers use it too: with the history scaled to nothing, the history cannot matter
    nothing = trained_like(replace(SMALL, dropout=0.0))
    gone = MoGlow(replace(nothing.config, dropout=0.999999)).eval()
    gone.load_state_dict(nothing.state_dict())
    noise = torch.randn(2, 3, 61, generator=torch.Generator().manual_seed(1))
    other = x.clone()
    other[..., gone.modelled] += 1.0
    a = gone.sample(x[:, 4:7, gone.control], x[:, :4], noise=noise)
    b = gone.sample(x[:, 4:7, gone.control], other[:, :4], noise=noise)
    assert torch.allclose(a, b, atol=1e-4)
    assert not torch.allclose(nothing.sample(x[:, 4:7, gone.control], x[:, :4], noise=noise),
                              nothing.sample(x[:, 4:7, gone.control], other[:, :4], noise=noise), atol=1e-4)


def test_with_full_history_is_the_same_model_under_the_papers_rule():
    model = trained_like(replace(SMALL, dropout=0.8))
    paper = model.with_full_history()
    assert paper.config == replace(model.config, scale_history=False) and model.config.scale_history
    assert paper.history_scale == 1.0 and model.history_scale == pytest.approx(0.2)
    for a, b in zip(model.state_dict().values(), paper.state_dict().values()):
        assert torch.equal(a, b)
    x = features(2, 9)
    poses, control = x[..., model.modelled], x[..., model.control]
    assert torch.allclose(model.conditioning(poses, control)[..., :4 * 61],
                          0.2 * paper.conditioning(poses, control)[..., :4 * 61])


def test_stream_equals_the_batch_sampler_for_the_same_noise():
    model = trained_like()
    x = features(3, 16)
    history, control = x[:, :4], x[:, 4:, -3:]
    noise = torch.randn(3, 12, 61, generator=torch.Generator().manual_seed(1))
    reference = model.sample(control, history, temperature=0.7, noise=noise)
    stream = model.stream(history, temperature=0.7)
    streamed = torch.stack([stream.step(control[:, t], noise[:, t]) for t in range(12)], dim=1)
    assert streamed.shape == reference.shape == (3, 12, 66)
    assert torch.allclose(streamed, reference, atol=1e-4)
    assert torch.equal(reference[..., -3:], control)                      # the control is copied in
    assert torch.equal(reference[..., [0, 2]], torch.zeros(3, 12, 2))
    assert stream.frames == 12


def test_streams_in_a_batch_are_independent():
    model = trained_like()
    x = features(3, 16)
    noise = torch.randn(3, 6, 61, generator=torch.Generator().manual_seed(2))
    together = model.stream(x[:, :4]).run(x[:, 4:10, -3:], noise)
    alone = model.stream(x[1:2, :4]).run(x[1:2, 4:10, -3:], noise[1:2])
    assert torch.allclose(together[1:2], alone, atol=1e-5)


def test_stream_in_data_units_with_a_normalizer():
    model = trained_like()
    mean, std = np.linspace(-1, 1, 66), np.linspace(0.5, 2.0, 66)
    normalizer = data.Normalizer(mean, std)
    x = features(2, 10)
    in_units = normalizer.denormalize(x.numpy())
    in_units[..., [0, 2]] = 0.0
    noise = torch.randn(2, 61, generator=torch.Generator().manual_seed(3))
    normalised = model.stream(x[:, :4]).step(x[:, 4, -3:], noise)
    physical = model.stream(torch.tensor(in_units[:, :4]), normalizer=normalizer).step(
        torch.tensor(in_units[:, 4, -3:]), noise)
    expected = normalizer.denormalize(normalised.numpy())
    expected[..., [0, 2]] = 0.0
    assert np.allclose(physical.numpy(), expected, atol=1e-4)


def test_temperature_zero_is_deterministic_and_sampling_is_reproducible():
    model = trained_like()
    x = features(2, 12)
    a = model.sample(x[:, 4:, -3:], x[:, :4], temperature=0.0, generator=torch.Generator().manual_seed(0))
    b = model.sample(x[:, 4:, -3:], x[:, :4], temperature=0.0, generator=torch.Generator().manual_seed(1))
    assert torch.allclose(a, b)
    c = model.sample(x[:, 4:, -3:], x[:, :4], generator=torch.Generator().manual_seed(5))
    d = model.sample(x[:, 4:, -3:], x[:, :4], generator=torch.Generator().manual_seed(5))
    assert torch.equal(c, d) and not torch.allclose(a, c)
    assert torch.isfinite(c).all()


def test_markov_variant_samples_and_refuses_to_stream():
    model = trained_like(replace(SMALL, recurrent=False))
    assert not any(isinstance(m, LSTMCouplingNet) for m in model.modules())
    x = features(2, 10)
    out = model.sample(x[:, 4:, -3:], x[:, :4])
    assert out.shape == (2, 6, 66) and torch.isfinite(out).all()
    with pytest.raises(ValueError, match="recurrent"):
        MoGlowStream(model, x[:, :4])


def test_bad_inputs_raise_value_errors_naming_the_argument():
    model = MoGlow(SMALL)
    with pytest.raises(ValueError, match="batch"):
        model.loss(torch.zeros(2, 4, 66))                          # no frame after the history
    with pytest.raises(ValueError, match="batch"):
        model.loss(torch.zeros(2, 16, 65))
    bad = features(2, 16)
    bad[..., 0] = 1.0
    with pytest.raises(ValueError, match="constant_features"):
        model.loss(bad)
    x = features(2, 16)
    with pytest.raises(ValueError, match="history"):
        model.sample(x[:, 4:, -3:], x[:, :3])
    with pytest.raises(ValueError, match="control"):
        model.sample(x[:1, 4:, -3:], x[:, :4])
    with pytest.raises(ValueError, match="noise"):
        model.sample(x[:, 4:, -3:], x[:, :4], noise=torch.zeros(2, 3, 61))
    stream = model.stream(x[:, :4])
    with pytest.raises(ValueError, match="control"):
        stream.step(torch.zeros(3, 3))
    with pytest.raises(ValueError, match="control"):
        stream.step(torch.tensor([0.0, float("nan"), 0.0]))
    with pytest.raises(ValueError, match="temperature"):
        model.stream(x[:, :4], temperature=-1)


def test_short_training_run_improves_the_likelihood():
    torch.manual_seed(0)
    clips = data.load("synthetic", fps=20, n_clips=8, duration_s=6)
    prepared = data.prepare(clips, window_s=1.0)
    model = MoGlow(replace(SMALL, window=20, history=5, hidden=32))
    before = model.nll(prepared.val.windows)["bits/frame"]
    history = training.train(model, prepared, training.TrainConfig(epochs=3, batch_size=32, lr=3e-3, progress=False))
    after = model.nll(prepared.val.windows)["bits/frame"]
    assert after < before - 20, (before, after)
    assert np.isfinite([row["loss"] for row in history.train]).all()
    assert not model.training
    out = model.sample(prepared.test.windows[:2, 5:, -3:], prepared.test.windows[:2, :5], temperature=0.5)
    assert torch.isfinite(out).all()


def lstm_driven(layers=2):
    """A model whose couplings depend strongly on their LSTMs (output weights ~ N(0, 0.3)):
    resetting the LSTM states every frame moves its 8-frame streams by ~0.3, while their
    bfloat16 rounding moves them by ~7e-4."""
    model = trained_like(replace(SMALL, lstm_layers=layers))
    with torch.no_grad():
        for module in model.modules():
            if isinstance(module, LSTMCouplingNet):
                module.output.weight.normal_(0, 0.3)
    return model


BFLOAT16_STREAM_TOLERANCE = 5e-3         # normalised units, over 8 frames of lstm_driven()


def test_stream_with_two_lstm_layers_and_bfloat16_weights():
    model = lstm_driven()
    x = features(2, 12)
    noise = torch.randn(2, 8, 61, generator=torch.Generator().manual_seed(4))
    reference = model.sample(x[:, 4:, -3:], x[:, :4], temperature=0.5, noise=noise)
    exact = model.stream(x[:, :4], temperature=0.5).run(x[:, 4:, -3:], noise)
    assert torch.allclose(exact, reference, atol=1e-4)
    half = model.stream(x[:, :4], temperature=0.5, weights=torch.bfloat16).run(x[:, 4:, -3:], noise)
    error = (half - reference).abs().max().item()
    assert 0 < error < BFLOAT16_STREAM_TOLERANCE, error
    with pytest.raises(ValueError, match="weights"):
        model.stream(x[:, :4], weights=torch.float16)


@pytest.mark.parametrize("streams", [1, 2])
def test_stream_with_three_lstm_layers_and_trained_biases_equals_the_batch_sampler(streams):
    # the stream keeps every coupling's inputs and hidden states side by side in one buffer,
    # gives the conditioning's part of all first layers in one product (one per coupling
    # for several streams), and folds the output layer's bias and σ(2) into its own maps
    model = trained_like(replace(SMALL, lstm_layers=3))
    with torch.no_grad():
        for module in model.modules():
            if isinstance(module, LSTMCouplingNet):
                module.output.bias.normal_(0, 0.5)
    x = features(streams, 12)
    noise = torch.randn(streams, 8, 61, generator=torch.Generator().manual_seed(7))
    reference = model.sample(x[:, 4:, -3:], x[:, :4], temperature=0.5, noise=noise)
    stream = model.stream(x[:, :4], temperature=0.5)
    assert stream._kernel == ("transposed" if streams == 1 else "product")
    assert len(stream._cond_chunks) == (1 if streams == 1 else SMALL.steps)
    assert torch.allclose(stream.run(x[:, 4:, -3:], noise), reference, atol=1e-4)


@pytest.mark.parametrize("kernel", ["matrix-vector", "own product", "product"])
def test_one_bfloat16_stream_with_any_kernel_follows_the_float32_stream(kernel):
    # one stream picks its kernel by the CPU (native bfloat16 or not); every one is checked here
    model = lstm_driven()
    x = features(1, 12)
    noise = torch.randn(1, 8, 61, generator=torch.Generator().manual_seed(5))
    exact = model.stream(x[:, :4], temperature=0.5).run(x[:, 4:, -3:], noise)
    stream = model.stream(x[:, :4], temperature=0.5, weights=torch.bfloat16)
    stream._kernel = kernel
    with torch.inference_mode():
        stream._precompute(torch.device("cpu"))                # the weights laid out for that kernel
    error = (stream.run(x[:, 4:, -3:], noise) - exact).abs().max().item()
    assert 0 < error < BFLOAT16_STREAM_TOLERANCE, error
    assert torch.backends.mkldnn.enabled                       # the own-product path restores oneDNN


def test_one_float32_stream_with_transposed_weights_equals_the_batch_sampler():
    model = trained_like(replace(SMALL, lstm_layers=2))
    x = features(1, 12)
    noise = torch.randn(1, 8, 61, generator=torch.Generator().manual_seed(6))
    reference = model.sample(x[:, 4:, -3:], x[:, :4], temperature=0.5, noise=noise)
    stream = model.stream(x[:, :4], temperature=0.5)
    assert stream._kernel == "transposed"
    assert torch.allclose(stream.run(x[:, 4:, -3:], noise), reference, atol=1e-4)


