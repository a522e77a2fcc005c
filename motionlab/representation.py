"""The motion representation every model in motionlab shares.

Per frame ``t`` a motion is a vector of 66 numbers (Holden 2016; Motegi §II; MoGlow §5.1;
Habibie §4.1):

* **pose** (63 values, features ``0:63``): the 21 joint positions in the *root frame* of
  frame ``t``, joint by joint as ``x, y, z``, in metres. The root frame has its origin on
  the floor (``y = 0``) directly below the hips, its ``y`` axis up and its ``z`` axis along
  the character's smoothed facing direction; ``x`` then points to the character's left.
* **control** (3 values, features ``63:66``): how the root frame moves from frame ``t`` to
  ``t + 1``, in frame ``t``'s own axes, as velocities: forward (m/s, along ``z``),
  sideways (m/s, along ``x``, positive to the left) and turning (rad/s about ``y``,
  positive = counter-clockwise seen from above = turning left). The last frame, which has
  no successor, repeats the previous frame's control.

The facing direction is Holden's: the horizontal vector perpendicular to
``(left shoulder - right shoulder) + (left hip - right hip)``, smoothed over time with a
Gaussian of ``facing_smoothing_s`` seconds so that the sway of each step stays in the
pose and only the overall heading goes into the control.

:func:`to_positions` integrates the control back into a world trajectory. Given the root
start pose (:func:`root_start`), ``to_positions(to_features(p)) == p`` up to float
rounding (far below 1 mm).

World positions are ``(frames, joints, 3)`` arrays in metres with ``y`` up and the floor
at ``y = 0``.
"""
from __future__ import annotations

import numpy as np

from . import checks
from .filters import gaussian_smooth
from .rotations import y_rotation
from .skeleton import LOCOMOTION, Skeleton

N_POSE = 3 * LOCOMOTION.n_joints
"""Number of pose features (63 for the 21-joint skeleton)."""
POSE = slice(0, N_POSE)
"""Feature columns of the root-local pose."""
CONTROL = slice(N_POSE, N_POSE + 3)
"""Feature columns of the control: forward, sideways, turning velocity."""
N_FEATURES = N_POSE + 3
CONTROL_NAMES = ("forward velocity (m/s)", "sideways velocity (m/s)", "turning velocity (rad/s)")
FEATURE_NAMES = tuple(f"{name}.{axis}" for name in LOCOMOTION.names for axis in "xyz") + (
    "forward", "sideways", "turning")
"""A short name for each of the 66 feature columns."""

FACING_SMOOTHING_S = 0.25
"""Default standard deviation (seconds) of the Gaussian that smooths the facing direction."""


def _check_positions(positions: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """World positions as a float64 array ``(frames, joints, 3)``, at least one frame, no NaN."""
    if len(np.shape(positions)) == 3 and np.shape(positions)[0] == 0:
        raise ValueError("positions: the clip has no frames")
    return checks.array(positions, "positions", ("frames", skeleton.n_joints, 3))


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Wrap radians into ``[-pi, pi)``."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def facing_angles(positions: np.ndarray, fps: float,
                  facing_smoothing_s: float = FACING_SMOOTHING_S,
                  skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """Smoothed heading ``(frames,)`` in radians: the character faces ``(sin a, 0, cos a)``.

    ``positions`` ``(frames, joints, 3)`` in metres; ``fps`` frames per second; the facing
    direction is smoothed with a Gaussian of ``facing_smoothing_s`` seconds (0: not at all).
    """
    positions = _check_positions(positions, skeleton)
    fps = checks.rate(fps, "fps")
    checks.non_negative(facing_smoothing_s, "facing_smoothing_s", checks.MAX_SECONDS)
    left_sh, right_sh = skeleton.index("LeftArm"), skeleton.index("RightArm")
    left_hip, right_hip = skeleton.index("LeftUpLeg"), skeleton.index("RightUpLeg")
    across = (positions[:, left_sh] - positions[:, right_sh]
              + positions[:, left_hip] - positions[:, right_hip])
    forward = np.cross(across, [0.0, 1.0, 0.0])          # left x up = forward
    forward[:, 1] = 0.0
    forward /= np.linalg.norm(forward, axis=-1, keepdims=True) + 1e-12
    forward = gaussian_smooth(forward, facing_smoothing_s * fps)
    return np.arctan2(forward[:, 0], forward[:, 2])


def root_trajectory(positions: np.ndarray, fps: float,
                    facing_smoothing_s: float = FACING_SMOOTHING_S,
                    skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """Root frame per frame, ``(frames, 3)``: floor position ``x``, ``z`` (m) and heading (rad)."""
    positions = _check_positions(positions, skeleton)
    fps = checks.rate(fps, "fps")
    heading = facing_angles(positions, fps, facing_smoothing_s, skeleton)
    hips = positions[:, skeleton.index("Hips")]
    return np.stack([hips[:, 0], hips[:, 2], heading], axis=-1)


def root_start(positions: np.ndarray, fps: float,
               facing_smoothing_s: float = FACING_SMOOTHING_S,
               skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """The root frame of the first frame, ``(3,)``: ``x``, ``z`` (m), heading (rad).

    Pass it as ``start`` to :func:`to_positions` to put a decoded clip back where it was.
    """
    return root_trajectory(positions, fps, facing_smoothing_s, skeleton)[0]


def to_features(positions: np.ndarray, fps: float,
                facing_smoothing_s: float = FACING_SMOOTHING_S,
                skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """World positions ``(frames, joints, 3)`` (m, y up) -> features ``(frames, 3 * joints + 3)``.

    See the module docstring for the definition of every column.
    """
    positions = _check_positions(positions, skeleton)
    fps = checks.rate(fps, "fps")
    root = root_trajectory(positions, fps, facing_smoothing_s, skeleton)
    origin = np.stack([root[:, 0], np.zeros(len(root)), root[:, 1]], axis=-1)
    to_local = y_rotation(-root[:, 2])                              # world -> root frame
    pose = np.einsum("fab,fjb->fja", to_local, positions - origin[:, None])

    control = np.zeros((len(root), 3))
    if len(root) > 1:
        step = np.einsum("fab,fb->fa", to_local[:-1], origin[1:] - origin[:-1])
        control[:-1, 0] = step[:, 2] * fps                          # forward
        control[:-1, 1] = step[:, 0] * fps                          # sideways (left +)
        control[:-1, 2] = wrap_angle(np.diff(root[:, 2])) * fps     # turning (left +)
        control[-1] = control[-2]
    return np.concatenate([pose.reshape(len(root), -1), control], axis=-1)


def integrate_control(control: np.ndarray, fps: float,
                      start: np.ndarray | None = None) -> np.ndarray:
    """Integrate controls ``(frames, 3)`` into root frames ``(frames, 3)`` (``x``, ``z``, heading).

    ``start`` is the first frame's ``(x, z, heading)``; default the origin, facing ``+z``.
    The last frame's control is not needed: it would move the root past the clip's end.
    """
    control = checks.array(control, "control", ("frames", 3))
    fps = checks.rate(fps, "fps")
    start = np.zeros(3) if start is None else checks.array(start, "start", (3,))
    frames = len(control)
    heading = start[2] + np.concatenate([[0.0], np.cumsum(control[:-1, 2]) / fps])
    local_step = np.stack([control[:-1, 1], np.zeros(frames - 1), control[:-1, 0]], -1) / fps
    world_step = np.einsum("fab,fb->fa", y_rotation(heading[:-1]), local_step)
    xz = np.concatenate([[start[:2]], start[:2] + np.cumsum(world_step[:, [0, 2]], axis=0)])
    return np.concatenate([xz, heading[:, None]], axis=-1)


def to_positions(features: np.ndarray, fps: float, start: np.ndarray | None = None,
                 skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """Features ``(frames, 3 * joints + 3)`` -> world positions ``(frames, joints, 3)`` (m).

    Integrates the control from ``start`` (``(x, z, heading)`` of the first root frame,
    default the origin facing ``+z``) and places each frame's pose in its root frame.
    A batch of clips ``(..., frames, 3 * joints + 3)`` gives ``(..., frames, joints, 3)``,
    each clip from the same ``start``.
    """
    n_pose = 3 * skeleton.n_joints
    one_clip = np.ndim(features) <= 2
    shape = ("frames", n_pose + 3) if one_clip else (..., "frames", n_pose + 3)
    features = checks.array(features, "features", shape)
    fps = checks.rate(fps, "fps")
    if not one_clip:
        flat = features.reshape(-1, *features.shape[-2:])
        positions = np.stack([to_positions(clip, fps, start, skeleton) for clip in flat])
        return positions.reshape(*features.shape[:-1], skeleton.n_joints, 3)
    root = integrate_control(features[:, n_pose:], fps, start)
    pose = features[:, :n_pose].reshape(len(features), skeleton.n_joints, 3)
    origin = np.stack([root[:, 0], np.zeros(len(root)), root[:, 1]], axis=-1)
    return np.einsum("fab,fjb->fja", y_rotation(root[:, 2]), pose) + origin[:, None]


def along_path(positions: np.ndarray, control: np.ndarray, fps: float, start: np.ndarray | None = None,
               skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """World positions ``(..., frames, joints, 3)`` -> features ``(..., frames, 3 * joints + 3)``
    on a *given* root path: the root frames integrated from ``control`` ``(..., frames, 3)``
    (from ``start``, as :func:`to_positions` does), each pose placed in its own. The inverse
    of :func:`to_positions` for the same control: ``along_path(to_positions(f), f[..., -3:])``
    gives ``f`` back. Use it for motion edited in the world (feet locked) whose root moved
    along the same path, so that it is measured in the same root frames as before."""
    n_pose = 3 * skeleton.n_joints
    positions = checks.array(positions, "positions", (..., "frames", skeleton.n_joints, 3))
    control = checks.array(control, "control", (..., "frames", 3))
    if control.shape[:-1] != positions.shape[:-2]:
        raise ValueError(f"control: expected {positions.shape[:-2] + (3,)} for positions {positions.shape}, "
                         f"got {control.shape}")
    fps = checks.rate(fps, "fps")
    flat_p, flat_c = positions.reshape(-1, *positions.shape[-3:]), control.reshape(-1, *control.shape[-2:])
    out = np.empty(flat_c.shape[:-1] + (n_pose + 3,))
    for k, (p, c) in enumerate(zip(flat_p, flat_c)):
        root = integrate_control(c, fps, start)
        origin = np.stack([root[:, 0], np.zeros(len(root)), root[:, 1]], axis=-1)
        pose = np.einsum("fab,fjb->fja", y_rotation(-root[:, 2]), p - origin[:, None])
        out[k] = np.concatenate([pose.reshape(len(root), n_pose), c], axis=-1)
    return out.reshape(control.shape[:-1] + (n_pose + 3,))


def mirror_features(features: np.ndarray, skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """Mirror left and right: reflect ``x``, swap left/right joints, negate sideways and
    turning velocity. Works on ``(..., frames, 3 * joints + 3)``; applying it twice is exact."""
    n_pose = 3 * skeleton.n_joints
    features = checks.array(features, "features", (..., "frames", n_pose + 3), dtype=None)
    pose = features[..., :n_pose].reshape(features.shape[:-1] + (skeleton.n_joints, 3))
    pose = pose[..., skeleton.mirror, :] * np.array([-1.0, 1.0, 1.0])
    control = features[..., n_pose:] * np.array([1.0, -1.0, -1.0])
    return np.concatenate([pose.reshape(features.shape[:-1] + (n_pose,)), control], axis=-1)


def reverse_features(features: np.ndarray, fps: float, skeleton: Skeleton = LOCOMOTION) -> np.ndarray:
    """Play a clip backwards (MoGlow §5.1), in feature space: ``(frames, 3 * joints + 3)``.

    Poses are reversed in order. Each control is recomputed for the reversed clip: the
    step from frame ``t`` back to ``t - 1`` seen from frame ``t`` is the forward step
    ``t - 1 -> t`` negated and rotated by the turn ``-omega / fps``. The result equals
    ``to_features`` of the reversed world positions, and reversing twice is the identity
    (to float rounding).
    """
    n_pose = 3 * skeleton.n_joints
    features = checks.array(features, "features", ("frames", n_pose + 3))
    fps = checks.rate(fps, "fps")
    out = features[::-1].copy()
    control = features[:, n_pose:]
    if len(features) > 1:
        step = control[:-1]                         # forward steps t-1 -> t, t = 1..F-1
        turn = -step[:, 2] / fps                    # rotation from frame t to frame t-1
        c, s = np.cos(turn), np.sin(turn)
        # the step t-1 -> t in frame t's axes is R(-omega/fps) applied to (side, fwd);
        # the reversed step t -> t-1 is its negation.
        side = -(c * step[:, 1] + s * step[:, 0])
        fwd = -(-s * step[:, 1] + c * step[:, 0])
        reversed_control = np.stack([fwd, side, -step[:, 2]], axis=-1)[::-1]
        out[:-1, n_pose:] = reversed_control
        out[-1, n_pose:] = out[-2, n_pose:]
    return out
