"""The autoregressive LSTM-3LR baselines: with and without the control signal."""
import pytest
import torch

from motionlab import data, training
from motionlab.models.lstm import LSTMConfig, MotionLSTM


def small(control="predicted", **changes):
    torch.manual_seed(0)
    return MotionLSTM(LSTMConfig(window=12, control=control, hidden=8, layers=2, **changes))


def test_paper_config_is_lstm_3lr():
    paper = LSTMConfig.paper()
    assert (paper.hidden, paper.layers, paper.window, paper.fps) == (1000, 3, 240, 60.0)


def test_shapes_of_both_variants():
    x = torch.randn(2, 12, 66)
    predicted, given = small(), small("given")
    assert predicted(x)[0].shape == (2, 12, 66)
    assert given(x, x[..., 63:])[0].shape == (2, 12, 63)
    assert predicted.lstm.input_size == 66 and given.lstm.input_size == 69


def test_prediction_after_priming_equals_the_teacher_forced_step():
    model = small().eval()
    x = torch.randn(3, 12, 66)
    rollout = model.sample(x[:, :5], 6)
    assert rollout.shape == (3, 6, 66) and torch.equal(rollout[:, :5], x[:, :5])
    teacher, _ = model(x[:, :5])
    assert torch.allclose(rollout[:, 5], teacher[:, 4], atol=1e-6)
    assert torch.equal(model.sample(x[:, :1], 1), x[:, :1])            # nothing to predict
    assert model.sample(x[:, :1], 9).shape == (3, 9, 66)               # a single priming frame


def test_given_control_is_used_and_kept():
    x = torch.randn(2, 12, 66)
    model = small("given").eval()
    rollout = model.sample(x[:, :4], 12, control=x[..., 63:])
    assert rollout.shape == (2, 12, 66) and torch.equal(rollout[..., 63:], x[..., 63:])
    teacher, _ = model(x[:, :4], x[:, 1:5, 63:])
    assert torch.allclose(rollout[:, 4, :63], teacher[:, 3], atol=1e-6)
    other = model.sample(x[:, :4], 12, control=-x[..., 63:])
    assert not torch.allclose(other[:, 6:, :63], rollout[:, 6:, :63])   # the pose follows the control
    # Habibie's Table 2 protocol: a model that predicts the control gets the true one instead
    substituted = small().sample(x[:, :4], 12, control=x[..., 63:])
    assert torch.equal(substituted[..., 63:], x[..., 63:])


def test_input_noise_only_while_training():
    model = small(input_noise=0.5)
    x = torch.randn(2, 12, 66)
    assert model.loss(x)["loss"] != model.loss(x)["loss"]
    model.eval()
    assert model.loss(x)["loss"] == model.loss(x)["loss"]


def test_bad_configs_and_inputs_name_the_argument():
    with pytest.raises(ValueError, match="control: expected 'predicted' or 'given'"):
        LSTMConfig(control="oracle")
    with pytest.raises(ValueError, match="layers"):
        LSTMConfig(layers=0)
    with pytest.raises(ValueError, match="window"):
        LSTMConfig(window=1)
    model, given = small(), small("given")
    x = torch.randn(2, 12, 66)
    with pytest.raises(ValueError, match=r"prefix: expected \(batch, frames >= 1, 66\)"):
        model.sample(x[..., :63], 12)
    with pytest.raises(ValueError, match="frames: must be >= the 5 prefix frames"):
        model.sample(x[:, :5], 3)
    with pytest.raises(ValueError, match="control: a control='given' model needs"):
        given.sample(x[:, :4], 12)
    with pytest.raises(ValueError, match=r"control: expected \(batch, frames >= 20, 3\)"):
        given.sample(x[:, :4], 20, control=x[..., 63:])
    with pytest.raises(ValueError, match="next_control"):
        given(x)
    with pytest.raises(ValueError, match="batch: expected"):
        model.loss(x[:, :1])


@pytest.mark.parametrize("control", ["predicted", "given"])
def test_a_short_training_run_lowers_the_loss(control):
    prepared = data.prepare(data.load("synthetic", fps=20, n_clips=8, duration_s=6), window_s=2.0)
    torch.manual_seed(0)
    model = MotionLSTM(LSTMConfig(window=40, control=control, hidden=32, layers=2))
    before = model.eval().loss(prepared.val.windows)["loss"].item()
    history = training.train(model, prepared, training.TrainConfig(epochs=10, batch_size=8, lr=5e-3,
                                                                 progress=False))
    assert history.last("loss") < 0.7 * before


def test_the_stream_is_sample_one_frame_at_a_time():
    import numpy as np
    torch.manual_seed(0)
    model = MotionLSTM(LSTMConfig(hidden=16, layers=2, control="given")).eval()
    prefix, control = torch.randn(2, 5, 66), torch.randn(2, 12, 3)
    whole = model.sample(prefix, 12, torch.cat([prefix[..., 63:], control], dim=1)[:, :12])
    stream = model.stream(prefix)
    frames = torch.stack([stream.step(whole[:, t, 63:]) for t in range(5, 12)], dim=1)
    assert torch.allclose(frames, whole[:, 5:], atol=1e-6)
    norm = data.Normalizer(np.full(66, 0.5), np.full(66, 2.0))       # data units in and out
    units = model.stream(norm.denormalize(prefix), normalizer=norm)
    assert torch.allclose(units.step(norm.denormalize(whole[:, 5])[:, 63:]), norm.denormalize(whole[:, 5]), atol=1e-5)
    with pytest.raises(ValueError, match="control: expected finite"):
        stream.step(torch.full((2, 3), float("nan")))
    with pytest.raises(ValueError, match="control='given'"):
        MotionLSTM(LSTMConfig(hidden=16, layers=2, control="predicted")).stream(prefix)
