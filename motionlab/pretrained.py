"""The trained models shipped with the course, ready to generate.

``motionlab/checkpoints`` holds weights made by ``make checkpoints`` (the command line,
``python -m motionlab.train``, on the built-in synthetic data). Each file holds the model's
config, its weights, the normaliser of its training data and how that data was made::

    from motionlab import pretrained
    pretrained.available()                       # ['moglow', 'moglow_markov', ...]
    model = pretrained.load("moglow")            # ready: eval mode, normaliser attached
    motion = model.generate(control, prefix=start, n=4, seed=0)

:func:`shipped_or_train` and :func:`moglow_or_train` are what the notebooks call: the shipped checkpoint when it fits the
notebook's config and data, else a model trained now (and cached in :data:`CACHE`).

Loading never runs code from a file: only motionlab's registered model classes are built
(:func:`motionlab.training.load_checkpoint`).
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import torch

from . import files, training
from .models.moglow import MoGlow, MoGlowConfig
from .recipes import RECIPES

CHECKPOINTS = files.checkpoints()
"""The shipped checkpoints: ``motionlab/checkpoints``, installed with the package
(``$MOTIONLAB_CHECKPOINTS`` to use others)."""

CACHE = files.cache()
"""Where notebooks cache the models they train: the repository's ``data/cache`` (ignored by
git) in a checkout, else the user's cache folder (:func:`motionlab.files.cache`)."""

MOGLOW_VARIANTS = {"dropout": "moglow", "no_dropout": "moglow_no_dropout", "markov": "moglow_markov",
                   "markov_matched": "moglow_markov_matched", "foot_anchor": "moglow_foot_anchor"}
"""The MoGlow models notebook 06 compares: variant -> the recipe (:mod:`motionlab.recipes`) that
says how it differs from the base config and how it is trained. ``markov_matched`` is the
Markov model widened to as many weights as the laptop LSTM model (803 k), for a fair
comparison of the two at the laptop size. ``foot_anchor`` models each ankle relative to
where it would be had it stayed planted and the toes and knees relative to the leg
(``MoGlowConfig.foot_anchor``, ``leg_anchor``, ``anchor_conditioning``; notebooks 06, 08)."""

NAMES = {name: recipe.file for name, recipe in RECIPES.items()}
"""Model name -> file in :data:`CHECKPOINTS`, from the recipes (:data:`motionlab.recipes.RECIPES`
says what each model is and how it was trained). ``"conv_ae"`` is Motegi's temporal conv
autoencoder and ``"vae"`` his VAE on its features (loaded as one
:class:`~motionlab.models.vae.MotionVAE`)."""


def available() -> list[str]:
    """The names :func:`load` accepts whose checkpoint is present, sorted."""
    return sorted(name for name, file in NAMES.items() if (CHECKPOINTS / file).is_file())


def path(name: str) -> Path:
    """The checkpoint file of the shipped model ``name``."""
    if name not in NAMES:
        raise ValueError(f"name: expected one of {', '.join(sorted(NAMES))}, got {name!r}")
    return CHECKPOINTS / NAMES[name]


def load(name: str, device: str = "cpu") -> torch.nn.Module:
    """The shipped model ``name`` (see :func:`available`), in eval mode on ``device``, with
    its normaliser as ``model.normalizer`` and its training history as ``model.history``."""
    file = path(name)
    if not file.is_file():
        raise ValueError(f"name: the checkpoint of {name!r} is missing ({file}); run `make checkpoints`")
    if name == "vae":
        model = load_motion_vae(file)
        model.vae.to(device), model.conv_ae.to(device)
        return model
    checkpoint = training.load_checkpoint(file, device=device)
    checkpoint.model.history = checkpoint.history
    checkpoint.model.description = checkpoint.description
    return checkpoint.model


def shipped_or_train(name: str, model: torch.nn.Module, prepared, config: training.TrainConfig,
                     retrain: bool = False) -> tuple[torch.nn.Module, "training.History"]:
    """The shipped model ``name`` when its checkpoint holds ``model``'s class and config
    trained on data made like ``prepared``; otherwise ``model`` trained now with ``config``
    (and cached in ``CACHE/<name>.pt``, so a second run loads it). ``retrain=True``
    always trains. Returns the model in eval mode, with ``model.normalizer``, and its
    history (the shipped one: how long the checkpoint took, its loss curves)."""
    path(name)                                                    # a known name, or ValueError
    return training.train_or_load(CACHE / NAMES[name], model, prepared, config, retrain=retrain,
                                  pretrained=path(name))


def moglow_or_train(prepared, variant: str = "dropout", config: MoGlowConfig = MoGlowConfig(), epochs: int | None = None,
                    retrain: bool = False, cache: str | Path | None = None):
    """A trained MoGlow ``variant`` (a key of :data:`MOGLOW_VARIANTS`) of ``config`` for the
    data ``prepared`` (:func:`motionlab.data.prepare`), and its history.

    Uses the shipped checkpoint when it holds this config trained on data made the same
    way; otherwise trains as the variant's recipe does (:mod:`motionlab.recipes`: Adam 3e-3,
    batches of 32, 60 epochs unless ``epochs`` is given) and caches the result in ``cache``
    (default ``CACHE/moglow_<variant>.pt``). ``retrain=True`` always trains.
    """
    if variant not in MOGLOW_VARIANTS:
        raise ValueError(f"variant: expected one of {', '.join(MOGLOW_VARIANTS)}, got {variant!r}")
    recipe = RECIPES[MOGLOW_VARIANTS[variant]]
    torch.manual_seed(0)
    model = MoGlow(replace(config, **recipe.changes()))
    cache = Path(cache) if cache is not None else CACHE / f"moglow_{variant}.pt"
    how = recipe.train_config(len(prepared.train), progress=False,
                              **({} if epochs is None else {"epochs": epochs}))
    return training.train_or_load(cache, model, prepared, how, retrain=retrain, pretrained=path(recipe.name))


def load_motion_vae(path: str | Path):
    """The :class:`motionlab.models.vae.MotionVAE` of a ``vae`` checkpoint made by
    ``python -m motionlab.train vae --conv-ae CONV_AE.pt``: the VAE, and the conv AE whose
    path it names (as given when training, or relative to the VAE's folder)."""
    from .data import Normalizer
    from .models.vae import MotionVAE
    vae = training.load_checkpoint(path)
    if "conv_ae" not in vae.description or "motion_normalizer" not in vae.description:
        raise ValueError(f"{path}: not a vae checkpoint of the command line (no conv_ae / motion_normalizer)")
    conv_ae_path = Path(vae.description["conv_ae"])
    if not conv_ae_path.exists() and not conv_ae_path.is_absolute():
        conv_ae_path = Path(path).parent / conv_ae_path.name
    conv_ae = training.load_checkpoint(conv_ae_path)
    motion_normalizer = Normalizer.from_state_dict(vae.description["motion_normalizer"])
    model = MotionVAE(vae.model, conv_ae.model, vae.normalizer, motion_normalizer)
    model.history, model.description = vae.history, vae.description
    model.conv_ae.history = conv_ae.history              # the features' own training, for the record
    return model
