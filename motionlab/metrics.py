"""Measures of motion quality, shared by every notebook and benchmark.

All take numpy arrays of joint positions in metres, ``(frames, joints, 3)`` (or with
leading batch dimensions where stated), y up, floor at y = 0, and return metres or
metres per second. Multiply by 100 for the centimetres the papers report.
"""
from __future__ import annotations

import numpy as np

from . import checks
from .filters import gaussian_smooth
from .representation import N_FEATURES, N_POSE, POSE, to_positions
from .skeleton import FEET, LOCOMOTION, Skeleton


def _same_shape(a: np.ndarray, b: np.ndarray, names: str, shape_text: str) -> None:
    if a.shape != b.shape:
        raise ValueError(f"{names}: expected two {shape_text} arrays of one shape, got {a.shape} and {b.shape}")


def _joint_indices(joints, n_joints: int, name: str = "joints") -> list[int]:
    """``joints`` as a non-empty list of joint indices, each from 0 to ``n_joints - 1``."""
    if not np.iterable(joints) or isinstance(joints, str) or len(joints) == 0:
        raise ValueError(f"{name}: expected a list of joint indices, got {joints!r}")
    indices = [checks.whole(j, name, minimum=0) for j in joints]
    if max(indices) >= n_joints:
        raise ValueError(f"{name}: joint index {max(indices)} out of range (0..{n_joints - 1})")
    return indices


def _features(value, name: str) -> np.ndarray:
    """Features ``(..., 66)`` or just the pose ``(..., 63)``, any dtype, checked."""
    last = N_POSE if np.shape(value)[-1:] == (N_POSE,) else N_FEATURES
    return checks.array(value, name, (..., last), dtype=None)


def pose_error(pred_features: np.ndarray, true_features: np.ndarray,
               joints: list[int] | None = None) -> float:
    """Mean per-joint position error in the root frame (Habibie's *pose error*), metres.

    Takes features ``(..., frames, 66)`` (or just the 63 pose values): the translation and
    rotation of the character are ignored, only the body pose counts. ``joints``: average
    over these joint indices only (default: all).
    """
    p = _features(pred_features, "pred_features")[..., POSE]
    t = _features(true_features, "true_features")[..., POSE]
    _same_shape(p, t, "pred_features, true_features", f"(..., {N_POSE} or {N_FEATURES})")
    shape = p.shape[:-1] + (N_POSE // 3, 3)
    distances = np.linalg.norm(p.reshape(shape) - t.reshape(shape), axis=-1)
    return float((distances if joints is None else distances[..., _joint_indices(joints, N_POSE // 3)]).mean())


def motion_error(pred_positions: np.ndarray, true_positions: np.ndarray) -> float:
    """Mean per-joint position error in the world (Habibie's *motion error*), metres.

    Takes world positions ``(..., frames, joints, 3)``: drift of the trajectory counts.
    """
    p = checks.array(pred_positions, "pred_positions", (..., "joints", 3))
    t = checks.array(true_positions, "true_positions", (..., "joints", 3))
    _same_shape(p, t, "pred_positions, true_positions", "(..., joints, 3)")
    return float(np.linalg.norm(p - t, axis=-1).mean())


def window_errors(pred_features: np.ndarray, true_features: np.ndarray, fps: float) -> dict[str, float]:
    """Pose and motion error (metres) of windows of features ``(windows, frames, 66)``.

    Both are turned into world positions from the same start (the origin, facing +z), so
    the *motion error* also counts the drift that errors in the control cause.
    """
    pred = checks.array(pred_features, "pred_features", ("windows", "frames", N_FEATURES), dtype=None)
    true = checks.array(true_features, "true_features", ("windows", "frames", N_FEATURES), dtype=None)
    _same_shape(pred, true, "pred_features, true_features", f"(windows, frames, {N_FEATURES})")
    fps = checks.rate(fps, "fps")
    pred_world = np.stack([to_positions(w, fps) for w in pred])
    true_world = np.stack([to_positions(w, fps) for w in true])
    return {"pose error (m)": pose_error(pred, true), "motion error (m)": motion_error(pred_world, true_world)}


def control_drift(pred_features: np.ndarray, true_features: np.ndarray, fps: float) -> dict[str, float]:
    """The part of the motion error each control channel causes, metres: for forward,
    sideways and turning velocity in turn, the motion error of ``true_features`` with only
    that channel taken from ``pred_features`` (the pose and the other two channels kept
    true), so that all of it is the drift of the path that one channel's errors integrate
    to. Windows ``(windows, frames, 66)`` in the data's units, as :func:`window_errors`.
    Returns ``{"forward": m, "sideways": m, "turning": m}``."""
    pred = checks.array(pred_features, "pred_features", ("windows", "frames", N_FEATURES), dtype=None)
    true = checks.array(true_features, "true_features", ("windows", "frames", N_FEATURES), dtype=None)
    _same_shape(pred, true, "pred_features, true_features", f"(windows, frames, {N_FEATURES})")
    fps = checks.rate(fps, "fps")
    true_world = np.stack([to_positions(w, fps) for w in true])
    drift = {}
    for k, name in enumerate(("forward", "sideways", "turning")):
        mixed = np.array(true, dtype=np.float64)
        mixed[..., N_POSE + k] = pred[..., N_POSE + k]
        drift[name] = motion_error(np.stack([to_positions(w, fps) for w in mixed]), true_world)
    return drift


FOOT_PERCENTILE = 5.0
"""The percentile of a foot joint's height taken as its height when planted (see
:func:`foot_rest_heights`): low enough to be a frame on the floor, high enough that one
noisy frame does not set it."""


def foot_rest_heights(positions: np.ndarray, feet: tuple[int, ...] = FEET) -> np.ndarray:
    """How high each foot joint sits when the foot is planted, metres: ``(len(feet),)``.

    Joint centres are not on the floor: a planted ankle sits about 8 cm up, a planted toe
    3-4 cm (the bones end in the joint, the shoe sole is below it). This is each joint's
    :data:`FOOT_PERCENTILE`-th percentile height over all frames of ``positions``
    ``(..., frames, joints, 3)``: measure it on the *data* and pass it to
    :func:`foot_skating` for samples, so that a model whose feet hover is not credited
    with a floor of its own.
    """
    positions = checks.array(positions, "positions", (..., "frames", "joints", 3))
    feet = _joint_indices(feet, positions.shape[-2], "feet")
    heights = positions[..., feet, 1].reshape(-1, len(feet))
    return np.percentile(heights, FOOT_PERCENTILE, axis=0)


def foot_contact_weights(positions: np.ndarray, feet: tuple[int, ...] = FEET, rest_height_m=None,
                         contact_height_m: float | tuple[float, ...] = 0.025) -> np.ndarray:
    """How much each foot joint is on the floor between consecutive frames, 0 to 1:
    ``(..., frames - 1, len(feet))``. ``w = clip(2 - 2**(h / H), 0, 1)``, where ``h`` is how
    far the joint is above its planted height (mean of frames ``t`` and ``t + 1``, minus
    ``rest_height_m``) and ``H`` the contact height: planted (``h = 0``) gives 1, ``H`` or
    more above it 0. See :func:`foot_skating` for the arguments."""
    positions = checks.array(positions, "positions", (..., "frames", "joints", 3))
    if positions.shape[-3] < 2:
        raise ValueError(f"positions: expected (..., frames >= 2, joints, 3), got {positions.shape}")
    feet = _joint_indices(feet, positions.shape[-2], "feet")
    H = checks.array(contact_height_m, "contact_height_m")
    if H.ndim > 1 or H.size not in (1, len(feet)) or not (H > 0).all():
        raise ValueError(f"contact_height_m: expected one height > 0 (m) or one per foot joint ({len(feet)}), "
                         f"got {contact_height_m!r}")
    if rest_height_m is None:
        rest = foot_rest_heights(positions, feet)
    else:
        rest = checks.array(rest_height_m, "rest_height_m")
        if rest.ndim > 1 or rest.size not in (1, len(feet)):
            raise ValueError(f"rest_height_m: expected one height (m) or one per foot joint ({len(feet)}), "
                             f"got {rest_height_m!r}")
    heights = positions[..., feet, 1]
    above = 0.5 * (heights[..., 1:, :] + heights[..., :-1, :]) - np.broadcast_to(rest, (len(feet),))
    return np.clip(2 - 2 ** (np.maximum(above, 0) / np.broadcast_to(H, (len(feet),))), 0, 1)


def foot_skating(positions: np.ndarray, fps: float, feet: tuple[int, ...] = FEET,
                 rest_height_m=None, contact_height_m: float | tuple[float, ...] = 0.025) -> float:
    """How much the feet slide while on the floor, m/s (lower is better).

    The measure of Zhang et al. (MANN, 2018), per foot joint: its horizontal speed
    ``v_t = |p_xz(t+1) - p_xz(t)| * fps`` weighted by how much it is on the floor
    (:func:`foot_contact_weights`: 1 at its planted height, 0 from ``H`` above it). The
    result is the mean of ``w * v`` over frames and foot joints.

    A sample that never puts its feet down scores low here without being good: report
    skating beside :func:`leg_swing` and the ankles' height (:func:`locomotion_report`).

    Args:
        positions: ``(..., frames, joints, 3)``, metres.
        fps: frames per second.
        feet: joint indices of the foot joints (default: both ankles and toes).
        rest_height_m: each foot joint's planted height, ``(len(feet),)`` or one value, m;
            default: :func:`foot_rest_heights` of ``positions`` itself (right for real
            data; for a model's samples pass the data's).
        contact_height_m: ``H``, one value or one per foot joint, m. 2.5 cm: a joint 1 cm
            above its planted height counts 68 %, 2 cm up 26 %; real capture's planted
            ankles and toes wobble by a centimetre or two (foot roll, marker noise), while a
            swinging foot is well clear of the floor within a frame or two.
    """
    weight = foot_contact_weights(positions, feet, rest_height_m, contact_height_m)
    fps = checks.rate(fps, "fps")
    feet_xz = np.asarray(positions)[..., _joint_indices(feet, np.shape(positions)[-2], "feet"), :][..., [0, 2]]
    speed = np.linalg.norm(np.diff(feet_xz, axis=-3), axis=-1) * fps
    return float((weight * speed).mean())


GMD_HEIGHT_M, GMD_SPEED_MS, GMD_WINDOW_S = 0.05, 0.5, 0.25
"""The thresholds of the foot-skating ratio of GMD (Karunratanakul et al. 2023), used since
by MDM-family papers on HumanML3D (20 fps): a toe within 5 cm of the floor in two
consecutive frames, moving faster than 0.5 m/s in that frame and on average over 5 frames."""


def skating_ratio(positions: np.ndarray, fps: float, rest_height_m=None) -> float:
    """The GMD foot-skating ratio: the share of frames in which either toe skates, 0 to 1.

    A toe skates in a frame when it is within :data:`GMD_HEIGHT_M` of the floor in that
    frame and the next, and its horizontal speed is above :data:`GMD_SPEED_MS` both in the
    frame and on average over :data:`GMD_WINDOW_S` (5 frames at 20 fps, centred). HumanML3D's
    floor is each clip's lowest foot joint, so the height here is above each toe's planted
    height (``rest_height_m``, the toes' entries of :func:`foot_rest_heights`: pass the
    data's; default the motion's own). Real HumanML3D motion scores 0.000 and MDM 0.094 in
    GMD's table: the figure places a model among the field's, next to :func:`foot_skating`.
    Takes ``(..., frames, joints, 3)``; the mean over clips.
    """
    positions = checks.array(positions, "positions", (..., "frames", "joints", 3))
    fps = checks.rate(fps, "fps")
    if positions.shape[-3] < 2:
        raise ValueError(f"positions: expected (..., frames >= 2, joints, 3), got {positions.shape}")
    toes = [FEET[1], FEET[3]]
    if rest_height_m is None:
        rest = foot_rest_heights(positions, tuple(toes))
    else:                                        # one height, one per toe, or one per foot joint
        rest = checks.array(rest_height_m, "rest_height_m").ravel()
        rest = rest[[1, 3]] if rest.size == len(FEET) else np.broadcast_to(rest, (2,))
    feet = positions[..., toes, :]
    low = feet[..., 1] - rest < GMD_HEIGHT_M
    low = low[..., 1:, :] & low[..., :-1, :]
    speed = np.linalg.norm(np.diff(feet[..., [0, 2]], axis=-3), axis=-1) * fps          # (..., frames-1, 2)
    width = max(1, int(round(GMD_WINDOW_S * fps)))
    kernel = np.ones(width) / width
    average = np.apply_along_axis(lambda v: np.convolve(v, kernel, mode="same"), -2, speed)
    skating = low & (speed > GMD_SPEED_MS) & (average > GMD_SPEED_MS)
    return float(skating.any(-1).mean())


def foot_acceleration(positions: np.ndarray, fps: float, percentile: float = 99.0) -> float:
    """The ``percentile``-th percentile of the ankles' and toes' acceleration, m/s², over
    all frames of ``positions`` ``(..., frames, joints, 3)`` (second differences). A foot
    that pops (a lock that lets go at once, a jittery sample) shows here first."""
    positions = checks.array(positions, "positions", (..., "frames", "joints", 3))
    fps = checks.rate(fps, "fps")
    if positions.shape[-3] < 3:
        raise ValueError(f"positions: expected (..., frames >= 3, joints, 3), got {positions.shape}")
    if not 0 <= percentile <= 100:
        raise ValueError(f"percentile: expected 0 to 100, got {percentile!r}")
    feet = positions[..., _joint_indices(FEET, positions.shape[-2], "feet"), :]
    return float(np.percentile(np.linalg.norm(np.diff(feet, 2, axis=-3), axis=-1) * fps * fps, percentile))


def bone_length(positions: np.ndarray, joint: str, skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """The length of the bone that ends in ``joint`` (``"RightFoot"``: the right shin, knee to
    ankle) in every frame of ``positions`` ``(..., frames, joints, 3)``: ``(..., frames)``, metres."""
    if joint not in skeleton.names or skeleton.index(joint) == 0:
        raise ValueError(f"joint: expected a joint with a parent, one of {', '.join(skeleton.names[1:])}; "
                         f"got {joint!r}")
    positions = checks.array(positions, "positions", (..., "frames", skeleton.n_joints, 3))
    bone = [child for _, child in skeleton.bones].index(skeleton.index(joint))
    return skeleton.bone_lengths(positions)[..., bone]


def bone_length_drift(positions: np.ndarray, skeleton: Skeleton = LOCOMOTION) -> float:
    """How much bone lengths change over time: mean over bones of ``std / mean`` length.

    A rigid skeleton gives 0; ``0.01`` means bones stretch by about 1 % on average.
    Takes ``(frames, joints, 3)``, or ``(clips, frames, joints, 3)`` (averaged over clips).
    """
    positions = checks.array(positions, "positions", (..., "frames", skeleton.n_joints, 3))
    if positions.ndim == 3:
        positions = positions[None]
    if positions.ndim != 4:
        raise ValueError(f"positions: expected (frames, {skeleton.n_joints}, 3) or (clips, frames, "
                         f"{skeleton.n_joints}, 3), got {positions.shape}")
    lengths = skeleton.bone_lengths(positions)                 # (clips, frames, bones)
    return float((lengths.std(axis=1) / lengths.mean(axis=1)).mean())


def diversity(samples: np.ndarray) -> np.ndarray:
    """Diversity over time (Chen et al. 2020, §6.3), metres per frame, ``(frames,)``.

    For ``samples`` ``(n_samples, frames, joints, 3)`` drawn from one starting point, the
    mean over samples and joints of each joint's distance to the samples' mean pose at
    that frame. Zero where all samples agree; it grows as they spread apart.
    """
    samples = checks.array(samples, "samples", ("n_samples", "frames", "joints", 3))
    if samples.shape[0] < 2:
        raise ValueError(f"samples: expected (n_samples >= 2, frames, joints, 3), got {samples.shape}")
    mean = samples.mean(axis=0, keepdims=True)
    return np.linalg.norm(samples - mean, axis=-1).mean(axis=(0, 2))


ANKLES = (LOCOMOTION.index("LeftFoot"), LOCOMOTION.index("RightFoot"))


def _pose_joints(features: np.ndarray, name: str = "features") -> np.ndarray:
    """The joints ``(..., frames, 21, 3)`` of features ``(..., frames, 66)`` or poses ``(..., frames, 63)``."""
    last = N_POSE if np.shape(features)[-1:] == (N_POSE,) else N_FEATURES
    features = checks.array(features, name, (..., "frames", last))
    return features[..., POSE].reshape(*features.shape[:-1], -1, 3)


def stepping_speed(features: np.ndarray, fps: float, joints: tuple[int, ...] = ANKLES,
                   smooth_s: float = 0.0) -> np.ndarray:
    """How fast the feet move *relative to the body*, m/s, per frame: ``(..., frames - 1)``.

    The horizontal speed of the ankles in the root frame (the pose features), averaged
    over both ankles. Walking in place or along a path gives about the walking speed;
    standing still, or gliding along a path without stepping, gives about 0. Takes
    features ``(..., frames, 66)`` (or just the 63 pose values) in the data's units.

    ``smooth_s``: smooth the ankle paths with a Gaussian of this many seconds first, so
    frame-to-frame jitter (which a sampled model adds) does not count as stepping; 0.1 s
    keeps 85 % of a walking stride's motion and removes most jitter.
    """
    ankles = _pose_joints(features)[..., _joint_indices(joints, N_POSE // 3), :][..., [0, 2]]
    if ankles.shape[-3] < 2:
        raise ValueError(f"features: need at least 2 frames, got {ankles.shape[-3]}")
    fps = checks.rate(fps, "fps")
    checks.non_negative(smooth_s, "smooth_s", checks.MAX_SECONDS)
    if smooth_s > 0:
        ankles = np.moveaxis(gaussian_smooth(np.moveaxis(ankles, -3, 0), smooth_s * fps), 0, -3)
    return np.linalg.norm(np.diff(ankles, axis=-3), axis=-1).mean(axis=-1) * fps


def pose_spread(features: np.ndarray) -> np.ndarray:
    """How much the pose changes over time, metres: the standard deviation over frames of
    every root-local joint coordinate, averaged over coordinates; ``(...)`` for features
    ``(..., frames, 66)``. A motion frozen in one pose gives 0 (MoGlow §5.3's "reverting
    to a static pose"); walking gives about 0.1 m."""
    joints = _pose_joints(features)
    return joints.std(axis=-3).mean(axis=(-1, -2))


def leg_swing(features: np.ndarray) -> float:
    """How far the legs swing, metres: the standard deviation over time of the left ankle's
    lead over the right along the facing direction, averaged over clips. Features
    ``(frames, 66)`` or ``(clips, frames, 66)``; a body that glides without stepping gives 0."""
    joints = _pose_joints(features)
    lead = joints[..., ANKLES[0], 2] - joints[..., ANKLES[1], 2]
    return float(lead.std(axis=-1).mean())


def stepping_by_second(features: np.ndarray, fps: float, smooth_s: float = 0.1) -> np.ndarray:
    """:func:`stepping_speed` (smoothed ``smooth_s``) averaged over each whole second, m/s:
    ``(..., seconds)`` for features ``(..., frames, 66)``. Steps that fade over a long
    sample show here as falling numbers, where one mean over the sample would hide them."""
    fps = checks.rate(fps, "fps")
    speed = stepping_speed(features, fps, smooth_s=smooth_s)
    per_second = int(round(fps))
    seconds = speed.shape[-1] // per_second
    if seconds < 1:
        raise ValueError(f"features: need at least one second ({per_second + 1} frames), got {speed.shape[-1] + 1}")
    return speed[..., :seconds * per_second].reshape(speed.shape[:-1] + (seconds, per_second)).mean(-1)


def locomotion_report(features: np.ndarray, fps: float, rest_height_m=None) -> dict[str, float]:
    """The numbers that say whether motion walks like people, for features ``(..., frames,
    66)`` in the data's units (each window integrated from its own start):

    * ``stepping (m/s)``: :func:`stepping_speed`, smoothed 0.1 s, mean;
    * ``leg swing (m)``: :func:`leg_swing`;
    * ``ankle height (m)``: the ankles' median height above their planted height;
    * ``foot skating (m/s)``: :func:`foot_skating`;
    * ``bone drift``: :func:`bone_length_drift` (a fraction: 0.01 = 1 %).

    Skating alone rewards feet that never touch the floor; read it beside the other four.
    ``rest_height_m``: the foot joints' planted heights (:func:`foot_rest_heights` of the
    data); default: measured on ``features`` themselves (right for real data only).
    """
    features = checks.array(features, "features", (..., "frames", N_FEATURES))
    fps = checks.rate(fps, "fps")
    positions = to_positions(features, fps)
    rest = foot_rest_heights(positions) if rest_height_m is None else np.broadcast_to(
        checks.array(rest_height_m, "rest_height_m"), (len(FEET),))
    ankles = [FEET.index(j) for j in ANKLES]
    return {"stepping (m/s)": float(stepping_speed(features, fps, smooth_s=0.1).mean()),
            "leg swing (m)": leg_swing(features.reshape((-1,) + features.shape[-2:])),
            "ankle height (m)": float(np.median(positions[..., ANKLES, 1] - rest[ankles])),
            "foot skating (m/s)": foot_skating(positions, fps, rest_height_m=rest),
            "bone drift": bone_length_drift(positions.reshape((-1,) + positions.shape[-3:]))}


def errors_by_frame(pred_features: np.ndarray, true_features: np.ndarray,
                    fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Pose error (root frame) and motion error (world) per frame, metres: two ``(frames,)``
    arrays for feature windows ``(windows, frames, 66)``, averaged over windows and joints.
    The motion error integrates each window's control from the same start, so it grows
    with the horizon where the control is wrong."""
    pred = checks.array(pred_features, "pred_features", ("windows", "frames", N_FEATURES))
    true = checks.array(true_features, "true_features", ("windows", "frames", N_FEATURES))
    _same_shape(pred, true, "pred_features, true_features", f"(windows, frames, {N_FEATURES})")
    fps = checks.rate(fps, "fps")
    pose = np.linalg.norm(_pose_joints(pred) - _pose_joints(true), axis=-1).mean(axis=(0, 2))
    motion = np.linalg.norm(to_positions(pred, fps) - to_positions(true, fps), axis=-1).mean(axis=(0, 2))
    return pose, motion


def describe_motion(features: np.ndarray) -> dict[str, np.ndarray]:
    """A few interpretable numbers per window of features ``(n, frames, 66)``, each ``(n,)``.

    * ``hand height (m)``: mean height of both hands above the floor;
    * ``arm swing (m)``: how far the hands swing forward and back (std of their z);
    * ``knee bend (deg)``: mean flexion of both knees (0 = straight leg);
    * ``leg swing (m)``: how far the feet move apart along the walking direction (std of
      left ankle z minus right ankle z: the stride);
    * ``forward speed (m/s)``, ``turning (rad/s)``: means of the control.
    """
    features = checks.array(features, "features", ("n", "frames", N_FEATURES))
    pose = features[..., POSE].reshape(features.shape[:2] + (N_POSE // 3, 3))
    j = LOCOMOTION.index
    hands = pose[..., [j("LeftHand"), j("RightHand")], :]

    def knee_bend(hip, knee, ankle):
        thigh, shin = pose[..., hip, :] - pose[..., knee, :], pose[..., ankle, :] - pose[..., knee, :]
        cos = (thigh * shin).sum(-1) / (np.linalg.norm(thigh, axis=-1) * np.linalg.norm(shin, axis=-1) + 1e-9)
        return 180.0 - np.degrees(np.arccos(np.clip(cos, -1, 1)))

    knees = 0.5 * (knee_bend(j("LeftUpLeg"), j("LeftLeg"), j("LeftFoot"))
                   + knee_bend(j("RightUpLeg"), j("RightLeg"), j("RightFoot")))
    stride = pose[..., j("LeftFoot"), 2] - pose[..., j("RightFoot"), 2]
    return {"hand height (m)": hands[..., 1].mean(axis=(1, 2)),
            "arm swing (m)": hands[..., 2].std(axis=1).mean(axis=1),
            "knee bend (deg)": knees.mean(axis=1),
            "leg swing (m)": stride.std(axis=1),
            "forward speed (m/s)": features[..., N_POSE].mean(axis=1),
            "turning (rad/s)": features[..., N_POSE + 2].mean(axis=1)}


CMU_REFERENCE = {"foot skating (cm/s)": 6.07, "bone-length drift (%)": 0.092}
"""Medians over the 55 real CMU clips of ``../shared/mocap/cmu`` at 20 fps, as printed by
``benchmarks/real_data.py`` (and checked against the files by the tests where they exist):
the ground truth that generated motion is compared with when no real data is at hand."""


def summarize(positions: np.ndarray, fps: float, skeleton: Skeleton = LOCOMOTION) -> dict[str, float]:
    """Foot skating (cm/s) and bone-length drift (%) of one clip ``(frames, joints, 3)``, for tables."""
    fps = checks.rate(fps, "fps")
    return {"foot skating (cm/s)": 100 * foot_skating(positions, fps),
            "bone-length drift (%)": 100 * bone_length_drift(positions, skeleton)}


# ----------------------------------------------------------------------------------------
# Diversity of samples over time (Chen et al. 2020, §6.3), for any model's samples
# ----------------------------------------------------------------------------------------

def _check_samples(samples: np.ndarray, name: str = "samples", min_samples: int = 2) -> np.ndarray:
    """``samples`` ``(n_samples, frames, ...)`` as float64 ``(n_samples, frames, values)``."""
    if np.ndim(samples) < 2 or np.shape(samples)[0] < min_samples:
        raise ValueError(f"{name}: expected (n_samples >= {min_samples}, frames >= 1, ...), "
                         f"got {np.shape(samples)}")
    samples = checks.array(samples, name)
    return samples.reshape(samples.shape[0], samples.shape[1], -1)


def _check_points(points: np.ndarray, name: str) -> np.ndarray:
    """``points`` ``(n >= 2, ...)`` as a float64 array, no NaN."""
    points = checks.array(points, name)
    if points.ndim < 1 or points.shape[0] < 2:
        raise ValueError(f"{name}: expected (n >= 2, ...), got {points.shape}")
    return points


def distances_to_mean(points: np.ndarray) -> np.ndarray:
    """Euclidean distance of each of ``points`` ``(n, ...)`` to their mean, ``(n,)``.

    Everything after the first axis is one vector (a pose ``(joints, 3)``, a feature
    vector, a latent state). The training data's *mean-distance distribution* of Chen et
    al. (§6.3, Fig. 9) is this over all training frames: pass ``(frames, ...)``.
    """
    points = _check_points(points, "points")
    flat = points.reshape(points.shape[0], -1)
    return np.linalg.norm(flat - flat.mean(axis=0), axis=-1)


def mean_distance_over_time(samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mean-distance distribution over time (Chen et al. §6.3, Fig. 9; Wang et al. 2019).

    For ``samples`` ``(n_samples, frames, ...)`` generated from one start: at each frame
    the mean of the samples, then each sample's Euclidean distance to it (everything
    after the frame axis is one vector). Returns the mean and the standard deviation of
    those distances, each ``(frames,)``, in the samples' units. Compare with
    ``distances_to_mean`` of the training data (:func:`data_band`).
    """
    flat = _check_samples(samples)
    distances = np.linalg.norm(flat - flat.mean(axis=0, keepdims=True), axis=-1)   # (n, frames)
    return distances.mean(axis=0), distances.std(axis=0)


def data_band(frames: np.ndarray) -> tuple[float, float]:
    """Mean and standard deviation of :func:`distances_to_mean` over data ``frames``
    ``(n, ...)``: the band that Fig. 9 of Chen et al. draws behind the samples' curve."""
    distances = distances_to_mean(_check_points(frames, "frames"))
    return float(distances.mean()), float(distances.std())


def pairwise_distance_over_time(samples: np.ndarray) -> np.ndarray:
    """Mean Euclidean distance between every two samples at each frame, ``(frames,)``.

    ``samples`` ``(n_samples, frames, ...)``; everything after the frame axis is one
    vector. Zero where all samples agree (the "average pairwise distance" of
    diverse-prediction papers, per frame).
    """
    flat = _check_samples(samples)
    n = flat.shape[0]
    total = np.zeros(flat.shape[1])
    for i in range(n - 1):
        total += np.linalg.norm(flat[i + 1:] - flat[i], axis=-1).sum(axis=0)
    return total / (n * (n - 1) / 2)


def frame_speed(sequences: np.ndarray, fps: float) -> np.ndarray:
    """How fast each sequence changes: the norm of the frame-to-frame difference times
    ``fps``, ``(n, frames - 1)``, for ``sequences`` ``(n, frames, ...)`` (units per second).

    A generator that *freezes* has a speed that falls to zero; one that *explodes*, a
    speed far above the data's.
    """
    flat = _check_samples(sequences, "sequences", min_samples=1)
    if flat.shape[1] < 2:
        raise ValueError(f"sequences: need at least 2 frames, got {flat.shape[1]}")
    fps = checks.rate(fps, "fps")
    return np.linalg.norm(np.diff(flat, axis=1), axis=-1) * fps


def fraction_in_range(samples: np.ndarray, reference: np.ndarray,
                      quantiles: tuple[float, float] = (0.001, 0.999), margin: float = 0.1,
                      atol: float = 0.0) -> np.ndarray:
    """Per frame, the fraction of values of ``samples`` ``(n, frames, ...)`` inside the
    range the ``reference`` data ``(m, ...)`` covers, ``(frames,)`` in ``[0, 1]``.

    The range of each value (each trailing index: a joint coordinate, a feature) is the
    ``quantiles`` of the reference over its first axis, widened on each side by
    ``margin`` times its width and by ``atol`` (in the samples' units: values the
    reference never varies, such as the hips' root-local ``x`` and ``z``, have a range of
    width 0). Long generations that stay realistic stay near 1; ones that explode fall
    towards 0.
    """
    flat = _check_samples(samples, min_samples=1)
    reference = checks.array(reference, "reference")
    if reference.ndim < 1 or reference.shape[0] < 2 or \
            reference.reshape(reference.shape[0], -1).shape[1] != flat.shape[2]:
        raise ValueError(f"reference: expected (m >= 2, ...) with the samples' trailing shape "
                         f"{np.shape(samples)[2:]}, got {reference.shape}")
    low_q, high_q = checks.array(quantiles, "quantiles", (2,))
    if not 0 <= low_q < high_q <= 1:
        raise ValueError(f"quantiles: expected 0 <= low < high <= 1, got {quantiles}")
    checks.non_negative(margin, "margin")
    checks.non_negative(atol, "atol")
    low, high = np.quantile(reference.reshape(reference.shape[0], -1), [low_q, high_q], axis=0)
    slack = margin * (high - low) + atol
    inside = (flat >= low - slack) & (flat <= high + slack)
    return inside.mean(axis=(0, 2))


def pca_2d(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The two main axes of ``points`` ``(n, d)`` (PCA by SVD): their mean ``(d,)``, the
    axes ``(2, d)`` (unit rows) and the share of the variance they explain. Project with
    ``(points - mean) @ axes.T``."""
    points = _check_points(points, "points")
    if points.shape[1] < 2 or len(points) < 2:
        raise ValueError(f"points: need at least 2 points of at least 2 dimensions, got {points.shape}")
    center = points.mean(0)
    _, singular, axes = np.linalg.svd(points - center, full_matrices=False)
    return center, axes[:2], float((singular[:2] ** 2).sum() / (singular ** 2).sum())
