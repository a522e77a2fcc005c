"""Checkpoints, loaded safely: :func:`save_checkpoint` writes weights, config, normaliser,
data description and history in one file; :func:`load_checkpoint` builds only registered
model classes (:func:`register_model`, :func:`registered_models`) from plain values and
checks every part of the file first; :func:`train_or_load` trains only when no matching
checkpoint exists."""
from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from torch import nn

from .training.config import History, TrainConfig
from .training.loop import train


CHECKPOINT_FORMAT = "motionlab-checkpoint-1"


@dataclass
class Checkpoint:
    """A loaded checkpoint: the model with its weights, and what it was trained on.

    Attributes:
        model: the ``nn.Module``, in eval mode.
        normalizer: the :class:`motionlab.data.Normalizer` of its training data.
        description: how the data was made (``MotionData.description``).
        history: the training :class:`History`.
    """

    model: nn.Module
    normalizer: Any
    description: dict
    history: History


class CheckpointMismatch(ValueError):
    """A sound checkpoint that holds another model, config or data than the one asked for
    (:func:`train_or_load` then trains instead). Every other problem with a checkpoint file
    is a plain ``ValueError``."""


_REGISTERED: dict[str, tuple[type, type]] = {}


def _class_path(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def register_model(model_class: type, config_class: type) -> None:
    """Let checkpoints hold ``model_class`` (built as ``model_class(config_class(**saved))``).

    motionlab's own models (:func:`registered_models`) are always registered.
    Loading never imports or calls a name read from the file: the file's class name is only
    looked up among the classes registered here, in code.
    """
    if not (isinstance(model_class, type) and issubclass(model_class, nn.Module)):
        raise ValueError(f"model_class: expected an nn.Module subclass, got {model_class!r}")
    if not (isinstance(config_class, type) and dataclasses.is_dataclass(config_class)):
        raise ValueError(f"config_class: expected a dataclass, got {config_class!r}")
    _REGISTERED[_class_path(model_class)] = (model_class, config_class)


def registered_models() -> dict[str, tuple[type, type]]:
    """``{"module.ModelClass": (model class, config class)}`` of every model a checkpoint may hold."""
    from . import models                       # the model cards (motionlab.models.FILES)
    known = {_class_path(card.model): (card.model, card.config) for card in models.cards().values()}
    known.update(_REGISTERED)
    return known


def save_checkpoint(path: str | Path, model: nn.Module, data=None, history: History | None = None,
                    normalizer=None, description: dict | None = None, half: bool = False) -> None:
    """Save weights, config, normaliser and data description in one file.

    ``data`` is the :class:`motionlab.data.MotionData` the model trained on (its normaliser
    and description are saved); or pass ``normalizer`` and ``description`` directly.
    ``half=True`` stores floating-point weights as float16 (half the size, for checkpoints
    shipped with the course); they load back into the float32 model. Buffers (fitted
    statistics such as a model's normalisation or skeleton) are kept in float32. The file is
    written under another name first and then renamed, so an interrupted save never leaves
    half a checkpoint behind.
    """
    if not dataclasses.is_dataclass(getattr(model, "config", None)):
        raise ValueError("model: needs a dataclass `config` attribute to be saved")
    if normalizer is None:
        normalizer = getattr(data, "normalizer", None) or getattr(model, "normalizer", None)
    description = description if description is not None else getattr(data, "description", {})
    weights = {name for name, _ in model.named_parameters()}     # buffers (statistics, a skeleton) stay float32
    state = {
        "format": CHECKPOINT_FORMAT,
        "model_class": _class_path(type(model)),
        "config_class": _class_path(type(model.config)),
        "config": dataclasses.asdict(model.config),
        "state_dict": {k: (v.detach().cpu().half() if half and k in weights and v.is_floating_point()
                           else v.detach().cpu()) for k, v in model.state_dict().items()},
        "normalizer": normalizer.state_dict() if normalizer is not None else None,
        "description": description,
        "history": history.to_dict() if history is not None else None,
    }
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".partial")
    torch.save(state, partial)
    os.replace(partial, path)


_CHECKPOINT_KEYS = {"model_class": str, "config_class": str, "config": dict, "state_dict": dict,
                    "normalizer": (dict, type(None)), "description": dict, "history": (dict, type(None))}


def _read_state(path: Path) -> dict:
    """The checkpoint's dict of plain data and tensors, every key present with its type."""
    if not path.is_file():
        raise ValueError(f"{path}: no such checkpoint file")
    try:   # weights_only: the unpickler builds tensors and plain containers, never a class from the file
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:         # torch raises many kinds on a damaged file; all mean "unreadable"
        raise ValueError(f"{path}: cannot read checkpoint ({type(err).__name__}: {err})") from None
    if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"{path}: not a motionlab checkpoint")
    for key, kind in _CHECKPOINT_KEYS.items():
        if key not in state:
            raise ValueError(f"{path}: checkpoint is missing {key!r}")
        if not isinstance(state[key], kind):
            raise ValueError(f"{path}: checkpoint's {key!r} is a {type(state[key]).__name__}")
    for name, tensor in state["state_dict"].items():
        if not isinstance(name, str) or not isinstance(tensor, torch.Tensor):
            raise ValueError(f"{path}: checkpoint's weights must map names to tensors ({name!r})")
        if tensor.is_floating_point() and not torch.isfinite(tensor).all():
            raise ValueError(f"{path}: weight {name!r} holds NaN or infinite values")
    return state


def _saved_config(path: Path, state: dict, config_class: type):
    """The config the checkpoint was trained with, built from plain values only."""
    fields = {f.name for f in dataclasses.fields(config_class)}
    unknown = sorted(set(map(str, state["config"])) - fields)
    if unknown:
        raise ValueError(f"{path}: config has fields {config_class.__name__} does not know: {', '.join(unknown)}")
    defaults = config_class()
    for name, value in state["config"].items():
        default = getattr(defaults, name)
        if not _same_kind(value, default):
            raise ValueError(f"{path}: config does not make a {config_class.__name__} "
                             f"({name} = {value!r}, expected a {type(default).__name__})")
    try:
        return config_class(**state["config"])
    except (TypeError, ValueError) as err:
        raise ValueError(f"{path}: config does not make a {config_class.__name__} ({err})") from None


def _same_kind(value, default) -> bool:
    """Whether a config value read from a file has the type of the field's default."""
    if default is None or value is None:
        return True                                      # optional fields
    if isinstance(default, bool) or isinstance(value, bool):
        return type(value) is type(default)
    if isinstance(default, float):
        return isinstance(value, (int, float))
    if isinstance(default, (tuple, list)):
        return isinstance(value, (tuple, list)) and all(
            _same_kind(item, default[0]) for item in value) if default else isinstance(value, (tuple, list))
    return isinstance(value, type(default))


def _meta_model(path: Path, model_class: type, config, state_dict: dict) -> None:
    """Build the model without memory (torch's meta device) and check that the file's
    weights fit it exactly, before anything real is allocated.

    A config read from a file could ask for any size; building it for real first could
    allocate gigabytes (or loop for ever). Here construction stops as soon as the model
    registers more tensors than the file holds, and the model's full size (buffers too)
    must be within reach of the weights' size in the file.
    """
    limit = 2 * len(state_dict) + 64                        # plus buffers that are not saved
    registered = 0

    def count(*_):
        nonlocal registered
        registered += 1
        if registered > limit:
            raise CheckpointMismatch(f"{path}: its config builds a model with more than {limit} tensors, "
                                     f"but the file holds {len(state_dict)}")

    hooks = [nn.modules.module.register_module_parameter_registration_hook(count),
             nn.modules.module.register_module_buffer_registration_hook(count)]
    try:
        with torch.random.fork_rng(devices=[]), torch.device("meta"):   # leave the caller's RNG alone
            model = model_class(config)
    except (TypeError, ValueError, RuntimeError, IndexError, ZeroDivisionError) as err:
        if isinstance(err, CheckpointMismatch):
            raise
        raise ValueError(f"{path}: its config does not build a {model_class.__name__} ({err})") from None
    finally:
        for hook in hooks:
            hook.remove()
    expected = model.state_dict()
    optional = set(getattr(model_class, "optional_state", ()))      # buffers added since: filled in by the model
    missing = sorted(k for k in set(expected) - set(state_dict) if k not in optional)
    unexpected = sorted(set(state_dict) - set(expected))
    wrong = [f"{k} {tuple(state_dict[k].shape)} != {tuple(v.shape)}" for k, v in expected.items()
             if k in state_dict and state_dict[k].shape != v.shape]
    if missing or unexpected or wrong:
        raise CheckpointMismatch(
            f"{path}: weights do not fit {model_class.__name__}: "
            + "; ".join(part for part in [f"missing {missing[:5]}" if missing else "",
                                          f"unexpected {unexpected[:5]}" if unexpected else "",
                                          f"shapes {wrong[:5]}" if wrong else ""] if part))
    in_file = sum(t.numel() * t.element_size() for t in state_dict.values())
    in_model = sum(t.numel() * t.element_size() for t in (*model.parameters(), *model.buffers()))
    if in_model > 4 * in_file + 2 ** 28:                   # 256 MB of unsaved buffers at most
        raise ValueError(f"{path}: its config builds a model of {in_model / 2 ** 30:.1f} GiB "
                         f"from {in_file / 2 ** 20:.1f} MiB of weights")


def _feature_count(config) -> int | None:
    """How many data features (columns of the normaliser) a model's config reads, if it says."""
    if hasattr(config, "n_features"):
        return config.n_features
    if hasattr(config, "n_pose") and hasattr(config, "n_control"):
        return config.n_pose + config.n_control
    return None


def load_checkpoint(path: str | Path, config=None, device: str = "cpu") -> Checkpoint:
    """Load a checkpoint saved by :func:`save_checkpoint`.

    With ``config``, the checkpoint must have been trained with exactly that config (same
    class and values); otherwise a :class:`CheckpointMismatch` (a ``ValueError``) names the
    fields that differ.

    Only registered model classes (:func:`registered_models`) are ever built, from plain
    values; nothing named in the file is imported or called. A file that cannot be read,
    is missing keys, names another class, holds NaN or infinite weights, weights that do
    not fit the model, or a normaliser of the wrong width raises ``ValueError`` naming it.
    """
    from .data import Normalizer
    path = Path(path)
    state = _read_state(path)
    classes = registered_models().get(state["model_class"])
    if classes is None:
        raise ValueError(f"{path}: holds a {state['model_class']!r}, which is not one of motionlab's "
                         "registered models (see motionlab.training.register_model)")
    model_class, config_class = classes
    if state["config_class"] != _class_path(config_class):
        raise ValueError(f"{path}: a {model_class.__name__} is configured by {config_class.__name__}, "
                         f"not {state['config_class']!r}")
    saved = _saved_config(path, state, config_class)
    if config is not None:
        if type(config) is not config_class:
            raise CheckpointMismatch(f"{path}: holds a {config_class.__name__}, not a {type(config).__name__}")
        different = [f"{f.name}: checkpoint {getattr(saved, f.name)!r} != requested {getattr(config, f.name)!r}"
                     for f in dataclasses.fields(saved) if getattr(saved, f.name) != getattr(config, f.name)]
        if different:
            raise CheckpointMismatch(f"{path}: trained with another config; " + "; ".join(different))
    _meta_model(path, model_class, saved, state["state_dict"])
    model = model_class(saved)
    model.load_state_dict(state["state_dict"])
    model.to(device).eval()
    normalizer = None
    if state["normalizer"] is not None:
        try:
            normalizer = Normalizer.from_state_dict(state["normalizer"])
        except (TypeError, ValueError) as err:
            raise ValueError(f"{path}: normaliser is not valid ({err})") from None
        width = _feature_count(saved)
        if width is not None and len(normalizer.mean) != width:
            raise ValueError(f"{path}: normaliser has {len(normalizer.mean)} features, "
                             f"the model reads {width}")
        model.normalizer = normalizer
    try:
        history = History.from_dict(state["history"]) if state["history"] else History()
    except (TypeError, ValueError) as err:
        raise ValueError(f"{path}: training history is not valid ({err})") from None
    return Checkpoint(model, normalizer, state["description"], history)


_DATA_KEYS = ("source", "fps", "window_frames", "stride_frames", "augment", "clips")


def _matching_checkpoint(path: Path, model: nn.Module, data) -> Checkpoint | None:
    """The checkpoint at ``path`` if it holds ``model``'s class and config, trained on data
    made the same way as ``data``; else ``None``."""
    if not path.exists():
        return None
    try:
        checkpoint = load_checkpoint(path, config=model.config)
    except CheckpointMismatch:
        return None                                # another model or config: train instead
    wanted = getattr(data, "description", {})
    if type(checkpoint.model) is not type(model) or \
            any(checkpoint.description.get(k) != wanted.get(k) for k in _DATA_KEYS):
        return None
    return checkpoint


def train_or_load(path: str | Path, model: nn.Module, data, config: TrainConfig | None = None,
                  retrain: bool = False, pretrained: str | Path | None = None) -> tuple[nn.Module, History]:
    """Load ``path`` if it holds this model with this config, else train and save it there.

    Notebooks use it so that a second run (or a later notebook that needs this model) skips
    training. ``pretrained`` is a checkpoint shipped with the course, tried first and never
    written: used when it holds this model and config trained on the same data, so a
    notebook can start from weights that took longer to train than it has. ``retrain=True``
    ignores both and trains. Returns the model (in eval mode) and its history.

    Only a :class:`CheckpointMismatch` (another model, config or data) means "train instead";
    a damaged or unsafe file raises its ``ValueError``, so nothing wrong passes unnoticed.
    """
    if not retrain:
        for candidate in ([Path(pretrained)] if pretrained is not None else []) + [Path(path)]:
            checkpoint = _matching_checkpoint(candidate, model, data)
            if checkpoint is not None:
                model.load_state_dict(checkpoint.model.state_dict())
                model.normalizer = checkpoint.normalizer
                return model.eval(), checkpoint.history
    history = train(model, data, config)
    save_checkpoint(path, model, data, history)
    return model.eval(), history
