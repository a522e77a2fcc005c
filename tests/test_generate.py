"""One generation contract: every generative model answers the same ``generate`` call
(:mod:`motionlab.models.base`), checked here by one piece of code over all of them."""
import copy

import numpy as np
import pytest
import torch

from motionlab import data, pretrained
from motionlab.models.base import Generated, GenerativeModel, eval_mode
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder
from motionlab.models.dfn import DFN, DFNConfig
from motionlab.models.flows import AffineCoupling
from motionlab.models.glow import Glow, GlowConfig
from motionlab.models.lstm import LSTMConfig, MotionLSTM
from motionlab.models.moglow import MoGlow, MoGlowConfig
from motionlab.models.vae import FeatureVAE, MotionVAE, VAEConfig
from motionlab.models.vae_lstm import VAELSTM, VAELSTMConfig

FRAMES, PREFIX = 16, 8


@pytest.fixture(scope="module")
def prepared():
    return data.prepare(data.load("synthetic", fps=20, n_clips=6, seed=0), window_s=2.0, seed=0)


def motion_vae(prepared):
    conv_ae = ConvAutoencoder(ConvAEConfig(window=FRAMES, filters=4))
    features = conv_ae.encode(prepared.train.windows[:, :FRAMES]).flatten(1).detach()
    return MotionVAE(FeatureVAE(VAEConfig(n_inputs=features.shape[1], hidden=8, latent=3)), conv_ae,
                     data.Normalizer.fit(features.numpy()), prepared.normalizer)


MAKERS = {
    "vae": motion_vae,
    "vae_lstm": lambda p: VAELSTM(VAELSTMConfig(window=16, width=5, control_filters=4, control_code=6,
                                                inference_filters=8, units=8, decoder_filters=8)),
    "lstm": lambda p: MotionLSTM(LSTMConfig(hidden=8, layers=1)),
    "lstm_given_control": lambda p: MotionLSTM(LSTMConfig(hidden=8, layers=1, control="given")),
    "glow": lambda p: Glow(GlowConfig(window=16, levels=2, steps=2, hidden=8)),
    "glow_unconditional": lambda p: Glow(GlowConfig(window=16, levels=2, steps=2, hidden=8, conditional=False)),
    "glow_contacts": lambda p: Glow(GlowConfig(window=16, levels=2, steps=2, hidden=8, contact_head=True)),
    "moglow": lambda p: MoGlow(MoGlowConfig(window=16, history=4, steps=2, hidden=8)),
    "moglow_markov": lambda p: MoGlow(MoGlowConfig(window=16, history=4, steps=2, hidden=8, recurrent=False)),
    "dfn": lambda p: DFN(DFNConfig()),
}
STOCHASTIC = {"vae", "vae_lstm", "glow", "glow_unconditional", "glow_contacts", "moglow", "moglow_markov", "dfn"}
IGNORE_CONTROL = {"vae", "glow_unconditional", "dfn"}     # no control input (the LSTM-3LR feeds a given one back)


@pytest.fixture(scope="module")
def models(prepared):
    torch.manual_seed(0)
    made = {name: make(prepared) for name, make in MAKERS.items()}
    for model in made.values():
        model.normalizer = prepared.normalizer
    return made


@pytest.fixture(scope="module")
def real(prepared):
    return prepared.normalizer.denormalize(prepared.test.windows[:2].numpy())        # (2, 40, 66) data units


def call(model, real, **changes):
    """The same call for every model: what it does not use, it ignores or refuses by name."""
    arguments = dict(control=real[:, PREFIX:PREFIX + FRAMES, 63:], frames=FRAMES, n=2, temperature=0.7, seed=3)
    if model.continues_motion:
        arguments["prefix"] = real[:, :PREFIX]
    return model.generate(**{**arguments, **changes})


@pytest.mark.parametrize("name", MAKERS)
def test_every_model_answers_the_same_call(models, real, name):
    model = models[name]
    assert isinstance(model, GenerativeModel)
    result = call(model, real)
    assert isinstance(result, Generated) and result.fps == 20.0
    assert result.features.shape == (2, FRAMES, 66)                   # the prefix is never prepended
    assert result.positions.shape == (2, FRAMES, 21, 3)
    assert np.isfinite(result.features).all() and np.isfinite(result.positions).all()
    assert np.array_equal(result.features, call(model, real).features)                 # the seed decides
    if name in STOCHASTIC:
        assert not np.array_equal(result.features, call(model, real, seed=4).features)
    if name not in IGNORE_CONTROL:                                     # the control is followed as given
        assert np.allclose(result.features[..., 63:], real[:, PREFIX:PREFIX + FRAMES, 63:], atol=1e-4)
    else:                                                              # ... or ignored, as documented
        assert np.array_equal(result.features, call(model, real, control=-real[:, :FRAMES, 63:]).features)


@pytest.mark.parametrize("name", MAKERS)
def test_every_model_refuses_bad_arguments_by_name(models, real, name):
    model = models[name]
    for changes, word in [({"n": 0}, "n"), ({"temperature": -1.0}, "temperature"), ({"seed": -1}, "seed"),
                          ({"seed": 1.5}, "seed")]:
        with pytest.raises(ValueError, match=word):
            call(model, real, **changes)
    if model.continues_motion:
        if name == "vae_lstm":                                     # optional: without one, z_1 ~ prior
            assert call(model, real, prefix=None).features.shape == (2, FRAMES, 66)
        else:
            with pytest.raises(ValueError, match="prefix"):
                call(model, real, prefix=None)
        with pytest.raises(ValueError, match="prefix"):
            call(model, real, prefix=real[:, :PREFIX, :63])
    else:
        with pytest.raises(ValueError, match="prefix: .* does not continue motion"):
            call(model, real, prefix=real[:, :PREFIX])
    if model.follows_control:
        with pytest.raises(ValueError, match="control"):
            call(model, real, control=None)
        with pytest.raises(ValueError, match="control"):
            call(model, real, control=np.full((FRAMES, 3), np.nan))


@pytest.mark.parametrize("name", [n for n in MAKERS if n != "vae"])
def test_generate_needs_a_normalizer_and_restores_the_training_mode(prepared, real, name):
    model = MAKERS[name](prepared)
    model.train()
    with pytest.raises(ValueError, match="no normaliser"):
        call(model, real)
    model.normalizer = prepared.normalizer
    call(model, real)
    assert model.training                                              # back in the mode it was in


def test_eval_mode_restores_the_mode_even_when_the_block_raises():
    model = torch.nn.Linear(2, 2).train()
    with pytest.raises(RuntimeError):
        with eval_mode(model):
            assert not model.training
            raise RuntimeError("shape error")
    assert model.training


def test_one_control_row_per_frame_for_all_samples_broadcasts(models, real):
    model = models["moglow"]
    one = model.generate(real[0, PREFIX:PREFIX + FRAMES, 63:], prefix=real[0, :PREFIX], n=3, seed=0)
    assert one.features.shape == (3, FRAMES, 66)
    with pytest.raises(ValueError, match="frames"):
        model.generate(real[0, PREFIX:PREFIX + FRAMES, 63:], frames=FRAMES + 1, prefix=real[0, :PREFIX])


def test_the_shipped_models_load_ready_to_generate(real):
    assert set(pretrained.available()) == set(pretrained.NAMES)
    walk = np.tile([1.3, 0.0, 0.0], (20, 1))
    for name in pretrained.available():
        model = pretrained.load(name)
        assert model.normalizer is not None and model.history.train, name
        if name == "conv_ae":
            assert not model.training
            continue
        prefix = real[0, :model.config.history] if name.startswith("moglow") else (
            real[0, :8] if name.startswith("lstm") or name == "dfn" else None)
        control = None if name in ("vae", "dfn") else walk
        frames = model.conv_ae.config.window if name == "vae" else (20 if name == "dfn" else None)
        result = model.generate(control, frames=frames, prefix=prefix, n=2, temperature=0.3, seed=0)
        assert result.features.shape[0] == 2 and np.isfinite(result.positions).all(), name
    with pytest.raises(ValueError, match="name: expected one of"):
        pretrained.load("moglow_paper")


@pytest.mark.parametrize("name", ["glow", "moglow", "moglow_markov", "lstm"])
def test_samples_that_are_not_finite_are_refused_by_name(models, real, name):
    """A flow whose inverse overflows (a coupling's scale near 0, which the inverse divides by) or a model
    with broken weights makes NaN/inf: generate refuses them, naming the temperature for a flow."""
    model = copy.deepcopy(models[name])
    with torch.no_grad():
        if name == "lstm":
            next(model.parameters()).fill_(float("nan"))
            expected = "generate: MotionLSTM made 2 of 2 samples that are not finite"
        else:                                         # raw scale -200: the inverse multiplies by about e^198
            coupling = next(m for m in model.modules() if isinstance(m, AffineCoupling))
            last = [m for m in coupling.network.modules()
                    if isinstance(getattr(m, "bias", None), torch.Tensor) and m.bias.shape == (2 * coupling.n_hi,)][-1]
            last.bias[coupling.n_hi:] = -200.0
            expected = f"temperature: {type(model).__name__} made 2 of 2 samples that are not finite"
    with pytest.raises(ValueError, match=expected):
        call(model, real)
