"""Where the feet slide: foot skating of every shipped model's samples, before and after
smoothing their root-local pose along time.

    python benchmarks/skating.py

The samples are those of notebook 08's table (``comparison.held_out_samples``: one per
held-out built-in window, 3.5 s after the prefix). Foot skating (``metrics.foot_skating``,
cm/s, the data's planted foot heights) is measured on them as generated, then again after
a Gaussian smoothing of the 63 root-local pose values with sigma 0.05, 0.1 and 0.2 s
(``filters.gaussian_smooth``); the root's path (the control) is left as it is.

A diagnosis, not a fix: smoothing also drags the data's own planted feet, so the data's
skating rises with sigma. What a one-frame smoothing removes from a model's skating is
frame-to-frame jitter of its poses; what stays is slower: legs that do not match the
root's motion.
"""
from __future__ import annotations

import numpy as np

from motionlab import comparison, experiments, filters, metrics
from motionlab.representation import N_POSE, to_positions

SIGMAS_S = (0.05, 0.1, 0.2)


def smoothed(features: np.ndarray, sigma_s: float) -> np.ndarray:
    """``features`` ``(n, frames, 66)`` with the pose values smoothed along time."""
    out = np.array(features, dtype=np.float64)
    pose = np.moveaxis(out[..., :N_POSE], 1, 0)                       # (frames, n, 63)
    out[..., :N_POSE] = np.moveaxis(filters.gaussian_smooth(pose, sigma_s * comparison.FPS), 0, 1)
    return out


def main() -> None:
    models = comparison.load_models()
    windows = experiments.held_out_windows(comparison.TEST_WINDOW, comparison.FPS)
    samples = {"data": windows[:, comparison.PREFIX_FRAMES:], **comparison.held_out_samples(models, windows)}
    rest = metrics.foot_rest_heights(to_positions(samples["data"], comparison.FPS))

    def skating(features) -> float:
        return 100 * metrics.foot_skating(to_positions(features, comparison.FPS), comparison.FPS, rest_height_m=rest)

    print(f"{len(windows)} held-out windows, {samples['data'].shape[1]} frames judged; foot skating (cm/s)\n")
    print("| samples | as generated | " + " | ".join(f"pose smoothed, sigma {s:g} s" for s in SIGMAS_S) + " |")
    print("|---|---|" + "---|" * len(SIGMAS_S))
    for label, features in samples.items():
        values = [skating(features)] + [skating(smoothed(features, s)) for s in SIGMAS_S]
        print(f"| {label} | " + " | ".join(f"{v:.1f}" for v in values) + " |")


if __name__ == "__main__":
    main()
