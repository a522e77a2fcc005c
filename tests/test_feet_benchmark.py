"""benchmarks/feet.py's options: more bodies per path, and a checkpoint of one's own in the
place of a shipped model."""
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def feet(benchmark_script):
    return benchmark_script("feet")


@pytest.mark.parametrize("argv, says", [
    (["--checkpoint", "Nope=x.pt"], "LABEL one of"),
    (["--checkpoint", "DFN"], "LABEL=PATH"),
    (["--checkpoint", f"DFN={ROOT / 'motionlab' / 'checkpoints' / 'glow.pt'}"], "holds a Glow, not the DFN"),
    (["--samples", "0"], "--samples: expected 1 to 64"),
])
def test_bad_arguments_are_refused_by_name(feet, capsys, argv, says):
    with pytest.raises(SystemExit):
        feet.main(argv)
    assert says in capsys.readouterr().err


def test_a_checkpoint_of_ones_own_is_measured_alone_on_as_many_bodies_as_asked(feet, capsys):
    feet.main(["--samples", "2", "--paths", "walk", "--checkpoint",
               f"DFN={ROOT / 'motionlab' / 'checkpoints' / 'dfn.pt'}"])
    out = capsys.readouterr().out
    assert "2 samples; the data: 2 held-out bodies" in out
    rows = [line for line in out.splitlines() if line.startswith("| DFN, walk")]
    assert len(rows) == 4                  # raw, finished, the lock alone (section 2), the causal lock (2b)
    assert "MoGlow" not in out and "VAE-LSTM" not in out   # only the model named
    raw, finished, _, causal = ([cell.strip() for cell in row.strip("|").split("|")] for row in rows)
    # section 2b's raw and offline columns are section 1's figures, measured again on the same samples
    assert causal[1:3] == [raw[2], finished[2]]
    assert float(causal[3]) > 0 and float(causal[5]) > 0


def test_the_vae_of_ones_own_is_loaded_with_the_conv_ae_that_decodes_it(feet, capsys):
    # a vae checkpoint holds the feature VAE; its samples need the conv AE it names
    feet.main(["--samples", "1", "--paths", "walk", "--checkpoint",
               f"VAE={ROOT / 'motionlab' / 'checkpoints' / 'vae.pt'}"])
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| VAE, walk")]
    assert len(rows) == 4
