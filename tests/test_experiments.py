"""The held-out data, trivial baselines and steering paths of motionlab.experiments."""
import numpy as np
import pytest

from motionlab import data, experiments, metrics
from motionlab.representation import CONTROL, POSE


@pytest.fixture(scope="module")
def held_out():
    return experiments.held_out_windows(40, n_clips=2)


def test_held_out_clips_are_not_the_training_clips(held_out):
    assert held_out.shape[1:] == (40, 66) and len(held_out) == 2 * (240 - 40) // 20 + 2
    trained_on = data.load("synthetic", fps=20, n_clips=2)            # what every checkpoint starts from
    first = data.cut_windows(trained_on[0].features(), 40, 20)
    assert not any(np.allclose(w, held_out[0]) for w in first)


def test_trivial_reconstructions(held_out):
    mean = held_out.reshape(-1, 66).mean(0)
    trivial = experiments.trivial_reconstructions(held_out, mean)
    assert set(trivial) == {"mean pose", "window average", "constant velocity"}
    assert all(t.shape == held_out.shape for t in trivial.values())
    assert np.allclose(trivial["mean pose"], mean)
    assert np.allclose(trivial["window average"][:, 0], held_out.mean(1))
    assert np.allclose(trivial["constant velocity"][:, :2], held_out[:, :2])      # frames 0 and 1 kept exactly


def test_mean_pose_on_path_keeps_the_path_and_loses_the_steps(held_out):
    mean = held_out.reshape(-1, 66).mean(0)
    glide = experiments.mean_pose_on_path(held_out, mean)
    assert np.array_equal(glide[..., CONTROL], held_out[..., CONTROL])
    assert np.allclose(glide[..., POSE], mean[POSE])
    assert metrics.leg_swing(glide) == pytest.approx(0.0, abs=1e-12)
    still = experiments.constant_pose(held_out)
    assert (still[..., CONTROL] == 0).all() and np.allclose(still[:, :, POSE], held_out[:, :1, POSE])


def test_walked_presets_and_the_data_stepping():
    walk = experiments.walked_preset("walk", 4.0, 20.0)
    assert walk.shape == (81, 3) and abs(walk[20:, 0].mean() - 1.3) < 0.1
    stepping, swing = experiments.data_stepping("walk", 4.0, 20.0, n=2)
    run_stepping, _ = experiments.data_stepping("run", 4.0, 20.0, n=2)
    standing, still_swing = experiments.data_stepping("stand still", 4.0, 20.0, n=2)
    assert stepping.shape == (4,) and swing > 0.2
    assert stepping[0] < stepping[1]                    # every path starts from standing (RAMP_S = 1 s)
    assert (0.8 < stepping[1:]).all() and (stepping[1:] < run_stepping[1:]).all()
    assert (standing < 0.01).all() and still_swing < 0.01
