"""Foot contacts from the motion: which of the ankles and toes (:data:`~motionlab.skeleton.FEET`
order) are planted, frame by frame, and how fast the planted ones still move.

:func:`detect` labels each joint by its height above its planted height
(:func:`planted_heights`) and its horizontal speed, with hysteresis (:data:`RELEASE`) and a
short majority filter (:data:`CLEAN_S`); :func:`planted_speed` measures the sliding the
labels show. The thresholds were measured on data (notebook 01, section 5). What is done with
the labels (the foot lock, the training term) is :mod:`motionlab.contacts`, where these names
are importable too.
"""
from __future__ import annotations

import numpy as np

from . import checks, metrics
from .skeleton import FEET, LOCOMOTION

# ----------------------------------------------------------------------------------------
# Thresholds (measured on the built-in data and on the 55 CMU clips of ../shared/mocap/cmu
# at 20 fps; see notebook 01, section 5)
# ----------------------------------------------------------------------------------------

CONTACT_HEIGHT_M = (0.05, 0.03, 0.05, 0.03)
"""How far above its planted height an ankle / toe (:data:`FEET` order) may be and still be
in contact, metres. The literature's 8 cm (ankle) and 4 cm (toe) are heights above the floor
of joints that sit 3-8 cm up when planted; measured above the planted height instead
(:func:`planted_heights`), the data's stance frames stay within 3 cm (toes) and 5 cm
(ankles: the heel rises first at toe-off)."""

CONTACT_SPEED_MS = 0.5
"""Horizontal speed below which a low foot joint is in contact, m/s. The literature uses
0.15-0.3 m/s on clean capture; generated feet slide (that is what locking fixes), so a
planted foot of a sampled model moves at up to about half the body's speed. A swinging
foot near the floor moves at 2-4 m/s while walking, so 0.5 m/s still tells them apart."""

SPEED_WINDOW_S = 0.2
"""The speed a joint is judged by: how far it moves horizontally over this long, centred
on the frame, divided by it (:func:`horizontal_speed`), seconds (4 frames at 20 fps). A
sampled model's foot jitters from frame to frame, and a frame-to-frame speed (0.1 s:
central differences at 20 fps) takes a planted but jittering foot for a moving one, and
lets the lock go; over 0.2 s the jitter cancels and the sliding does not (GMD's skating
ratio averages over 5 frames for the same reason). On the shipped models' finished
motion, against 0.1 s, 0.2 s lowered the skating of every generative model on notebook
08's held-out windows and of all but one (unchanged) on the CMU windows, and of most rows
on the walk and run paths; 0.3 s was better for some models and worse for others (the
README's feet section has the figures). The data's clean feet are labelled almost alike
either way (62 against 64 % of the built-in clips' foot-frames in contact)."""

BODY_FRACTION = 0.5
"""... or slower than this fraction of the hips' horizontal speed, whichever is higher. A
foot planted by the data stays below 0.3 of the body's speed; a model's planted foot slides
at up to about half of it; a swinging foot moves at 1.3-2 times the body's speed."""

RELEASE = 1.5
"""Hysteresis: a joint in contact stays in contact until it is more than ``RELEASE`` times
a threshold above it (height or speed), so noise near a threshold does not flicker."""

CLEAN_S = 0.25
"""Width of the majority filter that cleans the labels offline, seconds (the odd number of
frames nearest to it: 5 at 20 fps): a contact or a gap shorter than half of it (one or two
frames at 20 fps) is removed."""


def _positions(positions, name: str = "positions") -> np.ndarray:
    """World positions ``(..., frames, 21, 3)`` as float64, finite."""
    return checks.array(positions, name, (..., "frames", LOCOMOTION.n_joints, 3))


def _per_foot_joint(value, name: str, positive: bool = True) -> np.ndarray:
    """One value, or one per foot joint (4), as a ``(4,)`` array."""
    v = checks.array(value, name)
    if v.ndim > 1 or v.size not in (1, len(FEET)) or (positive and not (v > 0).all()):
        raise ValueError(f"{name}: expected one {'positive ' if positive else ''}number or one per foot joint "
                         f"({len(FEET)}: ankle and toe, left then right), got {value!r}")
    return np.broadcast_to(v, (len(FEET),)).astype(np.float64)


def planted_heights(positions) -> np.ndarray:
    """How high each ankle and toe sits when planted, metres ``(4,)``, over all frames of
    ``positions`` ``(..., frames, 21, 3)``: :func:`motionlab.metrics.foot_rest_heights` of
    the foot joints. Measure it on the data, and pass it for a model's samples, so that feet
    that hover are not credited with a floor of their own."""
    return metrics.foot_rest_heights(_positions(positions), FEET)


def _contact_array(contacts, shape: tuple[int, ...], name: str = "contacts") -> np.ndarray:
    """``contacts`` as booleans of exactly ``shape`` (..., 4), else ``ValueError`` naming ``name``."""
    contacts = np.asarray(contacts)
    if contacts.shape != shape or contacts.dtype != bool:
        raise ValueError(f"{name}: expected booleans of shape {shape} (ankle and toe of each foot), "
                         f"got {contacts.dtype} {contacts.shape}")
    return contacts


# ----------------------------------------------------------------------------------------
# 1. Contacts from data
# ----------------------------------------------------------------------------------------

def _hysteresis(low_enter: np.ndarray, low_stay: np.ndarray) -> np.ndarray:
    """Per frame (axis -2): in contact when ``low_enter``; once in, while ``low_stay``."""
    out = np.zeros_like(low_enter)
    state = np.zeros(low_enter.shape[:-2] + low_enter.shape[-1:], dtype=bool)
    for t in range(low_enter.shape[-2]):
        state = low_enter[..., t, :] | (state & low_stay[..., t, :])
        out[..., t, :] = state
    return out


def _majority(labels: np.ndarray, width: int) -> np.ndarray:
    """A majority filter of ``width`` (odd) frames along axis -2, the edges padded by
    repeating the first and last label."""
    if width < 3:
        return labels
    half = width // 2
    padded = np.concatenate([np.repeat(labels[..., :1, :], half, -2), labels,
                             np.repeat(labels[..., -1:, :], half, -2)], axis=-2).astype(np.int32)
    sums = np.cumsum(np.concatenate([np.zeros_like(padded[..., :1, :]), padded], axis=-2), axis=-2)
    return (sums[..., width:, :] - sums[..., :-width, :]) > half


def horizontal_speed(positions, fps: float, window_s: float = SPEED_WINDOW_S) -> np.ndarray:
    """Horizontal speed of every joint of ``positions`` ``(..., frames, joints, 3)``, m/s,
    ``(..., frames, joints)``: the distance in ``x, z`` between the frames ``k`` before and
    ``k`` after each frame, over ``2k`` frames, with ``k = round(window_s * fps / 2)`` (at
    least 1; :data:`SPEED_WINDOW_S`). Near the ends the window is cut to the frames there
    are. With ``k = 1`` these are central differences (``np.gradient``)."""
    positions = checks.array(positions, "positions", (..., "frames", "joints", 3))
    fps = checks.rate(fps, "fps")
    k = max(1, int(round(checks.non_negative(window_s, "window_s", checks.MAX_SECONDS) * fps / 2)))
    frames = positions.shape[-3]
    if frames < 2:
        raise ValueError(f"positions: need at least 2 frames to measure speed, got {frames}")
    t = np.arange(frames)
    before, after = np.maximum(t - k, 0), np.minimum(t + k, frames - 1)
    xz = positions[..., [0, 2]]
    step = xz[..., after, :, :] - xz[..., before, :, :]
    return np.linalg.norm(step, axis=-1) * fps / (after - before)[:, None]


def detect(positions, fps: float, planted_height_m=None, height_m=CONTACT_HEIGHT_M,
           speed_ms: float = CONTACT_SPEED_MS, body_fraction: float = BODY_FRACTION,
           clean_s: float = CLEAN_S, speed_window_s: float = SPEED_WINDOW_S) -> np.ndarray:
    """Foot contacts: ``(..., frames, 4)`` booleans for the ankles and toes (:data:`FEET`:
    left ankle, left toe, right ankle, right toe) of ``positions`` ``(..., frames, 21, 3)``.

    A joint enters contact when it is less than ``height_m`` above its planted height and
    moves horizontally slower than ``speed_ms`` (measured over ``speed_window_s`` seconds:
    :func:`horizontal_speed`), and stays in it until it is more than :data:`RELEASE` times
    either threshold above. The labels are then cleaned by a majority filter over
    ``clean_s`` seconds (the odd number of frames nearest to it; 0: none).

    Args:
        planted_height_m: each joint's planted height (``(4,)`` or one value, metres);
            default :func:`planted_heights` of ``positions`` (right for data; for a model's
            samples pass the data's).
        height_m, speed_ms: the thresholds (:data:`CONTACT_HEIGHT_M`, :data:`CONTACT_SPEED_MS`).
        speed_window_s: how long a stretch the speed is measured over (:data:`SPEED_WINDOW_S`).
    """
    positions = _positions(positions)
    fps = checks.rate(fps, "fps")
    if positions.shape[-3] < 2:
        raise ValueError(f"positions: need at least 2 frames to measure speed, got {positions.shape[-3]}")
    floor = planted_heights(positions) if planted_height_m is None else \
        _per_foot_joint(planted_height_m, "planted_height_m", positive=False)
    height_m = _per_foot_joint(height_m, "height_m")
    speed_ms = checks.positive(speed_ms, "speed_ms")
    clean_s = checks.non_negative(clean_s, "clean_s", checks.MAX_SECONDS)
    speed_window_s = checks.non_negative(speed_window_s, "speed_window_s", checks.MAX_SECONDS)
    feet = positions[..., FEET, :]
    above = feet[..., 1] - floor
    moving = horizontal_speed(positions[..., [0, *FEET], :], fps, speed_window_s)
    speed, hips = moving[..., 1:], moving[..., 0]
    limit = np.maximum(speed_ms, body_fraction * hips)[..., None]
    labels = _hysteresis((above < height_m) & (speed < limit),
                         (above < RELEASE * height_m) & (speed < RELEASE * limit))
    width = 2 * int(np.floor((clean_s * fps - 1) / 2 + 0.5)) + 1 if clean_s > 0 else 1     # odd, nearest
    return _majority(labels, min(width, 2 * ((labels.shape[-2] - 1) // 2) + 1))


def planted_speed(positions, fps: float, contacts) -> float:
    """How fast the feet move while in contact, m/s: the mean horizontal speed of the ankles
    and toes between frames ``t`` and ``t + 1`` where ``contacts`` ``(..., frames, 4)`` has
    the joint in contact in both. Zero for feet that stay where they land; what a lock is
    for (the skating measure also counts feet that are low but not planted)."""
    positions = _positions(positions)
    fps = checks.rate(fps, "fps")
    contacts = _contact_array(contacts, positions.shape[:-2] + (len(FEET),))
    speed = np.linalg.norm(np.diff(positions[..., FEET, :][..., [0, 2]], axis=-3), axis=-1) * fps
    held = contacts[..., 1:, :] & contacts[..., :-1, :]
    return float(speed[held].mean()) if held.any() else 0.0
