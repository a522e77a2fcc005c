"""The foot-contact velocity term (HuMoR, EDGE, MDM) in the VAE-LSTM's and DFN's losses: off
by default and then bit for bit the old loss; on, the data's planted feet must stay still in
the world in the reconstruction."""
from dataclasses import replace

import numpy as np
import pytest
import torch

from motionlab import contacts, data, training
from motionlab.models.dfn import DFN, DFNConfig
from motionlab.models.vae_lstm import VAELSTM, VAELSTMConfig
from motionlab.representation import to_positions
from motionlab.rotations import y_rotation
from motionlab.skeleton import FEET

FPS = 20.0
VAE_LSTM = VAELSTMConfig(window=16, width=5, control_filters=4, control_code=6, inference_filters=8, units=5,
                         decoder_filters=8)
DFN_SMALL = DFNConfig(frame_hidden=32, pose_code=6, velocity_code=2, horizon=4, summary=8, past=16, future=4,
                      current=4, future_prior_hidden=16, current_prior_hidden=16, summary_decoder_hidden=16,
                      current_posterior_hidden=8, future_posterior_hidden=16, td_hidden=8, td_max_skip=2)


@pytest.fixture(scope="module")
def prepared():
    return data.prepare(data.load("synthetic", fps=FPS, n_clips=6, duration_s=4), window_s=0.8)


def vae_lstm(prepared, weight: float, **changes) -> VAELSTM:
    torch.manual_seed(0)
    model = VAELSTM(replace(VAE_LSTM, contact_weight=weight, **changes))
    model.normalizer = prepared.normalizer
    return model


def dfn(prepared, weight: float, stage: str = "frame") -> DFN:
    torch.manual_seed(0)
    model = DFN(replace(DFN_SMALL, contact_weight=weight))
    model.normalizer = prepared.normalizer
    model.set_stage("frame", prepared.train.windows)
    if stage == "sequence":
        model.set_stage("sequence", prepared.train.windows)
    return model


def loss_and_decoder_grad(model, batch, decoder) -> tuple[dict, torch.Tensor]:
    model.zero_grad()
    torch.manual_seed(5)                                   # the same posterior samples and dropout
    terms = model.loss(batch)
    terms["loss"].backward()
    return terms, torch.cat([p.grad.flatten() for p in decoder.parameters() if p.grad is not None])


# ----------------------------------------------------------------------------------------
# The term itself
# ----------------------------------------------------------------------------------------

def test_foot_velocity_is_the_world_velocity_of_the_feet_in_the_roots_axes(prepared):
    features = prepared.in_data_units(prepared.train.windows[:3])
    positions = to_positions(features, FPS)
    heading = np.stack([np.concatenate([[0.0], np.cumsum(f[:-1, -1]) / FPS]) for f in features])
    world = np.diff(positions[..., FEET, :], axis=1) * FPS                              # (n, frames - 1, 4, 3)
    seen_from_root = np.einsum("nfba,nfjb->nfja", y_rotation(heading[:, :-1]), world)    # R(heading)^T v
    velocity = contacts.foot_velocity(torch.tensor(features), FPS).numpy()
    assert np.allclose(velocity, seen_from_root[..., [0, 2]], atol=1e-9)


def test_the_term_weighs_the_squared_velocity_by_the_datas_contacts(prepared):
    target = torch.tensor(prepared.in_data_units(prepared.train.windows[:4]))
    prediction = target.clone()
    prediction[..., 63] += 0.5                           # the body runs 0.5 m/s faster over planted feet
    labels = contacts.contact_labels(target, FPS)
    assert 0.2 < float(labels.mean()) < 0.9
    expected = (labels * contacts.foot_velocity(prediction, FPS).square().sum(-1)).mean()
    assert torch.equal(contacts.contact_velocity_loss(prediction, target, FPS), expected)
    # the data's planted feet barely move; the sliding ones move at about 0.5 m/s more
    own = float(contacts.contact_velocity_loss(target, target, FPS))
    assert own < 0.01 and float(expected) > own + 0.2 * float(labels.mean())
    with pytest.raises(ValueError, match="prediction, target"):
        contacts.contact_velocity_loss(prediction[:, 1:], target, FPS)


# ----------------------------------------------------------------------------------------
# Off by default: nothing changes
# ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("free_running", [0.0, 1.0])
def test_vae_lstm_loss_is_unchanged_without_the_term(prepared, free_running):
    batch = prepared.train.windows[:4]
    assert VAELSTMConfig().contact_weight == 0.0 and DFNConfig().contact_weight == 0.0
    plain = vae_lstm(prepared, 0.0, free_running=free_running)
    torch.manual_seed(5)
    with_normalizer = plain.loss(batch)
    plain.normalizer = None                               # the term needs none when it is off
    torch.manual_seed(5)
    without = plain.loss(batch)
    assert "contact" not in without and "free_contact" not in without
    assert with_normalizer.keys() == without.keys()
    assert all(torch.equal(with_normalizer[k], without[k]) for k in without)
    on = vae_lstm(prepared, 2.0, free_running=free_running)
    torch.manual_seed(5)
    with_term = on.loss(batch)
    for key in without:                                   # the term draws no random numbers
        if key != "loss":
            assert torch.equal(with_term[key], without[key]), key
    added = 2.0 * (with_term["contact"] + free_running * with_term.get("free_contact", 0.0))
    assert torch.allclose(with_term["loss"], without["loss"] + added, rtol=1e-6)


@pytest.mark.parametrize("stage", ["frame", "sequence"])
def test_dfn_loss_is_unchanged_without_the_term(prepared, stage):
    batch = prepared.train.windows[:4]
    plain, on = dfn(prepared, 0.0, stage), dfn(prepared, 0.5, stage)
    torch.manual_seed(5)
    with_normalizer = plain.loss(batch)
    plain.normalizer = None
    torch.manual_seed(5)
    without = plain.loss(batch)
    assert "contact" not in without and all(torch.equal(with_normalizer[k], without[k]) for k in without)
    torch.manual_seed(5)
    with_term = on.loss(batch)
    assert torch.allclose(with_term["loss"], without["loss"] + 0.5 * with_term["contact"], rtol=1e-6)


# ----------------------------------------------------------------------------------------
# On: the term is what it says, and trains the decoder
# ----------------------------------------------------------------------------------------

def test_vae_lstm_term_moves_the_reconstructed_pose_along_the_true_control(prepared):
    batch = prepared.train.windows[:4]
    model = vae_lstm(prepared, 1.0, free_running=0.0)
    torch.manual_seed(5)
    terms = model.loss(batch)
    torch.manual_seed(5)
    reconstruction = model(batch)["reconstruction"]
    # generation returns the model's pose with the given control: the decoded control is not judged
    moved = torch.cat([reconstruction[..., :63], batch[..., 63:]], -1)
    norm = prepared.normalizer
    expected = contacts.contact_velocity_loss(norm.denormalize(moved), norm.denormalize(batch), FPS)
    assert torch.allclose(terms["contact"], expected, rtol=1e-5)
    assert float(terms["contact"]) > 0.05                 # an untrained model's planted feet slide


@pytest.mark.parametrize("which", ["vae_lstm", "dfn frame", "dfn sequence"])
def test_the_term_is_positive_and_its_gradient_reaches_the_decoder(prepared, which):
    batch = prepared.train.windows[:4]
    if which == "vae_lstm":
        models = [vae_lstm(prepared, w) for w in (0.0, 3.0)]
        decoders = [m.decoder for m in models]
    else:
        stage = which.split()[1]
        models = [dfn(prepared, w, stage) for w in (0.0, 3.0)]
        decoders = [m.frame if stage == "frame" else m.sequence for m in models]
    (_, without), (terms, with_term) = (loss_and_decoder_grad(m, batch, d) for m, d in zip(models, decoders))
    assert float(terms["contact"]) > 0 and not terms["contact"].requires_grad
    assert (with_term - without).norm() > 1e-3 * without.norm()
    if which == "vae_lstm":
        assert float(terms["free_contact"]) > 0


def test_training_with_the_term_keeps_planted_feet_stiller(prepared):
    val = prepared.val.windows
    config = training.TrainConfig(epochs=100, max_steps=60, lr=3e-3, batch_size=16, progress=False)

    def vae_lstm_term(model) -> float:                   # the training form: it learns within a few steps
        r = model.reconstruct(val)
        return float(model.contact_term(torch.cat([r[..., :63], val[..., 63:]], -1), val))

    after = {}                                            # the held-out windows' term after training
    for weight in (0.0, 10.0):
        model = vae_lstm(prepared, weight)
        before = vae_lstm_term(model)
        history = training.train(model, prepared, config)
        after[weight] = vae_lstm_term(model)
        assert ("contact" in history.train[-1]) == (weight > 0)
    assert after[10.0] < before and after[10.0] < 0.9 * after[0.0]

    dfn_after = {}
    for weight in (0.0, 1.0):
        torch.manual_seed(0)
        model = DFN(replace(DFN_SMALL, contact_weight=weight))
        training.train_stages(model, prepared, config, stages=("frame",))
        dfn_after[weight] = float(model.contact_term(model.reconstruct(val), val))
    assert dfn_after[1.0] < 0.8 * dfn_after[0.0]


# ----------------------------------------------------------------------------------------
# Bad values, a missing normaliser, checkpoints
# ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("config_class", [VAELSTMConfig, DFNConfig])
@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf"), "1"])
def test_a_bad_weight_names_the_field(config_class, bad):
    with pytest.raises(ValueError, match="contact_weight"):
        config_class(contact_weight=bad)


def test_the_term_needs_the_normalizer(prepared):
    model = vae_lstm(prepared, 1.0)
    model.normalizer = None
    with pytest.raises(ValueError, match="contact_weight: .*normaliser"):
        model.loss(prepared.train.windows[:2])


def test_checkpoints_keep_the_weight_and_older_ones_load_without_it(tmp_path, prepared):
    model = vae_lstm(prepared, 2.5)
    path = tmp_path / "vae_lstm.pt"
    training.save_checkpoint(path, model, prepared)
    assert training.load_checkpoint(path).model.config.contact_weight == 2.5
    state = torch.load(path, weights_only=True)
    del state["config"]["contact_weight"]                 # a checkpoint saved before the term existed
    torch.save(state, path)
    loaded = training.load_checkpoint(path)
    assert loaded.model.config == replace(model.config, contact_weight=0.0)
    assert training.load_checkpoint(path, config=replace(model.config, contact_weight=0.0))


# ----------------------------------------------------------------------------------------
# Motegi's conv autoencoder (and through its decoder, the VAE's samples)
# ----------------------------------------------------------------------------------------

def test_the_conv_autoencoders_contact_term(prepared):
    from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder

    def model(weight: float) -> ConvAutoencoder:
        torch.manual_seed(0)
        m = ConvAutoencoder(ConvAEConfig(window=16, filters=8, width=5, input_dropout=0.0, contact_weight=weight))
        m.normalizer = prepared.normalizer
        return m

    batch = prepared.train.windows[:8]
    off, on = model(0.0), model(1.0)
    plain = off.loss(batch)
    assert set(plain) == {"loss", "mse"}                           # off: the old loss, nothing added
    torch.manual_seed(1)
    terms, grad = loss_and_decoder_grad(on, batch, on.decoder)
    assert terms["contact"] > 0 and torch.isclose(terms["loss"], plain["loss"] + terms["contact"])
    assert grad.abs().sum() > 0
    steps = training.train(model(3.0), prepared, training.TrainConfig(epochs=3, lr=3e-3, progress=False))
    assert steps.last("contact") < steps.train[0]["contact"]       # training lowers it
    bare = model(1.0)
    bare.normalizer = None
    with pytest.raises(ValueError, match="contact_weight"):
        bare.loss(batch)
    with pytest.raises(ValueError, match="contact_weight"):
        ConvAEConfig(contact_weight=-1.0)
