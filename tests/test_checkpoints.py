"""Checkpoints never run code from the file, and every damaged one is a clear ValueError."""
import dataclasses
import os
import time
from pathlib import Path

import numpy as np
import pytest
import torch

from motionlab import checkpoints, data, training
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder
from motionlab.models.glow import Glow, GlowConfig

SHIPPED = Path(__file__).resolve().parents[1] / "motionlab" / "checkpoints" / "moglow_dropout.pt"
SMALL = ConvAEConfig(window=8, filters=4, width=3)


@pytest.fixture(scope="module")
def prepared():
    return data.prepare(data.load("synthetic", fps=20, n_clips=5, duration_s=4), window_s=0.4)


def saved_state(prepared) -> dict:
    """A sound checkpoint's contents, as plain dicts and tensors (what an attacker can write)."""
    torch.manual_seed(0)
    model = ConvAutoencoder(SMALL)
    return {
        "format": training.CHECKPOINT_FORMAT,
        "model_class": "motionlab.models.conv_ae.ConvAutoencoder",
        "config_class": "motionlab.models.conv_ae.ConvAEConfig",
        "config": dataclasses.asdict(SMALL),
        "state_dict": model.state_dict(),
        "normalizer": prepared.normalizer.state_dict(),
        "description": prepared.description,
        "history": None,
    }


def write(tmp_path: Path, state, name: str = "crafted.pt") -> Path:
    path = tmp_path / name
    torch.save(state, path)
    return path


def test_a_sound_crafted_state_loads(tmp_path, prepared):
    # the baseline for every case below: these plain values do make a checkpoint
    checkpoint = training.load_checkpoint(write(tmp_path, saved_state(prepared)), config=SMALL)
    assert isinstance(checkpoint.model, ConvAutoencoder) and checkpoint.model.config == SMALL


# ----------------------------------------------------------------------------------------
# Nothing named in the file is imported or called
# ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("field", ["model_class", "config_class"])
@pytest.mark.parametrize("target", ["subprocess.run", "os.system", "builtins.exec",
                                    "motionlab.training.train", "torch.nn.Linear"])
def test_a_class_named_in_the_file_is_never_called(tmp_path, prepared, field, target):
    marker = tmp_path / "ran"
    state = saved_state(prepared)
    state[field] = target
    state["config"] = {"args": ["touch", str(marker)]} if target == "subprocess.run" else \
        {"command": f"touch {marker}"}
    path = write(tmp_path, state)
    for config in (None, SMALL):                              # also when the caller names the config
        with pytest.raises(ValueError, match="crafted.pt") as error:
            training.load_checkpoint(path, config=config)
        assert not isinstance(error.value, training.CheckpointMismatch)
    assert not marker.exists()


def test_train_or_load_stops_at_an_unsafe_file_instead_of_training_over_it(tmp_path, prepared):
    marker = tmp_path / "ran"
    state = saved_state(prepared)
    state["config_class"], state["config"] = "subprocess.run", {"args": ["touch", str(marker)]}
    path = write(tmp_path, state)
    stamp = path.stat().st_mtime_ns
    fast = training.TrainConfig(epochs=1, progress=False)
    for kwargs in ({"path": path}, {"path": tmp_path / "cache.pt", "pretrained": path}):
        with pytest.raises(ValueError, match="configured by ConvAEConfig, not 'subprocess.run'"):
            training.train_or_load(model=ConvAutoencoder(SMALL), data=prepared, config=fast, **kwargs)
    assert not marker.exists() and path.stat().st_mtime_ns == stamp
    assert not (tmp_path / "cache.pt").exists()                # nothing trained


def test_pickled_code_is_refused(tmp_path):
    marker = tmp_path / "ran"

    class Exploit:
        def __reduce__(self):
            return (os.system, (f"touch {marker}",))

    path = tmp_path / "exploit.pt"
    torch.save({"format": training.CHECKPOINT_FORMAT, "payload": Exploit()}, path)
    with pytest.raises(ValueError, match="exploit.pt: cannot read checkpoint"):
        training.load_checkpoint(path)
    assert not marker.exists()


def test_registered_models_are_motionlabs_own_and_one_can_register_more(tmp_path, prepared):
    names = training.registered_models()
    assert "motionlab.models.moglow.MoGlow" in names and "motionlab.models.dfn.DFN" in names
    assert all(name.startswith("motionlab.models.") for name in names if "test_" not in name)

    @dataclasses.dataclass
    class TinyConfig:
        size: int = 3

    class Tiny(torch.nn.Module):
        def __init__(self, config):
            super().__init__()
            self.config, self.weight = config, torch.nn.Parameter(torch.ones(config.size))

    path = tmp_path / "tiny.pt"
    training.save_checkpoint(path, Tiny(TinyConfig()))
    with pytest.raises(ValueError, match="not one of motionlab's registered models"):
        training.load_checkpoint(path)
    training.register_model(Tiny, TinyConfig)
    assert training.load_checkpoint(path).model.weight.tolist() == [1.0, 1.0, 1.0]
    with pytest.raises(ValueError, match="model_class"):
        training.register_model(print, TinyConfig)


# ----------------------------------------------------------------------------------------
# Damaged files: a ValueError naming the file, whatever the damage
# ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("key", ["model_class", "config_class", "config", "state_dict", "normalizer",
                                 "description", "history"])
def test_a_missing_key_is_named(tmp_path, prepared, key):
    state = saved_state(prepared)
    del state[key]
    with pytest.raises(ValueError, match=f"crafted.pt: checkpoint is missing '{key}'"):
        training.load_checkpoint(write(tmp_path, state))


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_weights_are_refused(tmp_path, prepared, value):
    state = saved_state(prepared)
    name = next(iter(state["state_dict"]))
    state["state_dict"][name] = state["state_dict"][name].clone().flatten().index_fill(0, torch.tensor([0]), value) \
        .reshape(state["state_dict"][name].shape)
    with pytest.raises(ValueError, match=f"crafted.pt: weight '{name}' holds NaN or infinite"):
        training.load_checkpoint(write(tmp_path, state))


def test_a_normalizer_that_does_not_fit_the_model_is_refused(tmp_path, prepared):
    state = saved_state(prepared)
    state["normalizer"] = {"mean": [0.0] * 65, "std": [1.0] * 65}
    with pytest.raises(ValueError, match="crafted.pt: normaliser has 65 features, the model reads 66"):
        training.load_checkpoint(write(tmp_path, state))
    state["normalizer"] = {"mean": [0.0] * 66, "std": [0.0] * 66}
    with pytest.raises(ValueError, match="crafted.pt: normaliser is not valid"):
        training.load_checkpoint(write(tmp_path, state))
    state["normalizer"] = {"mean": [0.0] * 66}
    with pytest.raises(ValueError, match="crafted.pt: normaliser is not valid"):
        training.load_checkpoint(write(tmp_path, state))


@pytest.mark.parametrize("change, message", [
    ({"config": {**dataclasses.asdict(SMALL), "surprise": 1}}, "fields ConvAEConfig does not know: surprise"),
    ({"config": {**dataclasses.asdict(SMALL), "filters": "many"}}, "config does not make a ConvAEConfig"),
    ({"config_class": "motionlab.models.glow.GlowConfig"}, "configured by ConvAEConfig"),
    ({"state_dict": {"encoder.weight": "not a tensor"}}, "must map names to tensors"),
    ({"history": {"train": 5}}, "training history is not valid"),
    ({"history": {"train": [{"loss": "low"}]}}, "training history is not valid"),
    ({"description": ["a", "list"]}, "'description' is a list"),
    ({"format": "something-else"}, "not a motionlab checkpoint"),
])
def test_wrong_contents_are_named(tmp_path, prepared, change, message):
    state = {**saved_state(prepared), **change}
    with pytest.raises(ValueError, match=f"crafted.pt: .*{message}"):
        training.load_checkpoint(write(tmp_path, state))


def test_weights_of_another_shape_are_a_mismatch_and_train_or_load_retrains(tmp_path, prepared):
    state = saved_state(prepared)
    state["state_dict"] = ConvAutoencoder(replace_filters := dataclasses.replace(SMALL, filters=5)).state_dict()
    assert replace_filters.filters == 5
    path = write(tmp_path, state, "stale.pt")
    with pytest.raises(training.CheckpointMismatch, match="stale.pt: weights do not fit ConvAutoencoder"):
        training.load_checkpoint(path)
    model, history = training.train_or_load(path, ConvAutoencoder(SMALL), prepared,
                                            training.TrainConfig(epochs=1, progress=False))
    assert len(history.train) > 0 and training.load_checkpoint(path, config=SMALL).history.train


@pytest.mark.parametrize("model_class, config", [
    (ConvAutoencoder, dataclasses.replace(SMALL, filters=10 ** 9)),         # ~3 TB of conv weights
    (Glow, GlowConfig(window=8, levels=1, steps=10 ** 7, hidden=4)),           # ten million steps
])
def test_a_config_asking_for_gigabytes_fails_fast_without_allocating(tmp_path, prepared, model_class, config):
    state = saved_state(prepared)
    state["model_class"] = f"{model_class.__module__}.{model_class.__qualname__}"
    state["config_class"] = f"{type(config).__module__}.{type(config).__qualname__}"
    state["config"] = dataclasses.asdict(config)
    began = time.perf_counter()
    with pytest.raises(ValueError, match="crafted.pt"):
        training.load_checkpoint(write(tmp_path, state))
    assert time.perf_counter() - began < 10


def random_files():
    rng = np.random.default_rng(0)
    shipped = SHIPPED.read_bytes()
    yield "empty", b""
    for size in (1, 7, 100, 4096, 100_000):
        yield f"random {size} bytes", rng.integers(0, 256, size, dtype=np.uint8).tobytes()
    yield "zip header then noise", b"PK\x03\x04" + rng.integers(0, 256, 5000, dtype=np.uint8).tobytes()
    yield "pickle protocol then noise", b"\x80\x02" + rng.integers(0, 256, 5000, dtype=np.uint8).tobytes()
    for fraction in (0.01, 0.5, 0.99):
        yield f"shipped checkpoint cut at {fraction:.0%}", shipped[:int(len(shipped) * fraction)]
    flipped = bytearray(shipped)
    for at in rng.integers(0, len(shipped), 200):
        flipped[at] ^= 0xFF
    yield "shipped checkpoint with 200 bytes flipped", bytes(flipped)


@pytest.mark.parametrize("name, content", list(random_files()), ids=[name for name, _ in random_files()])
def test_any_bytes_give_a_value_error_naming_the_file(tmp_path, name, content):
    path = tmp_path / "damaged.pt"
    path.write_bytes(content)
    with pytest.raises(ValueError, match="damaged.pt"):
        training.load_checkpoint(path)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(ValueError, match="nowhere.pt: no such checkpoint file"):
        training.load_checkpoint(tmp_path / "nowhere.pt")


def test_saving_leaves_no_partial_file_and_checking_draws_no_random_numbers(tmp_path, prepared):
    path = tmp_path / "model.pt"
    weights = ConvAutoencoder(SMALL).state_dict()
    training.save_checkpoint(path, ConvAutoencoder(SMALL), prepared)
    assert [p.name for p in tmp_path.iterdir()] == ["model.pt"]
    torch.manual_seed(7)
    expected = torch.rand(3)
    torch.manual_seed(7)
    checkpoints._meta_model(path, ConvAutoencoder, SMALL, weights)       # builds on the meta device
    assert torch.equal(torch.rand(3), expected)
