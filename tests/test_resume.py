"""Resumable training: a run interrupted after k steps and resumed from its state file ends
with exactly the weights, history and random state of a run that never stopped."""
import numpy as np
import pytest
import torch

from motionlab import training
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder
from motionlab.models.vae import FeatureVAE, VAEConfig

# input dropout draws from torch's generator in every step, validation too in the VAE
CONV_AE = ConvAEConfig(window=8, filters=8, width=3, input_dropout=0.2)


class Interrupted(Exception):
    pass


def interrupt_after(model, calls: int):
    """Make ``model.loss`` fail on its ``calls + 1``-th call (a crash in the middle of a run)."""
    loss, count = model.loss, [0]

    def failing(batch):
        count[0] += 1
        if count[0] > calls:
            raise Interrupted
        return loss(batch)
    model.loss = failing
    return model


def sets(n_train=40, n_val=8, shape=(8, 66), seed=0):
    g = torch.Generator().manual_seed(seed)
    return torch.randn(n_train, *shape, generator=g), torch.randn(n_val, *shape, generator=g)


def same_run(a, b, history_a, history_b):
    for (name, x), y in zip(a.state_dict().items(), b.state_dict().values()):
        assert torch.equal(x, y), name
    assert history_a.train == history_b.train and history_a.val == history_b.val


@pytest.mark.parametrize("make, shape", [(lambda: ConvAutoencoder(CONV_AE), (8, 66)),
                                         (lambda: FeatureVAE(VAEConfig(n_inputs=24, hidden=16, latent=4)), (24,))],
                         ids=["conv_ae", "vae"])
@pytest.mark.parametrize("stop_at", [7, 10, 23])          # mid-epoch, at an epoch's end (10 batches), later
def test_a_resumed_run_equals_an_uninterrupted_one(tmp_path, make, shape, stop_at):
    data = sets(shape=shape)
    config = training.TrainConfig(epochs=3, batch_size=4, lr=3e-3, progress=False, save_every_steps=1)
    torch.manual_seed(0)
    whole = make()
    whole_history = training.train(whole, data, config)

    state = tmp_path / "run.state"
    torch.manual_seed(0)
    with pytest.raises(Interrupted):
        training.train(interrupt_after(make(), stop_at), data, config, state_file=state)
    torch.manual_seed(1)                   # a fresh process: other weights and generators until resumed
    np.random.seed(1)
    resumed = make()
    resumed_history = training.train(resumed, data, config, state_file=state, resume=True)
    same_run(whole, resumed, whole_history, resumed_history)
    assert len(resumed_history.train) == 30
    # and the state of the finished run resumes to the same end, doing nothing
    again = make()
    same_run(whole, again, whole_history, training.train(again, data, config, state_file=state, resume=True))


def test_saving_every_few_steps_and_timed_saves(tmp_path):
    data = sets()
    state = tmp_path / "run.state"
    config = training.TrainConfig(epochs=2, batch_size=4, progress=False, save_every_steps=5)
    with pytest.raises(Interrupted):
        training.train(interrupt_after(ConvAutoencoder(CONV_AE), 13), data, config, state_file=state)
    saved = torch.load(state, weights_only=True)
    # saved after the 10th step, the last of epoch 0, before its validation
    assert saved["run"]["step"] == 10 and saved["run"]["position"] == 10 and saved["run"]["epoch"] == 0
    timed = training.TrainConfig(epochs=1, batch_size=4, progress=False, save_every_s=1e-9)
    with pytest.raises(Interrupted):
        training.train(interrupt_after(ConvAutoencoder(CONV_AE), 3), data, timed, state_file=state)
    assert torch.load(state, weights_only=True)["run"]["step"] == 3
    assert not list(tmp_path.glob("*.partial"))


def test_resuming_with_other_settings_or_a_bad_file_is_a_clear_error(tmp_path):
    data = sets()
    state = tmp_path / "run.state"
    config = training.TrainConfig(epochs=1, batch_size=4, progress=False)
    training.train(ConvAutoencoder(CONV_AE), data, config, state_file=state)
    with pytest.raises(ValueError, match="different lr"):
        training.train(ConvAutoencoder(CONV_AE), data, training.TrainConfig(epochs=1, batch_size=4, lr=0.1,
                                                                             progress=False),
                       state_file=state, resume=True)
    with pytest.raises(ValueError, match="the model's config"):
        training.train(ConvAutoencoder(ConvAEConfig(window=8, filters=4, width=3)), data, config,
                       state_file=state, resume=True)
    with pytest.raises(ValueError, match="saved while training ConvAutoencoder"):
        training.train(FeatureVAE(VAEConfig(n_inputs=66 * 8)), (data[0].flatten(1), data[1].flatten(1)), config,
                       state_file=state, resume=True)
    # device, threads, progress and the save interval may change
    training.train(ConvAutoencoder(CONV_AE), data, training.TrainConfig(epochs=1, batch_size=4, save_every_steps=3,
                                                                        progress=False, device="cpu"),
                   state_file=state, resume=True)
    state.write_bytes(b"not a torch file")
    with pytest.raises(ValueError, match="not a training state"):
        training.train(ConvAutoencoder(CONV_AE), data, config, state_file=state, resume=True)
    with pytest.raises(ValueError, match="needs a state_file"):
        training.train(ConvAutoencoder(CONV_AE), data, config, resume=True)
    with pytest.raises(ValueError, match="save_every"):
        training.TrainConfig(save_every_steps=0)
    # no state file yet: resume starts afresh
    training.train(ConvAutoencoder(CONV_AE), data, config, state_file=tmp_path / "new.state", resume=True)
    assert (tmp_path / "new.state").exists()


def test_the_command_line_saves_and_resumes(tmp_path, monkeypatch):
    from motionlab import train as cli
    out = tmp_path / "cli.pt"
    argv = ["conv_ae", "--max-steps", "6", "--batch-size", "4", "--synthetic-clips", "5", "--set", "filters=8",
            "--out", str(out)]
    # every run starts as a fresh process would: the same generator state when the model is built
    torch.manual_seed(0)
    whole = cli.main(argv)
    reference = training.load_checkpoint(out).model.state_dict()

    calls = [0]
    loss = ConvAutoencoder.loss

    def crash_after_four(self, batch):
        calls[0] += 1
        if calls[0] > 4:
            raise Interrupted
        return loss(self, batch)
    monkeypatch.setattr(ConvAutoencoder, "loss", crash_after_four)
    torch.manual_seed(0)
    with pytest.raises(Interrupted):
        cli.main(argv + ["--save-every", "2"])
    assert (tmp_path / "cli.pt.state").exists() and cli.state_path(cli.build_parser().parse_args(argv)) == \
        tmp_path / "cli.pt.state"
    monkeypatch.setattr(ConvAutoencoder, "loss", loss)
    resumed = cli.main(argv + ["--resume"])
    assert resumed.train == whole.train
    for name, value in training.load_checkpoint(out).model.state_dict().items():
        assert torch.equal(value, reference[name]), name
