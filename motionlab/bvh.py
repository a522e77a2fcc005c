"""BVH motion capture files: read, write, and forward kinematics; a BVH file as a
:class:`~motionlab.clip.Clip`, and joint positions as a BVH.

The format, its reader and its writer are :mod:`motionlab.bvh_file` (:class:`BVH`,
:func:`read`, :func:`write`, :func:`read_text_lines`), whose names are importable from here
too. This module reads a file with CMU joint names as the 21 locomotion joints
(:func:`load_clip`, dropping the T-pose frame cgspeed's files start with) and turns joint
positions into a BVH whose forward kinematics gives them back (:func:`from_positions`), to
open generated motion in animation tools.

>>> clip = read("../shared/mocap/cmu/16_15.bvh")
>>> clip.world_positions().shape        # (frames, joints, 3), file units
(471, 31, 3)
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import checks
from .bvh_file import (BVH, MAX_FRAME_TIME_S, POSITION_CHANNELS, ROTATION_CHANNELS, read, read_text_lines,
                       write)
from .clip import CMU_UNIT_M, Clip
from .rotations import matrix_to_euler_zyx, y_rotation
from .skeleton import LOCOMOTION_JOINTS

__all__ = ["BVH", "END_SITE_M", "MAX_FRAME_TIME_S", "POSITION_CHANNELS", "ROTATION_CHANNELS", "from_positions",
           "has_tpose_frame", "load_clip", "locomotion_joints", "read", "read_text_lines", "write"]

# --------------------------------------------------------------------------- as a Clip

def has_tpose_frame(clip: BVH) -> bool:
    """Whether frame 0 is a hand-made T-pose, as cgspeed BVH files prepend.

    That frame's rotations are whole degrees (mostly zero), unlike captured frames.
    """
    if clip.n_frames < 2:
        return False
    rotation_columns = [column.start + k
                        for column, names in zip(clip.channel_columns(), clip.channels)
                        for k, name in enumerate(names) if name.endswith("rotation")]
    first = clip.motion[0, rotation_columns]
    return bool(np.all(first == np.round(first)) and np.mean(first == 0) > 0.5)


def locomotion_joints(clip: BVH) -> list[int]:
    """Indices into ``clip.joint_names`` of the 21 locomotion joints, in locomotion order.

    Joints are found by their CMU names (:data:`motionlab.skeleton.LOCOMOTION_JOINTS`); the hips are the
    joint named ``Hips`` or, when there is none, the root joint whatever its name (some
    exporters call it ``Root`` or ``pelvis``). Raises ``ValueError`` listing missing joints.
    """
    index = {name: j for j, name in enumerate(clip.joint_names)}
    index.setdefault("Hips", int(np.flatnonzero(np.asarray(clip.parents) < 0)[0]))
    missing = [n for n in LOCOMOTION_JOINTS if n not in index]
    if missing:
        raise ValueError(f"{clip.path}: not a CMU-style skeleton, missing joints {', '.join(missing)}")
    return [index[n] for n in LOCOMOTION_JOINTS]


def load_clip(path: str | Path, fps: float | None = None, unit_m: float = CMU_UNIT_M,
             drop_tpose: bool | str = "auto") -> Clip:
    """A BVH file with CMU joint names as a 21-joint :class:`~motionlab.clip.Clip`, as
    :func:`motionlab.asfamc.load_clip` reads a CMU trial: every reader returns a Clip.

    Args:
        path: the ``.bvh`` file.
        fps: resample to this frame rate (default: keep the file's).
        unit_m: metres per file length unit (default: CMU units).
        drop_tpose: drop frame 0 if it is a cgspeed T-pose; ``"auto"`` detects it
            (:func:`has_tpose_frame`), ``True``/``False`` force it.

    The root joint stands in for ``Hips`` when no joint has that name
    (:func:`locomotion_joints`). A malformed file raises ``ValueError`` naming it.
    """
    path = Path(path)
    if fps is not None:
        fps = checks.rate(fps, "fps")
    unit_m = checks.positive(unit_m, "unit_m")
    if drop_tpose not in ("auto", True, False):
        raise ValueError(f"drop_tpose: expected 'auto', True or False, got {drop_tpose!r}")
    clip = read(path)
    index = locomotion_joints(clip)
    drop = has_tpose_frame(clip) if drop_tpose == "auto" else bool(drop_tpose)
    if drop:
        clip.motion = clip.motion[1:]
    if clip.n_frames < 2:
        raise ValueError(f"{path}: needs at least 2 frames of motion, has {clip.n_frames}")
    positions = clip.world_positions()[:, index] * unit_m
    result = Clip(path.stem, positions, clip.fps, str(path))
    return result.resampled(fps) if fps is not None else result


def _swing(rest: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Smallest rotations ``(F, 3, 3)`` taking unit vector ``rest`` ``(3,)`` to ``current`` ``(F, 3)``."""
    axis = np.cross(rest, current)
    cos = current @ rest
    k = np.zeros(current.shape[:-1] + (3, 3))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -axis[..., 2], axis[..., 1], -axis[..., 0]
    k = k - np.swapaxes(k, -1, -2)
    out = np.eye(3) + k + (k @ k) / np.maximum(1.0 + cos, 1e-12)[..., None, None]
    flipped = cos < -1 + 1e-9                      # opposite: half a turn about any perpendicular
    if flipped.any():
        perp = np.cross(rest, [1.0, 0.0, 0.0] if abs(rest[0]) < 0.9 else [0.0, 1.0, 0.0])
        perp /= np.linalg.norm(perp)
        out[flipped] = 2 * np.outer(perp, perp) - np.eye(3)
    return out


def _bone_rotation(in_body: np.ndarray, parent: int, child: int) -> tuple[np.ndarray, np.ndarray]:
    """The bone from ``parent`` to ``child`` of positions ``(frames, joints, 3)`` with the heading
    removed: its rest offset (frame 0's direction, the mean length) and its rotation per frame
    from there (:func:`_swing`)."""
    vector = in_body[:, child] - in_body[:, parent]
    length = np.linalg.norm(vector, axis=-1)
    rest = vector[0] / max(length[0], 1e-12)
    current = vector / np.maximum(length, 1e-12)[:, None]
    return rest * length.mean(), _swing(rest, current)


END_SITE_M = 0.05
"""How far :func:`from_positions` puts each leaf's End Site beyond the leaf joint, metres."""


def from_positions(positions: np.ndarray, fps: float, skeleton=None, unit_m: float = 1.0) -> BVH:
    """Joint positions -> a BVH clip whose forward kinematics gives them back.

    Args:
        positions: ``(frames, joints, 3)`` world positions in metres (y up) of ``skeleton``
            (default: the 21-joint locomotion skeleton).
        fps: frames per second.
        unit_m: metres per file unit (``clip.CMU_UNIT_M`` writes CMU units).

    Each bone's rest offset has the bone's mean length, pointing as in frame 0. The root
    carries the position and the character's heading; every other joint turns its bone by
    the smallest rotation from the rest direction, so positions come back exactly when bone
    lengths are constant (and with the mean lengths when they are not). A joint with several
    children (the hips, the chest) gets one zero-length helper joint per child, named
    ``<child>_base``, as the CMU skeleton has ``LHipJoint``, ``LowerBack`` and so on. Each
    leaf joint (toes, fingers, head) turns with the bone that ends in it and carries an
    ``End Site`` :data:`END_SITE_M` further along that bone, so that animation tools draw
    the last bone of each chain as a continuation of the one before it.
    """
    from .representation import facing_angles
    from .skeleton import LOCOMOTION
    skeleton = skeleton or LOCOMOTION
    positions = np.asarray(positions, dtype=np.float64)
    if positions.ndim != 3 or positions.shape[1:] != (skeleton.n_joints, 3):
        raise ValueError(f"positions: expected shape (frames, {skeleton.n_joints}, 3), got {positions.shape}")
    frames = len(positions)
    heading = y_rotation(facing_angles(positions, fps, skeleton=skeleton))
    in_body = np.einsum("fba,fjb->fja", heading, positions)       # heading removed
    children = {j: [c for c, p in enumerate(skeleton.parents) if p == j] for j in range(skeleton.n_joints)}

    names, parents, offsets, body_rot = [], [], [], []

    def add(name: str, parent: int, offset: np.ndarray, rotation: np.ndarray) -> int:
        names.append(name)
        parents.append(parent)
        offsets.append(offset)
        body_rot.append(rotation)
        return len(names) - 1

    end_sites: dict[int, np.ndarray] = {}

    def visit(joint: int, file_parent: int, offset: np.ndarray, rotation_in: np.ndarray | None,
              incoming: np.ndarray) -> None:
        """Add ``joint`` under ``file_parent``; ``incoming``: the rotation of the bone ending here."""
        kids = children[joint]
        if len(kids) == 1:
            kid_offset, rotation = _bone_rotation(in_body, joint, kids[0])
        elif not kids:
            rotation = incoming           # a leaf turns with its bone, so its End Site extends it
        else:
            rotation = rotation_in if rotation_in is not None else np.broadcast_to(np.eye(3), (frames, 3, 3))
        index = add(skeleton.names[joint], file_parent, offset, rotation)
        if not kids:                      # End Site: END_SITE_M further along the bone's rest direction
            direction = offset / max(np.linalg.norm(offset), 1e-12)
            end_sites[index] = direction * END_SITE_M / unit_m
        elif len(kids) == 1:
            visit(kids[0], index, kid_offset, None, rotation)
        else:
            for kid in kids:
                kid_offset, kid_rotation = _bone_rotation(in_body, joint, kid)
                helper = add(f"{skeleton.names[kid]}_base", index, np.zeros(3), kid_rotation)
                visit(kid, helper, kid_offset, None, kid_rotation)

    root = int(np.flatnonzero(skeleton.parents < 0)[0])
    identity = np.broadcast_to(np.eye(3), (frames, 3, 3))
    visit(root, -1, np.zeros(3), identity, identity)
    angles = _euler_channels(heading, np.stack(body_rot, axis=1), parents)
    motion = np.concatenate([positions[:, root] / unit_m, angles], axis=1)
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")] + \
        [("Zrotation", "Yrotation", "Xrotation")] * (len(names) - 1)
    return BVH(names, np.array(parents, dtype=np.int64), np.array(offsets) / unit_m, channels,
               motion, 1.0 / fps, end_sites)


def _euler_channels(heading: np.ndarray, body_rot: np.ndarray, parents: list[int]) -> np.ndarray:
    """The rotation channels of :func:`from_positions`: each file joint's rotation relative
    to its parent as ZYX Euler angles ``(frames, 3 * joints)``, degrees, from the heading
    ``(frames, 3, 3)`` and each joint's rotation in the body frame ``(frames, joints, 3, 3)``."""
    frames = len(body_rot)
    world_rot = heading[:, None] @ body_rot
    parent_rot = np.stack([world_rot[:, p] if p >= 0 else np.broadcast_to(np.eye(3), (frames, 3, 3))
                           for p in parents], axis=1)
    local = np.swapaxes(parent_rot, -1, -2) @ world_rot
    return matrix_to_euler_zyx(local).reshape(frames, -1)
