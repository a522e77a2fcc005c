"""Training across processes with torch.distributed (DistributedDataParallel, gloo on CPU):
two processes that share each global batch train the same model as one process with the
whole batch, to float rounding (the gradients are averaged in another order)."""
import subprocess
import sys

import numpy as np
import pytest
import torch

from motionlab import training

pytestmark = pytest.mark.skipif(not torch.distributed.is_available() or not torch.distributed.is_gloo_available(),
                                reason="this torch build has no gloo backend")

# The conv AE without input dropout: a loss with no randomness of its own, so that one
# process and two see exactly the same batches and the same computation.
ARGS = ["conv_ae", "--synthetic-clips", "6", "--max-steps", "8", "--batch-size", "8", "--lr", "3e-3",
        "--set", "filters=8", "input_dropout=0.0", "--device", "cpu"]
TOLERANCE = 1e-4
"""Relative difference allowed between the logged losses of 1 and 2 processes."""


def torchrun(processes: int, out, *extra) -> str:
    command = [sys.executable, "-m", "torch.distributed.run", "--standalone", f"--nproc_per_node={processes}",
               "-m", "motionlab.train", *ARGS, "--out", str(out), *extra]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300,
                            env={**__import__("os").environ, "OMP_NUM_THREADS": "1"})
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return result.stdout


@pytest.mark.slow
def test_two_processes_train_what_one_process_trains(tmp_path):
    one = torchrun(1, tmp_path / "one.pt")
    two = torchrun(2, tmp_path / "two.pt", "--save-every", "4")
    assert "8 windows per step in all (8 per process x 1 process)" in one
    assert "8 windows per step in all (4 per process x 2 processes)" in two
    assert two.count("saved ") == 1                       # rank 0 alone saves and reports
    a, b = training.load_checkpoint(tmp_path / "one.pt"), training.load_checkpoint(tmp_path / "two.pt")
    loss_a, loss_b = a.history.series("loss")[1], b.history.series("loss")[1]
    assert len(loss_a) == len(loss_b) == 8
    np.testing.assert_allclose(loss_b, loss_a, rtol=TOLERANCE)
    assert loss_a[-1] < loss_a[0]                         # it trained
    for name, value in a.model.state_dict().items():
        torch.testing.assert_close(b.model.state_dict()[name], value, rtol=1e-4, atol=1e-6)
    # the state holds each process's random generators: it resumes with as many processes only
    state = torch.load(tmp_path / "two.pt.state", weights_only=True)
    assert len(state["rng"]) == 2 and state["rng"][0]["torch"] != state["rng"][1]["torch"]
    command = [sys.executable, "-m", "motionlab.train", *ARGS, "--out", str(tmp_path / "two.pt"), "--resume"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode != 0 and "saved by 2 process(es), resumed by 1" in result.stderr


def test_a_global_batch_that_does_not_split_is_refused(monkeypatch, capsys):
    """Checked before any process trains (as if 2 processes had joined), in the command line
    and in the loop itself."""
    from motionlab import train as cli
    from motionlab.training import loop
    monkeypatch.setattr(training, "distributed", lambda: (0, 2))
    monkeypatch.setattr(loop, "distributed", lambda: (0, 2))           # what train() itself asks
    monkeypatch.setattr(training, "init_distributed", lambda: False)
    with pytest.raises(SystemExit):
        cli.main([*ARGS, "--batch-size", "7"])
    assert "--batch-size: 7 windows do not split over 2 processes" in capsys.readouterr().err
    with pytest.raises(ValueError, match="batch_size: 7 windows do not split over 2 processes"):
        training.train(torch.nn.Linear(1, 1), torch.zeros(8, 1), training.TrainConfig(batch_size=7))
