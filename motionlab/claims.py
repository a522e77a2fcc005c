"""The papers' claims as checks on measured motion: each returns a :class:`Verdict`.

A notebook asserts a claim with ``assert verdict, verdict`` (the verdict prints its
figures and, when it fails, why). Each check is written so that only a good model passes
it: ``tests/test_claims.py`` runs every one on trivial baselines (the data's mean pose
moved along the true path, a constant pose, a time-shuffled clip, steps that fade, a
decoder that ignores its latent) and asserts that each of them **fails**.

The bounds are the course's targets, fixed here once; they are never loosened to let a
model through. Where a model misses one, the notebook says so with the numbers.

Units: features ``(..., frames, 66)`` in the data's units (m, m/s, rad/s); errors in
metres; the figures a verdict reports are in the units their names say.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import checks, metrics
from .representation import N_FEATURES, to_positions

MOVES_LIKE_DATA = {"stepping": 0.8, "leg swing": 0.8, "skating": 2.0, "bone drift": 0.02}
"""Generated motion against the data (Motegi §V made measurable): stepping speed and leg
swing at least 80 % of the data's, foot skating at most 2x the data's, bones stretching
at most 2 %."""

STEADY_STEPPING = 0.25
"""Steered motion steps within ±25 % of the data's stepping speed in every second."""

TRAVERSAL_EFFECT = 0.5
"""A latent axis "controls" a body part when its sweep moves it by half the data's
standard deviation or more (Motegi Figs. 7-9)."""

FOLLOWS_CONTROL = {"walk": 0.7, "stopped (m/s)": 0.15, "settle (s)": 1.0, "stop command": 0.05}
"""MoGlow §5.3 made measurable: told to walk, the body steps at least 70 % as fast as the
data in every second after the first; told to stop (the control's speeds below 0.05 m/s
and rad/s), it steps slower than 0.15 m/s from one second after the command on."""

KEEPS_MOVING = {"spread": 0.7, "chunk (s)": 5.0}
"""MoGlow §5.3's long samples: in every 5 s of a long sample the pose varies at least 70 %
as much as the data's on the same path (no reversion to a static pose)."""

BEATS_TRIVIAL = 0.8
"""A model that claims to use the control must beat the trivial model that uses it too
(the mean pose moved along the true path) by 20 % or more."""

DIVERSE_FUTURES = {"growth": 1.5, "early (s)": (0.5, 1.5), "late (s)": (20.0, 30.0), "fast (m/s)": 2.0,
                   "fast share": 0.3, "pace window (s)": 10.0, "pose speed": 0.5, "speed window (s)": 5.0,
                   "bone drift": 0.005}
"""DFN §6.3 made measurable. For the samples of each prefix: their distance to their mean
pose at 20-30 s is at least 1.5 times that at 0.5-1.5 s and within one standard deviation
of the data's (Fig. 9), and over the last 5 s the pose changes at least half as fast as the
data's (no freezing). Over all samples: in the last 10 s the share of frames faster than
2 m/s is within ±30 % of the data's (they run as often as the data does), and bones stretch
at most 0.5 % (the joint-rotation decoder of §5.1)."""


@dataclass
class Verdict:
    """Whether a claim holds, with the measured figures and the reasons it fails.

    ``bool(verdict)`` is whether it holds; ``str(verdict)`` is a short report, one line per
    figure, then the failures."""

    claim: str
    figures: dict[str, float] = field(default_factory=dict)
    failures: list[str] = field(default_factory=list)

    @property
    def holds(self) -> bool:
        return not self.failures

    def __bool__(self) -> bool:
        return self.holds

    def require(self, ok: bool, failure: str) -> None:
        """Record ``failure`` unless ``ok``."""
        if not ok:
            self.failures.append(failure)

    def __str__(self) -> str:
        lines = [f"{self.claim}: {'holds' if self.holds else 'does NOT hold'}"]
        lines += [f"  {name}: {value:.4g}" for name, value in self.figures.items()]
        lines += [f"  fails: {why}" for why in self.failures]
        return "\n".join(lines)


def _features(value, name: str) -> np.ndarray:
    return checks.array(value, name, (..., "frames", N_FEATURES))


# ----------------------------------------------------------------------------------------
# Motegi 2018: an autoencoder that beats trivial reconstructions; samples that move
# ----------------------------------------------------------------------------------------

def beats_trivial_reconstructions(errors: dict[str, tuple[float, float]], model: str) -> Verdict:
    """The autoencoder reconstructs motion better than any trivial reconstruction (Motegi
    §III): ``errors`` maps a name to ``(pose error, motion error)`` in metres, for
    ``model`` and for each trivial baseline (mean pose, window average, constant velocity,
    ...); the model's pose *and* motion error must be below the best baseline's."""
    if model not in errors or len(errors) < 2:
        raise ValueError(f"errors: expected {model!r} and at least one baseline, got {sorted(errors)}")
    verdict = Verdict(f"{model} beats every trivial reconstruction")
    baselines = {name: e for name, e in errors.items() if name != model}
    for k, kind in enumerate(("pose", "motion")):
        best_name = min(baselines, key=lambda name: baselines[name][k])
        ours, best = errors[model][k], baselines[best_name][k]
        verdict.figures[f"{kind} error, {model} (cm)"] = 100 * ours
        verdict.figures[f"{kind} error, best baseline: {best_name} (cm)"] = 100 * best
        verdict.require(ours < best, f"{kind} error {100 * ours:.2f} cm is not below {best_name}'s {100 * best:.2f} cm")
    return verdict


def moves_like_data(samples: np.ndarray, data: np.ndarray, fps: float, name: str = "samples") -> Verdict:
    """Generated windows move like the data (Motegi §V, made measurable): their stepping
    speed and leg swing are at least 80 % of the data's, their feet skate at most 2x the
    data's (measured against the data's planted foot heights) and their bones stretch at
    most 2 % (:data:`MOVES_LIKE_DATA`). ``samples`` and ``data``: features ``(..., frames,
    66)``; each window is integrated from its own start."""
    fps = checks.rate(fps, "fps")
    data = _features(data, "data")
    samples = _features(samples, "samples")
    rest = metrics.foot_rest_heights(to_positions(data, fps))
    ours, theirs = metrics.locomotion_report(samples, fps, rest), metrics.locomotion_report(data, fps, rest)
    verdict = Verdict(f"{name} move like the data")
    for key in ours:
        verdict.figures[f"{key}, {name}"] = ours[key]
        verdict.figures[f"{key}, data"] = theirs[key]
    bound = MOVES_LIKE_DATA
    for key, label in (("stepping (m/s)", "stepping"), ("leg swing (m)", "leg swing")):
        ratio = ours[key] / max(theirs[key], 1e-9)
        verdict.require(ratio >= bound[label], f"{label} is {100 * ratio:.0f} % of the data's (need >= "
                                               f"{100 * bound[label]:.0f} %)")
    skating = ours["foot skating (m/s)"] / max(theirs["foot skating (m/s)"], 1e-9)
    verdict.require(skating <= bound["skating"], f"feet skate {skating:.1f}x the data's (need <= {bound['skating']:g}x)")
    verdict.require(ours["bone drift"] <= bound["bone drift"],
                    f"bones stretch {100 * ours['bone drift']:.1f} % (need <= {100 * bound['bone drift']:g} %)")
    return verdict


def axes_control_parts(effects: dict[str, np.ndarray], spread: dict[str, float],
                       parts: tuple[str, ...] = ("hand height (m)", "knee bend (deg)")) -> Verdict:
    """Distinct latent axes control distinct body parts (Motegi §V, Figs. 7-9).

    ``effects[part]``: ``(latent,)`` how much sweeping each axis (5th to 95th percentile of
    the prior, :func:`motionlab.models.vae.axis_effects`) changes ``part``; ``spread[part]``
    the data's standard deviation of it. Holds when each part's *strongest* axis is its own
    (no two parts share one) and its sweep moves that part by at least
    :data:`TRAVERSAL_EFFECT` of the data's spread: a traversal of that axis then shows the
    part move, and the other part's axis is a different slider. (Finding some distinct axes
    for each part by giving one part its second-best axis is not enough: the figure of the
    strongest axis would show both parts moving together.)"""
    if len(parts) < 2:
        raise ValueError(f"parts: expected two or more body-part measures, got {parts!r}")
    missing = [p for p in parts if p not in effects or p not in spread]
    if missing:
        raise ValueError(f"effects, spread: missing {missing}")
    standardised = np.stack([np.abs(np.asarray(effects[p], dtype=float)) / max(float(spread[p]), 1e-12)
                             for p in parts])                         # (parts, latent)
    if standardised.shape[1] < len(parts):
        raise ValueError(f"effects: need at least {len(parts)} latent axes, got {standardised.shape[1]}")
    verdict = Verdict("distinct latent axes move distinct body parts")
    strongest = [int(np.argmax(row)) for row in standardised]
    for k, part in enumerate(parts):
        verdict.figures[f"{part}: strongest axis"] = strongest[k]
        verdict.figures[f"{part}: its effect (data std)"] = float(standardised[k, strongest[k]])
        verdict.require(standardised[k, strongest[k]] >= TRAVERSAL_EFFECT,
                        f"{part}: its strongest axis {strongest[k]} moves it by {standardised[k, strongest[k]]:.2f} "
                        f"of the data's std (need >= {TRAVERSAL_EFFECT})")
    shared = sorted({a for a in strongest if strongest.count(a) > 1})
    verdict.require(not shared, f"axis {', '.join(map(str, shared))} is the strongest for "
                    f"{' and '.join(p for p, a in zip(parts, strongest) if a in shared)}: one slider moves them together")
    return verdict


# ----------------------------------------------------------------------------------------
# Habibie 2017: control beats no control; the steered character keeps stepping
# ----------------------------------------------------------------------------------------

def control_beats_no_control(errors: dict[str, np.ndarray], model: str, no_control: str,
                             trivial: str, horizons: slice = slice(-3, None)) -> Verdict:
    """Habibie Tables 1-2: at the long horizons, the control-conditioned ``model`` predicts
    motion better than the model without control *and* better than the trivial model that
    has the control too (the data's mean pose moved along the true path).

    ``errors[name]``: errors at the horizons, ``(horizons,)`` metres (the motion error of
    Table 1, or the pose error of Table 2). Holds when at every horizon of ``horizons``
    (default: the last three) the model's error is below ``no_control``'s and at most
    :data:`BEATS_TRIVIAL` times ``trivial``'s."""
    for name in (model, no_control, trivial):
        if name not in errors:
            raise ValueError(f"errors: no row {name!r} (rows: {sorted(errors)})")
    ours, theirs, base = (np.asarray(errors[n], dtype=float)[horizons] for n in (model, no_control, trivial))
    verdict = Verdict(f"{model} beats no control and the mean pose on the true path at long horizons")
    for k in range(len(ours)):
        verdict.figures[f"horizon {k + 1}: {model} (cm)"] = 100 * ours[k]
        verdict.figures[f"horizon {k + 1}: {no_control} (cm)"] = 100 * theirs[k]
        verdict.figures[f"horizon {k + 1}: {trivial} (cm)"] = 100 * base[k]
    verdict.require(bool((ours < theirs).all()), f"not below {no_control} at every long horizon")
    verdict.require(bool((ours <= BEATS_TRIVIAL * base).all()),
                    f"not <= {BEATS_TRIVIAL:g}x {trivial} at every long horizon "
                    f"(ratios {np.round(ours / base, 2).tolist()})")
    return verdict


def steps_steadily(samples: np.ndarray, reference_stepping, reference_leg_swing: float,
                   fps: float, name: str = "steered motion") -> Verdict:
    """A character steered along a path keeps stepping like the data on that path: in every
    second its stepping speed (:func:`motionlab.metrics.stepping_by_second`, averaged over
    the samples) is within ±25 % (:data:`STEADY_STEPPING`) of the data's in the same second,
    and its leg swing is at least 80 % of the data's.

    Args:
        samples: features ``(n, frames, 66)`` generated for one path, data units.
        reference_stepping: the data's stepping on that path, m/s: ``(seconds,)`` second by
            second (:func:`motionlab.experiments.data_stepping`), or one number for all.
        reference_leg_swing: the data's :func:`motionlab.metrics.leg_swing` on it, m.
        fps: frames per second.
    """
    samples = _features(samples, "samples")
    fps = checks.rate(fps, "fps")
    by_second = metrics.stepping_by_second(samples, fps)
    per_second = by_second.reshape(-1, by_second.shape[-1]).mean(0)            # (seconds,)
    reference = np.broadcast_to(np.asarray(reference_stepping, dtype=float), per_second.shape) \
        if np.ndim(reference_stepping) == 0 or np.size(reference_stepping) == len(per_second) else None
    if reference is None:
        raise ValueError(f"reference_stepping: expected one number or {len(per_second)} (one per second), "
                         f"got {np.shape(reference_stepping)}")
    if not ((reference > 0).all() and reference_leg_swing > 0):
        raise ValueError(f"reference_stepping, reference_leg_swing: expected > 0, got "
                         f"{reference_stepping!r}, {reference_leg_swing!r}")
    swing = metrics.leg_swing(samples.reshape((-1,) + samples.shape[-2:]))
    verdict = Verdict(f"{name} keeps stepping")
    for k, (value, data_value) in enumerate(zip(per_second, reference)):
        verdict.figures[f"second {k + 1}: stepping / the data's"] = float(value / data_value)
    verdict.figures["leg swing / the data's"] = swing / reference_leg_swing
    off = np.abs(per_second / reference - 1) > STEADY_STEPPING
    verdict.require(not off.any(), f"stepping off the data's by more than {100 * STEADY_STEPPING:.0f} % in seconds "
                                   f"{(np.flatnonzero(off) + 1).tolist()} (ratios "
                                   f"{np.round(per_second / reference, 2).tolist()})")
    verdict.require(swing >= MOVES_LIKE_DATA["leg swing"] * reference_leg_swing,
                    f"leg swing {100 * swing / reference_leg_swing:.0f} % of the data's (need >= 80 %)")
    return verdict


def follows_control(walking: np.ndarray, walking_reference, stopping: np.ndarray, stop_control: np.ndarray,
                    fps: float, name: str = "model") -> Verdict:
    """The body does what the control says (MoGlow §5.3): it steps when told to walk and
    stops when told to stop (:data:`FOLLOWS_CONTROL`).

    A model whose steps fade fails the first half, one that ignores the control and walks
    on fails the second, a constant or gliding pose fails the first.

    Args:
        walking: features ``(n, frames, 66)`` generated along a walking path (data units).
        walking_reference: the data's stepping on that path, m/s, second by second
            ``(seconds,)`` (:func:`motionlab.experiments.data_stepping`).
        stopping: features ``(n, frames, 66)`` generated along a path that walks and then
            stops (``"walk, then stop"``), frame 0 = the path's frame 0.
        stop_control: that path's control ``(frames, 3)``, m/s and rad/s: the stop command
            is the frame from which its speed stays below 0.05 m/s and 0.05 rad/s.
        fps: frames per second.
    """
    fps = checks.rate(fps, "fps")
    walking, stopping = _features(walking, "walking"), _features(stopping, "stopping")
    stop_control = np.asarray(stop_control, dtype=float)
    if stop_control.ndim != 2 or stop_control.shape[1] != 3 or len(stop_control) != stopping.shape[-2]:
        raise ValueError(f"stop_control: expected ({stopping.shape[-2]}, 3), one row per frame of stopping, "
                         f"got {stop_control.shape}")
    by_second = metrics.stepping_by_second(walking, fps)
    per_second = by_second.reshape(-1, by_second.shape[-1]).mean(0)                 # (seconds,)
    reference = np.asarray(walking_reference, dtype=float)
    if reference.shape != per_second.shape or not (reference > 0).all():
        raise ValueError(f"walking_reference: expected {per_second.shape[0]} stepping speeds > 0 (one per second), "
                         f"got {reference.shape}")
    moving = np.abs(stop_control).max(axis=1) >= FOLLOWS_CONTROL["stop command"]
    if not moving.any() or moving[-1]:
        raise ValueError("stop_control: the path must move and then stop (speed < 0.05 at its end)")
    stop = int(np.flatnonzero(moving)[-1]) + 1                              # first frame of the stop
    settled = stop + int(round(FOLLOWS_CONTROL["settle (s)"] * fps))
    per = int(round(fps))
    after = metrics.stepping_speed(stopping, fps, smooth_s=0.1).reshape(-1, stopping.shape[-2] - 1).mean(0)[settled:]
    seconds_after = len(after) // per
    if seconds_after < 1:
        raise ValueError(f"stopping: needs at least {FOLLOWS_CONTROL['settle (s)'] + 1:g} s after the stop "
                         f"command (frame {stop}), got {len(after) / fps:.2f} s")
    after = after[:seconds_after * per].reshape(seconds_after, per).mean(1)
    ratios = per_second[1:] / reference[1:]
    verdict = Verdict(f"{name} follows the control")
    for k, r in enumerate(ratios):
        verdict.figures[f"told to walk, second {k + 2}: stepping / the data's"] = float(r)
    for k, v in enumerate(after):
        verdict.figures[f"told to stop, second {k + 1} after settling: stepping (m/s)"] = float(v)
    bound = FOLLOWS_CONTROL
    low = ratios < bound["walk"]
    verdict.require(not low.any(), f"told to walk, steps under {100 * bound['walk']:.0f} % of the data's in seconds "
                                   f"{(np.flatnonzero(low) + 2).tolist()} (ratios {np.round(ratios, 2).tolist()})")
    verdict.require(bool((after < bound["stopped (m/s)"]).all()),
                    f"told to stop, still steps {np.round(after, 2).tolist()} m/s from {bound['settle (s)']:g} s "
                    f"after the command (need < {bound['stopped (m/s)']:g})")
    return verdict


def follows_speed(speeds, stepping, data_stepping, name: str = "model") -> Verdict:
    """The body steps as fast as the commanded speed asks (notebook 08's comparison): told
    to stand (speed 0) it steps slower than ``FOLLOWS_CONTROL["stopped (m/s)"]``, and over
    the commanded speeds above 0 its stepping is on average within ``STEADY_STEPPING``
    (±25 %) of the data's mean stepping at those speeds (mean absolute difference).

    A model that ignores the control steps alike at every speed and fails; so do steps that
    fade, a standing or gliding pose, and a model that walks when told to stand.

    Args:
        speeds: commanded forward speeds, m/s ``(k,)``, one of them 0.
        stepping: the model's stepping speed at each (m/s, :func:`motionlab.metrics.stepping_by_second`).
        data_stepping: the data's stepping on the same paths (m/s).
    """
    speeds, stepping, data_stepping = (np.asarray(v, dtype=float) for v in (speeds, stepping, data_stepping))
    if speeds.ndim != 1 or stepping.shape != speeds.shape or data_stepping.shape != speeds.shape:
        raise ValueError(f"speeds, stepping, data_stepping: expected three (k,) arrays, got {speeds.shape}, "
                         f"{stepping.shape}, {data_stepping.shape}")
    if not (speeds == 0).any() or not (speeds > 0).any():
        raise ValueError(f"speeds: expected 0 and at least one speed above 0, got {speeds.tolist()}")
    if not np.isfinite(stepping).all() or not (data_stepping[speeds > 0] > 0).all():
        raise ValueError("stepping, data_stepping: expected finite speeds, the data stepping at every speed > 0")
    moving = speeds > 0
    standing = float(stepping[speeds == 0].max())
    error = float(np.abs(stepping[moving] - data_stepping[moving]).mean() / data_stepping[moving].mean())
    verdict = Verdict(f"{name} steps at the commanded speed")
    verdict.figures["told to stand: stepping (m/s)"] = standing
    verdict.figures["moving: mean |stepping - the data's| / the data's mean"] = error
    stopped = FOLLOWS_CONTROL["stopped (m/s)"]
    verdict.require(standing < stopped, f"told to stand, steps at {standing:.2f} m/s (need < {stopped:g})")
    verdict.require(error <= STEADY_STEPPING, f"stepping is {100 * error:.2f} % off the data's on average "
                                              f"(need <= {100 * STEADY_STEPPING:.0f} %)")
    return verdict


FOLLOWS_KEYS = {"walk": 0.7, "settle (s)": 1.0, "stopped for (s)": 0.5, "turn": 0.5, "turn lag (s)": 0.5}
"""Live steering (:mod:`motionlab.live`): held forward, after its first second the body
steps at least 70 % as fast as the data walking at that speed (§5.3's measure); let go,
from a second later it steps slower than ``FOLLOWS_CONTROL["stopped (m/s)"]`` for half a
second; where a turn was held, the body's heading turns the same way by at least half the
angle the control asked for (measured until half a second after the key, the body's lag)."""


def follows_keys(steered: dict, data: np.ndarray, fps: float, name: str = "live character") -> Verdict:
    """The keys steer the character (:data:`FOLLOWS_KEYS`), measured on the last stretch in
    which ``"forward"`` was held (and the last in which a turn was).

    A character that ignores the keys fails: it never walks, or it walks on after the key
    is let go; so does one whose steps fade while the key is held.

    Args:
        steered: ``{"positions": (frames, 21, 3), "intents": [per frame: what was held],
            "control": (frames, 3)}`` (the control is needed only where a turn was held;
            :meth:`motionlab.live.SteeringPanel.steered`, :func:`motionlab.live.record`).
        data: features ``(n, frames, 66)`` of bodies walking the walk preset (the speed
            "forward" asks for), e.g. :func:`motionlab.experiments.preset_walks`.
        fps: frames per second.
    """
    fps = checks.rate(fps, "fps")
    positions = checks.array(steered.get("positions"), "steered['positions']", ("frames", 21, 3))
    intents = steered.get("intents")
    if intents is None or len(intents) != len(positions):
        raise ValueError(f"steered['intents']: expected one entry per frame ({len(positions)})")
    data = _features(data, "data")
    from .representation import to_features
    held = np.array(["forward" in i for i in intents])
    stepping = metrics.stepping_speed(to_features(positions, fps), fps, smooth_s=0.1)
    data_walk = float(metrics.stepping_speed(data, fps, smooth_s=0.1)[..., int(2 * fps):].mean())
    verdict = Verdict(f"{name}: held forward it walks, let go it stops")
    edges = np.flatnonzero(np.diff(np.concatenate([[0], held.astype(int), [0]])))
    if len(edges) < 2:
        verdict.require(False, "forward was never held")
        return verdict
    begin, end = edges[-2], edges[-1]
    settle, stopped = int(round(FOLLOWS_KEYS["settle (s)"] * fps)), int(round(FOLLOWS_KEYS["stopped for (s)"] * fps))
    walking = stepping[begin + settle:end]
    after = stepping[end + settle:end + settle + stopped]
    if len(walking) < 5 or len(after) < stopped:
        verdict.require(False, f"forward held {(end - begin) / fps:.1f} s and the motion goes on "
                               f"{(len(positions) - end) / fps:.1f} s after: too short to measure "
                               f"(need > {FOLLOWS_KEYS['settle (s)'] + 0.25:g} s and "
                               f"{FOLLOWS_KEYS['settle (s)'] + FOLLOWS_KEYS['stopped for (s)']:g} s)")
        return verdict
    ratio, still = float(walking.mean() / data_walk), float(after.max())
    verdict.figures["held: stepping / the data's walking"] = ratio
    verdict.figures[f"let go, from {FOLLOWS_KEYS['settle (s)']:g} s: stepping, max (m/s)"] = still
    verdict.require(ratio >= FOLLOWS_KEYS["walk"], f"held forward, steps at {100 * ratio:.0f} % of the data's "
                                                   f"(need >= {100 * FOLLOWS_KEYS['walk']:.0f} %)")
    bound = FOLLOWS_CONTROL["stopped (m/s)"]
    verdict.require(still < bound, f"let go, still steps at up to {still:.2f} m/s a second later (need < {bound:g})")
    turning = np.array([("left" in i) != ("right" in i) for i in intents])
    if turning.any():
        control = checks.array(steered.get("control"), "steered['control']", (len(positions), 3))
        edges = np.flatnonzero(np.diff(np.concatenate([[0], turning.astype(int), [0]])))
        begin, end = edges[-2], edges[-1]
        asked = float(control[begin:end, 2].sum() / fps)
        from .representation import facing_angles
        heading = np.unwrap(facing_angles(positions, fps))
        until = min(len(positions) - 1, end + int(round(FOLLOWS_KEYS["turn lag (s)"] * fps)))
        share = float((heading[until] - heading[begin]) / asked) if abs(asked) > 1e-6 else 0.0
        verdict.figures["turn held: heading turned / asked"] = share
        verdict.require(share >= FOLLOWS_KEYS["turn"], f"a turn held for {(end - begin) / fps:.1f} s turned the body "
                                                       f"{100 * share:.0f} % of the angle asked "
                                                       f"(need >= {100 * FOLLOWS_KEYS['turn']:.0f} %, the same way)")
    return verdict


def keeps_moving(samples: np.ndarray, data: np.ndarray, fps: float, name: str = "long samples") -> Verdict:
    """Long samples do not freeze into a static pose (MoGlow §5.3): in every
    ``KEEPS_MOVING["chunk (s)"]`` seconds their pose spread (:func:`motionlab.metrics.pose_spread`,
    averaged over the samples) is at least 70 % of the data's in the same seconds
    (:data:`KEEPS_MOVING`).

    Args:
        samples: features ``(n, frames, 66)`` generated along one long path (data units).
        data: features ``(m, frames, 66)``: the data on the same path, the same frames.
        fps: frames per second.
    """
    fps = checks.rate(fps, "fps")
    samples, data = _features(samples, "samples"), _features(data, "data")
    if samples.shape[-2] != data.shape[-2]:
        raise ValueError(f"samples, data: expected the same number of frames, got {samples.shape[-2]} "
                         f"and {data.shape[-2]}")
    chunk = int(round(KEEPS_MOVING["chunk (s)"] * fps))
    chunks = samples.shape[-2] // chunk
    if chunks < 2:
        raise ValueError(f"samples: need at least two chunks of {KEEPS_MOVING['chunk (s)']:g} s "
                         f"({2 * chunk} frames), got {samples.shape[-2]}")

    def spread(x):                                                    # (chunks,), metres
        x = x.reshape((-1,) + x.shape[-2:])[:, :chunks * chunk].reshape(-1, chunks, chunk, x.shape[-1])
        return metrics.pose_spread(x).mean(0)

    ratios = spread(samples) / np.maximum(spread(data), 1e-9)
    verdict = Verdict(f"{name} keep moving")
    for k, r in enumerate(ratios):
        start = k * KEEPS_MOVING["chunk (s)"]
        verdict.figures[f"{start:g}-{start + KEEPS_MOVING['chunk (s)']:g} s: pose spread / the data's"] = float(r)
    low = ratios < KEEPS_MOVING["spread"]
    verdict.require(not low.any(), f"pose spread under {100 * KEEPS_MOVING['spread']:.0f} % of the data's in chunks "
                                   f"{(np.flatnonzero(low) + 1).tolist()} (ratios {np.round(ratios, 2).tolist()})")
    return verdict


# ----------------------------------------------------------------------------------------
# Chen 2020 (DFN): futures that diversify like the data, at the data's pace
# ----------------------------------------------------------------------------------------

def diverse_futures(samples: np.ndarray, data: np.ndarray, fps: float, prefix_frames: int,
                    name: str = "DFN") -> Verdict:
    """Samples from a prefix spread out to the data's variety and keep its pace (Chen et al.
    2020 §6.3, Fig. 9, with the bounds of :data:`DIVERSE_FUTURES`).

    A constant pose, the mean pose, copies of one motion and steps that fade fail the growth
    or the pose speed; a model that only runs, or only walks, fails the pace.

    Args:
        samples: features ``(n >= 2, frames, 66)`` from one prefix, or ``(prefixes, n,
            frames, 66)`` from several; frame 0 = the prefix's first frame, at least 30 s
            (data units). The growth, the band and the pose speed must hold for every prefix;
            the share of fast frames is taken over all samples (what one prefix leads to is
            the model's choice; in the long run it should run as often as the data does).
        data: training windows ``(m, frames >= 2, 66)``: their band
            (:func:`motionlab.metrics.data_band`), share of fast frames and pose speed are
            the yardsticks.
        fps: frames per second.
        prefix_frames: how many of the first frames are the given prefix (a real body, not
            generated): bone drift is measured on the frames after it.
    """
    fps = checks.rate(fps, "fps")
    samples, data = _features(samples, "samples"), _features(data, "data")
    prefix_frames = checks.whole(prefix_frames, "prefix_frames", 0)
    bound = DIVERSE_FUTURES
    if samples.ndim == 3:
        samples = samples[None]
    if samples.ndim != 4 or samples.shape[1] < 2:
        raise ValueError(f"samples: expected (n >= 2, frames, 66) from one prefix or (prefixes, n >= 2, frames, 66), "
                         f"got {samples.shape}")
    if samples.shape[2] < round(bound["late (s)"][1] * fps):
        raise ValueError(f"samples: need {bound['late (s)'][1]:g} s ({round(bound['late (s)'][1] * fps)} frames), "
                         f"got {samples.shape[2]}")
    if data.ndim != 3 or data.shape[1] < 2:
        raise ValueError(f"data: expected windows (m, frames >= 2, 66), got {data.shape}")

    def seconds(values, first, last):
        return float(values[int(round(first * fps)):int(round(last * fps))].mean())

    band_mean, band_std = metrics.data_band(data.reshape(-1, N_FEATURES)[:, :63])
    last = int(round(bound["speed window (s)"] * fps))
    early, late, speed = [], [], []                                  # one of each per prefix
    for one_prefix in samples:
        distance, _ = metrics.mean_distance_over_time(one_prefix[..., :63])
        early.append(seconds(distance, *bound["early (s)"]))
        late.append(seconds(distance, *bound["late (s)"]))
        speed.append(float(metrics.frame_speed(one_prefix[:, -last:, :63], fps).mean()))
    early, late, speed = np.array(early), np.array(late), np.array(speed)
    pace = int(round(bound["pace window (s)"] * fps))
    fast = float((samples[..., -pace:, 63] > bound["fast (m/s)"]).mean())
    fast_data = float((data[..., 63] > bound["fast (m/s)"]).mean())
    speed_data = float(metrics.frame_speed(data[..., :63], fps).mean())
    generated = samples[:, :, prefix_frames:].reshape(-1, samples.shape[2] - prefix_frames, N_FEATURES)
    drift = metrics.bone_length_drift(to_positions(generated, fps))
    verdict = Verdict(f"{name}'s futures diversify like the data")
    verdict.figures.update({"early distance to the mean pose (m), lowest": float(early.min()),
                            "late distance to the mean pose (m), lowest": float(late.min()),
                            "late distance to the mean pose (m), highest": float(late.max()),
                            "data band, mean (m)": band_mean, "data band, std (m)": band_std,
                            "share fast, late": fast, "share fast, data": fast_data,
                            "pose speed at the end (m/s), lowest": float(speed.min()),
                            "pose speed, data (m/s)": speed_data, "bone drift": drift})
    flat = np.flatnonzero(late <= bound["growth"] * early)
    verdict.require(not len(flat), f"the samples of prefixes {(flat + 1).tolist()} do not spread out: "
                                   f"{np.round(late[flat], 2).tolist()} m late against {np.round(early[flat], 2).tolist()} "
                                   f"m early (need {bound['growth']:g}x)")
    out = np.flatnonzero(np.abs(late - band_mean) >= band_std)
    verdict.require(not len(out), f"late distance {np.round(late[out], 2).tolist()} m (prefixes {(out + 1).tolist()}) "
                                  f"is outside the data's band {band_mean:.2f} ± {band_std:.2f} m")
    verdict.require(abs(fast - fast_data) <= bound["fast share"] * fast_data,
                    f"{100 * fast:.0f} % of late frames faster than {bound['fast (m/s)']:g} m/s against the data's "
                    f"{100 * fast_data:.0f} % (need within ±{100 * bound['fast share']:.0f} % of it)")
    frozen = np.flatnonzero(speed < bound["pose speed"] * speed_data)
    verdict.require(not len(frozen), f"the pose changes at {np.round(speed[frozen], 2).tolist()} m/s at the end "
                                     f"(prefixes {(frozen + 1).tolist()}) against the data's {speed_data:.2f} (freezing)")
    verdict.require(drift <= bound["bone drift"], f"bones stretch {100 * drift:.2f} % (need <= "
                                                  f"{100 * bound['bone drift']:g} %)")
    return verdict
