import numpy as np
import pytest

from motionlab import skeleton as sk


def test_locomotion_skeleton_is_the_papers_21_joints():
    assert sk.LOCOMOTION.names == (
        "Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RightUpLeg", "RightLeg",
        "RightFoot", "RightToeBase", "Spine", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm",
        "LeftHand", "LeftHandIndex1", "RightArm", "RightForeArm", "RightHand", "RightHandIndex1")
    assert list(sk.CMU_TO_LOCOMOTION) == [0, 2, 3, 4, 5, 7, 8, 9, 10, 12, 13, 15, 16, 18, 19, 20,
                                          22, 25, 26, 27, 29]


def test_parents_come_first_and_follow_the_body():
    names, parents = sk.LOCOMOTION.names, sk.LOCOMOTION.parents
    assert parents[0] == -1 and all(0 <= p < j for j, p in enumerate(parents) if j > 0)
    parent_of = {names[j]: names[p] for j, p in enumerate(parents) if p >= 0}
    assert parent_of["LeftUpLeg"] == "Hips"        # through the zero-length LHipJoint
    assert parent_of["Spine"] == "Hips"            # through LowerBack
    assert parent_of["Neck1"] == "Spine1"          # through Neck
    assert parent_of["LeftArm"] == "Spine1"        # through LeftShoulder
    assert parent_of["RightHandIndex1"] == "RightHand"
    assert len(sk.LOCOMOTION.bones) == 20


def test_mirror_map_swaps_left_and_right():
    m = sk.LOCOMOTION.mirror
    names = sk.LOCOMOTION.names
    assert np.array_equal(m[m], np.arange(21))
    for i, name in enumerate(names):
        expected = name.replace("Left", "#").replace("Right", "Left").replace("#", "Right")
        assert names[m[i]] == expected
    cmu = sk.CMU.mirror
    assert sk.CMU.names[cmu[sk.CMU.index("LHipJoint")]] == "RHipJoint"
    assert sk.CMU.names[cmu[sk.CMU.index("LThumb")]] == "RThumb"


def test_reduce_hierarchy_finds_nearest_kept_ancestor():
    parents = np.array([-1, 0, 1, 2, 1])
    assert list(sk.reduce_hierarchy(parents, np.array([0, 2, 3, 4]))) == [-1, 0, 1, 0]
    with pytest.raises(ValueError, match="no kept ancestor"):
        sk.reduce_hierarchy(parents, np.array([2, 4]))  # 4's ancestors 1 and 0 are dropped


def test_bone_lengths_and_errors():
    pos = np.zeros((2, 21, 3))
    pos[:, :, 1] = np.arange(21)
    lengths = sk.LOCOMOTION.bone_lengths(pos)
    assert lengths.shape == (2, 20)
    with pytest.raises(ValueError, match="expected shape"):
        sk.LOCOMOTION.bone_lengths(np.zeros((5, 20, 3)))
    with pytest.raises(ValueError, match="unknown joint 'Tail'"):
        sk.LOCOMOTION.index("Tail")
    assert sk.cmu_to_locomotion(np.zeros((4, 31, 3))).shape == (4, 21, 3)
