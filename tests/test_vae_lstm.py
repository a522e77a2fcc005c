"""The VAE-LSTM of Habibie et al. 2017: shapes, the cell of eqs. 7-9, the loss, generation."""
import math

import numpy as np
import pytest
import torch

from motionlab import data, training
from motionlab.models.gaussian import kl_divergence
from motionlab.models.vae_lstm import ControlledLSTMCell, VAELSTM, VAELSTMConfig, pad_to_canvas

SMALL = VAELSTMConfig(window=16, width=5, control_filters=4, control_code=6, inference_filters=8,
                      units=5, decoder_filters=8)


def test_paper_config_gives_the_sizes_of_section_4_2():
    paper = VAELSTMConfig.paper()
    assert (paper.window, paper.fps, paper.width, paper.units) == (240, 60.0, 25, 128)
    assert paper.free_running == 0.0                        # eq. 5 alone: the paper's objective
    assert VAELSTMConfig.paper(free_running=1.0).free_running == 1.0
    model = VAELSTM(paper).eval()
    assert model.control_encoder.conv0.weight.shape == (64, 3, 25)          # (3, 25) * 64
    assert model.control_encoder.conv1.weight.shape == (128, 64, 25)        # (64, 25) * 128
    assert model.inference.conv0.weight.shape == (64, 63, 25)               # (63, 25) * 64
    assert model.inference.conv1.weight.shape == (256, 64, 25)              # (64, 25) * 256
    assert model.decoder.conv0.weight.shape == (128, 128, 25)               # (128, 25) * 128
    assert model.decoder.conv1.weight.shape == (66, 128, 25)                # to 66 features
    out = model(torch.randn(1, 240, 66))
    assert out["canvas"].shape == (1, 60, 128)                              # the 128 x 60 canvas
    assert out["mu"].shape == out["log_var"].shape == (1, 60, 128)
    assert out["reconstruction"].shape == (1, 240, 66)


@pytest.mark.parametrize("frames", [16, 17, 18, 19, 5, 1])
def test_any_length_is_padded_to_a_multiple_of_4_and_cropped(frames):
    model = VAELSTM(SMALL).eval()
    x = torch.randn(2, frames, 66)
    out = model(x)
    steps = math.ceil(frames / 4)
    assert out["reconstruction"].shape == (2, frames, 66)
    assert out["mu"].shape == out["canvas"].shape == (2, steps, 5)
    assert out["control_code"].shape == (2, steps, 6)
    generated = model.sample(x[..., 63:], generator=torch.Generator().manual_seed(0))
    assert generated.shape == (2, frames, 66) and torch.isfinite(generated).all()
    assert model.reconstruct(x, free_running=True).shape == (2, frames, 66)


def test_padding_repeats_the_last_frame():
    x = torch.arange(2 * 6 * 3, dtype=torch.float32).reshape(2, 6, 3)
    padded = pad_to_canvas(x)
    assert padded.shape == (2, 8, 3)
    assert torch.equal(padded[:, :6], x) and torch.equal(padded[:, 6], x[:, 5]) and torch.equal(padded[:, 7], x[:, 5])
    assert pad_to_canvas(padded) is padded


def test_cell_matches_equations_7_to_9_computed_by_hand():
    cell = ControlledLSTMCell(units=2, control_code=1)
    with torch.no_grad():
        cell.W_ic.weight.copy_(torch.tensor([[0.5, -1.0], [0.0, 2.0]])); cell.W_ic.bias.copy_(torch.tensor([0.1, -0.2]))
        cell.W_ih.weight.copy_(torch.tensor([[1.0], [-1.0]])); cell.W_ih.bias.copy_(torch.tensor([0.0, 0.3]))
        cell.W_fc.weight.copy_(torch.tensor([[1.0, 1.0], [-0.5, 0.0]])); cell.W_fc.bias.copy_(torch.tensor([0.2, 0.0]))
        cell.W_fh.weight.copy_(torch.tensor([[0.0], [2.0]])); cell.W_fh.bias.copy_(torch.tensor([-0.1, 0.1]))
        cell.W_c.weight.copy_(torch.tensor([[2.0, 0.0], [1.0, -1.0]]))
        cell.W_h.weight.copy_(torch.tensor([[0.5], [1.5]]))
    previous, z, h = np.array([0.4, -0.6]), np.array([1.0, 2.0]), np.array([0.8])
    sigmoid = lambda v: 1 / (1 + np.exp(-v))                                     # noqa: E731
    # eq. 7: i = s(W_ic c + b_ic + W_ih h + b_ih)
    i = sigmoid(np.array([0.5 * 0.4 + 1.0 * 0.6 + 0.1 + 0.8, 2.0 * -0.6 - 0.2 - 0.8 + 0.3]))
    # eq. 8: f = s(W_fc c + b_fc + W_fh h + b_fh)
    f = sigmoid(np.array([0.4 - 0.6 + 0.2 - 0.1, -0.5 * 0.4 + 1.6 + 0.1]))
    train_c = np.tanh(f * np.array([2.0, 1.0 - 2.0]) + i * np.array([0.4, 1.2]))       # eq. 9, training: W_c z
    test_c = np.tanh(f * np.array([0.8, 0.4 + 0.6]) + i * np.array([0.4, 1.2]))        # eq. 9, test: W_c c
    t = lambda a: torch.tensor(a, dtype=torch.float32)[None]                       # noqa: E731
    assert np.allclose(cell(t(previous), t(z), t(h))[0].detach().numpy(), train_c, atol=1e-6)
    assert np.allclose(cell(t(previous), t(previous), t(h))[0].detach().numpy(), test_c, atol=1e-6)


def test_canvas_training_form_and_test_time_form():
    torch.manual_seed(0)
    model = VAELSTM(SMALL).eval()
    code, z = torch.randn(3, 4, 6), torch.randn(3, 4, 5)
    trained = model.canvas(code, z)
    previous, expected = z[:, 0], []
    for s in range(4):                                   # training: z_s drives, gates see c_{s-1}
        previous = model.cell(previous, z[:, s], code[:, s])
        expected.append(previous)
    assert torch.allclose(trained, torch.stack(expected, 1))
    free = model.canvas(code, z[:, :1])
    previous = z[:, 0]
    c1 = model.cell(previous, z[:, 0], code[:, 0])         # Algorithm 1: c(1) = RNN(z_1, h_1)
    assert torch.allclose(free[:, 0], trained[:, 0]) and torch.allclose(free[:, 0], c1)
    c2 = model.cell(c1, c1, code[:, 1])                   # then c(t) = RNN(c(t-1), h_t)
    assert torch.allclose(free[:, 1], c2)
    assert not torch.allclose(free[:, 1], trained[:, 1])
    with pytest.raises(ValueError, match="latents: expected 1 or 4 steps"):
        model.canvas(code, z[:, :2])


def test_loss_is_equation_5_per_frame():
    torch.manual_seed(1)
    config = VAELSTMConfig(**{**SMALL.__dict__, "dropout": 0.0, "l1": 0.0, "observation_std": 0.7,
                                      "free_running": 0.0})
    model = VAELSTM(config)
    x = torch.randn(3, 18, 66)
    torch.manual_seed(5)
    terms = model.loss(x)
    torch.manual_seed(5)                                 # the same posterior sample
    out = model(x)
    nll = -torch.distributions.Normal(out["reconstruction"], 0.7).log_prob(x).sum((1, 2)) / 18
    kl = kl_divergence(out["mu"], out["log_var"]).sum((1, 2)) / 18
    assert torch.allclose(terms["nll"], nll.mean(), rtol=1e-5)
    assert torch.allclose(terms["kl"], kl.mean(), rtol=1e-5)
    assert torch.allclose(terms["loss"], (nll + kl).mean(), rtol=1e-5)
    l1_model = VAELSTM(VAELSTMConfig(**{**config.__dict__, "l1": 0.5}))
    l1_model.load_state_dict(model.state_dict())
    torch.manual_seed(5)
    assert torch.allclose(l1_model.loss(x)["loss"], terms["loss"] + 0.5 * model.l1_penalty(), rtol=1e-5)
    free = VAELSTM(VAELSTMConfig(**{**config.__dict__, "free_running": 1.0}))
    free.load_state_dict(model.state_dict())
    torch.manual_seed(5)
    with_free = free.loss(x)
    torch.manual_seed(5)
    out = free(x)
    decoded = free.decode(free.canvas(out["control_code"], out["z"][:, :1]))[:, :18]
    free_nll = -torch.distributions.Normal(decoded, 0.7).log_prob(x).sum((1, 2)) / 18
    assert torch.allclose(with_free["loss"], terms["loss"] + free_nll.mean(), rtol=1e-5)
    assert torch.allclose(with_free["free_mse"], ((decoded - x) ** 2).mean(), rtol=1e-5)


def test_generation_from_the_prior_and_from_4_frames():
    torch.manual_seed(0)
    model = VAELSTM(SMALL)
    control, x = torch.randn(2, 22, 3), torch.randn(2, 22, 66)
    g = lambda: torch.Generator().manual_seed(3)                                    # noqa: E731
    prior = model.sample(control, generator=g())
    assert prior.shape == (2, 22, 66) and model.training                 # mode restored
    assert torch.equal(prior[..., 63:], control)                         # follows the given control
    assert torch.equal(prior, model.sample(control, generator=g()))    # reproducible
    assert not torch.equal(prior, model.sample(control))               # and stochastic
    assert not torch.allclose(prior[..., :63], model.sample(-control, generator=g())[..., :63])
    primed = model.sample(control, prefix=x[:, :4], generator=g())
    assert primed.shape == (2, 22, 66) and not torch.allclose(primed, prior)
    # the first canvas step of 4 frames sets z_1: pose-only frames give the same result
    assert torch.equal(primed, model.sample(control, prefix=x[:, :4, :63], generator=g()))
    mean = model.sample(control, prefix=x[:, :4], temperature=0.0)
    assert torch.equal(mean, model.sample(control, prefix=x[:, :4], temperature=0.0))


def test_dropout_removes_whole_joints_and_controls_only_while_training():
    model = VAELSTM(VAELSTMConfig(dropout=0.5))
    out = model.corrupt(torch.ones(512, 1, 66))
    joints = out[:, 0, :63].reshape(512, 21, 3)
    assert torch.equal((joints == 0).all(-1), (joints == 0).any(-1))         # all of x, y, z or none
    assert 0.4 < (joints == 0).all(-1).float().mean() < 0.6
    assert 0.4 < (out[:, 0, 63:] == 0).float().mean() < 0.6
    assert set(out.unique().tolist()) == {0.0, 2.0}
    assert model.corrupt(torch.ones(4, 2, 3)).shape == (4, 2, 3)             # control alone
    x = torch.randn(2, 12, 66)
    model.eval()
    assert torch.equal(model(x, sample=False)["reconstruction"], model(x, sample=False)["reconstruction"])


def test_control_smoothing_removes_the_step_wobble_and_is_off_by_default():
    t = torch.arange(80) / 20.0
    wobble = torch.stack([1.3 + 0.0 * t, 0.1 * torch.sin(2 * math.pi * 0.9 * t), 0.5 + 0.0 * t], -1)[None]
    assert torch.equal(VAELSTM(SMALL).smooth_control(wobble), wobble)
    smoothing = VAELSTM(VAELSTMConfig(**{**SMALL.__dict__, "control_smoothing_s": 0.5}))
    smooth = smoothing.smooth_control(wobble)
    assert smooth.shape == wobble.shape
    assert torch.allclose(smooth[..., [0, 2]], wobble[..., [0, 2]], atol=1e-5)     # constants stay
    assert smooth[0, 10:70, 1].abs().max() < 0.01                                   # a 0.9 Hz sway goes
    assert smoothing(torch.randn(2, 13, 66))["reconstruction"].shape == (2, 13, 66)  # shorter than the kernel


def test_bad_configs_and_inputs_name_the_argument():
    for changes, message in [({"width": 8}, "width: must be odd"), ({"dropout": 1.0}, "dropout"),
                             ({"upsample": "cubic"}, "upsample"), ({"units": 0}, "units"),
                             ({"observation_std": 0.0}, "observation_std"),
                             ({"control_smoothing_s": -1.0}, "control_smoothing_s"),
                             ({"free_running": -1.0}, "free_running")]:
        with pytest.raises(ValueError, match=message):
            VAELSTMConfig(**changes)
    model = VAELSTM(SMALL)
    with pytest.raises(ValueError, match=r"x: expected \(batch, frames >= 1, 66\)"):
        model.loss(torch.randn(2, 16, 63))
    with pytest.raises(ValueError, match="control: expected"):
        model.sample(torch.randn(16, 3))
    with pytest.raises(ValueError, match="prefix: expected .*frames >= 4"):
        model.sample(torch.randn(2, 16, 3), prefix=torch.randn(2, 3, 66))
    with pytest.raises(ValueError, match="prefix: expected 2 sequences"):
        model.sample(torch.randn(2, 16, 3), prefix=torch.randn(1, 4, 66))
    with pytest.raises(ValueError, match="control: contains NaN"):
        model.sample(torch.full((1, 8, 3), float("nan")))
    with pytest.raises(ValueError, match="canvas: expected"):
        model.decode(torch.randn(1, 4, 7))


def test_trace_lists_every_stage():
    model = VAELSTM(SMALL)
    trace = dict(model.trace(torch.randn(2, 18, 66)))
    assert trace["padded to a multiple of 4 frames"] == (2, 20, 66)
    assert trace["  = mu and log sigma^2 of q(z_s | X), each"] == (2, 5, 5)
    assert list(trace.values())[-1] == (2, 18, 66) and model.training


def test_a_short_training_run_lowers_both_reconstructions():
    prepared = data.prepare(data.load("synthetic", fps=20, n_clips=8, duration_s=6), window_s=2.0)
    torch.manual_seed(0)
    model = VAELSTM(VAELSTMConfig(window=40, units=16, free_running=1.0))
    val = prepared.val.windows
    before = (model.loss(val)["loss"].item(), model.reconstruct(val, free_running=True))
    history = training.train(model, prepared, training.TrainConfig(epochs=12, lr=3e-3, progress=False))
    assert history.last("loss") < before[0] - 5                          # nats per frame
    free_before = ((before[1] - val) ** 2).mean()
    free_after = ((model.reconstruct(val, free_running=True) - val) ** 2).mean()
    assert free_after < 0.6 * free_before
    assert history.last("kl") > 0.05                                      # the latents are used
