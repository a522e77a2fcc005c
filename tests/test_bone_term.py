"""The bone-length term in the VAE-LSTM's and the conv autoencoder's losses (``bone_weight``):
off by default and then the old loss bit for bit; on, it is the squared error of the
reconstruction's bone lengths (cm²) and training with it keeps the bones nearer their lengths."""
import numpy as np
import pytest
import torch

from motionlab import metrics, training
from motionlab.models.base import bone_term
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder
from motionlab.models.vae_lstm import VAELSTM, VAELSTMConfig
from motionlab.representation import N_POSE, to_positions
from motionlab.skeleton import LOCOMOTION

from test_contact_term import FPS, prepared, vae_lstm  # noqa: F401 (prepared: the same small data set)


def model(prepared, bone: float, **changes) -> VAELSTM:
    """test_contact_term's small VAE-LSTM, without the contact term, with ``bone_weight``."""
    return vae_lstm(prepared, 0.0, bone_weight=bone, **changes)


def test_the_term_is_the_squared_bone_length_error_in_cm2(prepared):
    m = model(prepared, 1.0)
    batch = prepared.train.windows[:4]
    assert float(m.bone_term(batch, batch)) == 0.0
    # stretch every pose about its root by 2 %: each bone 2 % longer
    units = torch.tensor(prepared.normalizer.denormalize(batch.numpy()))
    stretched = units.clone()
    stretched[..., :N_POSE] *= 1.02
    lengths = LOCOMOTION.bone_lengths(units[..., :N_POSE].reshape(*units.shape[:2], -1, 3).numpy())
    expected = float(np.mean((100 * 0.02 * lengths) ** 2))
    prediction = torch.tensor(prepared.normalizer.normalize(stretched.numpy()), dtype=torch.float32)
    assert float(bone_term(m, prediction, batch)) == pytest.approx(expected, rel=1e-3)


@pytest.mark.parametrize("free_running", [0.0, 1.0])
def test_off_it_is_the_old_loss_and_on_it_adds_its_weight_times_the_term(prepared, free_running):
    batch = prepared.train.windows[:4]
    assert VAELSTMConfig().bone_weight == 0.0
    off, on = model(prepared, 0.0, free_running=free_running), model(prepared, 3.0, free_running=free_running)
    torch.manual_seed(5)
    without = off.loss(batch)
    torch.manual_seed(5)
    with_term = on.loss(batch)
    assert "bone" not in without and ("free_bone" in with_term) == (free_running > 0)
    for key in without:                                       # the term draws no random numbers
        if key != "loss":
            assert torch.equal(with_term[key], without[key]), key
    added = 3.0 * (with_term["bone"] + free_running * with_term.get("free_bone", 0.0))
    assert torch.allclose(with_term["loss"], without["loss"] + added, rtol=1e-6)
    assert float(with_term["bone"]) > 0 and not with_term["bone"].requires_grad


def drift_after_training(prepared, make, rebuild, val, weights, max_steps: int) -> dict:
    """``{weight: bone drift}`` of ``val`` rebuilt by ``rebuild(model, val)`` after training
    ``make(prepared, weight)`` briefly at each weight (the term logged only when it is on)."""
    config = training.TrainConfig(epochs=100, max_steps=max_steps, lr=3e-3, batch_size=16, progress=False)
    drift = {}
    for weight in weights:
        m = make(prepared, weight)
        history = training.train(m, prepared, config)
        assert ("bone" in history.train[-1]) == (weight > 0)
        rebuilt = prepared.normalizer.denormalize(rebuild(m, val).double().numpy())
        drift[weight] = metrics.bone_length_drift(to_positions(rebuilt, FPS))
    return drift


def test_training_with_the_term_keeps_the_bones_nearer_their_lengths(prepared):
    drift = drift_after_training(prepared, model, lambda m, x: m.reconstruct(x), prepared.val.windows,
                                 (0.0, 3.0), max_steps=60)
    assert drift[3.0] < 0.8 * drift[0.0]


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf"), "1"])
def test_a_bad_weight_names_the_field(bad):
    with pytest.raises(ValueError, match="bone_weight"):
        VAELSTMConfig(bone_weight=bad)


def test_the_term_needs_the_normalizer(prepared):
    m = model(prepared, 1.0)
    m.normalizer = None
    with pytest.raises(ValueError, match="bone_weight: .*normaliser"):
        m.loss(prepared.train.windows[:2])


# ----------------------------------------------------------------------------------------
# Motegi's conv autoencoder (whose decoder also decodes the VAE's samples)
# ----------------------------------------------------------------------------------------

def conv_ae(prepared, bone: float, contact: float = 0.0) -> ConvAutoencoder:
    torch.manual_seed(0)
    m = ConvAutoencoder(ConvAEConfig(window=16, filters=8, width=5, input_dropout=0.0, bone_weight=bone,
                                     contact_weight=contact))
    m.normalizer = prepared.normalizer
    return m


def test_the_conv_autoencoders_term_adds_its_weight_times_the_bone_error(prepared):
    batch = prepared.train.windows[:8]
    assert ConvAEConfig().bone_weight == 0.0
    plain = conv_ae(prepared, 0.0).loss(batch)
    assert set(plain) == {"loss", "mse"}                           # off: the old loss, nothing added
    on = conv_ae(prepared, 2.0).loss(batch)
    assert torch.equal(on["mse"], plain["mse"]) and float(on["bone"]) > 0 and not on["bone"].requires_grad
    assert torch.isclose(on["loss"], plain["loss"] + 2.0 * on["bone"])
    both = conv_ae(prepared, 2.0, contact=1.0).loss(batch)         # each term logged, both added
    assert torch.isclose(both["loss"], plain["loss"] + 2.0 * both["bone"] + both["contact"])
    with pytest.raises(ValueError, match="bone_weight"):
        ConvAEConfig(bone_weight=-1.0)
    bare = conv_ae(prepared, 1.0)
    bare.normalizer = None
    with pytest.raises(ValueError, match="bone_weight: .*normaliser"):
        bare.loss(batch)


def test_training_the_conv_autoencoder_with_the_term_keeps_the_bones_nearer_their_lengths(prepared):
    drift = drift_after_training(prepared, conv_ae, lambda m, x: m.project(x), prepared.val.windows[:, :16],
                                 (0.0, 1.0), max_steps=80)
    assert drift[1.0] < 0.8 * drift[0.0]
