"""The papers' findings as measurements: small functions the notebooks and benchmarks call,
written against the one ``generate`` contract (:mod:`motionlab.models.base`) so that they
work for any model that follows a control path from a prefix.
"""
from __future__ import annotations

import numpy as np

from . import checks, metrics, synthetic
from .representation import POSE, to_features, to_positions


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


# ----------------------------------------------------------------------------------------
# Held-out data, trivial baselines and steering: what benchmarks/quality.py and the
# notebooks measure every model against
# ----------------------------------------------------------------------------------------

HELD_OUT_SEED = 10_000
"""Seed of the built-in clips no shipped model is trained on: every checkpoint trains on
clips seeded 0, 1, 2, ... (``data.load("synthetic", n_clips=N)``, N < 10,000)."""


def held_out_windows(window_frames: int, fps: float = 20.0, n_clips: int = 12, seed: int = HELD_OUT_SEED):
    """Windows of built-in clips that no shipped model saw: features ``(windows,
    window_frames, 66)`` in the data's units, cut every half window from ``n_clips`` clips
    of 12 s."""
    from . import data
    clips = data.load("synthetic", fps=fps, n_clips=n_clips, seed=seed)
    half = max(1, window_frames // 2)
    return np.concatenate([data.cut_windows(c.features(), window_frames, half) for c in clips])


def trivial_reconstructions(windows: np.ndarray, mean_features: np.ndarray) -> dict[str, np.ndarray]:
    """What an autoencoder must beat, for windows ``(n, frames, 66)`` in data units:

    * ``"mean pose"``: the training data's mean features (``mean_features``, ``(66,)``)
      in every frame: the average pose, moving at the average speed;
    * ``"window average"``: each window's own average frame, held for the whole window;
    * ``"constant velocity"``: each window's first frame, moved on with its first frame's
      velocity (features extrapolated linearly from frames 0 and 1).
    """
    windows = np.asarray(windows, dtype=np.float64)
    frames = windows.shape[-2]
    step = windows[..., 1:2, :] - windows[..., :1, :]
    return {"mean pose": np.broadcast_to(mean_features, windows.shape).copy(),
            "window average": np.repeat(windows.mean(axis=-2, keepdims=True), frames, axis=-2),
            "constant velocity": windows[..., :1, :] + np.arange(frames)[:, None] * step}


def mean_pose_on_path(windows: np.ndarray, mean_features: np.ndarray) -> np.ndarray:
    """The trivial model that knows the control: the data's mean pose (``mean_features[:63]``)
    in every frame, moved along each window's true path (its own control kept)."""
    out = np.array(windows, dtype=np.float64)
    out[..., POSE] = np.asarray(mean_features)[POSE]
    return out


def constant_pose(windows: np.ndarray) -> np.ndarray:
    """The trivial model that stands: each window's first pose in every frame, not moving."""
    out = np.repeat(np.array(windows, dtype=np.float64)[..., :1, :], np.shape(windows)[-2], axis=-2)
    out[..., POSE.stop:] = 0.0
    return out


RAMP_S = 1.0
"""Steering paths start from standing and reach their speed over this many seconds, for
the data and for the models alike (:func:`motionlab.synthetic.preset_control`)."""


def _preset(name: str, seconds: float, fps: float) -> np.ndarray:
    # one frame more than the seconds, so the last second has all its frame-to-frame steps
    return synthetic.preset_control(name, seconds + 1.0 / fps, fps, ramp_s=RAMP_S)


def walked_preset(name: str, seconds: float, fps: float) -> np.ndarray:
    """The control ``(seconds * fps + 1, 3)`` of a drawn preset path
    (:data:`motionlab.synthetic.PRESETS`, from standing, reached over :data:`RAMP_S`) as the synthetic walker follows
    it: what the course steers models with."""
    return synthetic.walked_control(_preset(name, seconds, fps), fps)


def preset_walks(name: str, seconds: float, fps: float, n: int = 4, lead_frames: int = 0) -> np.ndarray:
    """``n`` built-in bodies (held-out seeds) following the preset path ``name``: features
    ``(n, lead_frames + seconds * fps + 1, 66)`` in data units. The path starts from
    standing (:data:`RAMP_S`); ``lead_frames`` frames of standing come first, the prefix
    a model that continues motion is given (:func:`steer`)."""
    return walks(_preset(name, seconds, fps), fps, n, lead_frames)


def walks(control: np.ndarray, fps: float, n: int = 4, lead_frames: int = 0) -> np.ndarray:
    """``n`` built-in bodies (held-out seeds) following the drawn path ``control``
    ``(frames, 3)`` (m/s, rad/s), after ``lead_frames`` frames of its first control:
    features ``(n, lead_frames + frames, 66)`` in data units."""
    rng = np.random.default_rng(HELD_OUT_SEED)
    control = np.concatenate([np.repeat(control[:1], lead_frames, axis=0), control])
    return np.stack([to_features(synthetic.generate(control, fps, synthetic.Body.random(rng),
                                                    synthetic.Style.random(rng)).positions, fps)
                     for _ in range(n)])


MAX_CLIPS_S = 3 * 3600.0
"""The most built-in motion :func:`own_futures` generates, seconds (about 100 MB of features at 20 fps)."""


def own_futures(speed_ms: tuple[float, float], prefix_frames: int, seconds: float, fps: float, clips: int = 40,
                clip_s: float = 40.0, spacing_s: float = 5.0) -> tuple[np.ndarray, np.ndarray]:
    """Held-out random built-in clips (:func:`motionlab.synthetic.random_motion`, seeds from
    :data:`HELD_OUT_SEED`, ``clips`` of ``clip_s`` seconds), cut where the body moved forward
    at ``speed_ms`` ``(low, high)`` m/s through ``prefix_frames`` frames, and what each clip
    did next: ``(prefixes (m, prefix_frames, 66), futures (m, seconds * fps + 1, 66))``, data
    units, cuts at least ``spacing_s`` apart within a clip.

    The futures are the reference a model of these clips continues towards: their activity
    changes every 1.5-4 s (:func:`motionlab.synthetic.random_control`), so from a run the
    data's own future slows down, where a body kept on the run path does not."""
    low, high = checks.array(speed_ms, "speed_ms", (2,))
    if not low < high:
        raise ValueError(f"speed_ms: expected (low, high) m/s with low < high, got {speed_ms!r}")
    prefix_frames, clips = checks.whole(prefix_frames, "prefix_frames"), checks.whole(clips, "clips")
    fps, seconds = checks.rate(fps), checks.seconds(seconds, "seconds")
    spacing_s = checks.seconds(spacing_s, "spacing_s")
    if not seconds < checks.seconds(clip_s, "clip_s") or clips * clip_s > MAX_CLIPS_S:
        raise ValueError(f"clip_s: expected longer than seconds ({seconds:g}) and clips x clip_s at most "
                         f"{MAX_CLIPS_S:g} s, got {clip_s:g} s x {clips}")
    ahead = int(round(seconds * fps)) + 1
    prefixes, futures = [], []
    for i in range(clips):
        features = to_features(synthetic.random_motion(clip_s, fps, HELD_OUT_SEED + i).positions, fps)
        forward = features[:, POSE.stop]
        t = prefix_frames
        while t + ahead <= len(features):
            window = forward[t - prefix_frames:t]
            if low <= window.min() and window.max() <= high:
                prefixes.append(features[t - prefix_frames:t])
                futures.append(features[t:t + ahead])
                t += int(round(spacing_s * fps))
            else:
                t += 1
    if not prefixes:
        raise ValueError(f"speed_ms: no {prefix_frames}-frame stretch of {clips} clips moves at {low:g}-{high:g} m/s")
    return np.stack(prefixes), np.stack(futures)


def data_stepping(name: str, seconds: float, fps: float, n: int = 4) -> tuple[np.ndarray, float]:
    """The data on the preset path ``name``: ``n`` built-in bodies (held-out seeds) follow it
    for ``seconds``. Returns their stepping speed second by second (m/s, ``(seconds,)``,
    :func:`motionlab.metrics.stepping_by_second` averaged over the bodies) and their leg
    swing (m, :func:`motionlab.metrics.leg_swing`)."""
    walks = preset_walks(name, seconds, fps, n)
    return metrics.stepping_by_second(walks, fps).mean(0), metrics.leg_swing(walks)


def steer(model, name: str, seconds: float, n: int = 4, temperature: float = 0.3,
          seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A model that continues motion (MoGlow, DFN) steered along the preset path ``name``
    for ``seconds``, beside the data on the same path.

    ``n`` held-out bodies stand for the model's ``τ`` history frames
    (``model.config.history``) and then follow the path (:func:`preset_walks`); the model
    is given their standing frames as its prefix and the path's control (as the first body
    walked it), and generates ``n`` samples. Returns ``(samples, data)``, both features
    ``(n, seconds * fps + 1, 66)`` in data units, frame 0 = the first frame after the
    prefix."""
    tau = model.config.history
    walks = preset_walks(name, seconds, model.fps, n, lead_frames=tau)
    control = walks[0, tau:, POSE.stop:]
    samples = model.generate(control, prefix=walks[:, :tau], n=n, temperature=temperature, seed=seed).features
    return samples, walks[:, tau:]


def steering_report(model, name: str, seconds: float = 10.0, n: int = 4, temperature: float = 0.3,
                    seed: int = 0) -> dict:
    """How a model steered along the preset path ``name`` moves, beside the data on the
    same path (:func:`steer`; ``n`` samples and ``n`` held-out bodies, ``seconds`` long).

    Returns a dict: ``"samples"``, ``"data"`` (features ``(n, frames, 66)``, data units),
    ``"control"`` (the control the model was given, ``(frames, 3)``),
    ``"stepping"``, ``"data stepping"`` (m/s, second by second, ``(seconds,)``, averaged
    over the bodies; :func:`motionlab.metrics.stepping_by_second`), and ``"model"``,
    ``"data report"``: :func:`motionlab.metrics.locomotion_report` of each, the feet's
    planted heights measured on the data.
    """
    samples, walks = steer(model, name, seconds, n, temperature, seed)
    fps = model.fps
    rest = metrics.foot_rest_heights(to_positions(walks, fps))
    return {"samples": samples, "data": walks, "control": walks[0, :, POSE.stop:],
            "stepping": metrics.stepping_by_second(samples, fps).mean(0),
            "data stepping": metrics.stepping_by_second(walks, fps).mean(0),
            "model": metrics.locomotion_report(samples, fps, rest),
            "data report": metrics.locomotion_report(walks, fps, rest)}


def temperature_sweep(model, windows: np.ndarray, temperatures=(0.0, 0.25, 0.5, 0.75, 1.0), seed: int = 0) -> dict:
    """Glow's trade-off (MoGlow paper §3, Kingma & Dhariwal's temperature): one sample per
    window of ``windows`` ``(n, frames, 66)`` (data units), given that window's control, at
    each temperature, judged by :func:`motionlab.claims.moves_like_data` against the windows
    themselves. Returns ``{temperature: Verdict}``; each verdict's figures hold stepping, leg
    swing, ankle height, skating and bone drift, the samples' and the data's."""
    from . import claims
    windows = np.asarray(windows, dtype=np.float64)
    control = windows[..., POSE.stop:]
    return {float(t): claims.moves_like_data(model.generate(control, n=len(windows), temperature=t, seed=seed).features,
                                             windows, model.fps) for t in temperatures}


def finished_feet(model, windows: np.ndarray, temperature: float, seed: int = 0) -> dict[str, float]:
    """Feet raw and finished: one sample per window of ``windows`` ``(n, frames, 66)`` (data
    units), given that window's control (as :func:`temperature_sweep` draws them), made into a
    character by :func:`motionlab.contacts.finish` (bones fitted, feet locked, the windows'
    planted heights; a contact head's drawn contacts held as well as the detected ones).
    Returns the foot skating (:func:`metrics.foot_skating`, cm/s) of the ``"data"``, the
    ``"raw"`` samples and the ``"finished"`` ones, and the share of contacts the lock let go
    for reach (``"out of reach"``)."""
    from . import contacts
    windows = np.asarray(windows, dtype=np.float64)
    fps = model.fps
    data_positions = to_positions(windows, fps)
    floor = metrics.foot_rest_heights(data_positions)
    generated = model.generate(windows[..., POSE.stop:], n=len(windows), temperature=temperature, seed=seed)
    samples = generated.features
    done = contacts.finish(samples, fps, planted_height_m=floor, drawn=generated.contacts)
    skating = {name: 100 * metrics.foot_skating(p, fps, rest_height_m=floor)
               for name, p in (("data", data_positions), ("raw", to_positions(samples, fps)), ("finished", done.positions))}
    return {**skating, "out of reach": done.lock.out_of_reach}
