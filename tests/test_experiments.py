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


def test_steering_gives_the_model_the_data_bodies_standing_prefix_and_their_path():
    """steer / steering_report: a model that continues motion gets the held-out bodies' τ
    standing frames and the first body's control; the report sets it beside the data."""
    import torch
    from motionlab.models.moglow import MoGlow, MoGlowConfig

    torch.manual_seed(0)
    model = MoGlow(MoGlowConfig(window=16, history=4, steps=2, hidden=8))
    walks = experiments.preset_walks("walk", 3.0, 20.0, n=2, lead_frames=4)
    model.normalizer = data.Normalizer.fit(walks.reshape(-1, 66))
    assert walks.shape == (2, 4 + 61, 66)
    assert np.abs(walks[:, :4, CONTROL]).max() < 0.01                        # the prefix stands
    report = experiments.steering_report(model, "walk", 3.0, n=2, temperature=0.3)
    assert report["samples"].shape == report["data"].shape == (2, 61, 66)
    assert np.allclose(report["data"], walks[:, 4:])
    assert np.allclose(report["control"], walks[0, 4:, CONTROL])
    assert np.allclose(report["samples"][..., CONTROL], report["control"])   # it follows the path it is given
    assert report["stepping"].shape == report["data stepping"].shape == (3,)
    assert set(report["model"]) == set(report["data report"]) == {
        "stepping (m/s)", "leg swing (m)", "ankle height (m)", "foot skating (m/s)", "bone drift"}


def test_temperature_sweep_judges_the_shipped_glow_at_each_temperature():
    from motionlab import pretrained
    windows = experiments.held_out_windows(80, 20.0)[:6]
    sweep = experiments.temperature_sweep(pretrained.load("glow"), windows, temperatures=(0.0, 1.0))
    assert list(sweep) == [0.0, 1.0]
    cold, hot = sweep[0.0].figures, sweep[1.0].figures
    assert cold["leg swing (m), data"] == hot["leg swing (m), data"]                 # one yardstick
    assert cold["leg swing (m), samples"] > 0.8 * cold["leg swing (m), data"]        # the shipped model steps
    assert hot["foot skating (m/s), samples"] > cold["foot skating (m/s), samples"]  # noise costs the feet


class _Replay:
    """A "model" that returns the windows it was made with, whatever it is asked."""
    fps = 20.0

    def __init__(self, windows):
        self.windows = windows

    def generate(self, control, n, temperature, seed):
        from motionlab.models.base import Generated
        return Generated(self.windows[:n], None, self.fps)


def test_finished_feet_measures_raw_and_locked_sliding_against_the_data(held_out):
    windows = held_out[:4]
    same = experiments.finished_feet(_Replay(windows), windows, temperature=0.5)
    assert same["raw"] == pytest.approx(same["data"])                      # the data itself: 1x raw
    assert same["finished"] <= same["raw"] + 0.05 and 0 <= same["out of reach"] <= 1
    frozen = windows.copy()
    frozen[..., POSE] = windows[:, :1, POSE]                             # one pose carried along the path
    glide = experiments.finished_feet(_Replay(frozen), windows, temperature=0.5)
    assert glide["raw"] > 5 * glide["data"]                               # its feet glide with the body


def test_own_futures_cut_held_out_clips_where_they_move_at_the_speed_and_keep_what_came_next():
    prefixes, futures = experiments.own_futures((2.8, 4.5), 10, 4.0, 20.0, clips=6, clip_s=20.0)
    assert prefixes.shape[1:] == (10, 66) and futures.shape[1:] == (81, 66) and len(prefixes) == len(futures) >= 3
    forward = prefixes[..., CONTROL.start]
    assert (forward >= 2.8).all() and (forward <= 4.5).all()          # every cut runs through its prefix
    # each future continues its prefix: the first frame's speed is the prefix's last, within a step's change
    assert np.abs(futures[:, 0, CONTROL.start] - forward[:, -1]).max() < 0.2
    # the clips' activity changes: running does not last 4 s in every cut
    assert futures[:, -20:, CONTROL.start].mean() < 0.8 * forward.mean()
    for bad, name in [((3.0, 2.0), "speed_ms"), ((np.nan, 2.0), "speed_ms"), ((9.0, 10.0), "speed_ms")]:
        with pytest.raises(ValueError, match=name):
            experiments.own_futures(bad, 10, 4.0, 20.0, clips=2, clip_s=10.0)
    with pytest.raises(ValueError, match="clip_s"):
        experiments.own_futures((1.0, 2.0), 10, 4.0, 20.0, clip_s=3.0)


def test_the_bound_against_the_data_s_own_future_fails_on_a_frozen_pose_and_on_fading_steps():
    """Notebook 07 and benchmarks/dfn_steps.py ask a continuation to step 0.5-1.3 times as fast
    as the clips' own futures: a pose frozen at the prefix's last frame and steps that fade
    out over a couple of seconds (both moving along the clips' own path) fall below it."""
    _, futures = experiments.own_futures((2.8, 4.5), 10, 10.0, 20.0, clips=6, clip_s=20.0)
    own = metrics.stepping_by_second(futures, 20.0).mean(0)
    frozen = futures.copy()
    frozen[..., POSE] = futures[:, :1, POSE]
    fade = np.exp(-np.arange(futures.shape[1]) / 20.0 / 2.0)[None, :, None]      # 2-s time constant
    fading = futures.copy()
    fading[..., POSE] = futures[:, :1, POSE] + fade * (futures[..., POSE] - futures[:, :1, POSE])
    for baseline in (frozen, fading):
        assert (metrics.stepping_by_second(baseline, 20.0).mean(0) / own).mean() < 0.5
