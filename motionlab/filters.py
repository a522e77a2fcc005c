"""Filters along the time axis: Gaussian smoothing, anti-aliased resampling.

Both pad the signal by *odd reflection* (``2 x[0] - x[k]``), which continues a linear
trend past the ends, so a steadily moving root is not dragged back at the clip edges.
"""
from __future__ import annotations


import numpy as np

from . import checks

MAX_SIGMA_FRAMES = 1e6
"""Widest Gaussian accepted, in frames (its kernel alone takes 64 MB)."""


def _signal(x) -> np.ndarray:
    """``x`` as a float64 array ``(frames, ...)``: at least one frame, no NaN."""
    x = checks.array(x, "x")
    if x.ndim == 0:
        raise ValueError("x: expected an array (frames, ...), got a single number")
    return x


def _convolve_time(x: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Convolve every column of ``x`` ``(frames, ...)`` with a symmetric odd-length kernel."""
    half = len(kernel) // 2
    if half == 0:
        return x.copy()
    frames = x.shape[0]
    flat = x.reshape(frames, -1)
    pad = min(half, frames - 1)
    head = 2 * flat[:1] - flat[pad:0:-1]
    tail = 2 * flat[-1:] - flat[-2:-2 - pad:-1]
    padded = np.concatenate([head, flat, tail], axis=0)
    if pad < half:  # clip shorter than the kernel: extend with the edge values
        padded = np.concatenate([np.repeat(padded[:1], half - pad, 0), padded,
                                 np.repeat(padded[-1:], half - pad, 0)], axis=0)
    windows = np.lib.stride_tricks.sliding_window_view(padded, len(kernel), axis=0)
    return (windows @ kernel).reshape(x.shape)


def smoothstep(x: np.ndarray) -> np.ndarray:
    """``3x² - 2x³`` on ``x`` clipped to [0, 1]: a ramp from 0 to 1 with zero slope at both
    ends, for blends that must not jump (a foot lock's release, a gait's onset)."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def gaussian_smooth(x: np.ndarray, sigma_frames: float) -> np.ndarray:
    """Smooth ``x`` ``(frames, ...)`` along time with a Gaussian of ``sigma_frames`` frames
    (0: no smoothing, a copy of ``x``)."""
    x = _signal(x)
    checks.non_negative(sigma_frames, "sigma_frames", MAX_SIGMA_FRAMES)
    if sigma_frames == 0:
        return np.array(x, dtype=np.float64)
    half = max(1, int(np.ceil(4 * sigma_frames)))
    t = np.arange(-half, half + 1)
    kernel = np.exp(-0.5 * (t / sigma_frames) ** 2)
    return _convolve_time(x, kernel / kernel.sum())


def lowpass(x: np.ndarray, cutoff_hz: float, fps: float) -> np.ndarray:
    """Low-pass filter ``x`` ``(frames, ...)`` sampled at ``fps`` below ``cutoff_hz``.

    A Hann-windowed sinc FIR filter spanning four periods of the cutoff on each side,
    normalised to unit gain at 0 Hz (zero phase: it does not delay the motion).
    """
    x = _signal(x)
    fps = checks.rate(fps, "fps")
    cutoff_hz = checks.positive(cutoff_hz, "cutoff_hz")
    if cutoff_hz >= fps / 2:
        return np.array(x, dtype=np.float64)
    half = int(np.ceil(4 * fps / cutoff_hz))
    t = np.arange(-half, half + 1)
    kernel = np.sinc(2 * cutoff_hz / fps * t) * np.hanning(2 * half + 3)[1:-1]
    return _convolve_time(x, kernel / kernel.sum())


def resample(x: np.ndarray, fps_in: float, fps_out: float) -> np.ndarray:
    """Resample ``x`` ``(frames, ...)`` from ``fps_in`` to ``fps_out``.

    Downsampling first low-passes at 0.9 x the new Nyquist frequency (no aliasing of
    fast limb motion into slow drift), then samples frames at ``k / fps_out`` seconds
    by linear interpolation, from the first frame up to the last. With an integer ratio
    (120 -> 20 fps) the samples fall exactly on original frames.
    """
    x = _signal(x)
    fps_in = checks.rate(fps_in, "fps_in")
    fps_out = checks.rate(fps_out, "fps_out")
    if fps_out < fps_in:
        x = lowpass(x, 0.45 * fps_out, fps_in)
    if fps_out == fps_in:
        return x.copy()
    duration = (x.shape[0] - 1) / fps_in
    source = np.arange(int(np.floor(duration * fps_out + 1e-9)) + 1) * (fps_in / fps_out)
    lo = np.minimum(np.floor(source + 1e-9).astype(int), x.shape[0] - 1)
    hi = np.minimum(lo + 1, x.shape[0] - 1)
    w = (source - lo).reshape((-1,) + (1,) * (x.ndim - 1))
    w = np.clip(w, 0.0, 1.0)
    return (1 - w) * x[lo] + w * x[hi]
