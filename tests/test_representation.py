import numpy as np
import pytest

from motionlab import representation as rep
from motionlab.rotations import y_rotation
from motionlab.skeleton import LOCOMOTION

from conftest import walker


def test_feature_layout_and_root_local_pose(walk):
    f = rep.to_features(walk, fps=20)
    assert f.shape == (80, 66) and len(rep.FEATURE_NAMES) == 66
    pose = f[:, rep.POSE].reshape(80, 21, 3)
    assert np.allclose(pose[:, 0, [0, 2]], 0)                     # hips above the origin
    assert np.all(pose[:, LOCOMOTION.index("LeftUpLeg"), 0] > 0)  # left is +x
    assert np.all(pose[:, LOCOMOTION.index("LeftToeBase"), 2] >   # toes point forward (+z)
                  pose[:, LOCOMOTION.index("LeftFoot"), 2] - 0.2)


def test_controls_of_a_known_path():
    fps = 20.0
    w = walker(frames=200, fps=fps, speed=1.5, turn_rate=0.4, side_speed=0.3)
    f = rep.to_features(w, fps)
    control = f[20:-20, rep.CONTROL]                             # away from smoothing edges
    assert np.allclose(control[:, 0], 1.5, atol=0.02)
    assert np.allclose(control[:, 1], 0.3, atol=0.02)
    assert np.allclose(control[:, 2], 0.4, atol=0.01)
    mirrored = rep.to_features(w[:, LOCOMOTION.mirror] * [-1, 1, 1], fps)
    assert np.allclose(mirrored[20:-20, rep.CONTROL], control * [1, -1, -1], atol=1e-9)


@pytest.mark.parametrize("fps", [20.0, 120.0])
def test_round_trip_to_world_positions(fps):
    w = walker(frames=int(4 * fps), fps=fps, speed=2.0, turn_rate=-1.0)
    w = w @ y_rotation(np.array(2.0)).T + np.array([5.0, 0, -3.0])
    f = rep.to_features(w, fps)
    back = rep.to_positions(f, fps, start=rep.root_start(w, fps))
    assert np.abs(back - w).max() < 1e-9
    at_origin = rep.to_positions(f, fps)                         # default start
    assert np.allclose(at_origin[0, 0, [0, 2]], 0)


def test_mirroring_twice_is_exact(walk):
    f = rep.to_features(walk, 20)
    assert np.array_equal(rep.mirror_features(rep.mirror_features(f)), f)
    batch = np.stack([f, f[::-1]])
    assert np.array_equal(rep.mirror_features(batch)[1], rep.mirror_features(f[::-1]))


def test_mirror_in_feature_space_equals_mirroring_the_world(walk):
    mirrored_world = walk[:, LOCOMOTION.mirror] * np.array([-1.0, 1.0, 1.0])
    assert np.allclose(rep.mirror_features(rep.to_features(walk, 20)),
                       rep.to_features(mirrored_world, 20), atol=1e-12)


def test_reversal_matches_world_reversal_and_is_an_involution():
    w = walker(frames=60, fps=20, speed=1.3, turn_rate=0.8, side_speed=-0.2)
    f = rep.to_features(w, 20)
    reversed_f = rep.reverse_features(f, 20)
    assert np.allclose(reversed_f, rep.to_features(w[::-1], 20), atol=1e-12)
    assert np.allclose(rep.reverse_features(reversed_f, 20), f, atol=1e-12)
    assert np.all(reversed_f[5:-5, 63] < 0)                       # walking backwards now


def test_integrate_control_straight_and_turning():
    fps = 10.0
    straight = rep.integrate_control(np.tile([1.0, 0, 0], (11, 1)), fps)
    assert np.allclose(straight[-1], [0, 1.0, 0])                 # 1 s at 1 m/s along +z
    spin = rep.integrate_control(np.tile([0, 0, np.pi], (11, 1)), fps, start=np.array([1, 2, 0]))
    assert np.allclose(spin[:, :2], [1, 2]) and np.isclose(spin[-1, 2], np.pi)
    with pytest.raises(ValueError, match="start"):
        rep.integrate_control(np.zeros((3, 3)), fps, start=np.zeros(2))


def test_bad_inputs_are_value_errors():
    with pytest.raises(ValueError, match=r"positions: expected shape \(frames, 21, 3\)"):
        rep.to_features(np.zeros((10, 20, 3)), 20)
    with pytest.raises(ValueError, match="NaN"):
        rep.to_features(np.full((10, 21, 3), np.nan), 20)
    with pytest.raises(ValueError, match="no frames"):
        rep.to_features(np.zeros((0, 21, 3)), 20)
    with pytest.raises(ValueError, match=r"features: expected shape \(frames, 66\)"):
        rep.to_positions(np.zeros((10, 63)), 20)


def test_single_frame_clip_has_zero_control(walk):
    f = rep.to_features(walk[:1], 20)
    assert f.shape == (1, 66) and np.all(f[0, rep.CONTROL] == 0)
    assert np.allclose(rep.to_positions(f, 20, rep.root_start(walk[:1], 20)), walk[:1])
