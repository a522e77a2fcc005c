"""The diversity-over-time measures of motionlab.metrics (Chen et al. 2020, §6.3)."""
import numpy as np
import pytest

from motionlab import metrics


def test_distances_to_mean_by_hand():
    points = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 3.0]])          # mean (1, 1)
    expected = [np.sqrt(2), np.sqrt(2), 2.0]
    assert np.allclose(metrics.distances_to_mean(points), expected)
    # trailing axes are one vector: (n, joints, 3) gives the same as (n, joints * 3)
    poses = np.random.default_rng(0).normal(size=(5, 4, 3))
    assert np.allclose(metrics.distances_to_mean(poses), metrics.distances_to_mean(poses.reshape(5, 12)))


def test_mean_distance_over_time_grows_with_spread():
    rng = np.random.default_rng(1)
    frames = 30
    scale = np.linspace(0.0, 2.0, frames)                              # samples spread out over time
    samples = rng.normal(size=(400, frames, 6)) * scale[None, :, None] + 5.0
    mean, std = metrics.mean_distance_over_time(samples)
    assert mean.shape == std.shape == (frames,)
    assert mean[0] == 0.0 and std[0] == 0.0                            # identical at the start
    assert np.all(np.diff(mean) > 0)
    # chi distribution with 6 degrees of freedom: mean = sigma * 2.3499
    assert mean[-1] == pytest.approx(2.0 * 2.3499, rel=0.05)
    # each frame is distances_to_mean of that frame
    assert mean[7] == pytest.approx(metrics.distances_to_mean(samples[:, 7]).mean())


def test_data_band_is_mean_and_std_of_distances():
    frames = np.random.default_rng(2).normal(size=(1000, 21, 3))
    mean, std = metrics.data_band(frames)
    d = metrics.distances_to_mean(frames)
    assert (mean, std) == pytest.approx((d.mean(), d.std()))


def test_pairwise_distance_by_hand():
    samples = np.array([[[0.0, 0.0]], [[3.0, 4.0]], [[0.0, 0.0]]])    # (3 samples, 1 frame, 2)
    # pairs: 5, 0, 5 -> mean 10 / 3
    assert metrics.pairwise_distance_over_time(samples) == pytest.approx([10 / 3])
    same = np.zeros((4, 7, 21, 3))
    assert np.all(metrics.pairwise_distance_over_time(same) == 0)


def test_frame_speed():
    t = np.arange(20) / 10.0                                           # 10 fps
    moving = np.stack([np.stack([t, 2 * t], -1)])                      # (1, 20, 2): speed sqrt(5) units/s
    assert np.allclose(metrics.frame_speed(moving, fps=10.0), np.sqrt(5))
    frozen = np.ones((3, 20, 4))
    assert np.all(metrics.frame_speed(frozen, fps=10.0) == 0)


def test_fraction_in_range():
    reference = np.random.default_rng(3).uniform(-1, 1, size=(5000, 4))
    inside = np.zeros((2, 5, 4))
    assert np.all(metrics.fraction_in_range(inside, reference) == 1.0)
    exploding = inside.copy()
    exploding[:, 3:] = 100.0                                           # last two frames blow up
    fraction = metrics.fraction_in_range(exploding, reference)
    assert np.all(fraction[:3] == 1.0) and np.all(fraction[3:] == 0.0)
    half = inside.copy()
    half[:, :, :2] = -50.0                                             # two of four values outside
    assert np.allclose(metrics.fraction_in_range(half, reference), 0.5)
    constant = np.zeros((100, 3))                                      # a value the data never varies
    near = np.full((1, 4, 3), 0.005)
    assert np.all(metrics.fraction_in_range(near, constant) == 0.0)
    assert np.all(metrics.fraction_in_range(near, constant, atol=0.01) == 1.0)


@pytest.mark.parametrize("call", [
    lambda: metrics.mean_distance_over_time(np.zeros((1, 5, 3))),      # one sample
    lambda: metrics.mean_distance_over_time(np.zeros(5)),
    lambda: metrics.pairwise_distance_over_time(np.full((3, 4, 2), np.nan)),
    lambda: metrics.distances_to_mean(np.zeros((1, 3))),
    lambda: metrics.frame_speed(np.zeros((2, 1, 3)), fps=20.0),        # one frame
    lambda: metrics.frame_speed(np.zeros((2, 5, 3)), fps=0.0),
    lambda: metrics.fraction_in_range(np.zeros((2, 5, 3)), np.zeros((10, 4))),
    lambda: metrics.fraction_in_range(np.zeros((2, 5, 3)), np.zeros((10, 3)), quantiles=(0.9, 0.1)),
    lambda: metrics.fraction_in_range(np.zeros((2, 5, 3)), np.zeros((10, 3)), atol=-1.0),
])
def test_bad_arguments_raise(call):
    with pytest.raises(ValueError):
        call()
