"""Every claim check in motionlab.claims fails on trivial baselines, and passes real motion.

The baselines are the ways a model can look good without being good: the data's mean pose
moved along the true path (glides), a constant pose (stands), the data's frames shuffled in
time (jitters), steps that fade, a decoder that ignores its latent, one latent axis that
moves everything.
"""
import numpy as np
import pytest

from motionlab import claims, metrics, synthetic
from motionlab.representation import CONTROL, POSE, to_features

FPS = 20.0


def walk(seconds=10.0, preset="walk", seed=0):
    """Synthetic features of a character following a preset control path, (frames, 66)."""
    rng = np.random.default_rng(seed)
    body, style = synthetic.Body.random(rng), synthetic.Style.random(rng)
    control = synthetic.preset_control(preset, seconds, FPS, ramp_s=0.0)
    return to_features(synthetic.generate(control, FPS, body, style).positions, FPS)


def test_one_reference_for_every_second_or_one_per_second(walks):
    assert claims.steps_steadily(walks[:2], 1.24, 0.55, FPS)
    with pytest.raises(ValueError, match="one per second"):
        claims.steps_steadily(walks[:2], np.ones(7), 0.55, FPS)


@pytest.fixture(scope="module")
def walks():
    """Eight 4-s windows of real (synthetic) walking: (8, 80, 66)."""
    return np.stack([walk(4.0, "walk", seed=s) for s in range(8)])


def mean_pose_on_path(features):
    out = features.copy()
    out[..., POSE] = features[..., POSE].reshape(-1, 63).mean(0)
    return out


def constant_pose(features):
    out = features.copy()
    out[..., POSE] = features[..., :1, POSE]
    out[..., CONTROL] = 0.0
    return out


def shuffled(features, seed=0):
    rng = np.random.default_rng(seed)
    return np.stack([w[rng.permutation(len(w))] for w in features])


def fading(features):
    """Steps that fade: the pose blends from the real one to the mean pose over the window."""
    mean = features[..., POSE].reshape(-1, 63).mean(0)
    fade = np.linspace(1.0, 0.0, features.shape[-2])[:, None]
    out = features.copy()
    out[..., POSE] = fade * features[..., POSE] + (1 - fade) * mean
    return out


# -- moves_like_data -----------------------------------------------------------------------

def test_real_motion_moves_like_data(walks):
    verdict = claims.moves_like_data(walks[4:], walks[:4], FPS)
    assert verdict, verdict


@pytest.mark.parametrize("baseline", [mean_pose_on_path, constant_pose, shuffled, fading])
def test_trivial_samples_do_not_move_like_data(walks, baseline):
    verdict = claims.moves_like_data(baseline(walks[4:]), walks[:4], FPS)
    assert not verdict, verdict
    assert "does NOT hold" in str(verdict)


def test_stretched_bones_fail(walks):
    stretched = walks[4:].copy()
    noise = np.random.default_rng(0).normal(0, 0.02, stretched[..., POSE].shape)
    stretched[..., POSE] += noise
    verdict = claims.moves_like_data(stretched, walks[:4], FPS)
    assert not verdict
    assert any("bones" in f for f in verdict.failures)


# -- steps_steadily ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def long_walks():
    return np.stack([walk(10.0, "walk", seed=s) for s in range(4)])


def reference(features):
    return metrics.stepping_by_second(features, FPS).mean(0), metrics.leg_swing(features)


def test_a_real_long_walk_steps_steadily(long_walks):
    stepping, swing = reference(long_walks[:2])
    assert claims.steps_steadily(long_walks[2:], stepping, swing, FPS)


@pytest.mark.parametrize("baseline", [mean_pose_on_path, constant_pose, fading])
def test_gliding_standing_and_fading_do_not_step_steadily(long_walks, baseline):
    stepping, swing = reference(long_walks[:2])
    verdict = claims.steps_steadily(baseline(long_walks[2:]), stepping, swing, FPS)
    assert not verdict, verdict


def test_a_model_that_ignores_the_control_fails(long_walks):
    """Asked to walk, it stands (what a model that ignores the control does half the time)."""
    stepping, swing = reference(long_walks[:2])
    standing = np.stack([walk(10.0, "stand still", seed=s) for s in range(2)])
    assert not claims.steps_steadily(standing, stepping, swing, FPS)


def test_running_is_not_walking(long_walks):
    stepping, swing = reference(long_walks[:2])
    running = np.stack([walk(10.0, "run", seed=s) for s in range(2)])
    assert not claims.steps_steadily(running, stepping, swing, FPS)


# -- follows_control (MoGlow §5.3) ---------------------------------------------------------

STOP_PATH = synthetic.preset_control("walk, then stop", 10.0, FPS, ramp_s=0.0)


@pytest.fixture(scope="module")
def stops():
    """Two bodies that walk and stop at 5 s, as the drawn path says: (2, 200, 66)."""
    return np.stack([walk(10.0, "walk, then stop", seed=s) for s in range(2)])


def test_real_motion_follows_the_control(long_walks, stops):
    stepping, _ = reference(long_walks[:2])
    verdict = claims.follows_control(long_walks[2:], stepping, stops, STOP_PATH, FPS)
    assert verdict, verdict


@pytest.mark.parametrize("baseline", [mean_pose_on_path, constant_pose, fading])
def test_gliding_standing_and_fading_do_not_follow_the_walk(long_walks, stops, baseline):
    stepping, _ = reference(long_walks[:2])
    verdict = claims.follows_control(baseline(long_walks[2:]), stepping, stops, STOP_PATH, FPS)
    assert not verdict, verdict
    assert any("told to walk" in why for why in verdict.failures)


def test_a_model_that_ignores_the_stop_and_walks_on_fails(long_walks):
    stepping, _ = reference(long_walks[:2])
    verdict = claims.follows_control(long_walks[2:], stepping, long_walks[:2], STOP_PATH, FPS)
    assert not verdict, verdict
    assert any("told to stop" in why for why in verdict.failures)


def test_follows_control_refuses_paths_that_do_not_stop(long_walks, stops):
    stepping, _ = reference(long_walks[:2])
    with pytest.raises(ValueError, match="stop_control"):
        claims.follows_control(long_walks[2:], stepping, stops, STOP_PATH[:-1], FPS)
    walking_path = synthetic.preset_control("walk", 10.0, FPS, ramp_s=0.0)
    with pytest.raises(ValueError, match="must move and then stop"):
        claims.follows_control(long_walks[2:], stepping, stops, walking_path, FPS)
    with pytest.raises(ValueError, match="walking_reference"):
        claims.follows_control(long_walks[2:], stepping[:3], stops, STOP_PATH, FPS)


# -- keeps_moving (MoGlow §5.3, long samples) ------------------------------------------------

@pytest.fixture(scope="module")
def circles():
    """Four bodies walking a circle for 20 s: (4, 400, 66)."""
    return np.stack([walk(20.0, "circle", seed=s) for s in range(4)])


def test_real_long_motion_keeps_moving(circles):
    verdict = claims.keeps_moving(circles[2:], circles[:2], FPS)
    assert verdict, verdict


@pytest.mark.parametrize("baseline", [mean_pose_on_path, constant_pose, fading])
def test_frozen_and_fading_long_samples_do_not_keep_moving(circles, baseline):
    verdict = claims.keeps_moving(baseline(circles[2:]), circles[:2], FPS)
    assert not verdict, verdict


def test_keeps_moving_refuses_short_or_unequal_samples(circles):
    with pytest.raises(ValueError, match="two chunks"):
        claims.keeps_moving(circles[2:, :150], circles[:2, :150], FPS)
    with pytest.raises(ValueError, match="same number of frames"):
        claims.keeps_moving(circles[2:], circles[:2, :300], FPS)


# -- beats_trivial_reconstructions ---------------------------------------------------------

def test_reconstruction_claim_needs_both_errors_below_the_best_baseline():
    errors = {"mean pose": (0.10, 0.20), "window average": (0.05, 0.08), "model": (0.03, 0.05)}
    assert claims.beats_trivial_reconstructions(errors, "model")
    worse_motion = {**errors, "model": (0.03, 0.09)}
    assert not claims.beats_trivial_reconstructions(worse_motion, "model")
    # a trivial reconstruction offered as the model ties with itself: fails
    assert not claims.beats_trivial_reconstructions({**errors, "model": errors["window average"]}, "model")


# -- axes_control_parts --------------------------------------------------------------------

SPREAD = {"hand height (m)": 0.02, "knee bend (deg)": 5.0}


def test_distinct_strong_axes_hold():
    effects = {"hand height (m)": np.array([0.0, 0.015, 0.002, 0.0]),
               "knee bend (deg)": np.array([0.5, 0.0, 0.3, 4.0])}
    verdict = claims.axes_control_parts(effects, SPREAD)
    assert verdict, verdict
    assert verdict.figures["hand height (m): strongest axis"] == 1
    assert verdict.figures["knee bend (deg): strongest axis"] == 3


def test_a_decoder_that_ignores_its_latent_fails():
    effects = {name: np.zeros(8) for name in SPREAD}
    assert not claims.axes_control_parts(effects, SPREAD)


def test_one_axis_that_moves_everything_is_not_two():
    effects = {"hand height (m)": np.array([0.0, 0.02, 0.001, 0.0]),
               "knee bend (deg)": np.array([0.1, 5.0, 0.2, 0.3])}
    verdict = claims.axes_control_parts(effects, SPREAD)
    assert not verdict and "axis 1 is the strongest for hand height (m) and knee bend (deg)" in str(verdict)


def test_a_second_best_axis_does_not_make_the_parts_distinct():
    # the hands' strongest axis is the knees' too; the hands' second-best (axis 2, 1.5 std)
    # would give each part an axis of its own, but the traversal of axis 1 moves both
    effects = {"hand height (m)": np.array([0.0, 0.045, 0.03, 0.0]),
               "knee bend (deg)": np.array([0.1, 16.0, 0.2, 0.3])}
    assert not claims.axes_control_parts(effects, SPREAD)


def test_weak_sweeps_fail():
    effects = {"hand height (m)": np.array([0.0, 0.008, 0.0]), "knee bend (deg)": np.array([2.0, 0.0, 0.0])}
    assert not claims.axes_control_parts(effects, SPREAD)      # 0.4 and 0.4 of the data's std


# -- control_beats_no_control --------------------------------------------------------------

def test_tables_claim_requires_beating_the_mean_pose_on_the_true_path():
    rows = {"VAE-LSTM": np.array([0.05, 0.06, 0.07, 0.08, 0.09]),
            "LSTM, no control": np.array([0.10, 0.20, 0.40, 0.80, 1.60]),
            "mean pose on the true path": np.array([0.14, 0.14, 0.14, 0.14, 0.14])}
    assert claims.control_beats_no_control(rows, "VAE-LSTM", "LSTM, no control", "mean pose on the true path")
    # the mean pose on the true path itself, offered as the model, fails
    as_model = {**rows, "VAE-LSTM": rows["mean pose on the true path"]}
    assert not claims.control_beats_no_control(as_model, "VAE-LSTM", "LSTM, no control",
                                               "mean pose on the true path")
    # a model a little below the trivial one is not enough
    barely = {**rows, "VAE-LSTM": 0.95 * rows["mean pose on the true path"]}
    assert not claims.control_beats_no_control(barely, "VAE-LSTM", "LSTM, no control", "mean pose on the true path")


def test_claims_refuse_missing_rows():
    with pytest.raises(ValueError, match="no row"):
        claims.control_beats_no_control({"a": np.zeros(3)}, "a", "b", "c")
    with pytest.raises(ValueError, match="baseline"):
        claims.beats_trivial_reconstructions({"model": (0.1, 0.1)}, "model")


# -- diverse_futures (DFN §6.3) --------------------------------------------------------------

@pytest.fixture(scope="module")
def futures():
    """24 bodies-alike samples of 30 s sharing their first 1.5 s, and 24 other clips as the
    data: real (synthetic) motion that diversifies. ((24, 600, 66), (24, 600, 66))"""
    body = synthetic.Body.random(np.random.default_rng(7))
    samples = np.stack([to_features(synthetic.random_motion(30.0, FPS, seed=100 + k, body=body).positions, FPS)
                        for k in range(24)])
    samples[:, :30] = samples[:1, :30]
    data = np.stack([to_features(synthetic.random_motion(30.0, FPS, seed=200 + k).positions, FPS) for k in range(24)])
    return samples, data


def test_real_motion_from_one_start_diversifies_like_the_data(futures):
    verdict = claims.diverse_futures(*futures, FPS, 10)
    assert verdict, verdict


def copies(features):
    return np.repeat(features[:1], len(features), axis=0)


@pytest.mark.parametrize("baseline", [mean_pose_on_path, constant_pose, fading, copies])
def test_frozen_fading_and_identical_futures_do_not_diversify(futures, baseline):
    samples, data = futures
    verdict = claims.diverse_futures(baseline(samples), data, FPS, 10)
    assert not verdict, verdict


def test_a_model_that_only_runs_or_only_walks_misses_the_pace(futures):
    samples, data = futures
    body = synthetic.Body.random(np.random.default_rng(7))
    for preset in ("run", "walk"):
        control = synthetic.preset_control(preset, 30.0, FPS, ramp_s=0.0)
        one_gait = np.stack([to_features(synthetic.generate(control, FPS, body, synthetic.Style.random(
            np.random.default_rng(k))).positions, FPS) for k in range(4)])
        verdict = claims.diverse_futures(one_gait, data, FPS, 10)
        assert any("faster than" in why for why in verdict.failures), (preset, verdict)


def test_stretching_bones_fail_the_futures_check(futures):
    samples, data = futures
    stretched = samples.copy()
    stretched[..., POSE] *= 1 + 0.05 * np.sin(np.linspace(0, 20, samples.shape[1]))[:, None]
    verdict = claims.diverse_futures(stretched, data, FPS, 10)
    assert any("bones stretch" in why for why in verdict.failures), verdict


def test_diverse_futures_refuses_short_or_single_samples(futures):
    samples, data = futures
    with pytest.raises(ValueError, match="30 s"):
        claims.diverse_futures(samples[:, :400], data, FPS, 10)
    with pytest.raises(ValueError, match="n >= 2"):
        claims.diverse_futures(samples[:1], data, FPS, 10)


def test_futures_of_several_prefixes_are_judged_per_prefix_and_paced_together(futures):
    samples, data = futures
    two = np.stack([samples[:12], samples[12:]])                       # (2 prefixes, 12, 600, 66)
    assert claims.diverse_futures(two, data, FPS, 10)
    two[1] = copies(two[1])                                            # the second prefix's samples: one motion
    verdict = claims.diverse_futures(two, data, FPS, 10)
    assert any("prefixes [2] do not spread out" in why for why in verdict.failures), verdict


# -- follows_speed: stepping at the commanded speed (notebook 08) ---------------------------

SPEEDS = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
DATA_STEPPING = np.array([0.0, 0.52, 0.98, 1.42, 1.74, 1.36, 1.50])      # the built-in bodies, measured


def test_follows_speed_holds_for_stepping_close_to_the_data():
    verdict = claims.follows_speed(SPEEDS, 1.1 * DATA_STEPPING + 0.02, DATA_STEPPING)
    assert verdict, str(verdict)


@pytest.mark.parametrize("baseline", [
    lambda d: np.full_like(d, d[1:].mean()),          # ignores the control: the data's mean stepping at every speed
    lambda d: np.zeros_like(d),                        # a constant pose, or the mean pose moved along the path
    lambda d: 0.5 * d,                                 # steps that fade to half
    lambda d: d + 0.3,                                 # walks on when told to stand
    lambda d: d[::-1].copy(),                          # runs when told to stand, stands when told to run
], ids=["ignores control", "constant pose", "fading", "never stands", "reversed"])
def test_follows_speed_fails_for_trivial_baselines(baseline):
    assert not claims.follows_speed(SPEEDS, baseline(DATA_STEPPING), DATA_STEPPING)


def test_follows_speed_checks_its_arguments():
    with pytest.raises(ValueError, match="speeds: expected 0"):
        claims.follows_speed(SPEEDS[1:], DATA_STEPPING[1:], DATA_STEPPING[1:])
    with pytest.raises(ValueError, match="three"):
        claims.follows_speed(SPEEDS, DATA_STEPPING[:3], DATA_STEPPING)
    with pytest.raises(ValueError, match="finite"):
        claims.follows_speed(SPEEDS, np.full(7, np.nan), DATA_STEPPING)
