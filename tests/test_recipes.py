"""Every shipped checkpoint has one named recipe, and the recipe is what made it."""
from pathlib import Path

import pytest

from motionlab import pretrained, recipes, train, training

ROOT = Path(__file__).resolve().parents[1]


def test_every_shipped_model_has_one_recipe_and_its_file():
    assert set(recipes.RECIPES) == set(pretrained.NAMES)
    assert len({r.file for r in recipes.RECIPES.values()}) == len(recipes.RECIPES)
    assert list(recipes.RECIPES).index("conv_ae") < list(recipes.RECIPES).index("vae")   # the VAE needs it


@pytest.mark.parametrize("name", [n for n in recipes.RECIPES if n != "vae"])
def test_the_recipe_builds_the_config_and_data_its_checkpoint_holds(name):
    recipe = recipes.recipe(name)
    if name not in pretrained.available():
        pytest.skip(f"{name}: no shipped checkpoint")
    checkpoint = training.load_checkpoint(pretrained.path(name))
    assert checkpoint.model.config == recipe.config()
    args = recipe._parsed()
    described = checkpoint.description
    assert sum(len(names) for names in described["clips"].values()) == args.synthetic_clips
    assert described["source"] == "synthetic" and checkpoint.history.train
    if args.stride is not None:
        assert described["stride_frames"] == round(args.stride * checkpoint.model.config.fps)


def test_the_vae_recipe_matches_its_checkpoint():
    if "vae" not in pretrained.available():
        pytest.skip("no shipped VAE")
    vae = pretrained.load("vae")
    changes = recipes.recipe("vae").changes()
    assert (vae.vae.config.latent, vae.vae.config.beta) == (changes["latent"], changes["beta"])


def test_a_moglow_variant_trains_as_its_recipe_says():
    recipe = recipes.recipe("moglow_no_dropout")
    assert recipe.changes() == {"dropout": 0.0, "bone_coordinates": True}
    how = recipe.train_config(1000, progress=False)
    assert (how.epochs, how.batch_size, how.lr, how.progress) == (60, 32, 3e-3, False)
    assert how == training.TrainConfig(epochs=60, batch_size=32, lr=3e-3, progress=False)


def test_recipes_live_in_one_place_not_in_the_makefile():
    makefile = (ROOT / "Makefile").read_text()
    assert "motionlab.train " not in makefile and "-m motionlab.recipes" in makefile


def test_the_command_line_lists_and_refuses(capsys):
    recipes.main(["--list", "glow"])
    printed = capsys.readouterr().out
    assert printed.startswith("glow ") and "python -m motionlab.train glow --synthetic-clips 200" in printed
    with pytest.raises(SystemExit) as exit_info:
        recipes.main(["moglow_paper"])
    assert exit_info.value.code == 2 and "moglow_paper" in capsys.readouterr().err


def test_a_bad_recipe_is_refused_naming_the_field():
    with pytest.raises(ValueError, match="model"):
        recipes.Recipe("x", "x.pt", "transformer", (), "")
    with pytest.raises(ValueError, match="file"):
        recipes.Recipe("x", "../x.pt", "glow", (), "")
    with pytest.raises(ValueError, match="--out"):
        recipes.Recipe("x", "x.pt", "glow", ("--out", "y.pt"), "")
    assert recipes.recipe("glow").argv("ck")[-2:] == ["--out", str(Path("ck") / "glow.pt")]
    assert train.build_parser().parse_args(recipes.recipe("dfn").argv("ck")).stage_epochs == \
        [("frame", 10), ("sequence", 10), ("dynamics", 20)]


@pytest.mark.parametrize("name", ["conv_ae", "vae", "vae_lstm"])
def test_quality_trains_the_same_recipes_on_real_clips(benchmark_script, name, tmp_path):
    """``benchmarks/quality.py --data`` takes its command lines from the recipes: the same
    config changes (and window=20 for the models that cut windows), no built-in-data options."""
    quality = benchmark_script("quality")
    options, epochs = quality.on_real_clips(name)
    recipe = recipes.RECIPES[name]
    conv_ae = ["--conv-ae", str(pretrained.path("conv_ae"))] if name == "vae" else []   # any checkpoint file
    argv = [name, "--data", str(tmp_path), *conv_ae, *options]
    parsed = train.build_parser().parse_args(argv)
    window = [] if name == "vae" else [f"window={quality.REAL_WINDOW}"]
    assert sorted(parsed.set) == sorted(recipe._parsed().set + window)
    assert parsed.lr == recipe._parsed().lr and epochs == recipe._parsed().epochs
    assert not set(options) & {"--synthetic-clips", "--epochs", "--half", "--stride"}
