"""Procedural locomotion: the built-in data set, so every notebook runs without downloads.

A control trajectory (forward, sideways and turning velocity per frame: the same three
numbers as the control part of :mod:`motionlab.representation`) drives a walking, jogging or
running body of 21 joints: the walker, :mod:`motionlab.gait` (:func:`generate`, six steps from
the root path to the upper body). This module makes what the walker follows and assembles the
data set from it:

* random control trajectories strung together from :data:`ACTIVITIES` (:func:`random_control`),
  hand-drawn ones (:func:`preset_control`, the kinds of test control of MoGlow §5.4);
* the walker's own control, with the wobble of its strides (:func:`walked_control`), and
  :class:`StrideWobble`, that wobble made causally for a live controller;
* clips of a random control, body and style drawn from a seed (:func:`random_motion`),
  and the data set of them (:func:`dataset`).

Every clip draws its own :class:`Body` (proportions within human ranges, constant bone
lengths) and :class:`Style` (stride, step width, toe-out, arm swing, elbow bend, lean,
bounce, asymmetry), so models have a distribution to learn rather than one gait cycle.
Everything is vectorised over frames and deterministic given a seed. The walker's names
(:func:`generate`, :class:`Body`, :class:`Style`, :class:`Motion`, its steps) are importable
from here too.

Positions are metres, y up, floor at y = 0; angles in :class:`Style` are degrees.
"""
from __future__ import annotations

import numpy as np

from . import checks
from .filters import gaussian_smooth, smoothstep
from .gait import (GRAVITY, J, Body, Foot, Gait, Motion, Pelvis, Style, cadence_steps_per_s, footsteps,
                   gait_timing, generate, legs, padding_frames, pelvis_motion, root_path, upper_body)
from .representation import CONTROL, to_features

__all__ = ["ACTIVITIES", "GRAVITY", "J", "PRESETS", "WOBBLE_SIDEWAYS_MS", "WOBBLE_TURNING_RADS",
           "WOBBLE_TURN_LEAD_RAD", "Body", "Foot", "Gait", "Motion", "Pelvis", "StrideWobble", "Style",
           "cadence_steps_per_s", "dataset", "footsteps", "gait_timing", "generate", "legs", "padding_frames",
           "pelvis_motion", "preset_control", "random_control", "random_motion", "root_path", "upper_body",
           "walked_control"]


# ----------------------------------------------------------------------------------------
# Control trajectories
# ----------------------------------------------------------------------------------------

# (name, probability, forward m/s range, sideways m/s range, turning rad/s spread)
ACTIVITIES = (
    ("stand", 0.08, (0.0, 0.0), (0.0, 0.0), 0.0),
    ("slow walk", 0.12, (0.4, 0.9), (0.0, 0.0), 0.4),
    ("walk", 0.30, (0.9, 1.8), (0.0, 0.0), 0.5),
    ("jog", 0.14, (2.0, 3.0), (0.0, 0.0), 0.35),
    ("run", 0.12, (3.0, 4.0), (0.0, 0.0), 0.25),
    ("backwards", 0.08, (-1.0, -0.4), (0.0, 0.0), 0.2),
    ("side step", 0.10, (-0.1, 0.3), (0.25, 0.6), 0.1),
    ("turn on the spot", 0.06, (0.0, 0.2), (0.0, 0.0), 1.2),
)
"""The activities a random control trajectory strings together."""


def random_control(duration_s: float, fps: float, rng: np.random.Generator | int = 0,
                   segment_s: tuple[float, float] = (1.5, 4.0)) -> np.ndarray:
    """A random control trajectory ``(frames, 3)``: forward, sideways (m/s), turning (rad/s).

    Strings together :data:`ACTIVITIES` (standing, walking, running, walking backwards,
    side-stepping, turning), each held for ``segment_s`` seconds, with smooth changes
    between them (starts and stops take about a second).
    """
    rng = np.random.default_rng(rng)
    if duration_s <= 0 or fps <= 0:
        raise ValueError(f"duration_s and fps must be > 0, got {duration_s} and {fps}")
    frames = max(2, int(round(duration_s * fps)))
    probabilities = np.array([a[1] for a in ACTIVITIES])
    target = np.zeros((frames, 3))
    start = 0
    while start < frames:
        length = int(rng.uniform(*segment_s) * fps)
        _, _, fwd, side, turn = ACTIVITIES[rng.choice(len(ACTIVITIES), p=probabilities / probabilities.sum())]
        value = [rng.uniform(*fwd), rng.choice([-1, 1]) * rng.uniform(*side),
                 np.clip(rng.normal(0.0, turn), -1.5, 1.5)]
        target[start:start + length] = value
        start += length
    return gaussian_smooth(target, 0.35 * fps)


PRESETS = ("stand still", "walk", "run", "circle", "side-step", "backwards", "walk, then stop")
"""The names :func:`preset_control` knows: the kinds of test control of MoGlow §5.4."""


def preset_control(name: str, duration_s: float = 8.0, fps: float = 20.0, ramp_s: float = 1.0) -> np.ndarray:
    """A hand-drawn control trajectory ``(frames, 3)``: forward, sideways (m/s), turning (rad/s).

    Every preset starts from standing and reaches its speed over ``ramp_s`` seconds (smoothly):
    ``"stand still"`` (all zero), ``"walk"`` (1.3 m/s), ``"run"`` (3.2 m/s), ``"circle"``
    (walking at 1.2 m/s, turning left at 0.6 rad/s: a circle of 2 m radius),
    ``"side-step"`` (0.5 m/s to the left), ``"backwards"`` (-0.8 m/s), ``"walk, then stop"``
    (1.3 m/s, slowing to a stop over the second half).

    A drawn path is perfectly smooth; real and synthetic control wobble with every step
    (the hips sway). Models that read the step timing from the wobble glide along a smooth
    path: pass it through :func:`walked_control` first.
    """
    if name not in PRESETS:
        raise ValueError(f"name: unknown preset {name!r}; presets are {', '.join(PRESETS)}")
    if duration_s <= 0 or fps <= 0 or ramp_s < 0:
        raise ValueError(f"duration_s, fps must be > 0 and ramp_s >= 0, got {duration_s}, {fps}, {ramp_s}")
    frames = max(2, int(round(duration_s * fps)))
    t = np.arange(frames) / fps
    ramp = smoothstep(t / ramp_s) if ramp_s > 0 else np.ones(frames)
    target = {"stand still": (0.0, 0.0, 0.0), "walk": (1.3, 0.0, 0.0), "run": (3.2, 0.0, 0.0),
              "circle": (1.2, 0.0, 0.6), "side-step": (0.0, 0.5, 0.0), "backwards": (-0.8, 0.0, 0.0),
              "walk, then stop": (1.3, 0.0, 0.0)}[name]
    control = ramp[:, None] * np.asarray(target)[None]
    if name == "walk, then stop":
        half = duration_s / 2
        control *= 1.0 - smoothstep((t - half) / max(ramp_s, 1.0 / fps))[:, None]
    return control


def walked_control(control: np.ndarray, fps: float, body: Body | None = None,
                   style: Style | None = None) -> np.ndarray:
    """The control ``(frames, 3)`` of the synthetic walker following ``control``: the same
    path, with the stride-by-stride wobble of real locomotion (the hips sway and surge
    with each step). Control-driven models learn to read step timing from that wobble."""
    return to_features(generate(control, fps, body, style).positions, fps)[:, CONTROL]


# The wobble of walked_control, measured on the synthetic walker at steady speeds: the hips'
# sideways velocity and turning rate swing once per stride (forward velocity barely moves),
# the turn leading the sway; amplitudes at walking / running.
WOBBLE_SIDEWAYS_MS = (0.125, 0.07)
WOBBLE_TURNING_RADS = (0.038, 0.011)
WOBBLE_TURN_LEAD_RAD = (2.0, 1.1)


class StrideWobble:
    """:func:`walked_control`'s stride-by-stride wobble, made causally: one control frame in,
    the same with the sway of a stride added, using nothing from later frames. What a live
    controller (a keyboard) feeds a model that reads step timing from the wobble.

    Each frame advances the stride phase by the walker's cadence at that speed
    (:func:`cadence_steps_per_s`, half a stride per step), and adds to the sideways
    velocity and turning rate a sine of that phase with the amplitudes of
    :data:`WOBBLE_SIDEWAYS_MS` and :data:`WOBBLE_TURNING_RADS` (blended from walking to
    running as :func:`gait_timing` blends them), faded out towards standing.

    >>> wobble = StrideWobble(fps=20)
    >>> frame = wobble.step(np.array([1.3, 0.0, 0.0]))     # walking forward, swaying
    """

    def __init__(self, fps: float, style: Style | None = None):
        self.fps = checks.rate(fps, "fps")
        self.style = style or Style()
        self.reset()

    def reset(self) -> None:
        self.phase = 0.0                                   # strides so far

    def step(self, control) -> np.ndarray:
        control = checks.array(control, "control", (3,))
        forward, sideways, turning = control
        planar = float(np.hypot(forward, sideways))
        running = float(smoothstep((forward - self.style.run_speed + 0.3) / 0.6))
        active = float(smoothstep(max(planar / 0.5, abs(turning) / 0.8)))
        blend = lambda pair: pair[0] + (pair[1] - pair[0]) * running          # noqa: E731
        angle = 2 * np.pi * self.phase
        out = control.copy()
        out[1] += active * blend(WOBBLE_SIDEWAYS_MS) * np.sin(angle)
        out[2] += active * blend(WOBBLE_TURNING_RADS) * np.sin(angle + blend(WOBBLE_TURN_LEAD_RAD))
        cadence = self.style.cadence * float(cadence_steps_per_s(np.array(planar), np.array(running)))
        self.phase = (self.phase + cadence / 2 / self.fps) % 1.0
        return out


def random_motion(duration_s: float = 10.0, fps: float = 20.0, seed: int = 0,
                  body: Body | None = None, style: Style | None = None) -> Motion:
    """A clip with a random control trajectory, body and style, all drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    control = random_control(duration_s, fps, rng)
    body = body or Body.random(rng)
    style = style or Style.random(rng)
    heading = rng.uniform(-np.pi, np.pi)
    return generate(control, fps, body, style, start=np.array([0.0, 0.0, heading]),
                    phase=rng.uniform())


def dataset(n_clips: int = 60, duration_s: float = 10.0, fps: float = 20.0,
            seed: int = 0) -> list[tuple[str, Motion]]:
    """``n_clips`` random clips named ``synthetic_000``, ... (seeds ``seed``, ``seed + 1``, ...)."""
    if n_clips < 1:
        raise ValueError(f"n_clips must be >= 1, got {n_clips}")
    return [(f"synthetic_{seed + i:03d}", random_motion(duration_s, fps, seed + i))
            for i in range(n_clips)]
