"""Rotation matrices, Euler angles and forward kinematics, shared by the readers and the generator.

Rotations are ``(..., 3, 3)`` float64 matrices acting on column vectors (``R @ v``),
right-handed. Euler angles are in degrees; :func:`y_rotation` (headings) takes radians.

>>> np.round(axis_rotation("Z", 90.0) @ [1.0, 0.0, 0.0], 12)     # x turns into y
array([0., 1., 0.])
>>> euler_to_matrix([30.0, 0.0, 0.0], "XYZ") @ [0.0, 1.0, 0.0]
array([0.       , 0.8660254, 0.5      ])
"""
from __future__ import annotations

import numpy as np

AXES = "XYZ"


def _about_axis(axis: int, radians: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` about axis 0, 1 or 2 (x, y, z) by ``radians``."""
    j, k = (axis + 1) % 3, (axis + 2) % 3                # the plane the rotation turns
    c, s = np.cos(radians), np.sin(radians)
    out = np.zeros(np.shape(c) + (3, 3), dtype=np.result_type(c))
    out[..., axis, axis] = 1.0
    out[..., j, j], out[..., j, k] = c, -s
    out[..., k, j], out[..., k, k] = s, c
    return out


def axis_rotation(axis: str, degrees: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` about ``axis`` (``"X"``, ``"Y"`` or ``"Z"``) by
    ``degrees`` (any shape ``...``)."""
    if axis not in ("X", "Y", "Z"):
        raise ValueError(f"axis: expected 'X', 'Y' or 'Z', got {axis!r}")
    return _about_axis(AXES.index(axis), np.deg2rad(np.asarray(degrees, dtype=np.float64)))


def y_rotation(angle: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` about the up axis by ``angle`` (any shape) in RADIANS.

    ``y_rotation(a) @ [0, 0, 1] = [sin a, 0, cos a]``: heading ``a`` faces that way.
    """
    return _about_axis(1, angle)


def euler_to_matrix(degrees: np.ndarray, order: str) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` from Euler angles ``(..., len(order))`` in degrees.

    The rotations are applied in ``order``, first letter first, to column vectors:
    ``euler_to_matrix([a, b, c], "XYZ") == Rz(c) @ Ry(b) @ Rx(a)``. An empty order gives
    identities.
    """
    degrees = np.asarray(degrees, dtype=np.float64)
    if not order:
        return np.broadcast_to(np.eye(3), degrees.shape[:-1] + (3, 3)).copy()
    result = axis_rotation(order[0], degrees[..., 0])
    for k in range(1, len(order)):
        result = axis_rotation(order[k], degrees[..., k]) @ result
    return result


def matrix_to_euler_zyx(rotations: np.ndarray) -> np.ndarray:
    """Euler angles ``(..., 3)`` in degrees, ``(z, y, x)`` with ``R = Rz(z) @ Ry(y) @ Rx(x)``,
    of rotation matrices ``(..., 3, 3)``; ``y`` is in ``[-90, 90]``.

    The inverse of ``euler_to_matrix(angles[..., ::-1], "XYZ")`` away from ``y = +-90``
    (gimbal lock, where only ``z - x`` or ``z + x`` is defined).
    """
    y = np.arcsin(np.clip(-rotations[..., 2, 0], -1.0, 1.0))
    z = np.arctan2(rotations[..., 1, 0], rotations[..., 0, 0])
    x = np.arctan2(rotations[..., 2, 1], rotations[..., 2, 2])
    return np.rad2deg(np.stack([z, y, x], axis=-1))


def parent_first(parents: np.ndarray) -> list[int]:
    """Joint indices ``0 .. J-1`` ordered so that each comes after its parent (breadth
    first from the roots, which have parent ``-1``)."""
    children = {j: [] for j in range(-1, len(parents))}
    for j, p in enumerate(parents):
        children[int(p)].append(j)
    order = list(children[-1])
    for j in order:                                     # grows while it is walked
        order.extend(children[j])
    return order


def forward_kinematics(parents: np.ndarray, rotations: np.ndarray, offsets: np.ndarray,
                       offset_frame: str = "parent",
                       fixed: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """World rotations ``(F, J, 3, 3)`` and positions ``(F, J, 3)`` from local ones.

    Args:
        parents: ``(J,)`` parent of each joint, ``-1`` for a root; in any order.
        rotations: ``(F, J, 3, 3)`` each joint's rotation relative to its parent.
        offsets: ``(F, J, 3)`` each joint's position relative to its parent, any length unit.
        offset_frame: ``"parent"`` when an offset turns with the parent's world rotation
            (BVH: a joint's offset), ``"own"`` when it turns with the joint's own world
            rotation (ASF: a bone's end from its start).
        fixed: ``(J,)`` bool, joints that never turn relative to their parent: they get
            their parent's world rotation as it is (``rotations`` there is not read).

    A root's world transform is its local one. Vectorised over frames, one step per joint.
    """
    if offset_frame not in ("parent", "own"):
        raise ValueError(f"offset_frame: expected 'parent' or 'own', got {offset_frame!r}")
    fixed = np.zeros(len(parents), dtype=bool) if fixed is None else fixed
    world_rot, world_pos = np.empty_like(rotations), np.empty_like(offsets)
    for j in parent_first(parents):
        p = parents[j]
        if p < 0:
            world_rot[:, j], world_pos[:, j] = rotations[:, j], offsets[:, j]
            continue
        world_rot[:, j] = world_rot[:, p] if fixed[j] else world_rot[:, p] @ rotations[:, j]
        frame = world_rot[:, p] if offset_frame == "parent" else world_rot[:, j]
        world_pos[:, j] = np.einsum("fab,fb->fa", frame, offsets[:, j]) + world_pos[:, p]
    return world_rot, world_pos
