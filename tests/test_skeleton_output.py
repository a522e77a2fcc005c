"""The skeleton output layer (``models/skeleton_output.py``) and the VAE-LSTM's, the conv
autoencoder's and the LSTM-3LR's ``skeleton`` option: in each sequence every bone keeps one
length (its mean over the frames), directions and hips are the decoder's, the legs reach the
decoder's ankles by IK, each sequence keeps its own body size, a pose already on a skeleton
passes unchanged, and a model with it trains and generates bones that do not stretch (for
the conv AE, also what it decodes from features no window gave, as the VAE's samples; for
the LSTM-3LR, the primed body's bones, however long it runs, in ``generate`` and the stream)."""
import numpy as np
import pytest
import torch

from motionlab import contacts, data, metrics, training
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder
from motionlab.models.lstm import LSTMConfig, MotionLSTM
from motionlab.models.skeleton_output import SkeletonOutput, reach
from motionlab.models.vae import FeatureVAE, MotionVAE, VAEConfig
from motionlab.models.vae_lstm import VAELSTMConfig
from motionlab.representation import N_POSE, to_positions
from motionlab.skeleton import LOCOMOTION

from test_contact_term import FPS, prepared, vae_lstm  # noqa: F401 (prepared: the same small data set)


def in_metres(features: torch.Tensor, normalizer) -> np.ndarray:
    """The pose of normalised features, ``(..., frames, 21, 3)`` metres."""
    return normalizer.denormalize(features.detach().double().numpy())[..., :N_POSE].reshape(
        *features.shape[:-1], LOCOMOTION.n_joints, 3)


def stretched(prepared, seed: int = 0, noise: float = 0.3) -> torch.Tensor:
    """Training windows with noise on every joint: bones of changing lengths."""
    windows = prepared.train.windows[:3]
    return windows + noise * torch.randn(windows.shape, generator=torch.Generator().manual_seed(seed))


LEG_JOINTS = {j for leg in contacts.LEGS for j in leg[1:]}             # knees, ankles, toes: placed by IK


def test_in_each_sequence_every_bone_takes_its_mean_length_and_keeps_its_direction(prepared):
    layer, norm = SkeletonOutput(), prepared.normalizer
    x = stretched(prepared)
    out = layer(x, norm)
    assert out.shape == x.shape and torch.equal(out[..., N_POSE:], x[..., N_POSE:])        # the control passes
    before, after = in_metres(x, norm), in_metres(out, norm)
    mean_lengths = LOCOMOTION.bone_lengths(before).mean(axis=-2, keepdims=True)           # (3, 1, 20)
    np.testing.assert_allclose(LOCOMOTION.bone_lengths(after), np.broadcast_to(mean_lengths, (*x.shape[:2], 20)),
                               rtol=1e-4)
    np.testing.assert_allclose(after[..., 0, :], before[..., 0, :], atol=1e-5)             # the hips stay
    for parent, child in [bone for bone in LOCOMOTION.bones if bone[1] not in LEG_JOINTS]:
        a = before[..., child, :] - before[..., parent, :]
        b = after[..., child, :] - after[..., parent, :]
        cosine = (a * b).sum(-1) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1)
        assert cosine.min() > 1 - 1e-5, (parent, child)


def test_the_legs_reach_the_decoders_ankles_with_the_knee_on_its_side(prepared):
    layer, norm = SkeletonOutput(), prepared.normalizer
    x = stretched(prepared, noise=0.1)
    before, after = in_metres(x, norm), in_metres(layer(x, norm), norm)
    lengths = LOCOMOTION.bone_lengths(before).mean(axis=-2)                               # (3, 20)
    child = [c for _, c in LOCOMOTION.bones]
    checked = 0
    for hip, knee, ankle, toe in contacts.LEGS:
        leg = lengths[:, child.index(knee)] + lengths[:, child.index(ankle)]
        within = np.linalg.norm(before[..., ankle, :] - after[..., hip, :], axis=-1) < 0.99 * leg[:, None]
        np.testing.assert_allclose(after[..., ankle, :][within], before[..., ankle, :][within], atol=1e-4)
        checked += within.sum()
        aim = after[..., toe, :] - after[..., ankle, :]
        wanted = before[..., toe, :] - after[..., ankle, :]
        cosine = (aim * wanted).sum(-1) / np.linalg.norm(aim, axis=-1) / np.linalg.norm(wanted, axis=-1)
        assert cosine.min() > 1 - 1e-5                                      # the foot points at the toe
        bend = np.cross(before[..., knee, :] - after[..., hip, :], before[..., ankle, :] - after[..., hip, :])
        new_bend = np.cross(after[..., knee, :] - after[..., hip, :], after[..., ankle, :] - after[..., hip, :])
        assert ((bend * new_bend).sum(-1)[within] > 0).all()                # the knee bends to the same side
    assert checked > 0.75 * 2 * np.prod(x.shape[:2])                        # most frames of the noisy legs


def test_the_torch_ik_is_contacts_two_bone_ik():
    rng = np.random.default_rng(0)
    hip, knee, target = rng.normal(size=(3, 50, 3))
    thigh, shin = rng.uniform(0.5, 1.0, size=(2, 50, 1))
    knee = hip + thigh * (knee / np.linalg.norm(knee, axis=-1, keepdims=True))
    ankle = knee + shin * np.array([0.0, -1.0, 0.0])
    expected_knee, expected_ankle, reached = contacts.two_bone_ik(hip, knee, ankle, target)
    new_knee, new_ankle = reach(*(torch.tensor(a) for a in (hip, knee, target, thigh, shin)))
    np.testing.assert_allclose(new_ankle.numpy()[reached], expected_ankle[reached], atol=1e-9)
    np.testing.assert_allclose(new_knee.numpy()[reached], expected_knee[reached], atol=1e-6)
    assert 0 < reached.sum() < 50


def test_each_sequence_keeps_its_own_body_size(prepared):
    layer, norm = SkeletonOutput(), prepared.normalizer
    units = torch.tensor(norm.denormalize(prepared.train.windows[:1].numpy()))
    pose = units[..., :N_POSE].unflatten(-1, (21, 3))
    big = units.clone()
    big[..., :N_POSE] = (pose[..., :1, :] + 1.1 * (pose - pose[..., :1, :])).flatten(-2)     # 10 % larger about the hips
    both = torch.tensor(norm.normalize(torch.cat([units, big]).numpy()), dtype=torch.float32)
    lengths = LOCOMOTION.bone_lengths(in_metres(layer(both, norm), norm))[:, 0]
    np.testing.assert_allclose(lengths[1] / lengths[0], 1.1, rtol=1e-4)


def test_a_pose_on_a_skeleton_passes_unchanged(prepared):
    layer, norm = SkeletonOutput(), prepared.normalizer
    once = layer(stretched(prepared, seed=1), norm)
    np.testing.assert_allclose(layer(once, norm).detach().numpy(), once.detach().numpy(), atol=1e-4)


def test_gradients_are_finite_even_for_a_collapsed_bone(prepared):
    layer, norm = SkeletonOutput(), prepared.normalizer
    units = torch.tensor(norm.denormalize(prepared.train.windows[:1].numpy()), dtype=torch.float32)
    units[..., 3:6] = units[..., 0:3]                            # joint 1 on top of the hips
    x = torch.tensor(norm.normalize(units.numpy()), dtype=torch.float32, requires_grad=True)
    out = layer(x, norm)
    out.square().sum().backward()
    assert torch.isfinite(out).all() and torch.isfinite(x.grad).all()


def test_the_vae_lstm_option_is_off_by_default_and_needs_the_normalizer(prepared):
    assert VAELSTMConfig().skeleton is False and vae_lstm(prepared, 0.0).skeleton is None
    model = vae_lstm(prepared, 0.0, skeleton=True)
    model.normalizer = None
    with pytest.raises(ValueError, match="normalizer"):
        model.loss(prepared.train.windows[:2])


def test_a_vae_lstm_on_a_skeleton_trains_and_generates_bones_that_do_not_stretch(prepared):
    config = training.TrainConfig(epochs=100, max_steps=40, lr=3e-3, batch_size=16, progress=False)
    free, on_skeleton = vae_lstm(prepared, 0.0), vae_lstm(prepared, 0.0, skeleton=True)
    drift = {}
    for name, model in (("free", free), ("skeleton", on_skeleton)):
        history = training.train(model, prepared, config)
        assert history.train[-1]["loss"] < history.train[0]["loss"]
        control = prepared.normalizer.denormalize(prepared.val.windows[0].double().numpy())[:, N_POSE:]
        drift[name] = metrics.bone_length_drift(model.generate(control, n=2, seed=0).positions)
        rebuilt = prepared.normalizer.denormalize(model.reconstruct(prepared.val.windows).double().numpy())
        drift[name, "reconstructed"] = metrics.bone_length_drift(to_positions(rebuilt, FPS))
    assert drift["skeleton"] < 1e-4 and drift["skeleton", "reconstructed"] < 1e-4
    assert drift["free"] > 100 * drift["skeleton"]                    # the same model without it stretches


@pytest.mark.parametrize("name", ["vae_lstm", "conv_ae", "lstm"])
def test_a_checkpoint_keeps_the_option(tmp_path, prepared, name):
    build = {"vae_lstm": lambda: vae_lstm(prepared, 0.0, skeleton=True),
             "conv_ae": lambda: conv_ae(prepared, skeleton=True), "lstm": lambda: lstm(prepared, skeleton=True)}
    model = build[name]()
    path = tmp_path / f"{name}.pt"
    training.save_checkpoint(path, model, prepared)
    loaded = training.load_checkpoint(path).model
    assert loaded.config.skeleton is True
    x = prepared.val.windows[:2]
    rebuild = {"vae_lstm": lambda m: m.reconstruct(x), "conv_ae": lambda m: m.project(x),
               "lstm": lambda m: m(x[:, :-1], x[:, 1:, N_POSE:])[0]}[name]
    with torch.no_grad():
        torch.testing.assert_close(rebuild(loaded), rebuild(model))


@pytest.mark.parametrize("distance", [0.0, 0.5, 1.5, 1.5 + 1e-9, 3.0])    # on the hip, bent, straight, beyond
def test_the_torch_ik_has_finite_gradients_at_any_reach(distance):
    hip = torch.zeros(1, 3, dtype=torch.float64)
    knee = torch.tensor([[0.0, -0.7, 0.2]], dtype=torch.float64)
    target = torch.tensor([[0.0, -distance, 0.0]], dtype=torch.float64, requires_grad=True)
    thigh, shin = (torch.full((1, 1), 0.75, dtype=torch.float64, requires_grad=True) for _ in range(2))
    new_knee, new_ankle = reach(hip, knee, target, thigh, shin)
    (new_knee.sum() + new_ankle.sum()).backward()
    assert all(torch.isfinite(t).all() for t in (new_knee, new_ankle, target.grad, thigh.grad, shin.grad))
    assert (new_ankle - hip).norm() <= 1.5 + 1e-9                        # never beyond the leg's length


# ------------------------------------------------------- the conv autoencoder's option (and the VAE's samples)

def conv_ae(prepared, **changes) -> ConvAutoencoder:
    torch.manual_seed(0)
    model = ConvAutoencoder(ConvAEConfig(window=16, filters=8, width=5, input_dropout=0.0, **changes))
    model.normalizer = prepared.normalizer
    return model


def test_a_conv_ae_on_a_skeleton_trains_and_decodes_bones_that_do_not_stretch(prepared):
    config = training.TrainConfig(epochs=100, max_steps=40, lr=3e-3, batch_size=16, progress=False)
    drift = {}
    for name, model in (("free", conv_ae(prepared)), ("skeleton", conv_ae(prepared, skeleton=True))):
        history = training.train(model, prepared, config)
        assert history.train[-1]["loss"] < history.train[0]["loss"]
        rebuilt = in_metres(model.project(prepared.val.windows), prepared.normalizer)
        drift[name] = metrics.bone_length_drift(rebuilt)
        # features no window encodes to (as the VAE's samples are): still one length per bone
        y = torch.randn(3, 8, 8, generator=torch.Generator().manual_seed(1)).abs()
        with torch.no_grad():
            drift[name, "decoded"] = metrics.bone_length_drift(in_metres(model.decode(y), prepared.normalizer))
        if name == "skeleton":
            vae = FeatureVAE(VAEConfig(n_inputs=8 * 8, hidden=16, latent=2))
            features = model.encode(prepared.train.windows).flatten(1).detach()
            motion_vae = MotionVAE(vae, model, data.Normalizer.fit(features.numpy()), prepared.normalizer)
            drift[name, "sampled"] = metrics.bone_length_drift(motion_vae.generate(n=3, seed=0).positions)
    assert max(drift["skeleton"], drift["skeleton", "decoded"], drift["skeleton", "sampled"]) < 1e-4
    assert drift["free"] > 100 * drift["skeleton"] and drift["free", "decoded"] > 0.01


# ------------------------------------------------------- the LSTM-3LR's option: the primed body's bones

def lstm(prepared, control: str = "given", **changes) -> MotionLSTM:
    torch.manual_seed(0)
    model = MotionLSTM(LSTMConfig(window=16, hidden=16, layers=2, control=control, **changes))
    model.normalizer = prepared.normalizer
    return model


# model -> (its config class, a config it cannot serve, the words of that error, what needs the normaliser)
REFUSALS = {
    "conv_ae": (ConvAEConfig, {"n_features": 58}, "skeleton: needs the 66 locomotion features", lambda m, x: m(x)),
    "lstm": (LSTMConfig, {"n_pose": 60}, "skeleton: needs the locomotion features", lambda m, x: m.loss(x)),
}


@pytest.mark.parametrize("name", sorted(REFUSALS))
def test_the_option_is_off_by_default_and_refuses_what_it_cannot_serve(prepared, name):
    config_class, bad, words, run = REFUSALS[name]
    build = conv_ae if name == "conv_ae" else lstm
    assert config_class().skeleton is False and build(prepared).skeleton is None
    with pytest.raises(ValueError, match=words):
        config_class(**bad, skeleton=True)
    model = build(prepared, skeleton=True)
    if name == "conv_ae":
        assert model.trace(prepared.train.windows[:2])[-1][0].startswith("put onto a skeleton")
    model.normalizer = None
    with pytest.raises(ValueError, match="normali[sz]er"):
        run(model, prepared.train.windows[:2])


def test_a_pose_is_put_onto_the_bones_of_the_frame_it_was_predicted_from(prepared):
    model, norm = lstm(prepared, skeleton=True), prepared.normalizer
    x = prepared.val.windows[:2]
    with torch.no_grad():
        prediction, _ = model(x[:, :-1], x[:, 1:, N_POSE:])                               # (2, frames - 1, 63)
    prediction = torch.cat([prediction, x[:, 1:, N_POSE:]], dim=-1)
    np.testing.assert_allclose(LOCOMOTION.bone_lengths(in_metres(prediction, norm)),
                               LOCOMOTION.bone_lengths(in_metres(x[:, :-1], norm)), rtol=1e-4)


@pytest.mark.parametrize("control", ["given", "predicted"])
def test_an_lstm_on_a_skeleton_trains_and_keeps_the_primed_bodys_bones(prepared, control):
    config = training.TrainConfig(epochs=100, max_steps=30, lr=3e-3, batch_size=16, progress=False)
    norm, prefix = prepared.normalizer, prepared.val.windows[:2, :4]
    body = LOCOMOTION.bone_lengths(in_metres(prefix[:, -1], norm))                       # (2, 20)
    changed = {}
    for name, model in (("free", lstm(prepared, control)), ("skeleton", lstm(prepared, control, skeleton=True))):
        history = training.train(model, prepared, config)
        assert history.train[-1]["loss"] < history.train[0]["loss"]
        control_signal = prepared.val.windows[:2, :, N_POSE:].repeat(1, 4, 1)             # 4 windows long
        sampled = model.sample(prefix, control_signal.shape[1], control_signal)
        bones = LOCOMOTION.bone_lengths(in_metres(sampled[:, 4:], norm))                   # (2, frames, 20)
        changed[name] = np.abs(bones / body[:, None] - 1).max()
    assert changed["skeleton"] < 1e-4                                   # the primed body's bones, every frame
    assert changed["free"] > 100 * changed["skeleton"]                  # the free read-out stretches them


def test_the_lstm_stream_keeps_the_bones_and_matches_generate(prepared):
    model = lstm(prepared, skeleton=True)
    norm = prepared.normalizer
    history = norm.denormalize(prepared.val.windows[:1, :4].double().numpy())
    control = norm.denormalize(prepared.val.windows[1:2].double().numpy())[0, :, N_POSE:]
    stream = model.stream(history, normalizer=norm)
    streamed = np.stack([stream.step(c).numpy() for c in control], axis=1)              # (1, frames, 66)
    generated = model.generate(control, prefix=history).features
    np.testing.assert_allclose(streamed, generated, atol=1e-4)
    positions = to_positions(np.concatenate([history, streamed], axis=1), FPS)
    assert metrics.bone_length_drift(positions) < 1e-5
