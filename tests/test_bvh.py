"""BVH reading, writing and forward kinematics on small hand-made files."""
import numpy as np
import pytest

from motionlab import bvh
from motionlab.rotations import axis_rotation

TWO_BONE = """HIERARCHY
ROOT Root
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Upper
\t{
\t\tOFFSET 0 1 0
\t\tCHANNELS 3 Xrotation Yrotation Zrotation
\t\tJOINT Lower
\t\t{
\t\t\tOFFSET 0 2 0
\t\t\tCHANNELS 4 Yposition Zrotation Yrotation Xrotation
\t\t\tEnd Site
\t\t\t{
\t\t\t\tOFFSET 0 0 3
\t\t\t}
\t\t}
\t}
}
MOTION
Frames: 3
Frame Time: .05
0 0 0 0 0 0 0 0 0 5 0 0 0
1 2 3 90 0 0 0 0 0 5 0 0 0
0 0 0 0 0 0 0 0 90 7 0 90 0
"""


def write_text(tmp_path, text, name="clip.bvh", newline="\n"):
    path = tmp_path / name
    path.write_bytes(text.replace("\n", newline).encode())
    return path


def test_reads_hierarchy_channels_and_header(tmp_path):
    clip = bvh.read(write_text(tmp_path, TWO_BONE))
    assert clip.joint_names == ["Root", "Upper", "Lower"]
    assert list(clip.parents) == [-1, 0, 1]
    assert clip.channels[2] == ("Yposition", "Zrotation", "Yrotation", "Xrotation")
    assert clip.frame_time == pytest.approx(0.05) and clip.fps == pytest.approx(20)
    assert clip.motion.shape == (3, 13)
    assert np.allclose(clip.end_sites[2], [0, 0, 3])


def test_forward_kinematics_by_hand(tmp_path):
    pos = bvh.read(write_text(tmp_path, TWO_BONE)).world_positions(include_end_sites=True)
    assert pos.shape == (3, 4, 3)
    # frame 0: straight up; Lower's Yposition channel (5) replaces its offset's y (2)
    assert np.allclose(pos[0], [[0, 0, 0], [0, 1, 0], [0, 6, 0], [0, 6, 3]])
    # frame 1: root moved to (1, 2, 3) and rotated 90 deg about z: +y turns into -x
    assert np.allclose(pos[1], [[1, 2, 3], [0, 2, 3], [-5, 2, 3], [-5, 2, 6]])
    # frame 2: Upper rotates 90 deg about z (its third channel), Lower 90 about y:
    # Lower's end site offset (0, 0, 3) -> Ry(90) -> (3, 0, 0) -> Rz(90) -> (0, 3, 0)
    assert np.allclose(pos[2], [[0, 0, 0], [0, 1, 0], [-7, 1, 0], [-7, 4, 0]])


def test_channel_order_is_applied_in_file_order():
    rz_then_rx = axis_rotation("Z", 90) @ axis_rotation("X", 90)
    rx_then_rz = axis_rotation("X", 90) @ axis_rotation("Z", 90)
    assert not np.allclose(rz_then_rx, rx_then_rz)
    assert np.allclose(axis_rotation("Z", 90) @ [1, 0, 0], [0, 1, 0])
    assert np.allclose(axis_rotation("X", 90) @ [0, 1, 0], [0, 0, 1])
    assert np.allclose(axis_rotation("Y", 90) @ [0, 0, 1], [1, 0, 0])


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_line_endings_and_frame_time_forms(tmp_path, newline):
    text = TWO_BONE.replace("Frame Time: .05", "Frame Time: 0.05")
    clip = bvh.read(write_text(tmp_path, text, newline=newline))
    assert clip.fps == pytest.approx(20) and clip.n_frames == 3
    mixed = TWO_BONE.replace("HIERARCHY\n", "HIERARCHY\r\n").replace("MOTION\n", "MOTION\r\n")
    assert bvh.read(write_text(tmp_path, mixed, "mixed.bvh")).n_frames == 3


def test_write_read_round_trip(tmp_path):
    clip = bvh.read(write_text(tmp_path, TWO_BONE))
    rng = np.random.default_rng(1)
    clip.motion = rng.uniform(-180, 180, clip.motion.shape)
    clip.offsets = rng.normal(size=clip.offsets.shape)
    out = tmp_path / "out.bvh"
    bvh.write(out, clip)
    again = bvh.read(out)
    assert again.joint_names == clip.joint_names and again.channels == clip.channels
    assert np.array_equal(again.parents, clip.parents)
    assert np.abs(again.motion - clip.motion).max() < 1e-4
    assert np.abs(again.offsets - clip.offsets).max() < 1e-4
    assert np.allclose(again.end_sites[2], clip.end_sites[2])
    assert np.abs(again.world_positions() - clip.world_positions()).max() < 1e-3
    assert again.frame_time == pytest.approx(clip.frame_time)


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace("MOTION", "MOTON"), r"clip.bvh:\d+: no MOTION section"),
    (lambda t: t.replace("0 0 0 0 0 0 0 0 90 7 0 90 0", "0 0 0 0 0 0 0 0 90 7 0 90"),
     r"clip.bvh:26: expected 13 values, found 12"),
    (lambda t: t.replace("1 2 3 90", "1 2 x 90"), r"clip.bvh:25: bad number 'x'"),
    (lambda t: t.replace("Xrotation Yrotation Zrotation", "Xrotation Yrotation Wrotation"),
     r"clip.bvh:9: unknown channel 'Wrotation' in joint Upper"),
    (lambda t: t.replace("OFFSET 0 1 0", "OFFSET 0 one 0"), r"clip.bvh:8: bad number 'one'"),
    (lambda t: t.replace("Frames: 3", "Frames: 4"), r"clip.bvh:\d+: header says 4 frames, file has 3"),
    (lambda t: t.replace("Frame Time: .05", "Frame Tme: .05"), r"clip.bvh:23: expected 'Frame Time:'"),
    (lambda t: t.replace("ROOT Root", "ROOT Root\nBOGUS"), r"clip.bvh:3: expected '\{', found 'BOGUS'"),
    (lambda t: t.replace("\t\t}\n\t}\n}\n", "\t\t}\n\t}\n"), r"clip.bvh:\d+: unexpected end of HIERARCHY"),
])
def test_malformed_files_name_file_and_line(tmp_path, edit, message):
    with pytest.raises(ValueError, match=message):
        bvh.read(write_text(tmp_path, edit(TWO_BONE)))


def test_missing_file_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="cannot read BVH file"):
        bvh.read(tmp_path / "nope.bvh")


def test_write_rejects_inconsistent_clips(tmp_path):
    clip = bvh.read(write_text(tmp_path, TWO_BONE))
    clip.motion = clip.motion[:, :5]
    with pytest.raises(ValueError, match="motion must be"):
        bvh.write(tmp_path / "bad.bvh", clip)


def test_from_positions_writes_a_bvh_that_gives_the_positions_back(tmp_path):
    from motionlab import data, synthetic
    from motionlab.skeleton import LOCOMOTION
    motion = synthetic.random_motion(6, 20, seed=4)
    clip = bvh.from_positions(motion.positions, 20, unit_m=data.CMU_UNIT_M)
    assert set(LOCOMOTION.names) <= set(clip.joint_names)
    assert "LeftUpLeg_base" in clip.joint_names and len(clip.joint_names) == 27
    bvh.write(tmp_path / "synthetic.bvh", clip)
    back = data.load_bvh(tmp_path / "synthetic.bvh")
    assert back.fps == 20 and back.n_frames == len(motion.positions)
    assert np.abs(back.positions - motion.positions).max() < 1e-4


def test_from_positions_points_each_end_site_along_its_bone(tmp_path):
    from motionlab import data, synthetic
    from motionlab.skeleton import LOCOMOTION
    motion = synthetic.random_motion(4, 20, seed=2)
    clip = bvh.from_positions(motion.positions, 20, unit_m=data.CMU_UNIT_M)
    bvh.write(tmp_path / "ends.bvh", clip)
    back = bvh.read(tmp_path / "ends.bvh")                     # as Blender would import it
    leaves = sorted(back.end_sites)
    assert [back.joint_names[j] for j in leaves] == ["LeftToeBase", "RightToeBase", "Head",
                                                     "LeftHandIndex1", "RightHandIndex1"]
    everything = back.world_positions(include_end_sites=True) * data.CMU_UNIT_M
    joints, ends = everything[:, :len(back.joint_names)], everything[:, len(back.joint_names):]
    for k, leaf in enumerate(leaves):
        name = back.joint_names[leaf]
        parent = LOCOMOTION.parents[LOCOMOTION.index(name)]
        bone = joints[:, leaf] - motion.positions[:, parent]
        extension = ends[:, k] - joints[:, leaf]
        assert np.allclose(np.linalg.norm(extension, axis=-1), bvh.END_SITE_M, atol=1e-6)
        cosine = (bone * extension).sum(-1) / np.linalg.norm(bone, axis=-1) / bvh.END_SITE_M
        assert cosine.min() > 0.999, (name, cosine.min())      # straight on, every frame: no hooks


def test_from_positions_survives_half_turns_and_rejects_bad_shapes():
    from conftest import walker
    walk = walker(frames=100, fps=20, speed=1.0, turn_rate=np.pi)      # turns 5 half-turns
    clip = bvh.from_positions(walk, 20)
    index = [clip.joint_names.index(n) for n in
             ("Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RightUpLeg", "RightLeg",
              "RightFoot", "RightToeBase", "Spine", "Spine1", "Neck1", "Head", "LeftArm",
              "LeftForeArm", "LeftHand", "LeftHandIndex1", "RightArm", "RightForeArm",
              "RightHand", "RightHandIndex1")]
    assert np.isfinite(clip.motion).all()
    # the walker's bones stretch slightly; directions are kept, lengths become the mean
    assert np.abs(clip.world_positions()[:, index] - walk).max() < 0.05
    with pytest.raises(ValueError, match="positions: expected shape"):
        bvh.from_positions(walk[:, :20], 20)


def test_keywords_in_any_case_a_byte_order_mark_and_deep_chains(tmp_path):
    expected = bvh.read(write_text(tmp_path, TWO_BONE)).world_positions(include_end_sites=True)
    lower = TWO_BONE
    for old, new in [("HIERARCHY", "hierarchy"), ("ROOT", "root"), ("JOINT", "joint"), ("OFFSET", "offset"),
                     ("CHANNELS", "channels"), ("End Site", "end site"), ("rotation", "ROTATION"),
                     ("MOTION", "motion"), ("Frame Time:", "frame time:"), ("Frames:", "FRAMES:")]:
        lower = lower.replace(old, new)
    clip = bvh.read(write_text(tmp_path, "\ufeff" + lower, "lower.bvh"))
    assert clip.channels[1] == ("Xrotation", "Yrotation", "Zrotation")
    assert np.array_equal(clip.world_positions(include_end_sites=True), expected)
    depth = 3000                                   # far beyond Python's recursion limit
    chain = (TWO_BONE.split("\tJOINT Upper")[0]
             + "".join(f"JOINT J{k} {{ OFFSET 0 1 0\n" for k in range(depth)) + "}\n" * depth
             + "}\nMOTION\nFrames: 1\nFrame Time: 0.05\n0 0 0 0 0 0\n")
    deep = bvh.read(write_text(tmp_path, chain, "deep.bvh"))
    assert len(deep.joint_names) == depth + 1
    assert deep.world_positions()[0, -1] == pytest.approx([0, depth, 0])


@pytest.mark.parametrize("old, new, message", [
    ("OFFSET 0 1 0", "OFFSET 0 nan 0", r"clip.bvh:8: bad number 'nan' for the OFFSET of Upper: not a finite"),
    ("OFFSET 0 0 3", "OFFSET 0 0 1e400", r"clip.bvh:16: bad number '1e400' for the End Site"),
    ("1 2 3 90", "1 2 inf 90", r"clip.bvh:25: bad number 'inf' for Root Zposition: not a finite"),
    ("JOINT Lower", "JOINT Upper", r"clip.bvh:10: joint name 'Upper' is used twice \(first on line 6\)"),
    ("Frame Time: .05", "Frame Time: 0", r"clip.bvh:23: Frame Time must be between 0.0005 s"),
    ("Frame Time: .05", "Frame Time: 1e-9", r"clip.bvh:23: Frame Time must be between"),
    ("Frame Time: .05", "Frame Time: nan", r"clip.bvh:23: Frame Time must be between"),
    ("Frames: 3", "Frames: -3", r"clip.bvh:22: bad frame count '-3'"),
    ("Frames: 3", f"Frames: {10**12}", r"clip.bvh:22: header says 1000000000000 frames, file has 3"),
    (TWO_BONE, "<html><body>Not Found</body></html>\n", r"clip.bvh:1: this line starts like HTML or XML .*, not BVH"),
])
def test_non_finite_duplicate_and_absurd_values_name_file_and_line(tmp_path, old, new, message):
    with pytest.raises(ValueError, match=message):
        bvh.read(write_text(tmp_path, TWO_BONE.replace(old, new)))


def test_binary_data_is_a_value_error_naming_the_file(tmp_path):
    path = tmp_path / "clip.bvh"
    path.write_bytes(np.random.default_rng(0).bytes(2000))
    with pytest.raises(ValueError, match=r"clip\.bvh: not text: it holds NUL bytes"):
        bvh.read(path)


def test_write_rejects_duplicate_names_and_non_finite_values(tmp_path):
    clip = bvh.read(write_text(tmp_path, TWO_BONE))
    clip.joint_names[2] = "Upper"
    with pytest.raises(ValueError, match="joint names must be unique"):
        bvh.write(tmp_path / "bad.bvh", clip)
    clip = bvh.read(write_text(tmp_path, TWO_BONE))
    clip.motion[1, 4] = np.nan
    with pytest.raises(ValueError, match="must be finite"):
        bvh.write(tmp_path / "bad.bvh", clip)
