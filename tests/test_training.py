"""The shared training loop, checkpoints and the command line."""
import re
from dataclasses import dataclass

import numpy as np
import pytest
import torch
from torch import nn

from motionlab import data, models, training
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder


@dataclass(frozen=True)
class LineConfig:
    n_features: int = 4
    scale: float = 1.0


class Line(nn.Module):
    """A linear map learning y = 2x on (batch, frames, features) windows."""

    def __init__(self, config=LineConfig()):
        super().__init__()
        self.config = config
        self.weight = nn.Parameter(torch.zeros(()))

    def loss(self, batch):
        error = ((self.weight * batch - 2 * batch * self.config.scale) ** 2).mean()
        return {"loss": error, "weight": self.weight}


def windows(n=64, seed=0):
    return data.MotionDataset(np.random.default_rng(seed).normal(size=(n, 8, 4)))


def test_training_reduces_the_loss_and_logs_history():
    model = Line()
    history = training.train(model, (windows(), windows(16, 1)),
                             training.TrainConfig(epochs=20, lr=0.2, progress=False))
    steps, losses = history.series("loss")
    assert len(steps) == 20 * 2 and losses[-1] < 0.01 * losses[0]
    assert abs(model.weight.item() - 2) < 0.1
    assert len(history.val) == 20 and history.last("loss", "val") < 0.01
    assert history.train[0]["lr"] > history.train[-1]["lr"]            # cosine schedule
    assert history.seconds > 0 and not model.training
    with pytest.raises(ValueError, match="'nope' was not logged"):
        history.series("nope")


def test_the_learning_rate_schedule():
    from motionlab.training.schedule import lr_factor
    warm = [lr_factor(step, 100, warmup_steps=4) for step in range(4)]
    assert warm == [0.25, 0.5, 0.75, 1.0]                               # linear warm-up to the peak
    cosine = [lr_factor(step, 100, warmup_steps=4, min_lr_ratio=0.1) for step in range(4, 101)]
    assert cosine[0] == 1.0 and cosine[-1] == pytest.approx(0.1)         # from the peak to the floor
    assert all(a > b for a, b in zip(cosine, cosine[1:]))               # falling all the way
    assert min(cosine) >= 0.1 - 1e-12
    assert lr_factor(50, 100, warmup_steps=0) == pytest.approx(0.55)     # half way: half way down
    assert {lr_factor(step, 100, 4, "constant") for step in range(3, 100)} == {1.0}
    # train() follows it: each step logs the rate the next step will use
    config = training.TrainConfig(epochs=3, batch_size=16, lr=0.1, warmup_steps=3, progress=False)
    history = training.train(Line(), windows(), config)
    total = len(history.train)
    assert [row["lr"] for row in history.train] == pytest.approx(
        [0.1 * lr_factor(step + 1, total, 3, "cosine", config.min_lr_ratio) for step in range(total)])


def test_a_finished_run_leaves_a_one_line_summary(capsys):
    """The progress bar's saved state in a notebook is its first; the summary line is its last."""
    model = Line()
    history = training.train(model, (windows(), windows(16, 1)), training.TrainConfig(epochs=3, lr=0.2))
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].startswith("Line: 6 steps in ")
    assert f"final loss {history.train[-1]['loss']:.4g} (validation {history.val[-1]['loss']:.4g})" in out[0]
    training.train(Line(), windows(), training.TrainConfig(epochs=1, progress=False))
    assert capsys.readouterr().out == ""                                   # progress=False: silent


def test_seeded_training_is_reproducible():
    def run():
        torch.manual_seed(123)
        model = ConvAutoencoder(ConvAEConfig(window=8, filters=4, width=3))
        history = training.train(model, windows(32, 3).windows.repeat(1, 1, 17)[..., :66],
                                 training.TrainConfig(epochs=2, batch_size=8, seed=5, progress=False))
        return history.series("loss")[1]
    assert np.array_equal(run(), run())


def test_max_steps_and_continuing_a_history():
    model = Line()
    config = training.TrainConfig(epochs=5, batch_size=16, lr=0.05, max_steps=3, progress=False)
    history = training.train(model, windows(), config)
    assert len(history.train) == 3
    history = training.train(model, windows(), config, history=history)
    assert [row["step"] for row in history.train] == list(range(6))


def test_nan_guard_stops_with_a_clear_message():
    model = Line()
    bad = windows()
    bad.windows[5, 3, 2] = float("nan")
    with pytest.raises(training.NonFiniteLossError, match=r"the loss became nan at epoch 0.*lower learning rate"):
        training.train(model, bad, training.TrainConfig(epochs=1, batch_size=64, progress=False))


def test_bad_train_configs_are_value_errors():
    with pytest.raises(ValueError, match="schedule"):
        training.TrainConfig(schedule="linear")
    with pytest.raises(ValueError, match="^epochs: expected a whole number >= 1"):
        training.TrainConfig(epochs=0)
    with pytest.raises(ValueError, match="training set is empty"):
        training.train(Line(), data.MotionDataset(np.zeros((0, 8, 4))), training.TrainConfig(progress=False))


@pytest.fixture(scope="module")
def prepared():
    return data.prepare(data.load("synthetic", fps=20, n_clips=6, duration_s=6), window_s=2.0)


def test_checkpoint_round_trip(tmp_path, prepared):
    config = ConvAEConfig(window=40, filters=8)
    model = ConvAutoencoder(config)
    history = training.train(model, prepared, training.TrainConfig(epochs=1, progress=False))
    path = tmp_path / "model.pt"
    training.save_checkpoint(path, model, prepared, history)
    loaded = training.load_checkpoint(path, config=config)
    assert isinstance(loaded.model, ConvAutoencoder) and loaded.model.config == config
    x = prepared.test.windows[:2]
    assert torch.equal(loaded.model(x), model(x))
    assert np.array_equal(loaded.normalizer.mean, prepared.normalizer.mean)
    assert loaded.description["clips"] == prepared.description["clips"]
    assert loaded.history.series("loss")[1].tolist() == history.series("loss")[1].tolist()


def test_loading_into_the_wrong_config_is_a_clear_error(tmp_path, prepared):
    path = tmp_path / "model.pt"
    training.save_checkpoint(path, ConvAutoencoder(ConvAEConfig(window=40, filters=8)), prepared)
    with pytest.raises(ValueError, match=r"model.pt: trained with another config; filters: checkpoint 8 != requested 16"):
        training.load_checkpoint(path, config=ConvAEConfig(window=40, filters=16))
    with pytest.raises(ValueError, match="holds a ConvAEConfig, not a LineConfig"):
        training.load_checkpoint(path, config=LineConfig())
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="junk.pt: cannot read checkpoint"):
        training.load_checkpoint(tmp_path / "junk.pt")


def test_train_or_load_trains_once(tmp_path, prepared):
    path = tmp_path / "ae.pt"
    config = ConvAEConfig(window=40, filters=8)
    fast = training.TrainConfig(epochs=1, progress=False)
    _, first = training.train_or_load(path, ConvAutoencoder(config), prepared, fast)
    stamp = path.stat().st_mtime_ns
    model, again = training.train_or_load(path, ConvAutoencoder(config), prepared, fast)
    assert path.stat().st_mtime_ns == stamp and again.train == first.train
    other = data.prepare(data.load("synthetic", fps=20, n_clips=6, duration_s=6, seed=9), window_s=2.0)
    training.train_or_load(path, ConvAutoencoder(config), other, fast)     # other data: retrains
    assert path.stat().st_mtime_ns != stamp


def test_command_line_trains_and_saves(tmp_path, capsys):
    from motionlab import train as cli
    out = tmp_path / "cli.pt"
    cli.main(["conv_ae", "--epochs", "1", "--synthetic-clips", "5", "--set", "filters=8",
              "--out", str(out)])
    printed = capsys.readouterr().out
    assert "saved" in printed and "filters=8" in printed
    assert training.load_checkpoint(out).model.config.filters == 8
    with pytest.raises(SystemExit):
        cli.main(["conv_ae", "--set", "filters=many"])
    assert "is not a int" in capsys.readouterr().err


def test_cli_overrides_parse_tuple_fields():
    from motionlab.models.glow import GlowConfig
    from motionlab.train import parse_overrides
    assert parse_overrides(GlowConfig, ["constant_features=0,2,4"]) == {"constant_features": (0, 2, 4)}
    with pytest.raises(ValueError, match="constant_features"):
        parse_overrides(GlowConfig, ["constant_features=a,b"])


def test_train_or_load_prefers_a_matching_pretrained_checkpoint_and_never_writes_it(tmp_path, prepared):
    config = ConvAEConfig(window=40, filters=8)
    fast = training.TrainConfig(epochs=1, progress=False)
    shipped = tmp_path / "shipped.pt"
    torch.manual_seed(1)
    original = ConvAutoencoder(config)
    training.save_checkpoint(shipped, original, prepared, training.History(seconds=123.0), half=True)
    stamp = shipped.stat().st_mtime_ns
    cache = tmp_path / "cache.pt"
    model, history = training.train_or_load(cache, ConvAutoencoder(config), prepared, fast, pretrained=shipped)
    assert history.seconds == 123.0 and not cache.exists()                # loaded, nothing trained
    for name, value in original.state_dict().items():                     # float16 on disk, float32 back
        assert model.state_dict()[name].dtype == value.dtype
        assert torch.allclose(model.state_dict()[name], value, rtol=1e-3, atol=1e-4)
    # another config: the shipped file does not fit, so it trains and caches elsewhere
    other, _ = training.train_or_load(cache, ConvAutoencoder(ConvAEConfig(window=40, filters=4)), prepared, fast,
                                      pretrained=shipped)
    assert cache.exists() and shipped.stat().st_mtime_ns == stamp
    # retrain=True ignores both
    training.train_or_load(cache, ConvAutoencoder(config), prepared, fast, pretrained=shipped, retrain=True)
    assert shipped.stat().st_mtime_ns == stamp


def test_shipped_moglow_checkpoints_fit_notebook_06s_config():
    # motionlab/checkpoints holds what `make checkpoints` makes; notebook 06 relies on them matching
    # its CONFIG: the default with the bones as lengths and directions
    from dataclasses import replace
    from pathlib import Path
    from motionlab.models.moglow import MoGlowConfig
    folder = Path(__file__).resolve().parents[1] / "motionlab" / "checkpoints"
    default = MoGlowConfig(bone_coordinates=True)
    for name, config in [("dropout", default), ("no_dropout", replace(default, dropout=0.0)),
                         ("markov", replace(default, recurrent=False)),
                         ("markov_matched", replace(default, recurrent=False, hidden=205))]:
        checkpoint = training.load_checkpoint(folder / f"moglow_{name}.pt", config=config)
        assert checkpoint.description["source"] == "synthetic" and checkpoint.description["window_frames"] == 80
        assert len(checkpoint.description["clips"]["train"]) == 160          # 200 clips: 160 / 20 / 20
        assert len(checkpoint.history.train) == 6000                         # 60 epochs of 100 steps



def test_shipped_glow_checkpoints_fit_notebook_05s_shipped_config():
    # notebook 05 trains the paper's Glow (joint positions) and loads the shipped ones, its
    # SHIPPED config: the same size with the bones as lengths and directions, with and without a head
    from pathlib import Path
    from motionlab.models.glow import GlowConfig
    folder = Path(__file__).resolve().parents[1] / "motionlab" / "checkpoints"
    for name, config in [("glow", GlowConfig(bone_coordinates=True)),
                         ("glow_contacts", GlowConfig(bone_coordinates=True, contact_head=True))]:
        checkpoint = training.load_checkpoint(folder / f"{name}.pt", config=config)
        assert checkpoint.description["source"] == "synthetic" and checkpoint.description["window_frames"] == 80
        assert len(checkpoint.description["clips"]["train"]) == 160          # 200 clips: 160 / 20 / 20
        assert len(checkpoint.history.train) == 3600                         # 20 epochs of 180 steps

def test_the_step_time_estimate_leaves_the_model_and_generators_alone(capsys):
    model = ConvAutoencoder(ConvAEConfig(window=8, filters=8, width=3))
    before = {k: v.clone() for k, v in model.state_dict().items()}
    torch.manual_seed(3)
    expected_draw = torch.rand(3)
    torch.manual_seed(3)
    seconds = training.seconds_per_step(model, torch.randn(4, 8, 66, generator=torch.Generator().manual_seed(0)))
    assert 0 < seconds < 10
    assert torch.equal(torch.rand(3), expected_draw)                      # the generator as it was
    assert all(torch.equal(v, before[k]) for k, v in model.state_dict().items())
    training.train(model, torch.randn(16, 8, 66), training.TrainConfig(epochs=1, batch_size=4, estimate=True))
    assert re.search(r"expected: [\d.e+-]+ s per step on cpu, about \d+ s for 4 steps", capsys.readouterr().out)


def _loss_inputs(name, card):
    torch.manual_seed(0)
    model = card.model(card.config())
    if name == "vae":
        return model, torch.randn(4, model.config.n_inputs)
    batch = 0.5 * torch.randn(4, getattr(model.config, "window", 40), 66)
    batch[..., [0, 2]] = 0.0                                         # the hips' root-local x and z
    if name == "dfn":
        model.set_stage("frame", batch)
    return model.train(), batch


@pytest.mark.parametrize("name", models.FILES)
def test_loss_leaves_finiteness_to_the_loop(name, monkeypatch):
    """A finiteness scan waits for the device (a host sync on a GPU); the loop's NaN guard
    already stops a run whose loss is not finite, so no model's loss() scans its batch, and a
    NaN batch makes a NaN loss (which the guard names, above)."""
    model, batch = _loss_inputs(name, models.card(name))
    scans = []
    real = torch.isfinite
    monkeypatch.setattr(torch, "isfinite", lambda x, *a, **k: scans.append(1) or real(x, *a, **k))
    monkeypatch.setattr(torch.Tensor, "isfinite", lambda self: scans.append(1) or real(self))
    model.loss(batch)
    assert scans == []
    assert not real(model.loss(torch.full_like(batch, float("nan")))["loss"])
