"""benchmarks/moglow_speed.py --compare: another implementation timed beside motionlab's."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from motionlab.models.moglow import MoGlowConfig

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def speed_script():
    spec = importlib.util.spec_from_file_location("moglow_speed", BENCHMARKS / "moglow_speed.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_compare_times_an_adapter_beside_motionlab():
    speed = speed_script()
    adapter = speed.load_adapter(BENCHMARKS / "compare_motionlab.py")
    rows = speed.compare(adapter, {"tiny": MoGlowConfig(steps=2, hidden=8)}, rounds=1, frames=3, bf16=True)
    assert [(r["config"], r["measure"], r["unit"]) for r in rows] == [
        ("tiny", "training step", "s"), ("tiny", "1 stream", "frames/s"), ("tiny", "64 streams", "frames/s")]
    assert all(r["other"] > 0 and r["motionlab"] > 0 and np.isfinite(r["speed-up"]) for r in rows)
    assert all(r["motionlab bf16"] > 0 and np.isfinite(r["bf16 speed-up"]) for r in rows)
    untrained = speed.compare(adapter, {"tiny": MoGlowConfig(steps=2, hidden=8)}, rounds=1, frames=3, trained=(),
                              bf16=False)
    assert [r["measure"] for r in untrained] == ["1 stream", "64 streams"]
    assert all("motionlab bf16" not in r for r in untrained)
    speed.print_comparison(rows, "compare_motionlab.py", 1)
    speed.print_comparison(untrained, "compare_motionlab.py", 1)


def test_an_adapter_must_be_a_python_file_with_both_functions(tmp_path):
    speed = speed_script()
    with pytest.raises(ValueError, match="expected a Python file"):
        speed.load_adapter(tmp_path / "adapter.txt")
    half = tmp_path / "half.py"
    half.write_text("def training_step(config, batch, frames):\n    return lambda: None\n")
    with pytest.raises(ValueError, match="half.py: an adapter defines .* missing: streaming_step"):
        speed.load_adapter(half)


def test_the_training_limit_puts_the_recurrent_products_at_their_own_rate():
    speed = speed_script()
    config = MoGlowConfig(steps=3, hidden=8, lstm_layers=2)
    model = speed.MoGlow(config)
    assert speed.recurrent_elements(model) == 3 * 2 * (4 * 8) * 8          # W_hh: 4H x H, per layer and step
    # the conditioning (10 x 61 history values and 11 x 3 controls) needs no input gradient
    assert speed.conditioning_elements(model) == 3 * (4 * 8) * (10 * 61 + 11 * 3)
    frames = speed.TRAIN_BATCH * speed.TRAIN_FRAMES
    everything_large = 2 * (3 * speed.weight_elements(model) - speed.conditioning_elements(model)) * frames / 100e9
    assert speed.training_limit(model, 100.0, 100.0) == pytest.approx(everything_large)
    # the forward and input-gradient products of W_hh at half the rate: 2 of its 3 products take twice as long
    slower = everything_large + 2 * 2 * speed.recurrent_elements(model) * frames / 100e9
    assert speed.training_limit(model, 100.0, 50.0) == pytest.approx(slower)
    assert speed.recurrent_rate(8, speed.torch.float32) > 0
    assert speed.lstm_seconds(MoGlowConfig(steps=2, hidden=8), "bf16", repeats=1) > 0
    assert speed.lstm_seconds(MoGlowConfig(steps=2, hidden=8), "fp32", repeats=1, written_out=False) > 0


def test_the_authors_adapter_says_where_their_code_must_be(monkeypatch, tmp_path):
    """compare_authors.py imports the authors' code from MOGLOW_AUTHORS_CODE (nothing of it
    is in motionlab); without a clone there it refuses with a clear message."""
    speed = speed_script()
    monkeypatch.setenv("MOGLOW_AUTHORS_CODE", str(tmp_path))
    clone = "MOGLOW_AUTHORS_CODE to a clone of github.com/simonalexanderson/StyleGestures"
    with pytest.raises(ValueError, match=clone):
        speed.load_adapter(BENCHMARKS / "compare_authors.py")
