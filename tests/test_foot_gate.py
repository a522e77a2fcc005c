"""The VAE-LSTM's gated feet (``foot_gate``): the decoder gives, per frame, the probability
that each ankle and toe has stayed planted since the previous frame; a foot held by the gate
does not move in the world, one the gate lets go is the decoder's; the gate is trained on the
data's contact labels, and ``generate`` returns where it holds the feet."""
import numpy as np
import pytest
import torch
import torch.nn.functional as F

from motionlab import contacts, training
from motionlab.models.anchor import FOOT_XZ
from motionlab.models.vae_lstm import N_FEET, VAELSTM, VAELSTMConfig
from motionlab.representation import N_POSE

from test_contact_term import FPS, VAE_LSTM, prepared, vae_lstm  # noqa: F401 (prepared: the same small data set)


def control_of(prepared, window: int = 0) -> np.ndarray:
    return prepared.normalizer.denormalize(prepared.val.windows[window].double().numpy())[:, N_POSE:]


def world_speed(model, features: torch.Tensor) -> torch.Tensor:
    """Each foot joint's horizontal world speed between frames, m/s ``(batch, frames - 1, 4)``."""
    return contacts.foot_velocity(model.normalizer.denormalize(features.float()), FPS).norm(dim=-1)


def test_off_by_default_and_refused_where_it_cannot_work(prepared):
    assert VAELSTMConfig().foot_gate is False
    assert vae_lstm(prepared, 0.0).decoder.conv1.out_channels == VAE_LSTM.n_features
    assert vae_lstm(prepared, 0.0, foot_gate=True).decoder.conv1.out_channels == VAE_LSTM.n_features + N_FEET
    with pytest.raises(ValueError, match="foot_gate"):
        VAELSTMConfig(n_pose=30, foot_gate=True)
    model = vae_lstm(prepared, 0.0, foot_gate=True)
    canvas = torch.zeros(1, 4, VAE_LSTM.units)
    with pytest.raises(ValueError, match="control"):
        model.decode(canvas)
    with pytest.raises(ValueError, match="control"):
        model.decode(canvas, torch.zeros(1, 15, 3))
    model.normalizer = None
    with pytest.raises(ValueError, match="foot_gate.*normaliser"):
        model.loss(prepared.train.windows[:2])


def test_a_held_foot_stays_put_in_the_world_and_a_free_one_is_the_decoders(prepared):
    model = vae_lstm(prepared, 0.0, foot_gate=True)
    windows = prepared.train.windows[:3]
    control = windows[..., N_POSE:]
    held = model.gate_feet(windows, torch.ones(*windows.shape[:2], N_FEET), control)
    assert world_speed(model, held).max() < 1e-4                       # planted: no world motion at all
    assert world_speed(model, windows).max() > 0.5                     # the data's feet do move
    torch.testing.assert_close(held[:, 0], windows[:, 0])              # the first frame is the decoder's
    others = [i for i in range(windows.shape[-1]) if i not in FOOT_XZ]
    torch.testing.assert_close(held[..., others], windows[..., others])  # heights, legs, control untouched
    free = model.gate_feet(windows, torch.zeros(*windows.shape[:2], N_FEET), control)
    torch.testing.assert_close(free, windows)
    # one joint held from frame 5 on, the rest free
    gate = torch.zeros(*windows.shape[:2], N_FEET)
    gate[:, 5:, 1] = 1.0
    mixed = world_speed(model, model.gate_feet(windows, gate, control))
    assert mixed[:, 4:, 1].max() < 1e-4
    torch.testing.assert_close(mixed[..., [0, 2, 3]], world_speed(model, windows)[..., [0, 2, 3]])


def test_a_released_foot_eases_back_to_the_decoders_without_a_jump(prepared):
    windows = prepared.train.windows[:3]
    gate = torch.zeros(*windows.shape[:2], N_FEET)
    gate[:, 1:6] = 1.0                                                 # held over frames 0-5, then let go
    std = torch.as_tensor(prepared.normalizer.std[list(FOOT_XZ)], dtype=torch.float32)
    out, jump, gap = {}, {}, {}
    for release_s in (0.0, 0.1):
        model = vae_lstm(prepared, 0.0, foot_gate=True, gate_release_s=release_s)
        out[release_s] = model.gate_feet(windows, gate, windows[..., N_POSE:])
        velocity = contacts.foot_velocity(model.normalizer.denormalize(out[release_s].float()), FPS)
        jump[release_s] = (velocity[:, 5] - velocity[:, 4]).norm(dim=-1).mean()    # the step into frame 6
        gap[release_s] = ((out[release_s] - windows)[..., list(FOOT_XZ)] * std).abs().amax(dim=(0, 2))
    assert gap[0.0][5] > 0.02                                          # the hold took the foot away from it
    assert gap[0.0][6:].max() < 1e-6                                   # without easing it jumps back at once
    assert jump[0.1] < 0.5 * jump[0.0]                                 # eased, its velocity hardly jumps
    assert gap[0.1][-1] < 0.25 * gap[0.1][5]                           # and the gap closes (10 frames, 5 half-lives)


def test_the_contact_loss_is_the_gates_likelihood_of_the_datas_labels(prepared):
    model = vae_lstm(prepared, 1.0, foot_gate=True)
    batch = prepared.train.windows[:4]
    torch.manual_seed(1)
    out = model.loss(batch)
    assert {"contacts", "free_contacts", "contact", "free_contact"} <= set(out)
    logits = torch.randn(*batch.shape[:2], N_FEET)
    labels = contacts.contact_labels(model.normalizer.denormalize(batch.float()), FPS)
    expected = F.binary_cross_entropy_with_logits(logits[:, 1:], labels, reduction="sum") / labels[..., 0].numel()
    torch.testing.assert_close(model.contact_nats(logits, batch), expected)
    # an untrained gate says about 1/2 for each of four joints: about 4 ln 2 nats per frame
    assert abs(float(out["contacts"]) - 4 * np.log(2)) < 1.0
    assert "contacts" not in vae_lstm(prepared, 1.0).loss(batch)


def test_sample_returns_where_the_gate_holds_the_feet(prepared):
    model = vae_lstm(prepared, 0.0, foot_gate=True)
    control = prepared.val.windows[:2, :, N_POSE:]
    a, planted = model.sample(control, generator=torch.Generator().manual_seed(3), gate=True)
    b = model.sample(control, generator=torch.Generator().manual_seed(3))
    torch.testing.assert_close(a, b)
    assert planted.shape == (2, control.shape[1], N_FEET) and ((planted >= 0) & (planted <= 1)).all()
    # the model holds its own feet: generate gives the lock no contacts to hold besides
    assert model.generate(control_of(prepared), seed=3).contacts is None
    with pytest.raises(ValueError, match="gate"):
        vae_lstm(prepared, 0.0).sample(control, gate=True)
    # where the gate holds a foot (above one half), that foot does not move in the world
    model.decoder.conv1.bias.data[-N_FEET:] = 20.0
    held, planted = model.sample(control, gate=True)
    assert (planted > 0.5).all()
    assert world_speed(model, held).max() < 1e-3
    model.decoder.conv1.bias.data[-N_FEET:] = -20.0                    # let go everywhere: the decoder's feet
    free, planted = model.sample(control, gate=True)
    assert (planted < 0.5).all() and world_speed(model, free).max() > 0.1


@pytest.mark.slow
def test_training_teaches_the_gate_and_a_checkpoint_keeps_it(tmp_path, prepared):
    model = vae_lstm(prepared, 1.0, foot_gate=True)
    config = training.TrainConfig(epochs=1000, max_steps=200, lr=3e-3, batch_size=16, progress=False)
    history = training.train(model, prepared, config)
    # below what the labels' rate alone gives (each joint's entropy): the gate reads the motion
    rate = contacts.contact_labels(prepared.normalizer.denormalize(prepared.train.windows.float()), FPS)
    rate = rate.mean(dim=(0, 1)).double()
    entropy = float(-(rate * rate.log() + (1 - rate) * (1 - rate).log()).sum())
    assert np.mean([step["contacts"] for step in history.train[-20:]]) < 0.9 * entropy
    path = tmp_path / "vae_lstm.pt"
    model = vae_lstm(prepared, 1.0, foot_gate=True, skeleton=True, gate_release_s=0.2)
    training.save_checkpoint(path, model, prepared)
    loaded = training.load_checkpoint(path).model
    assert isinstance(loaded, VAELSTM) and loaded.config == model.config
    x = prepared.val.windows[:2]
    torch.testing.assert_close(loaded.reconstruct(x), model.reconstruct(x))
