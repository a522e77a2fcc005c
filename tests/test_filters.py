import numpy as np
import pytest

from motionlab import filters


def test_gaussian_keeps_linear_trends_and_constants():
    t = np.arange(50.0)
    line = np.stack([3 * t + 1, -2 * t], axis=-1)
    assert np.allclose(filters.gaussian_smooth(line, 4.0), line)
    assert np.allclose(filters.gaussian_smooth(np.ones((3, 2)), 10.0), 1.0)  # shorter than kernel
    assert np.array_equal(filters.gaussian_smooth(line, 0), line)
    with pytest.raises(ValueError, match="sigma_frames"):
        filters.gaussian_smooth(line, -1)


def test_lowpass_passes_slow_and_removes_fast_motion():
    fps = 120.0
    t = np.arange(600) / fps
    slow, fast = np.sin(2 * np.pi * 2 * t), np.sin(2 * np.pi * 30 * t)
    out = filters.lowpass(slow + fast, cutoff_hz=9, fps=fps)
    middle = slice(100, 500)
    assert np.abs(out[middle] - slow[middle]).max() < 0.01


def test_resample_integer_ratio_hits_original_frames_and_keeps_duration():
    fps = 120.0
    t = np.arange(241) / fps
    x = np.stack([t, t ** 2], -1)                    # smooth: the low-pass barely changes it
    y = filters.resample(x, 120, 20)
    assert y.shape == (41, 2)
    assert np.allclose(y[:, 0], t[::6], atol=1e-9)
    up = filters.resample(x, 120, 240)
    assert up.shape == (481, 2) and np.allclose(up[1, 0], 0.5 / 120)
    with pytest.raises(ValueError, match="fps"):
        filters.resample(x, 0, 20)


def test_resample_avoids_aliasing():
    fps = 120.0
    t = np.arange(1200) / fps
    x = np.sin(2 * np.pi * 19 * t)                     # 19 Hz folds onto 1 Hz at 20 fps
    naive = x[::6]
    filtered = filters.resample(x, 120, 20)
    assert np.abs(naive).max() > 0.5
    assert np.abs(filtered[10:-10]).max() < 0.05
