import numpy as np
import pytest

from motionlab import metrics
from motionlab.representation import to_features

from conftest import walker


def test_pose_and_motion_error_known_offsets(walk):
    f = to_features(walk, 20)
    shifted = f.copy()
    shifted[:, :63] += np.tile([0.03, 0.0, 0.04], 21)          # every joint 5 cm away
    assert metrics.pose_error(shifted, f) == pytest.approx(0.05)
    assert metrics.pose_error(f, f) == 0
    moved = walk + np.array([0.0, 0.0, 0.1])
    assert metrics.motion_error(moved, walk) == pytest.approx(0.1)
    with pytest.raises(ValueError, match="one shape"):
        metrics.motion_error(walk, walk[:-1])


def test_control_drift_splits_the_motion_error_by_channel(walk):
    f = np.stack([to_features(walk, 20)] * 2)
    slower = f.copy()
    slower[..., 63] -= 0.1                                      # forward 0.1 m/s too slow, nothing else
    drift = metrics.control_drift(slower, f, 20)
    assert set(drift) == {"forward", "sideways", "turning"}
    assert drift["sideways"] == drift["turning"] == 0.0 < drift["forward"]
    whole = metrics.window_errors(slower, f, 20)["motion error (m)"]
    assert drift["forward"] == pytest.approx(whole)             # the one channel wrong: all of the drift
    assert metrics.control_drift(f, f, 20) == {"forward": 0.0, "sideways": 0.0, "turning": 0.0}
    with pytest.raises(ValueError, match="one shape"):
        metrics.control_drift(f[:1], f, 20)


def test_foot_skating_is_zero_for_planted_feet_and_grows_with_sliding():
    fps = 20.0
    planted = np.zeros((40, 21, 3))
    planted[..., 1] = 1.0                                       # everything off the floor
    planted[:, [3, 4, 7, 8], 1] = 0.0                           # feet on the floor, still
    assert metrics.foot_skating(planted, fps) == 0.0
    sliding = planted.copy()
    sliding[:, [3, 4, 7, 8], 2] = np.arange(40)[:, None] * 0.05  # 1 m/s along z, on the floor
    assert metrics.foot_skating(sliding, fps) == pytest.approx(1.0)
    lifted = sliding.copy()
    lifted[:, [3, 4, 7, 8], 1] = 0.2                            # 20 cm above the data's floor
    assert metrics.foot_skating(lifted, fps, rest_height_m=0.0) == 0.0
    half = sliding.copy()
    half[:, [3, 4, 7, 8], 1] = 0.0125                           # H/2 above the floor: weight 2 - sqrt(2)
    assert metrics.foot_skating(half, fps, rest_height_m=0.0) == pytest.approx(2 - np.sqrt(2))
    with pytest.raises(ValueError, match="frames >= 2"):
        metrics.foot_skating(planted[:1], fps)


def test_a_planted_joint_counts_fully_at_its_own_height():
    """Ankle centres sit ~8 cm and toes ~3.5 cm above the floor when planted: measured
    against their planted height they count fully (the old measure gave them 0.25 and 0.42)."""
    fps = 20.0
    sliding = np.zeros((40, 21, 3))
    sliding[..., 1] = 1.0
    sliding[:, [3, 7], 1], sliding[:, [4, 8], 1] = 0.08, 0.035
    sliding[:, [3, 4, 7, 8], 2] = np.arange(40)[:, None] * 0.05  # 1 m/s, planted
    rest = metrics.foot_rest_heights(sliding)
    assert rest == pytest.approx([0.08, 0.035, 0.08, 0.035])
    assert metrics.foot_skating(sliding, fps) == pytest.approx(1.0)
    assert metrics.foot_skating(sliding, fps, rest_height_m=rest) == pytest.approx(1.0)
    # hovering 5 cm above the data's planted height: not in contact, so it cannot skate ...
    hovering = sliding.copy()
    hovering[:, [3, 4, 7, 8], 1] += 0.05
    assert metrics.foot_skating(hovering, fps, rest_height_m=rest) == 0.0
    # ... which is why the report puts the ankles' height beside it
    walk = walker()
    rest = metrics.foot_rest_heights(walk)
    floating = to_features(walk + np.array([0.0, 0.05, 0.0]), fps)       # the whole body 5 cm up
    report = metrics.locomotion_report(floating, fps, rest_height_m=rest)
    grounded = metrics.locomotion_report(to_features(walk, fps), fps, rest_height_m=rest)
    assert report["ankle height (m)"] == pytest.approx(grounded["ankle height (m)"] + 0.05, abs=1e-6)
    assert report["foot skating (m/s)"] < grounded["foot skating (m/s)"]


def test_stepping_by_second_shows_fading_steps():
    fps = 20.0
    t = np.arange(200) / fps
    pose = np.zeros((200, 21, 3))
    pose[:, 3, 2] = 0.3 * np.sin(2 * np.pi * t) * np.linspace(1, 0, 200)   # a left ankle swinging less and less
    features = np.concatenate([pose.reshape(200, 63), np.zeros((200, 3))], axis=1)
    by_second = metrics.stepping_by_second(features, fps)
    assert by_second.shape == (9,)
    assert (np.diff(by_second) < 0).all()
    with pytest.raises(ValueError, match="one second"):
        metrics.stepping_by_second(features[:10], fps)


def test_bone_length_drift():
    walk = walker()
    rigid = np.repeat(walk[:1], 30, axis=0) + np.linspace(0, 1, 30)[:, None, None]
    assert metrics.bone_length_drift(rigid) < 1e-12
    stretched = rigid * np.where(np.arange(30) % 2, 1.1, 0.9)[:, None, None]
    stretched_about_hips = stretched - stretched[:, :1] + rigid[:, :1]
    assert metrics.bone_length_drift(stretched_about_hips) == pytest.approx(0.1, rel=1e-6)
    assert metrics.bone_length_drift(np.stack([rigid, stretched_about_hips])) == pytest.approx(0.05, rel=1e-6)


def test_diversity_over_time():
    base = np.zeros((1, 10, 21, 3))
    assert np.all(metrics.diversity(np.repeat(base, 4, 0)) == 0)
    spread = np.concatenate([base, base], axis=0)
    spread[0, :, :, 0] = np.arange(10)[:, None] * 0.1
    spread[1, :, :, 0] = -np.arange(10)[:, None] * 0.1
    assert np.allclose(metrics.diversity(spread), np.arange(10) * 0.1)
    with pytest.raises(ValueError, match="n_samples >= 2"):
        metrics.diversity(base)


def test_summarize_units(walk):
    s = metrics.summarize(walk, 20)
    assert set(s) == {"foot skating (cm/s)", "bone-length drift (%)"}
    assert all(np.isfinite(v) and v >= 0 for v in s.values())


def test_stepping_speed_sees_steps_not_travel():
    import numpy as np
    from motionlab import representation as rep
    from motionlab import synthetic
    walk = rep.to_features(synthetic.generate(np.tile([1.3, 0.0, 0.0], (80, 1)), 20.0).positions, 20.0)
    stand = rep.to_features(synthetic.generate(np.zeros((80, 3)), 20.0).positions, 20.0)
    glide = stand.copy()
    glide[:, rep.CONTROL] = walk[:, rep.CONTROL]                   # moving through space without stepping
    speed = metrics.stepping_speed(walk, 20.0)
    assert speed.shape == (79,)
    assert 0.8 < speed[20:].mean() < 2.0
    assert metrics.stepping_speed(stand, 20.0).mean() < 0.02
    assert metrics.stepping_speed(glide, 20.0).mean() < 0.02
    batch = metrics.stepping_speed(np.stack([walk, stand]), 20.0)
    assert batch.shape == (2, 79) and np.allclose(batch[0], speed)
    with pytest.raises(ValueError, match="features"):
        metrics.stepping_speed(walk[:1], 20.0)
    with pytest.raises(ValueError, match="features"):
        metrics.stepping_speed(np.zeros((10, 5)), 20.0)


def test_pose_spread_is_zero_for_a_frozen_pose():
    import numpy as np
    from motionlab import representation as rep
    from motionlab import synthetic
    walk = rep.to_features(synthetic.generate(np.tile([1.3, 0.0, 0.0], (80, 1)), 20.0).positions, 20.0)
    frozen = np.repeat(walk[:1], 80, axis=0)
    assert metrics.pose_spread(frozen) < 1e-12
    assert 0.02 < metrics.pose_spread(walk) < 0.3
    assert metrics.pose_spread(np.stack([walk, frozen])).shape == (2,)


def test_stepping_speed_smoothing_ignores_jitter_but_keeps_steps():
    import numpy as np
    from motionlab import representation as rep
    from motionlab import synthetic
    walk = rep.to_features(synthetic.generate(np.tile([1.3, 0.0, 0.0], (80, 1)), 20.0).positions, 20.0)
    stand = rep.to_features(synthetic.generate(np.zeros((80, 3)), 20.0).positions, 20.0)
    shaky = stand + np.random.default_rng(0).normal(0, 0.01, stand.shape)          # 1 cm of jitter per frame
    assert metrics.stepping_speed(shaky, 20.0).mean() > 0.2                        # raw: jitter looks like stepping
    assert metrics.stepping_speed(shaky, 20.0, smooth_s=0.1).mean() < 0.1
    kept = metrics.stepping_speed(walk, 20.0, smooth_s=0.1)[20:-20].mean() / metrics.stepping_speed(walk, 20.0)[20:-20].mean()
    assert 0.7 < kept <= 1.0
    with pytest.raises(ValueError, match="smooth_s"):
        metrics.stepping_speed(walk, 20.0, smooth_s=-1)


def test_leg_swing_and_errors_by_frame():
    import numpy as np
    from motionlab import representation as rep
    from motionlab import synthetic
    walk = rep.to_features(synthetic.generate(np.tile([1.3, 0.0, 0.0], (80, 1)), 20.0).positions, 20.0)
    stand = rep.to_features(synthetic.generate(np.zeros((80, 3)), 20.0).positions, 20.0)
    assert 0.2 < metrics.leg_swing(walk) < 1.0 and metrics.leg_swing(stand) < 0.01
    assert np.isclose(metrics.leg_swing(np.stack([walk, stand])), (metrics.leg_swing(walk) + metrics.leg_swing(stand)) / 2)
    pred, true = np.stack([walk, walk]), np.stack([walk, walk])
    pred[1, :, 63] += 0.1                                        # 0.1 m/s too fast: the world error grows
    pose, motion = metrics.errors_by_frame(pred, true, 20.0)
    assert pose.shape == motion.shape == (80,) and np.allclose(pose, 0)
    assert np.isclose(motion[0], 0) and np.isclose(motion[-1], 0.5 * 0.1 * 79 / 20, rtol=1e-3)
    with pytest.raises(ValueError, match="pred_features"):
        metrics.errors_by_frame(pred, true[:1], 20.0)


def test_to_positions_takes_batches():
    import numpy as np
    from motionlab import representation as rep
    from motionlab import synthetic
    clips = np.stack([rep.to_features(synthetic.random_motion(2.0, 20.0, seed=s).positions, 20.0) for s in range(3)])
    batch = rep.to_positions(clips, 20.0)
    assert batch.shape == (3, 40, 21, 3)
    assert np.allclose(batch[2], rep.to_positions(clips[2], 20.0))
    assert rep.to_positions(clips[None], 20.0).shape == (1, 3, 40, 21, 3)


def test_bone_length_is_the_bone_into_the_joint():
    from motionlab.skeleton import LOCOMOTION
    walk = walker()
    knee, ankle = LOCOMOTION.index("RightLeg"), LOCOMOTION.index("RightFoot")
    np.testing.assert_allclose(metrics.bone_length(walk, "RightFoot"),
                               np.linalg.norm(walk[:, ankle] - walk[:, knee], axis=-1), atol=1e-12)
    assert metrics.bone_length(walk[None], "RightFoot").shape == (1, len(walk))
    for bad in ("Hips", "Tail"):
        with pytest.raises(ValueError, match="joint"):
            metrics.bone_length(walk, bad)
