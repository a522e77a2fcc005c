"""benchmarks/dfn_steps.py: where the shipped DFN's steps fade, stage by stage."""
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def dfn_steps(benchmark_script):
    return benchmark_script("dfn_steps")


@pytest.mark.parametrize("argv, says", [
    (["--bodies", "0"], "--bodies: expected 1 to 64"),
    (["--checkpoint", str(ROOT / "motionlab" / "checkpoints" / "glow.pt")], "holds a Glow, not a DFN"),
    (["--checkpoint", str(ROOT / "no_such.pt")], "--checkpoint:"),
])
def test_bad_arguments_are_refused_by_name(dfn_steps, capsys, argv, says):
    with pytest.raises(SystemExit):
        dfn_steps.main(argv)
    assert says in capsys.readouterr().err


def test_the_reconstructions_step_like_the_data_and_every_row_has_every_second(dfn_steps, capsys):
    ratios = dfn_steps.main(["--bodies", "2"])
    out = capsys.readouterr().out
    assert set(ratios) == {"walk", "run"}
    priors = {"prior, τ = 1", "prior, τ = 0.5", "prior, τ = 0"}
    for path in ratios.values():
        rows, first = path["mean"], path["first second"]
        assert set(rows) == {"frame autoencoder", "posterior"} | priors and set(first) == priors
        # the decoder and the posterior's states keep the data's steps: what fades is the prior's
        assert 0.9 < rows["frame autoencoder"] < 1.1 and 0.9 < rows["posterior"] < 1.1
        assert all(0 < r < 2 for r in rows.values())
        # primed by the prefix's motion, not told it stops: the first second keeps the data's
        # steps (0.96-0.99 on 8 bodies; 0.4-0.5 when the prefix's last frame was held)
        assert 0.8 < first["prior, τ = 1"] < 1.2
        # the clips' own future from the same kind of prefix, and DFN beside it
        own = path["own future"]
        assert own["data"].shape == own["prior, τ = 1"].shape == (10,)
        assert 0.5 < own["prior, τ = 1"].mean() < 1.3
        raw, finished = own["skating"]
        assert raw > finished > 0                                      # the lock takes sliding away
    # from a run, the data's own clips slow down (their activity changes every 1.5-4 s)
    running = ratios["run"]["own future"]["data"]
    assert running[0] > 1.25 * running[5:].mean()
    table = [line for line in out.splitlines() if line.startswith("| prior") or line.startswith("| posterior")]
    assert len(table) == 8 and all(line.count("|") == 13 for line in table)   # 10 seconds and the speed
    own = [line for line in out.splitlines() if line.startswith("| the clips'") or line.startswith("| DFN, /")]
    assert len(own) == 4 and all(line.count("|") == 13 for line in own)
    assert out.count("Foot skating, / the clips' own") == 2
    assert out.count("Foot skating, / the data's") == 2
