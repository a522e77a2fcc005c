"""motionlab.comparison: every shipped model on one test set (notebook 08)."""
import numpy as np
import pytest

from motionlab import comparison, data, experiments
from motionlab.models.base import Generated

from conftest import CMU_DIR, requires_cmu
from test_data import cmu_like_bvh


class Recorder:
    """A stand-in model: remembers what it was given, returns zeros of the right shape."""

    def __init__(self):
        self.calls = []

    def generate(self, **kwargs):
        self.calls.append(kwargs)
        frames = len(kwargs["control"]) if "control" in kwargs else kwargs.get("frames", 80)
        return Generated(np.zeros((kwargs["n"], frames, 66)), np.zeros((kwargs["n"], frames, 21, 3)), fps=20.0)


def entry(**changes):
    base = dict(name="x", label="X", paper="", control=True, prefix=True, temperature=0.3)
    return comparison.Entry(**{**base, **changes})


def test_respond_gives_each_model_only_what_it_conditions_on():
    control, prefix = np.zeros((40, 3)), np.zeros((2, 10, 66))
    for control_in, prefix_in in ((True, True), (True, False), (False, True), (False, False)):
        model = Recorder()
        out = comparison.respond(entry(control=control_in, prefix=prefix_in), model, control, prefix, n=2, seed=3)
        assert out.shape == (2, 40, 66)
        call = model.calls[0]
        assert ("control" in call) == control_in and ("prefix" in call) == prefix_in
        assert ("frames" in call) == (not control_in) and call["temperature"] == 0.3 and call["seed"] == 3


def test_respond_refuses_what_a_model_cannot_do():
    with pytest.raises(ValueError, match="draws windows of 80 frames"):
        comparison.respond(entry(window=80, prefix=False), Recorder(), np.zeros((40, 3)))
    with pytest.raises(ValueError, match="prefix: X continues real frames"):
        comparison.respond(entry(), Recorder(), np.zeros((40, 3)))


def test_entries_say_what_each_model_conditions_on():
    conditions = {e.label: e.conditions for e in comparison.ENTRIES}
    assert conditions == {"VAE": "nothing", "LSTM-3LR": "prefix + control", "VAE-LSTM": "control",
                          "VAE-LSTM (gated)": "control",
                          "Glow": "control", "Glow (contacts)": "control", "MoGlow": "prefix + control", "MoGlow (anchored)": "prefix + control",
                          "MoGlow (contacts)": "prefix + control", "DFN": "prefix"}


def test_evaluation_windows_cut_every_clip_of_a_folder_and_refuse_short_ones(tmp_path):
    np.testing.assert_array_equal(comparison.evaluation_windows("synthetic"),
                                  experiments.held_out_windows(comparison.TEST_WINDOW, comparison.FPS))
    cmu_like_bvh(tmp_path / "long.bvh", frames=600)        # 5 s at 120 fps: 100 frames at 20 fps
    cmu_like_bvh(tmp_path / "short.bvh", frames=300)       # 2.5 s: no 4-s window
    windows = comparison.evaluation_windows(str(tmp_path), stride_s=1.0)
    long = data.load(tmp_path / "long.bvh", fps=comparison.FPS)[0].features()
    assert windows.shape == (2, comparison.TEST_WINDOW, 66)           # starts at 0 and 1 s
    np.testing.assert_allclose(windows[1], long[20:100])
    (tmp_path / "long.bvh").unlink()
    with pytest.raises(ValueError, match="no clip lasts the 4 s of a test window"):
        comparison.evaluation_windows(str(tmp_path))
    with pytest.raises(ValueError, match="stride_s"):
        comparison.evaluation_windows(str(tmp_path), stride_s=0)


@requires_cmu
def test_evaluation_windows_of_the_real_cmu_clips():
    clips = data.load(CMU_DIR, fps=comparison.FPS)
    windows = comparison.evaluation_windows(str(CMU_DIR))
    expected = sum(max(0, (len(c.features()) - comparison.TEST_WINDOW) // 20 + 1) for c in clips)
    assert windows.shape == (expected, comparison.TEST_WINDOW, 66) and expected > 0
    assert np.isfinite(windows).all()


@pytest.fixture(scope="module")
def shipped():
    models = comparison.load_models()
    if len(models) < len(comparison.ENTRIES):
        pytest.skip("not every checkpoint is shipped (make checkpoints)")
    return models


def test_the_table_on_a_few_held_out_windows(shipped):
    windows = experiments.held_out_windows(comparison.TEST_WINDOW, comparison.FPS, n_clips=1)[:3]
    rows = comparison.table_rows(shipped, windows)
    assert list(rows) == ["data"] + [label for e in comparison.ENTRIES for label in (e.label, e.label + comparison.FINISHED)]
    for e in comparison.ENTRIES:                      # finished: every bone one length, the feet locked
        finished = rows[e.label + comparison.FINISHED]
        assert finished["bone drift (%)"] < 1e-6 and 0 <= finished["out of reach"] <= 1
        assert finished["stepping (m/s)"] > 0.8 * rows[e.label]["stepping (m/s)"]
    assert rows["data"]["bone drift (%)"] < 1e-6 and rows["data"]["stepping (m/s)"] > 0.3
    assert np.isnan(rows["VAE"]["pose error 1 s (cm)"])                  # sees neither control nor prefix
    assert all(np.isfinite(rows[label]["pose error 3 s (cm)"]) for label in ("MoGlow", "DFN", "VAE-LSTM"))
    kinds = {label: r["test NLL is"] for label, r in rows.items()
             if np.isfinite(r.get("test NLL (bits/frame)", np.nan))}
    assert kinds == {"VAE": "bound, conv features", "VAE-LSTM": "bound", "VAE-LSTM (gated)": "bound", "Glow": "exact",
                     "Glow (contacts)": "bound, with contacts", "MoGlow": "exact", "MoGlow (anchored)": "exact",
                     "MoGlow (contacts)": "bound, with contacts"}
    assert rows["VAE-LSTM"]["test NLL (bits/frame)"] > max(rows[f]["test NLL (bits/frame)"] for f in ("Glow", "MoGlow"))
    assert rows["DFN"]["bone drift (%)"] < 0.01                           # the joint-rotation decoder
    long = comparison.long_run(shipped, seconds=10.0, n=2)
    assert set(long) == {"data", "LSTM-3LR", "VAE-LSTM", "VAE-LSTM (gated)", "MoGlow", "MoGlow (anchored)",
                         "MoGlow (contacts)", "DFN"}                                           # not the window models
    assert long["MoGlow"]["samples"].shape == (2, 201, 66) and len(long["MoGlow"]["pose spread (m)"]) == 2
    speed = {label: {1: 100.0, 64: 1000.0} for label in shipped}
    lines = comparison.table(shipped, rows, long, speed).splitlines()
    assert len(lines) == 2 + len(rows) and lines[2].startswith("| **data**")
    assert all(line.count("|") == 16 for line in lines)
    nll_cells = {line.split("|")[1].strip(): line.split("|")[5].strip() for line in lines[3:]
                 if not line.split("|")[1].strip().endswith(comparison.FINISHED)}
    assert nll_cells["**VAE**"].startswith("≤ ") and nll_cells["**VAE**"].endswith("(conv features)")
    assert nll_cells["**VAE-LSTM**"].startswith("≤ ") and nll_cells["**MoGlow**"][0] in "-0123456789"
    assert nll_cells["**Glow (contacts)**"].startswith("≤ ") and nll_cells["**Glow (contacts)**"].endswith("(with contacts)")
    assert nll_cells["**DFN**"] == nll_cells["**LSTM-3LR**"] == "n/a"


def test_one_drawn_path_for_every_controllable_model(shipped):
    path = comparison.walk_turn_stop(10.0)
    assert path.shape == (201, 3) and path[0].max() == 0 and np.abs(path[-1]).max() < 1e-9
    assert path[:, 2].max() > 0.5 and path[:, 0].max() == pytest.approx(1.3)
    steered = comparison.steer_all(shipped, path)
    assert list(steered) == ["data", "LSTM-3LR", "VAE-LSTM", "VAE-LSTM (gated)", "MoGlow", "MoGlow (anchored)",
                             "MoGlow (contacts)"]                        # Glow: windows; VAE, DFN: no control
    assert all(features.shape == (201, 66) for features in steered.values())
    np.testing.assert_allclose(steered["MoGlow"][:, -3:], steered["data"][:, -3:], atol=1e-4)   # the same path
