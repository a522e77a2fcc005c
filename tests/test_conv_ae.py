import pytest
import torch

from motionlab import data, training
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder


def test_shapes_follow_motegi():
    paper = ConvAEConfig.paper(n_features=58)
    assert (paper.window, paper.fps, paper.filters, paper.width) == (120, 30.0, 32, 15)
    model = ConvAutoencoder(paper)
    x = torch.randn(3, 120, 58)
    y = model.encode(x)
    assert y.shape == (3, 60, 32)                             # the 60 x 32 feature map of §III-A
    assert model.decode(y).shape == (3, 120, 58) and model(x).shape == x.shape
    trace = model.trace(x)
    assert trace[3][1] == (3, 32, 60) and trace[-1][1] == (3, 120, 58)


@pytest.mark.parametrize("depool", ["nearest", "linear", "unpool"])
def test_depooling_choices(depool):
    model = ConvAutoencoder(ConvAEConfig(window=16, filters=8, width=5, depool=depool)).eval()
    x = torch.randn(2, 16, 66)
    assert model(x).shape == x.shape
    if depool == "unpool":
        with pytest.raises(ValueError, match="needs the pooling indices"):
            model.decode(model.encode(x))


def test_bad_configs_and_inputs():
    with pytest.raises(ValueError, match="window: must be even"):
        ConvAEConfig(window=81)
    with pytest.raises(ValueError, match="width: must be odd"):
        ConvAEConfig(width=10)
    with pytest.raises(ValueError, match="depool"):
        ConvAEConfig(depool="magic")
    model = ConvAutoencoder(ConvAEConfig())
    with pytest.raises(ValueError, match=r"x: expected \(batch, even frames, 66\)"):
        model(torch.randn(2, 80, 63))
    with pytest.raises(ValueError, match=r"y: expected \(batch, frames, 32\)"):
        model.decode(torch.randn(2, 40, 16))


def test_corruption_only_while_training():
    model = ConvAutoencoder(ConvAEConfig(input_dropout=0.5, input_noise=0.1))
    x = torch.ones(4, 80, 66)
    torch.manual_seed(0)
    assert not torch.equal(model.encode(x), model.encode(x))     # training: corrupted anew
    model.eval()
    assert torch.equal(model.encode(x), model.encode(x))         # eval: deterministic
    assert torch.equal(model.project(x), model(x))


def test_dropout_removes_whole_joints():
    model = ConvAutoencoder(ConvAEConfig(input_dropout=0.5))
    out = model.corrupt(torch.ones(256, 1, 66))
    joints = out[:, 0, :63].reshape(256, 21, 3)
    assert torch.equal((joints == 0).all(-1), (joints == 0).any(-1))   # all or none of x, y, z
    assert 0.4 < (joints == 0).all(-1).float().mean() < 0.6


def test_a_short_training_run_reconstructs_better():
    prepared = data.prepare(data.load("synthetic", fps=20, n_clips=8, duration_s=6), window_s=2.0,
                            normalization="shared_pose")
    model = ConvAutoencoder(ConvAEConfig(window=40))
    before = model.loss(prepared.val.windows)["mse"].item()
    training.train(model, prepared, training.TrainConfig(epochs=15, progress=False))
    after = model.loss(prepared.val.windows)["mse"].item()
    assert after < 0.3 * before
