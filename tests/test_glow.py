"""The fixed-length sequence Glow: exact likelihood, invertibility, sampling, training."""
import math
from dataclasses import replace

import numpy as np
import pytest
import torch

from motionlab import data, training
from motionlab.models.flows import ActNorm, ConvCouplingNet
from motionlab.models.glow import Glow, GlowConfig

from conftest import CMU_DIR, requires_cmu

SMALL = GlowConfig(window=16, levels=2, steps=2, hidden=16)


@pytest.fixture(scope="module")
def synthetic():
    return data.prepare(data.load("synthetic", fps=20, n_clips=8, duration_s=6), window_s=0.8)


def _randomise(model, scale=0.05):
    """Couplings and ActNorms away from their starting values, so that the checks exercise
    every term. (The 1x1 maps stay orthogonal: random triangular factors would make them
    ill-conditioned in a way training never does.)"""
    with torch.no_grad():
        for module in model.modules():
            if isinstance(module, (ActNorm, ConvCouplingNet)):
                for p in module.parameters():
                    p.add_(scale * torch.randn_like(p))
    return model


def _trained_like(config, windows):
    """A model with coupling networks moved away from zero at random, whose ActNorms were
    then initialised on ``windows``: every block does something, on the scale of the data."""
    torch.manual_seed(0)
    model = _randomise(Glow(config))
    model.log_likelihood(windows)                            # data-dependent initialisation
    return model


def test_paper_config_is_section_5_2():
    paper = GlowConfig.paper()
    assert (paper.levels, paper.steps, paper.hidden, paper.window, paper.fps, paper.conditional) == \
        (4, 32, 512, 80, 20.0, True)
    model = Glow(GlowConfig.paper(steps=1, hidden=8))             # the paper's hierarchy, tiny nets
    assert model.n_modelled == 61                                  # 63 pose values less the hips' x, z
    assert model.describe() == [
        "level 1: 1 steps on 80 frames x 61 channels, conditioned on 3 control channels; then 30 channels split off to z",
        "level 2: 1 steps on 40 frames x 62 channels, conditioned on 6 control channels; then 31 channels split off to z",
        "level 3: 1 steps on 20 frames x 62 channels, conditioned on 12 control channels; then 31 channels split off to z",
        "level 4: 1 steps on 10 frames x 62 channels, conditioned on 24 control channels; all to z"]
    assert Glow(GlowConfig(conditional=False)).n_modelled == 64


@pytest.mark.parametrize("conditional", [True, False])
def test_the_whole_model_inverts_on_random_and_real_windows(synthetic, conditional):
    config = GlowConfig(window=16, levels=3, steps=3, hidden=32, conditional=conditional)
    real = synthetic.test.windows[:8]
    model = _trained_like(config, synthetic.train.windows[:64])
    random = torch.randn(8, 16, 66)
    random[..., [0, 2]] = 0                                         # the constant features
    for windows in (real, random):
        z, logdet = model.encode(windows)
        assert z.shape == (8, 16 * model.n_modelled) and logdet.shape == (8,)
        control = windows[..., 63:] if conditional else None
        assert (model.decode(z, control) - windows).abs().max() < 1e-4


@requires_cmu
def test_inverts_real_cmu_windows():
    prepared = data.prepare(data.load(CMU_DIR, fps=20), window_s=1.0)
    model = _trained_like(GlowConfig(window=20, levels=3, steps=3, hidden=32), prepared.train.windows[:64])
    windows = prepared.test.windows
    z, _ = model.encode(windows)
    assert (model.decode(z, windows[..., 63:]) - windows).abs().max() < 1e-4
    assert np.isfinite(model.nll(windows, prepared.normalizer)["bits/frame"])


def test_log_likelihood_is_eq_9_with_the_brute_force_jacobian():
    config = GlowConfig(window=4, levels=2, steps=2, hidden=8)
    model = _trained_like(config, _with_zero_hips(torch.randn(16, 4, 66))).double()
    windows = _with_zero_hips(torch.randn(2, 4, 66, dtype=torch.float64))
    x, control = model.split_features(windows)
    for i in range(2):
        jacobian = torch.autograd.functional.jacobian(
            lambda xi: model.flow(xi.reshape(1, 4, -1), control[i:i + 1])[0].reshape(-1), x[i].reshape(-1),
            vectorize=True)
        z = model.encode(windows[i:i + 1])[0]
        expected = torch.distributions.Normal(0.0, 1.0).log_prob(z).sum() + torch.linalg.slogdet(jacobian)[1]
        assert torch.allclose(model.log_likelihood(windows[i:i + 1])[0], expected, atol=1e-8)


def _with_zero_hips(windows):
    windows = windows.clone()
    windows[..., [0, 2]] = 0
    return windows


def test_loss_terms_and_units(synthetic):
    torch.manual_seed(0)
    model = Glow(SMALL)
    batch = synthetic.train.windows[:32]
    terms = model.loss(batch)
    nll = -model.log_likelihood(batch).mean()
    assert torch.allclose(terms["loss"], nll / (16 * 61))                  # nats per modelled value
    assert torch.allclose(terms["bits_per_frame"], nll / 16 / math.log(2))
    assert torch.allclose(terms["log_prior"] + terms["logdet"], -terms["loss"])
    # in the data's units, every frame adds Σ ln σ_d of the modelled features (the normalisation)
    normalised = model.nll(batch)
    in_data_units = model.nll(batch, synthetic.normalizer)
    modelled = [i for i in range(63) if i not in (0, 2)]
    shift = np.log(synthetic.normalizer.std[modelled]).sum()
    assert in_data_units["nats/frame"] == pytest.approx(normalised["nats/frame"] + shift, rel=1e-6)
    assert normalised["bits/frame"] == pytest.approx(normalised["nats/frame"] / math.log(2))


def test_actnorm_initialises_on_the_first_batch(synthetic):
    torch.manual_seed(0)
    model = Glow(SMALL)
    first = model.flow.levels[0].blocks[0].actnorm
    assert not bool(first.initialized)
    batch = synthetic.train.windows[:32]
    x, _ = model.split_features(batch)
    model.loss(batch)
    assert all(bool(m.initialized) for m in model.modules() if isinstance(m, ActNorm))
    a, _ = first(x)
    assert a.mean(dim=(0, 1)).abs().max() < 1e-4 and (a.std(dim=(0, 1), unbiased=False) - 1).abs().max() < 1e-3


def test_temperature_zero_is_the_mode_and_temperature_is_honoured(synthetic):
    model = _trained_like(SMALL, synthetic.train.windows[:32])
    control = synthetic.test.windows[:3, :, 63:]
    mode = model.sample(3, control=control, temperature=0.0)
    assert torch.equal(mode, model.sample(3, control=control, temperature=0.0))          # deterministic
    assert torch.allclose(mode, model.decode(torch.zeros(3, 16 * 61), control), atol=1e-6)
    seed = lambda: torch.Generator().manual_seed(3)  # noqa: E731
    eps = torch.randn(3, 16 * 61, generator=seed())
    for temperature in (0.3, 1.0, 1.7):
        sample = model.sample(3, control=control, temperature=temperature, generator=seed())
        assert torch.allclose(sample, model.decode(temperature * eps, control), atol=1e-5)
        assert torch.equal(sample[..., 63:], control)                         # the control is followed
    spread = [float((model.sample(3, control=control, temperature=t, generator=seed()) - mode).abs().mean())
              for t in (0.25, 0.5, 1.0)]
    assert 0 < spread[0] < spread[1] < spread[2]
    with pytest.raises(ValueError, match="temperature"):
        model.sample(3, control=control, temperature=-1.0)


def test_unconditional_sampling_makes_its_own_control(synthetic):
    config = GlowConfig(window=16, levels=2, steps=2, hidden=16, conditional=False)
    model = _trained_like(config, synthetic.train.windows[:32])
    samples = model.sample(4, temperature=0.7, generator=torch.Generator().manual_seed(0))
    assert samples.shape == (4, 16, 66) and torch.isfinite(samples).all()
    assert torch.equal(samples[..., [0, 2]], torch.zeros(4, 16, 2))          # the constant features
    assert samples[..., 63:].std() > 0.1
    assert model.sample(2, frames=32, temperature=0.0).shape == (2, 32, 66)  # any multiple of 2^(L-1)


def test_a_short_training_run_lowers_the_nll(synthetic):
    torch.manual_seed(0)
    model = Glow(SMALL)
    model.log_likelihood(synthetic.train.windows[:32])             # ActNorm's first batch
    before = model.loss(synthetic.val.windows)["loss"].item()
    history = training.train(model, synthetic, training.TrainConfig(epochs=6, lr=2e-3, progress=False))
    after = history.val[-1]["loss"]
    assert after < before - 1.0, (before, after)                   # nats per value, normalised units
    test = synthetic.test.windows
    assert model.nll(test)["nats/frame"] < 61 * 0.5 * math.log(2 * math.pi * math.e)   # beats N(0, I)
    z, _ = model.encode(test)
    assert (model.decode(z, test[..., 63:]) - test).abs().max() < 1e-4       # the trained model inverts


def test_checkpoint_round_trip(synthetic, tmp_path):
    model = _trained_like(SMALL, synthetic.train.windows[:32])
    path = tmp_path / "glow.pt"
    training.save_checkpoint(path, model, synthetic)
    loaded = training.load_checkpoint(path, config=SMALL).model
    batch = synthetic.test.windows[:4]
    assert torch.equal(loaded.log_likelihood(batch), model.eval().log_likelihood(batch))   # range held alike


def test_the_control_is_held_within_the_range_seen_in_training(synthetic, tmp_path):
    windows = synthetic.train.windows[:16]
    model = _randomise(Glow(SMALL))
    assert torch.equal(model.seen_control(4 * windows[..., 63:]), 4 * windows[..., 63:])   # none recorded: no limit
    model.train()
    model.log_likelihood(windows)                                             # training records the range
    low, high = model.control_range
    assert torch.equal(low, windows[..., 63:].amin(dim=(0, 1))) and torch.equal(high, windows[..., 63:].amax(dim=(0, 1)))
    model.log_likelihood(3 * windows)                                         # and widens it
    assert torch.equal(model.control_range[1], torch.maximum(high, 3 * windows[..., 63:].amax(dim=(0, 1))))
    model.control_range.copy_(torch.stack([low, high]))
    model.eval()
    # beyond the range the networks see it clipped: likelihood and samples as for the clipped control
    far = windows.clone()
    far[..., 63:] = 4 * far[..., 63:] + 2
    clipped = far.clone()
    clipped[..., 63:] = torch.maximum(torch.minimum(far[..., 63:], high), low)
    assert torch.allclose(model.log_likelihood(far), model.log_likelihood(clipped))
    draw = model.sample(len(far), far[..., 63:], temperature=0.5, generator=torch.Generator().manual_seed(0))
    same = model.sample(len(far), clipped[..., 63:], temperature=0.5, generator=torch.Generator().manual_seed(0))
    assert torch.equal(draw[..., 63:], far[..., 63:])                        # the output follows the control given
    assert torch.allclose(draw[..., :63], same[..., :63])
    z, _ = model.encode(far)
    assert (model.decode(z, far[..., 63:]) - far).abs().max() < 1e-4         # still one invertible map
    # saved and loaded with it; a file saved before the range existed loads without a limit
    path = tmp_path / "glow.pt"
    training.save_checkpoint(path, model, synthetic)
    assert torch.equal(training.load_checkpoint(path).model.control_range, model.control_range)
    state = torch.load(path, weights_only=True)
    del state["state_dict"]["control_range"]
    torch.save(state, path)
    older = training.load_checkpoint(path).model
    assert bool((older.control_range[0] > older.control_range[1]).all())
    assert torch.equal(older.seen_control(far[..., 63:]), far[..., 63:])
    assert not hasattr(Glow(replace(SMALL, conditional=False)), "control_range")

def test_bad_configs_and_inputs(synthetic):
    with pytest.raises(ValueError, match=r"window: 20 frames is not a multiple of 2\^\(levels - 1\) = 8"):
        GlowConfig(window=20, levels=4)
    with pytest.raises(ValueError, match="width: must be odd"):
        GlowConfig(width=4)
    with pytest.raises(ValueError, match="^steps: expected a whole number >= 1"):
        GlowConfig(steps=0)
    with pytest.raises(ValueError, match="constant_features"):
        GlowConfig(constant_features=(64,))                        # a control value: not modelled
    model = Glow(SMALL)
    with pytest.raises(ValueError, match=r"batch: expected \(batch, frames, 66\) with frames a multiple of 2"):
        model.loss(torch.zeros(2, 15, 66))
    with pytest.raises(ValueError, match=r"batch: expected \(batch, frames, 66\)"):
        model.loss(torch.zeros(2, 16, 63))
    with pytest.raises(ValueError, match=r"batch: features \(0, 2\) should be 0"):
        model.loss(torch.ones(2, 16, 66))
    with pytest.raises(ValueError, match="control: a conditional model needs the control"):
        model.sample(2)
    with pytest.raises(ValueError, match=r"control: expected \(2, 16, 3\)"):
        model.sample(2, control=torch.zeros(3, 16, 3))
    with pytest.raises(ValueError, match="n: expected at least 1"):
        model.sample(0, control=torch.zeros(0, 16, 3))
    with pytest.raises(ValueError, match="control: this model is unconditional"):
        Glow(GlowConfig(window=16, conditional=False)).sample(2, control=torch.zeros(2, 16, 3))
    with pytest.raises(ValueError, match=r"z: expected \(n, frames \* 61\)"):
        model.decode(torch.zeros(2, 100), torch.zeros(2, 16, 3))
