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

A second table looks at the planted feet alone (foot joints whose contact weight,
``metrics.foot_contact_weights``, is above 0.9), in the world: the share of frames they are
planted, their mean speed, and how much of it is a steady glide (the length of each
window's mean velocity of each planted foot joint) rather than a wobble about one place.
The flows are also measured at temperature 0 (their most likely motion, no sampling noise).
"""
from __future__ import annotations

from dataclasses import replace

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

    flows = {label: (replace(entry, temperature=0.0), model) for label, (entry, model) in models.items()
             if label in ("Glow", "MoGlow")}
    coldest = comparison.held_out_samples(flows, windows)
    samples.update({f"{label}, temperature 0": features for label, features in coldest.items()})
    print("\nPlanted feet (contact weight > 0.9), world speeds in cm/s\n")
    print("| samples | skating (cm/s) | share of foot frames planted | planted: mean speed | planted: glide |")
    print("|---|---|---|---|---|")
    for label, features in samples.items():
        share, speed, glide = planted_feet(features, rest)
        print(f"| {label} | {skating(features):.1f} | {share:.2f} | {speed:.1f} | {glide:.1f} |")


def planted_feet(features: np.ndarray, rest) -> tuple[float, float, float]:
    """Of the planted foot joints (contact weight > 0.9) in ``features`` ``(n, frames, 66)``:
    the share of foot frames planted, their mean world speed (cm/s) and their glide (cm/s:
    the length of each window's and foot's mean planted velocity, averaged over its planted
    frames, so never more than the mean speed)."""
    positions = to_positions(features, comparison.FPS)
    planted = metrics.foot_contact_weights(positions, rest_height_m=rest) > 0.9      # (n, frames-1, feet)
    feet_xz = positions[..., list(metrics.FEET), :][..., [0, 2]]
    velocity = np.diff(feet_xz, axis=1) * comparison.FPS                              # (n, frames-1, feet, 2)
    speed = np.linalg.norm(velocity, axis=-1)
    count = planted.sum(1)                                                            # (n, feet)
    mean_velocity = (velocity * planted[..., None]).sum(1) / np.maximum(count, 1)[..., None]
    glide = (np.linalg.norm(mean_velocity, axis=-1) * count).sum() / max(count.sum(), 1)   # weighted like the speed
    return float(planted.mean()), float(100 * speed[planted].mean()), float(100 * glide)


if __name__ == "__main__":
    main()
