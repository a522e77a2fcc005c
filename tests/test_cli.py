"""The command line trains every model (one step, tiny sizes) and --paper applies the paper's schedule."""
import importlib.util
import sys
import textwrap

import pytest

from motionlab import train as cli
from motionlab import pretrained, training
from motionlab import models
from motionlab.models.modelcard import ModelCard

TINY = {   # --set values that make each model small enough for one step in a second or two
    "conv_ae": ["window=8", "filters=4", "width=3"],
    "vae": ["hidden=8", "latent=2"],
    "vae_lstm": ["window=16", "width=5", "control_filters=4", "control_code=6", "inference_filters=8",
                 "units=5", "decoder_filters=8"],
    "lstm": ["window=12", "hidden=8", "layers=2"],
    "glow": ["window=16", "levels=2", "steps=2", "hidden=16"],
    "moglow": ["window=16", "history=4", "steps=3", "hidden=16"],
    "dfn": ["frame_hidden=16", "pose_code=4", "velocity_code=2", "horizon=4", "summary=8", "past=8",
            "future=4", "current=4", "future_prior_hidden=8", "current_prior_hidden=8",
            "summary_decoder_hidden=8", "current_posterior_hidden=8", "future_posterior_hidden=8",
            "td_hidden=8", "td_max_skip=2"],
}
QUICK = ["--synthetic-clips", "4", "--max-steps", "1", "--device", "cpu"]


def run(model: str, out, *extra: str) -> training.History:
    return cli.main([model, *QUICK, "--set", *TINY[model], "--out", str(out), *extra])


@pytest.fixture(scope="module")
def conv_ae_checkpoint(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "conv_ae.pt"
    run("conv_ae", path)
    return path


def model_class(name: str) -> type:
    return models.card(name).model


def test_the_registry_names_all_seven_models_each_in_its_own_file():
    assert models.FILES == ("conv_ae", "vae", "vae_lstm", "lstm", "glow", "moglow", "dfn")
    for name, card in models.cards().items():
        assert card.name == name and card.model.__module__ == f"motionlab.models.{name}"
        assert card.config.__module__ == card.model.__module__
    from motionlab.models.dfn import STAGES
    assert models.card("dfn").stages == STAGES and models.card("dfn").augment == ("mirror",)
    assert {name for name, card in models.cards().items() if card.stages} == {"dfn"}
    assert training.registered_models()["motionlab.models.moglow.MoGlow"] == (models.card("moglow").model,
                                                                               models.card("moglow").config)


@pytest.mark.parametrize("name", models.FILES)
def test_every_model_trains_one_step_and_its_checkpoint_loads(name, tmp_path, conv_ae_checkpoint):
    out = tmp_path / f"{name}.pt"
    extra = ["--conv-ae", str(conv_ae_checkpoint)] if name == "vae" else []
    history = run(name, out, *extra)
    checkpoint = training.load_checkpoint(out)
    assert type(checkpoint.model) is model_class(name)
    assert len(history.train) == (3 if name == "dfn" else 1)          # one step (per DFN stage)
    if name == "dfn":
        assert [row["stage"] for row in checkpoint.history.train] == [0, 1, 2]
    if name == "vae":                                                  # all MotionVAE needs
        conv_ae = training.load_checkpoint(conv_ae_checkpoint)
        assert checkpoint.description["conv_ae"] == str(conv_ae_checkpoint)
        assert checkpoint.description["motion_normalizer"] == conv_ae.normalizer.state_dict()
        assert checkpoint.model.config.n_inputs == 4 * 4                # window 8 / 2 x 4 filters
        motion_vae = pretrained.load_motion_vae(out)
        assert motion_vae.decode(checkpoint.model.sample_latents(2)).shape == (2, 8, 66)


def plan(*argv: str) -> cli.Plan:
    return cli.training_plan(cli.build_parser().parse_args(list(argv)))


PAPER = {   # what reaches TrainConfig with --paper (per DFN stage: epochs)
    "conv_ae": {"optimizer": "Adam", "batch_size": 100, "epochs": 200},                 # Motegi §III-B
    "vae": {"optimizer": "Adam", "batch_size": 100, "epochs": 200},                     # Motegi §IV-B
    "vae_lstm": {"optimizer": "Adam", "lr": 5e-4, "epochs": 5000},                      # Habibie §4.2
    "lstm": {},                                                                         # (none given)
    "glow": {"optimizer": "Adam", "max_steps": 20_000},                                 # Henter §5.2
    "moglow": {"optimizer": "Adam", "max_steps": 80_000},                               # Henter §5.2
    "dfn": {"stages": "frame, then sequence, then dynamics with both frozen"},          # Chen §5.6
}


@pytest.mark.parametrize("name", models.FILES)
def test_paper_schedule_reaches_train_config_and_says_where_each_value_comes_from(name):
    table = models.card(name).schedule
    assert {k: s.value for k, s in table.items() if s.from_paper} == PAPER[name]
    assert all(s.source for s in table.values()) and table["optimizer"].value == "Adam"
    p = plan(name, "--paper")
    stage = "dynamics" if name == "dfn" else None
    config = p.train_config(n_train=1000, stage=stage)
    for key, setting in table.items():
        if key == "stage_epochs":
            assert p.stage_epochs == setting.value and config.epochs == setting.value["dynamics"]
        elif key not in ("optimizer", "stages"):
            assert getattr(config, key) == setting.value, key
    if "max_steps" in table and "epochs" not in table:                  # steps, not epochs: enough epochs
        assert config.epochs * (1000 // config.batch_size) >= config.max_steps
    text = p.describe()
    assert "from the paper:" in text and "stated choices (not in the paper):" in text
    for setting in table.values():
        assert setting.source in text


def test_paper_prints_both_lists_before_training(tmp_path, capsys):
    run("conv_ae", tmp_path / "paper.pt", "--paper")
    printed = capsys.readouterr().out
    assert printed.index("from the paper:") < printed.index("stated choices (not in the paper):") \
        < printed.index("saved")
    assert "batch size: 100  (§III-B" in printed and "epochs: 200" in printed
    assert training.load_checkpoint(tmp_path / "paper.pt").model.config.fps == 30.0    # paper's sizes


def test_explicit_options_win_over_the_paper():
    p = plan("vae_lstm", "--paper", "--lr", "0.01", "--epochs", "3", "--schedule", "cosine")
    config = p.train_config(1000)
    assert (config.lr, config.epochs, config.schedule, config.batch_size) == (0.01, 3, "cosine", 32)
    assert "[not used: --lr given]" in p.describe() and "--lr 0.01" in p.given
    dfn = plan("dfn", "--paper", "--stage-epochs", "dynamics=5", "--batch-size", "8")
    assert dfn.stage_epochs == {"frame": 100, "sequence": 100, "dynamics": 5} and dfn.batch_size == 8
    assert plan("dfn", "--paper", "--epochs", "2").stage_epochs == {"frame": 2, "sequence": 2, "dynamics": 2}
    glow = plan("glow", "--paper", "--max-steps", "10").train_config(1000)
    assert glow.max_steps == 10 and glow.lr == 1e-4


def test_max_steps_alone_trains_exactly_that_many_steps_and_defaults_stay():
    config = plan("moglow", "--max-steps", "25").train_config(n_train=100)   # 3 batches of 32 per epoch
    assert (config.max_steps, config.epochs) == (25, 9)
    default = plan("conv_ae").train_config(100)
    assert (default.epochs, default.batch_size, default.lr, default.schedule, default.max_steps) == \
        (30, 32, 1e-3, "cosine", None)
    assert plan("dfn", "--stage-epochs", "frame=15", "sequence=15", "dynamics=30").stage_epochs == \
        {"frame": 15, "sequence": 15, "dynamics": 30}
    assert plan("dfn", "--epochs", "4").stage_epochs == {"frame": 4, "sequence": 4, "dynamics": 4}


def wrong_kind_checkpoint(tmp_path):
    from motionlab.models.glow import Glow, GlowConfig
    path = tmp_path / "glow.pt"
    training.save_checkpoint(path, Glow(GlowConfig(window=4, levels=2, steps=2, hidden=8)))
    return path


BAD = {
    "vae without --conv-ae": (["vae"], "--conv-ae"),
    "--conv-ae missing file": (["vae", "--conv-ae", "/no/such.pt"], "--conv-ae"),
    "--conv-ae of another model": (["vae", "--conv-ae", "GLOW"], "--conv-ae"),
    "--conv-ae for conv_ae": (["conv_ae", "--conv-ae", "GLOW"], "--conv-ae"),
    "--stage-epochs unknown stage": (["dfn", "--stage-epochs", "warmup=3"], "--stage-epochs"),
    "--stage-epochs zero": (["dfn", "--stage-epochs", "frame=0"], "--stage-epochs"),
    "--stage-epochs no number": (["dfn", "--stage-epochs", "frame"], "--stage-epochs"),
    "--stage-epochs twice": (["dfn", "--stage-epochs", "frame=2", "frame=3"], "--stage-epochs"),
    "--stage-epochs for glow": (["glow", "--stage-epochs", "frame=2"], "--stage-epochs"),
    "--max-steps zero": (["glow", "--max-steps", "0"], "--max-steps"),
    "--window-s for glow": (["glow", "--window-s", "2"], "--window-s"),
    "--window-s under the horizon": (["dfn", "--window-s", "0.2", "--synthetic-clips", "1"], "--window-s"),
    "--set n_inputs for vae": (["vae", "--conv-ae", "CONV_AE", "--set", "n_inputs=5"], "--set"),
}


@pytest.mark.parametrize("argv, option", BAD.values(), ids=BAD.keys())
def test_bad_model_options_are_usage_errors_naming_the_option(argv, option, tmp_path, capsys,
                                                             conv_ae_checkpoint):
    paths = {"GLOW": str(wrong_kind_checkpoint(tmp_path)), "CONV_AE": str(conv_ae_checkpoint)}
    with pytest.raises(SystemExit) as exit_info:
        cli.main([paths.get(a, a) for a in argv] + ["--out", str(tmp_path / "never.pt")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "usage:" in err and option in err.split("error:")[-1]
    assert not (tmp_path / "never.pt").exists()


def test_the_registry_imports_only_the_files_it_lists():
    with pytest.raises(ValueError, match="name: expected one of"):
        models.card("os")
    with pytest.raises(ValueError, match="name: expected one of"):
        models.card("..training")


BAD_CARDS = {
    "name": (dict(name="Glow 2"), "name"),
    "model": (dict(model=dict), "model"),
    "config": (dict(config=int), "config"),
    "schedule key": (dict(schedule={"learning_rate": None}), "schedule"),
    "augment": (dict(augment=("flip",)), "augment"),
    "stages": (dict(stages=("a", "a")), "stages"),
    "stage epochs without stages": (dict(schedule={"stage_epochs": models.card("dfn").schedule["stage_epochs"]}),
                                    "stage_epochs"),
}


@pytest.mark.parametrize("change, field", BAD_CARDS.values(), ids=BAD_CARDS.keys())
def test_a_bad_card_is_refused_naming_the_field(change, field):
    glow = models.card("glow")
    fields = dict(name=glow.name, model=glow.model, config=glow.config, schedule=glow.schedule)
    with pytest.raises(ValueError, match=field):
        ModelCard(**{**fields, **change})


TINY_MODEL = """
    from dataclasses import dataclass

    import torch
    from torch import nn

    from motionlab.models.modelcard import ModelCard, choice


    @dataclass(frozen=True)
    class MeanPoseConfig:
        n_features: int = 66
        window: int = 8
        fps: float = 20.0

        @classmethod
        def paper(cls, **changes):
            return cls(**changes)


    class MeanPose(nn.Module):
        # the simplest model there is: one learnt pose

        def __init__(self, config: MeanPoseConfig = MeanPoseConfig()):
            super().__init__()
            self.config = config
            self.pose = nn.Parameter(torch.zeros(config.n_features))

        def loss(self, batch):
            return {"loss": ((batch - self.pose) ** 2).mean()}


    CARD = ModelCard("mean_pose", MeanPose, MeanPoseConfig,
                     schedule={"lr": choice(1e-2, "a test's choice")})
"""


def test_adding_a_model_is_its_file_plus_its_name_twice(tmp_path, monkeypatch):
    """A new model file in motionlab/models, imported by motionlab/models/__init__.py and named
    in FILES: the command line trains it (with --paper too) and its checkpoint loads, with
    nothing else changed."""
    folder = tmp_path / "more_models"
    folder.mkdir()
    (folder / "mean_pose.py").write_text(textwrap.dedent(TINY_MODEL))
    # the file, as `from . import ..., mean_pose` in motionlab/models/__init__.py would import it
    spec = importlib.util.spec_from_file_location("motionlab.models.mean_pose", folder / "mean_pose.py")
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)
    spec.loader.exec_module(module)
    monkeypatch.setattr(models, "mean_pose", module, raising=False)              # the import line
    monkeypatch.setattr(models, "FILES", (*models.FILES, "mean_pose"))          # and its name
    out = tmp_path / "mean_pose.pt"
    history = cli.main(["mean_pose", *QUICK, "--paper", "--out", str(out)])
    assert len(history.train) == 1
    checkpoint = training.load_checkpoint(out)
    assert type(checkpoint.model).__name__ == "MeanPose" and checkpoint.model.config.window == 8
