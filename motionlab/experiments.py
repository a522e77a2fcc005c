"""The papers' findings as measurements: small functions the notebooks and benchmarks call,
written against the one ``generate`` contract (:mod:`motionlab.models.base`) so that they
work for any model that follows a control path from a prefix.
"""
from __future__ import annotations

import numpy as np

from . import metrics, synthetic


def control_following(model, start, temperature: float = 0.3, seconds: float = 4.0, seed: int = 0,
                      smooth_s: float = 0.1) -> dict[str, float]:
    """Does the body do what the control says (MoGlow §5.3)?

    From real frames ``start`` ``(n, k, 66)`` (data units, e.g. walking), generate
    ``seconds`` with the control of standing still and, separately, of walking at 1.3 m/s
    (through the synthetic walker); return how fast the feet step relative to the body
    (:func:`motionlab.metrics.stepping_speed`, ankles smoothed over ``smooth_s`` s, m/s) over
    the last half of each. A model that follows the control steps when told to walk and
    stops when told to stand still.
    """
    fps = model.fps
    controls = {"stand still": synthetic.preset_control("stand still", seconds, fps),
                "walk": synthetic.walked_control(synthetic.preset_control("walk", seconds, fps, ramp_s=0.01), fps)}
    start = np.asarray(start)
    half = int(seconds * fps / 2)
    result = {}
    for name, control in controls.items():
        motion = model.generate(control, prefix=start, n=len(start), temperature=temperature, seed=seed)
        speed = metrics.stepping_speed(motion.features, fps, smooth_s=smooth_s)
        result[name] = float(speed[:, -half:].mean())
    return result


def long_sample_spread(model, start, control, temperature: float = 0.3, seed: int = 0,
                       window_s: float = 5.0) -> dict[str, float]:
    """Does a long sample freeze into a static pose (MoGlow §5.3)?

    Follow ``control`` ``(frames, 3)`` (data units) from ``start`` ``(n, k, 66)`` and return
    the pose spread (:func:`motionlab.metrics.pose_spread`, metres) of the first and the
    last ``window_s`` seconds, averaged over the ``n`` samples.
    """
    frames = int(window_s * model.fps)
    if len(control) < 2 * frames:
        raise ValueError(f"control: {len(control)} frames is shorter than two windows of {window_s} s")
    motion = model.generate(control, prefix=np.asarray(start), n=len(start), temperature=temperature,
                            seed=seed).features
    return {"first": float(metrics.pose_spread(motion[:, :frames]).mean()),
            "last": float(metrics.pose_spread(motion[:, -frames:]).mean())}
