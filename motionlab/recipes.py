"""How every shipped model was trained: one named recipe per checkpoint, written once.

A recipe is the command line of :mod:`motionlab.train` that made the checkpoint, so anyone
can read it, change it and run it again::

    python -m motionlab.recipes                      # `make checkpoints`: every recipe, in order
    python -m motionlab.recipes moglow glow          # only these
    python -m motionlab.recipes --list               # names, files and command lines

The Makefile's ``checkpoints`` target runs this module; :mod:`motionlab.pretrained` reads
the recipes for the files it loads and, where a notebook trains a model itself, for how
to train it (:func:`Recipe.config` and :func:`Recipe.train_config`), so the notebooks and
the shipped models cannot disagree. ``tests/test_recipes.py`` checks that every recipe
builds the config its shipped checkpoint holds.
"""
from __future__ import annotations

import argparse
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path

from . import models

MOTEGI = ("--synthetic-clips", "100", "--stride", "1.0", "--normalization", "shared_pose", "--half")
"""Motegi's conv AE and VAE on its features (notebook 03's data)."""

HABIBIE = ("--synthetic-clips", "120", "--epochs", "20", "--lr", "3e-3", "--half")
"""Habibie's VAE-LSTM and its LSTM-3LR baselines: one budget for all four (notebook 04)."""

GLOW = ("--synthetic-clips", "200", "--stride", "1.0", "--epochs", "20", "--lr", "2e-3", "--batch-size", "32", "--half")
"""Glow for 4-s windows (notebook 05), with and without its contact head."""

MOGLOW = ("--synthetic-clips", "200", "--epochs", "60", "--lr", "3e-3", "--batch-size", "32", "--half")
"""Every MoGlow of notebook 06 (and the anchored one of 08): one budget."""


@dataclass(frozen=True)
class Recipe:
    """One shipped model: its name (:func:`motionlab.pretrained.load` takes it), its file in
    the checkpoint folder, the model it trains (a name of :data:`motionlab.models.FILES`) and
    the rest of its command line, and what it is for."""

    name: str
    file: str
    model: str
    options: tuple[str, ...]
    about: str

    def __post_init__(self):
        if self.model not in models.FILES:
            raise ValueError(f"model: expected one of {', '.join(models.FILES)}, got {self.model!r}")
        if not self.file.endswith(".pt") or "/" in self.file:
            raise ValueError(f"file: expected a file name ending in .pt, got {self.file!r}")
        if "--out" in self.options:
            raise ValueError("options: the recipe names no --out; the folder decides it")

    def argv(self, folder: str | Path) -> list[str]:
        """The command line (after ``python -m motionlab.train``) that writes ``folder/file``;
        a ``{folder}`` in the options (the VAE's conv AE) becomes ``folder``."""
        return [self.model, *(part.replace("{folder}", str(folder)) for part in self.options),
                "--out", str(Path(folder) / self.file)]

    def command(self, folder: str | Path = "motionlab/checkpoints") -> str:
        """The recipe as one shell line, to read or to paste."""
        return "python -m motionlab.train " + shlex.join(self.argv(folder))

    def _parsed(self, folder: str | Path = "motionlab/checkpoints") -> argparse.Namespace:
        from . import train
        parser = train.build_parser()
        args = parser.parse_args(self.argv(folder))
        train.check_model_options(parser, args)
        return args

    def changes(self) -> dict:
        """The recipe's ``--set`` changes to its model's config, typed (``{"dropout": 0.0}``)."""
        from . import train
        return train.parse_overrides(models.card(self.model).config, self._parsed().set)

    def config(self):
        """The model config this recipe trains (its changes on the model's default config)."""
        if self.model == "vae":
            raise ValueError("name: the VAE's config depends on its conv AE checkpoint; load that instead")
        config_class = models.card(self.model).config
        return config_class.paper(**self.changes()) if self._parsed().paper else config_class(**self.changes())

    def train_config(self, n_train: int, stage: str | None = None, **changes):
        """The :class:`motionlab.training.TrainConfig` this recipe trains with, for
        ``n_train`` training windows (and one stage of a staged model); ``changes`` replace
        fields (e.g. ``progress=False``)."""
        from dataclasses import replace

        from . import train
        return replace(train.training_plan(self._parsed()).train_config(n_train, stage), **changes)


RECIPES = {recipe.name: recipe for recipe in (
    Recipe("conv_ae", "conv_ae.pt", "conv_ae",
           (*MOTEGI, "--set", "depool=linear", "input_dropout=0.0", "l1=0.0", "skeleton=true", "--epochs", "40",
            "--lr", "2e-3"),
           "Motegi's temporal conv autoencoder, its decoder on a skeleton (notebook 03)"),
    Recipe("vae", "vae.pt", "vae",
           ("--conv-ae", "{folder}/conv_ae.pt", *MOTEGI, "--set", "latent=16", "beta=32.0", "--epochs", "60",
            "--lr", "1e-3"),
           "Motegi's VAE on the conv AE's features (notebook 03); needs conv_ae first"),
    Recipe("vae_lstm", "vae_lstm.pt", "vae_lstm",
           (*HABIBIE, "--set", "observation_std=3.0", "contact_weight=1.0", "skeleton=true"),
           "Habibie's VAE-LSTM, with the free-running and foot-contact terms, on a skeleton output layer "
           "(notebook 04)"),
    Recipe("vae_lstm_gated", "vae_lstm_gated.pt", "vae_lstm",
           (*HABIBIE, "--set", "observation_std=3.0", "contact_weight=1.0", "foot_gate=true", "skeleton=true"),
           "the same with gated feet on a skeleton output layer (notebooks 04 and 08)"),
    Recipe("vae_lstm_paper_objective", "vae_lstm_paper_objective.pt", "vae_lstm",
           (*HABIBIE, "--set", "observation_std=3.0", "free_running=0.0", "skeleton=true"),
           "the same trained on eq. 5 alone (notebook 04)"),
    Recipe("lstm_no_control", "lstm_no_control.pt", "lstm",
           (*HABIBIE, "--set", "hidden=64", "control=predicted", "skeleton=true"),
           "LSTM-3LR predicting its own control, on the primed body's skeleton (notebook 04)"),
    Recipe("lstm_control", "lstm_control.pt", "lstm",
           (*HABIBIE, "--set", "hidden=64", "control=given", "skeleton=true"),
           "LSTM-3LR given the control, on the primed body's skeleton (notebooks 04 and 08)"),
    Recipe("moglow", "moglow_dropout.pt", "moglow", (*MOGLOW, "--set", "bone_coordinates=true"),
           "MoGlow as the paper trains it, with history dropout, its bones as lengths and directions (notebook 06)"),
    Recipe("moglow_no_dropout", "moglow_no_dropout.pt", "moglow",
           (*MOGLOW, "--set", "dropout=0.0", "bone_coordinates=true"),
           "without history dropout (§5.3)"),
    Recipe("moglow_markov", "moglow_markov.pt", "moglow",
           (*MOGLOW, "--set", "recurrent=false", "bone_coordinates=true"),
           "feed-forward (Markov) couplings instead of LSTMs (§4.2)"),
    Recipe("moglow_markov_matched", "moglow_markov_matched.pt", "moglow",
           (*MOGLOW, "--set", "recurrent=false", "hidden=205", "bone_coordinates=true"),
           "the same, widened to the LSTM model's number of weights"),
    Recipe("moglow_foot_anchor", "moglow_foot_anchor.pt", "moglow",
           (*MOGLOW, "--set", "foot_anchor=true", "anchor_conditioning=true", "leg_anchor=true"),
           "each ankle modelled relative to where it would be had it stayed planted, toes and knees relative "
           "to the leg (notebooks 06, 08)"),
    Recipe("moglow_contacts", "moglow_contacts.pt", "moglow",
           (*MOGLOW, "--set", "contact_head=true", "bone_coordinates=true"),
           "MoGlow with a contact head: each frame's contacts drawn first, then the pose given them (notebook 08)"),
    Recipe("glow", "glow.pt", "glow", (*GLOW, "--set", "bone_coordinates=true"),
           "Glow for 4-s windows given their control, its bones as lengths and directions (notebook 05)"),
    Recipe("glow_contacts", "glow_contacts.pt", "glow",
           (*GLOW, "--set", "contact_head=true", "bone_coordinates=true"),
           "the same with a contact head: p(contacts | control), then the pose given both (notebooks 05, 08)"),
    Recipe("dfn", "dfn.pt", "dfn",
           ("--synthetic-clips", "120", "--stride", "0.5", "--stage-epochs", "frame=10", "sequence=10",
            "dynamics=20", "--lr", "3e-3", "--batch-size", "64", "--half"),
           "Dynamic Future Net, its three stages one after another (notebook 07)"),
)}
"""Every shipped model's recipe, in the order ``make checkpoints`` trains them."""


def recipe(name: str) -> Recipe:
    """The recipe of the shipped model ``name``."""
    if name not in RECIPES:
        raise ValueError(f"name: expected one of {', '.join(RECIPES)}, got {name!r}")
    return RECIPES[name]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m motionlab.recipes",
                                     description="Train the shipped models from their recipes.")
    parser.add_argument("names", nargs="*", metavar="NAME",
                        help=f"which (default: all, in order): {', '.join(RECIPES)}")
    parser.add_argument("--folder", default="motionlab/checkpoints", help="where the checkpoints go")
    parser.add_argument("--list", action="store_true", help="print the recipes and stop")
    args = parser.parse_args(argv)
    unknown = [name for name in args.names if name not in RECIPES]
    if unknown:
        parser.error(f"NAME: {', '.join(unknown)} is not a recipe; expected some of {', '.join(RECIPES)}")
    chosen = [RECIPES[name] for name in (args.names or RECIPES)]
    if args.list:
        for r in chosen:
            print(f"{r.name:26} {r.about}\n{'':26} {r.command(args.folder)}")
        return
    from . import train
    Path(args.folder).mkdir(parents=True, exist_ok=True)
    for r in chosen:
        print(f"== {r.name}: {r.command(args.folder)}", flush=True)
        train.main(r.argv(args.folder))


if __name__ == "__main__":
    sys.exit(main())
