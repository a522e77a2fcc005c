"""Rotation matrices, Euler angles and forward kinematics: hand-computed cases, and each
helper against the others."""
import numpy as np
import pytest

from motionlab.rotations import (axis_rotation, euler_to_matrix, forward_kinematics,
                                 matrix_to_euler_zyx, parent_first, y_rotation)

RNG = np.random.default_rng(0)


@pytest.mark.parametrize("axis, vector, turned", [
    ("X", [0, 1, 0], [0, 0, 1]), ("Y", [0, 0, 1], [1, 0, 0]), ("Z", [1, 0, 0], [0, 1, 0])])
def test_quarter_turns_are_right_handed(axis, vector, turned):
    assert np.allclose(axis_rotation(axis, 90.0) @ vector, turned)
    assert np.allclose(axis_rotation(axis, -90.0) @ turned, vector)


def test_axis_rotation_by_hand():
    c, s = np.cos(np.deg2rad(30.0)), np.sin(np.deg2rad(30.0))
    assert np.array_equal(axis_rotation("X", 30.0), [[1, 0, 0], [0, c, -s], [0, s, c]])
    assert np.array_equal(axis_rotation("Y", 30.0), [[c, 0, s], [0, 1, 0], [-s, 0, c]])
    assert np.array_equal(axis_rotation("Z", 30.0), [[c, -s, 0], [s, c, 0], [0, 0, 1]])
    with pytest.raises(ValueError, match="axis"):
        axis_rotation("W", 30.0)


def test_shapes_broadcast_over_any_leading_dimensions():
    assert axis_rotation("X", 10.0).shape == (3, 3)
    assert axis_rotation("Y", [10.0, 20.0]).shape == (2, 3, 3)
    assert axis_rotation("Z", np.zeros((4, 5))).shape == (4, 5, 3, 3)
    assert y_rotation(np.zeros((4, 5))).shape == (4, 5, 3, 3)
    assert euler_to_matrix(np.zeros((4, 5, 3)), "ZXY").shape == (4, 5, 3, 3)
    assert matrix_to_euler_zyx(np.zeros((4, 5, 3, 3))).shape == (4, 5, 3)


def test_rotations_are_orthonormal_with_determinant_one():
    angles = RNG.uniform(-180, 180, (50, 3))
    for r in [axis_rotation(a, angles[:, 0]) for a in "XYZ"] + [
            y_rotation(angles[:, 0]), euler_to_matrix(angles, "XYZ"), euler_to_matrix(angles, "YZX")]:
        assert np.allclose(r @ np.swapaxes(r, -1, -2), np.eye(3), atol=1e-12)
        assert np.allclose(np.linalg.det(r), 1.0)


def test_y_rotation_is_the_y_axis_rotation_in_radians():
    radians = RNG.uniform(-4, 4, 20)
    assert np.allclose(y_rotation(radians), axis_rotation("Y", np.rad2deg(radians)), atol=1e-15)
    a = 0.3
    assert np.allclose(y_rotation(a) @ [0, 0, 1], [np.sin(a), 0, np.cos(a)])      # heading a faces there


def test_euler_order_applies_the_first_letter_first():
    a, b, c = 30.0, -50.0, 70.0
    expected = axis_rotation("Z", c) @ axis_rotation("Y", b) @ axis_rotation("X", a)
    assert np.allclose(euler_to_matrix([a, b, c], "XYZ"), expected)
    assert np.allclose(euler_to_matrix([c, b, a], "ZYX"),
                       axis_rotation("X", a) @ axis_rotation("Y", b) @ axis_rotation("Z", c))
    assert np.allclose(euler_to_matrix([a, c], "XZ"), axis_rotation("Z", c) @ axis_rotation("X", a))
    assert np.array_equal(euler_to_matrix(np.zeros((2, 0)), ""), np.broadcast_to(np.eye(3), (2, 3, 3)))


def test_matrix_to_euler_zyx_by_hand_and_round_trip():
    assert np.allclose(matrix_to_euler_zyx(axis_rotation("Z", 90.0)), [90, 0, 0])
    assert np.allclose(matrix_to_euler_zyx(axis_rotation("Y", -45.0)), [0, -45, 0])
    assert np.allclose(matrix_to_euler_zyx(axis_rotation("X", 120.0)), [0, 0, 120])
    zyx = np.stack([RNG.uniform(-179, 179, 100), RNG.uniform(-89, 89, 100), RNG.uniform(-179, 179, 100)], -1)
    matrices = euler_to_matrix(zyx[:, ::-1], "XYZ")            # Rz @ Ry @ Rx
    assert np.allclose(matrix_to_euler_zyx(matrices), zyx, atol=1e-9)
    again = euler_to_matrix(matrix_to_euler_zyx(matrices)[:, ::-1], "XYZ")
    assert np.allclose(again, matrices, atol=1e-12)


def test_parent_first_orders_any_tree():
    assert parent_first(np.array([-1, 0, 1, 0])) == [0, 1, 3, 2]
    order = parent_first(np.array([2, -1, 1, 0]))                # children listed before parents
    assert order == [1, 2, 0, 3]
    assert all(order.index(p) < order.index(j) for j, p in enumerate([2, -1, 1, 0]) if p >= 0)


def test_forward_kinematics_of_a_bent_chain_by_hand():
    parents = np.array([-1, 0, 1])
    rotations = np.stack([axis_rotation("Z", 90.0), axis_rotation("Z", 90.0), np.eye(3)])[None]
    offsets = np.array([[[1.0, 2.0, 3.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]])
    world_rot, world_pos = forward_kinematics(parents, rotations, offsets)
    # BVH: each offset turns with the parent's world rotation (root: 90 deg, child: 180 deg)
    assert np.allclose(world_pos[0], [[1, 2, 3], [1, 3, 3], [0, 3, 3]])
    assert np.allclose(world_rot[0, 2], axis_rotation("Z", 180.0))
    # ASF: each offset turns with the joint's own world rotation
    _, own = forward_kinematics(parents, rotations, offsets, offset_frame="own")
    assert np.allclose(own[0], [[1, 2, 3], [0, 2, 3], [-1, 2, 3]])
    with pytest.raises(ValueError, match="offset_frame"):
        forward_kinematics(parents, rotations, offsets, offset_frame="child")


def test_fixed_joints_keep_their_parents_rotation_exactly():
    parents = np.array([-1, 0, 1])
    rotations = euler_to_matrix(RNG.uniform(-90, 90, (5, 3, 3)), "XYZ")
    offsets = RNG.normal(size=(5, 3, 3))
    garbage = rotations.copy()
    garbage[:, 1] = np.nan                                       # never read when fixed
    world_rot, world_pos = forward_kinematics(parents, garbage, offsets, fixed=np.array([False, True, False]))
    assert np.array_equal(world_rot[:, 1], world_rot[:, 0])
    assert np.isfinite(world_pos).all()


def test_forward_kinematics_matches_a_loop_over_frames_and_any_joint_order():
    parents = np.array([-1, 0, 1, 1, 0])
    rotations = euler_to_matrix(RNG.uniform(-180, 180, (4, 5, 3)), "ZXY")
    offsets = RNG.normal(size=(4, 5, 3))
    world_rot, world_pos = forward_kinematics(parents, rotations, offsets)
    for f in range(4):
        for j, p in enumerate(parents):
            if p >= 0:
                assert np.allclose(world_rot[f, j], world_rot[f, p] @ rotations[f, j])
                assert np.allclose(world_pos[f, j], world_pos[f, p] + world_rot[f, p] @ offsets[f, j])
    shuffle = np.array([3, 0, 4, 1, 2])                          # same tree, joints renumbered
    inverse = np.argsort(shuffle)
    rot2, pos2 = forward_kinematics(np.where(parents[shuffle] < 0, -1, inverse[parents[shuffle]]),
                                    rotations[:, shuffle], offsets[:, shuffle])
    assert np.array_equal(pos2, world_pos[:, shuffle]) and np.array_equal(rot2, world_rot[:, shuffle])
