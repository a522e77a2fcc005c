"""Acclaim ASF/AMC reading and forward kinematics: small hand-made files, then every CMU
trial in ../shared/mocap/cmu_asfamc against its BVH conversion in ../shared/mocap/cmu."""
import re

import numpy as np
import pytest

from motionlab import asfamc
from motionlab.rotations import axis_rotation, euler_to_matrix
from motionlab.skeleton import LOCOMOTION

from conftest import CMU_DIR

# A root, a chain of two moving bones, and a tip that never moves relative to its parent.
# ``upper``'s axis frame is turned 90 degrees about z, so its rx turns about world y.
ASF_TEXT = """# AST/ASF file, hand-made
:version 1.10
:name chain
:units
  mass 1.0
  length 0.45
  angle deg
:documentation
   a two-bone chain for tests
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name upper
     direction 0 1 0
     length 2
     axis 0 0 90 XYZ
    dof rx rz
    limits (-180.0 180.0)
           (-90.0 90.0)
  end
  begin
     id 2
     name lower
     direction 1 0 0
     length 3
     axis 0 0 0 XYZ
    dof ry
    limits (-10.0 170.0)
  end
  begin
     id 3
     name tip
     direction 0 0 1
     length 1
     axis 0 0 0 XYZ
  end
:hierarchy
  begin
    root upper
    upper lower
    lower tip
  end
"""

AMC_TEXT = """#!OML:ASF chain.asf
:FULLY-SPECIFIED
:DEGREES
1
root 0 0 0 0 0 0
upper 0 0
lower 0
2
root 1 2 3 0 0 90
upper 0 0
lower 0
3
root 0 0 0 0 0 0
upper 90 0
lower 90
4
root 0 0 0 0 0 0
lower 90
5
root 0 0 0 0 0 0
upper 90 90
lower 0
6
root 0 0 0 90 0 90
upper 0 0
lower 0
"""

# Root, upper end, lower end, tip end, worked out by hand (see test_forward_kinematics_by_hand).
EXPECTED = np.array([
    [[0, 0, 0], [0, 2, 0], [3, 2, 0], [3, 2, 1]],          # 1: rest pose
    [[1, 2, 3], [-1, 2, 3], [-1, 5, 3], [-1, 5, 4]],       # 2: moved, turned 90 about z
    [[0, 0, 0], [0, 2, 0], [-3, 2, 0], [-3, 2, -1]],       # 3: upper rx in its own frame
    [[0, 0, 0], [0, 2, 0], [0, 2, -3], [1, 2, -3]],        # 4: upper missing -> rest
    [[0, 0, 0], [-2, 0, 0], [-2, 0, -3], [-2, 1, -3]],     # 5: rx then rz, in that order
    [[0, 0, 0], [0, 0, 2], [0, 3, 2], [1, 3, 2]],          # 6: root RX then RZ
], dtype=float)

SHARED = CMU_DIR.parent / "cmu_asfamc"
TRIALS = sorted(p.stem for p in SHARED.glob("*.amc")
                if (CMU_DIR / f"{p.stem}.bvh").is_file()) if SHARED.is_dir() else []
requires_asfamc = pytest.mark.skipif(
    not TRIALS, reason=f"CMU ASF/AMC files (with BVH twins in {CMU_DIR}) not found in {SHARED}")


def write(tmp_path, name, text, newline="\n"):
    path = tmp_path / name
    path.write_bytes(text.replace("\n", newline).encode())
    return path


def chain(tmp_path, asf_text=ASF_TEXT, amc_text=AMC_TEXT):
    asf = asfamc.read_asf(write(tmp_path, "chain.asf", asf_text))
    return asf, asfamc.read_amc(write(tmp_path, "chain_01.amc", amc_text), asf)


def line_of(text, needle):
    """1-based number of the first line of ``text`` containing ``needle``."""
    return next(n for n, line in enumerate(text.splitlines(), 1) if needle in line)


# --------------------------------------------------------------------------- parsing

def test_reads_units_root_bones_and_hierarchy(tmp_path):
    asf, _ = chain(tmp_path)
    assert (asf.name, asf.mass, asf.length, asf.angle) == ("chain", 1.0, 0.45, "deg")
    assert asf.root_order == ("TX", "TY", "TZ", "RX", "RY", "RZ") and asf.root_axis == "XYZ"
    assert asf.bone_names == ["upper", "lower", "tip"]
    upper = asf.bone("upper")
    assert upper.id == 1 and upper.length == 2 and np.allclose(upper.direction, [0, 1, 0])
    assert np.allclose(upper.axis, [0, 0, 90]) and upper.axis_order == "XYZ"
    assert upper.dof == ("rx", "rz")
    assert np.allclose(upper.limits, [[-180, 180], [-90, 90]])
    assert asf.bone("tip").dof == () and asf.bone("tip").limits.shape == (0, 2)
    assert asf.children == {"root": ("upper",), "upper": ("lower",), "lower": ("tip",)}
    assert asf.parents == {"upper": "root", "lower": "upper", "tip": "lower"}
    assert asf.topological_order() == ["upper", "lower", "tip"]
    assert asfamc.metres_per_unit(asf) == pytest.approx(0.0254 / 0.45)


def test_reads_frames_per_bone_and_fills_missing_bones_with_zeros(tmp_path):
    _, amc = chain(tmp_path)
    assert amc.n_frames == 6 and amc.first_frame == 1
    assert amc.fully_specified and amc.angle == "deg"
    assert amc.values["root"].shape == (6, 6) and amc.values["upper"].shape == (6, 2)
    assert amc.values["lower"].shape == (6, 1) and amc.values["tip"].shape == (6, 0)
    assert np.allclose(amc.values["root"][1], [1, 2, 3, 0, 0, 90])
    assert np.allclose(amc.values["upper"][:, 0], [0, 0, 90, 0, 90, 0])   # frame 4: missing
    assert np.allclose(amc.values["lower"][:, 0], [0, 0, 90, 90, 0, 0])


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_line_endings_and_comments(tmp_path, newline):
    amc_text = AMC_TEXT.replace("2\nroot", "# a comment between frames\n\n2\nroot")
    asf = asfamc.read_asf(write(tmp_path, "chain.asf", ASF_TEXT, newline))
    amc = asfamc.read_amc(write(tmp_path, "chain_01.amc", amc_text, newline), asf)
    assert amc.n_frames == 6
    assert np.allclose(asfamc.world_positions(asf, amc)[0], EXPECTED)


def test_radians_in_either_file_come_back_as_degrees(tmp_path):
    asf_text = (ASF_TEXT.replace("angle deg", "angle rad")
                .replace("axis 0 0 90 XYZ", f"axis 0 0 {np.pi / 2!r} XYZ")
                .replace("(-180.0 180.0)", f"({-np.pi!r} {np.pi!r})")
                .replace("(-10.0 170.0)", "(-0.5 1.5)"))
    amc_text = re.sub(r"\b90\b", repr(np.pi / 2), AMC_TEXT.replace(":DEGREES", ":RADIANS"))
    asf, amc = chain(tmp_path, asf_text, amc_text)
    assert np.allclose(asf.bone("upper").axis, [0, 0, 90])
    assert np.allclose(asf.bone("upper").limits[0], [-180, 180])
    assert np.allclose(asf.bone("lower").limits[0], np.rad2deg([-0.5, 1.5]))
    assert amc.angle == "rad" and np.allclose(amc.values["upper"][4], [90, 90])
    assert np.allclose(amc.values["root"][1], [1, 2, 3, 0, 0, 90])      # translations kept
    assert np.allclose(asfamc.world_positions(asf, amc)[0], EXPECTED)


# --------------------------------------------------------------------------- kinematics

def test_euler_order_is_first_letter_first():
    angles = np.array([30.0, -50.0, 70.0])
    expected = axis_rotation("Z", 70) @ axis_rotation("Y", -50) @ axis_rotation("X", 30)
    assert np.allclose(euler_to_matrix(angles, "XYZ"), expected)
    assert not np.allclose(euler_to_matrix(angles, "XYZ"), expected.T)
    assert np.allclose(euler_to_matrix(angles[::-1], "ZYX"),
                       axis_rotation("X", 30) @ axis_rotation("Y", -50) @ axis_rotation("Z", 70))


def test_forward_kinematics_by_hand(tmp_path):
    """EXPECTED, worked out with Rz(90): x -> y -> -x, Ry(90): z -> x -> -z, Rx(90): y -> z -> -y.

    2: root at (1, 2, 3) turned by Rz(90): upper (0, 2, 0) -> (-2, 0, 0), lower (3, 0, 0)
       -> (0, 3, 0), tip (0, 0, 1) unchanged.
    3: upper's frame C = Rz(90), so rx = 90 is C Rx(90) C^-1 = Ry(90): upper (along y)
       stays; lower adds its own Ry(90): Ry(180) (3, 0, 0) = (-3, 0, 0), tip -> (0, 0, -1).
    4: upper not given (rest); lower Ry(90): (3, 0, 0) -> (0, 0, -3), tip -> (1, 0, 0).
    5: upper rx 90 then rz 90: L = C Rz(90) Rx(90) C^-1 takes (0, 2, 0) -> (-2, 0, 0),
       (3, 0, 0) -> (0, 0, -3) and (0, 0, 1) -> (0, 1, 0).
    6: root RX 90 then RZ 90: Rz(90) Rx(90) takes (0, 2, 0) -> (0, 0, 2), (3, 0, 0) ->
       (0, 3, 0), (0, 0, 1) -> (1, 0, 0).
    """
    asf, amc = chain(tmp_path)
    positions, names = asfamc.world_positions(asf, amc)
    assert names == ["root", "upper", "lower", "tip"]
    assert positions.shape == (6, 4, 3)
    assert np.allclose(positions, EXPECTED)
    rotations, again, _ = asfamc.world_transforms(asf, amc)
    assert np.allclose(again, positions)
    assert np.allclose(rotations[:, 3], rotations[:, 2])        # tip has no dof
    assert np.allclose(rotations @ np.swapaxes(rotations, -1, -2), np.eye(3))


def test_root_position_orientation_and_translation_dofs(tmp_path):
    asf_text = (ASF_TEXT.replace("position 0 0 0", "position 0 10 0")
                .replace("dof ry\n    limits (-10.0 170.0)", "dof ry l")
                .replace("name tip\n     direction 0 0 1\n     length 1\n     axis 0 0 0 XYZ",
                         "name tip\n     direction 0 0 1\n     length 1\n     axis 0 0 90 XYZ\n"
                         "    dof tx"))
    amc_text = "1\nroot 0 0 0 0 0 0\nupper 0 0\nlower 0 2\ntip 0.5\n"
    asf, amc = chain(tmp_path, asf_text, amc_text)
    positions, _ = asfamc.world_positions(asf, amc)
    # lower stretched by l = 2 along its direction; tip moved 0.5 along its frame's x (= world y)
    assert np.allclose(positions[0], [[0, 10, 0], [0, 12, 0], [5, 12, 0], [5, 12.5, 1]])


# --------------------------------------------------------------------------- malformed files

ASF_ERRORS = [
    (":documentation", ":documents", ":documents", r"unknown section ':documents'"),
    ("length 2\n", "length two\n", "length two", r"bad number 'two' for length"),
    ("dof ry\n", "dof rw\n", "dof rw", r"unknown dof 'rw'"),
    ("axis 0 0 0 XYZ\n    dof ry", "axis 0 0 0 XYY\n    dof ry", "XYY", r"axis order must be"),
    ("(-90.0 90.0)\n", "(-90.0 90.0) (0 1)\n", "limits (-180", r"bone upper has 2 dofs but 3 limits"),
    ("    lower tip\n", "    lower tip elbow\n", "lower tip elbow", r"unknown bone 'elbow' in :hierarchy"),
    ("     name tip", "     nme tip", "nme tip", r"unknown bone keyword 'nme'"),
    ("    upper lower\n", "    upper lower\n    root lower\n", "root lower", r"'root' listed twice"),
    ("  begin\n     id 3", "  begin\n     id 3\n  begin", "id 3", r"'begin' inside a bone"),
]


@pytest.mark.parametrize("old, new, where, message", ASF_ERRORS, ids=[e[3][:20] for e in ASF_ERRORS])
def test_malformed_asf_names_file_and_line(tmp_path, old, new, where, message):
    assert old in ASF_TEXT
    text = ASF_TEXT.replace(old, new, 1)
    line = line_of(text, where) + (1 if "inside" in message else 0)
    with pytest.raises(ValueError, match=rf"chain\.asf:{line}: {message}"):
        asfamc.read_asf(write(tmp_path, "chain.asf", text))


def test_asf_without_hierarchy_or_with_loose_bones(tmp_path):
    no_hierarchy = ASF_TEXT[:ASF_TEXT.index(":hierarchy")]
    last_line = len(no_hierarchy.splitlines())
    with pytest.raises(ValueError, match=rf"chain\.asf:{last_line}: no :hierarchy section"):
        asfamc.read_asf(write(tmp_path, "chain.asf", no_hierarchy))
    loose = ASF_TEXT.replace("    lower tip\n", "")
    with pytest.raises(ValueError, match=rf"chain\.asf:{line_of(loose, ':hierarchy')}: "
                                         r"bones not connected to the root in :hierarchy: tip"):
        asfamc.read_asf(write(tmp_path, "chain.asf", loose))


AMC_ERRORS = [
    ("lower 90\n5", "elbow 90\n5", "elbow 90", r"bone 'elbow' is not in the skeleton"),
    ("upper 90 0\n", "upper 90\n", "upper 90\n", r"bone upper has 2 dofs, found 1 values"),
    ("upper 90 0\n", "upper 90 0 0\n", "upper 90 0 0", r"bone upper has 2 dofs, found 3 values"),
    ("root 1 2 3 0", "root 1 2 x 0", "root 1 2 x", r"bad number 'x' for bone root"),
    ("\n5\n", "\n7\n", "7", r"frame 7 follows frame 4; frames must be contiguous"),
    (":DEGREES", ":SECONDS", ":SECONDS", r"unknown keyword ':SECONDS'"),
    ("lower 90\n4", "lower 90\nlower 90\n4", "lower 90\nlower 90", r"bone lower given twice in frame 3"),
    (":DEGREES\n1\n", ":DEGREES\nroot 0 0 0 0 0 0\n1\n", "root 0 0 0 0 0 0", r"expected a frame number"),
    ("\n3\n", "\n3 three\n", "3 three", r"a frame number line must hold only the number"),
]


@pytest.mark.parametrize("old, new, where, message", AMC_ERRORS, ids=[e[3][:20] for e in AMC_ERRORS])
def test_malformed_amc_names_file_and_line(tmp_path, old, new, where, message):
    assert old in AMC_TEXT
    text = AMC_TEXT.replace(old, new, 1)
    start = text.index(where) + (where.index("\n") + 1 if "twice" in message else 0)
    line = text[:start].count("\n") + 1
    asf = asfamc.read_asf(write(tmp_path, "chain.asf", ASF_TEXT))
    with pytest.raises(ValueError, match=rf"chain_01\.amc:{line}: {message}"):
        asfamc.read_amc(write(tmp_path, "chain_01.amc", text), asf)


def test_a_frame_without_bones_is_refused_before_any_array_is_made(tmp_path):
    asf = asfamc.read_asf(write(tmp_path, "chain.asf", ASF_TEXT))
    head = AMC_TEXT.split("\n3\n")[0]                       # frames 1 and 2
    bare = head + "\n3\n\n# nothing here\n4\nroot 0 0 0 0 0 0\n"
    line = head.count("\n") + 2                              # frame 3's line
    with pytest.raises(ValueError, match=rf"chain_01\.amc:{line}: frame 3 gives no bone \(the next line is frame 4\)"):
        asfamc.read_amc(write(tmp_path, "chain_01.amc", bare), asf)
    # a file of bare frame numbers (millions of them would make gigabytes of rest poses)
    numbers = ":FULLY-SPECIFIED\n:DEGREES\n1\nroot 0 0 0 0 0 0\n" + "\n".join(map(str, range(2, 200_000))) + "\n"
    with pytest.raises(ValueError, match=r"chain_01\.amc:5: frame 2 gives no bone"):
        asfamc.read_amc(write(tmp_path, "chain_01.amc", numbers), asf)


def test_missing_files_and_skeleton_lookup(tmp_path):
    with pytest.raises(ValueError, match="cannot read ASF file"):
        asfamc.read_asf(tmp_path / "nope.asf")
    amc_path = write(tmp_path, "16_15.amc", AMC_TEXT)
    with pytest.raises(ValueError, match=r"16_15\.amc: its skeleton 16\.asf is not in"):
        asfamc.load_locomotion(amc_path)
    with pytest.raises(ValueError, match="cannot tell the subject from the name"):
        asfamc.skeleton_path(tmp_path / "walk.amc")
    write(tmp_path, "16.asf", ASF_TEXT)
    assert asfamc.skeleton_path(amc_path) == tmp_path / "16.asf"
    with pytest.raises(ValueError, match="not a CMU skeleton, missing bones"):
        asfamc.load_locomotion(amc_path)


def test_locomotion_mapping_covers_the_21_joints():
    assert tuple(asfamc.LOCOMOTION_FROM_ASF) == LOCOMOTION.names
    assert asfamc.LOCOMOTION_FROM_ASF["LeftUpLeg"] == "lhipjoint"
    assert asfamc.LOCOMOTION_FROM_ASF["LeftToeBase"] == "lfoot"
    assert set(asfamc.LOCOMOTION_BELOW_THORAX) <= set(LOCOMOTION.names)


# --------------------------------------------------------------------------- real CMU data

UPPER_BODY = [n for n in LOCOMOTION.names if n not in asfamc.LOCOMOTION_BELOW_THORAX]
FINGERS = ["LeftHandIndex1", "RightHandIndex1"]


@pytest.fixture(scope="module")
def cmu_unit_m():
    from motionlab.clip import CMU_UNIT_M
    return CMU_UNIT_M


@requires_asfamc
@pytest.mark.parametrize("trial", TRIALS)
def test_cmu_trial_matches_its_bvh_conversion(trial, cmu_unit_m):
    """Legs, root and spine agree within 1 mm; above the thorax the BVH is shifted by
    exactly the thorax vector (plus the wrist vector for the fingers), which it drops."""
    from motionlab import data
    amc_path = SHARED / f"{trial}.amc"
    asf = asfamc.read_asf(asfamc.skeleton_path(amc_path))
    assert asfamc.metres_per_unit(asf) == pytest.approx(cmu_unit_m)
    positions, fps = asfamc.load_locomotion(amc_path)
    reference = data.load_bvh(CMU_DIR / f"{trial}.bvh", drop_tpose=False)
    assert fps == reference.fps == 120
    assert positions.shape == reference.positions.shape

    difference = positions - reference.positions                      # (frames, 21, 3) metres
    exact = [LOCOMOTION.index(n) for n in asfamc.LOCOMOTION_BELOW_THORAX]
    assert np.linalg.norm(difference[:, exact], axis=-1).max() < 1e-3

    ends, names = asfamc.world_positions(asf, asfamc.read_amc(amc_path, asf))
    vector = {bone: (ends[:, names.index(bone)] - ends[:, names.index(asf.parents[bone])])
              * asfamc.metres_per_unit(asf) for bone in ("thorax", "lwrist", "rwrist")}
    for name in UPPER_BODY:
        dropped = vector["thorax"] + (vector[name[0].lower() + "wrist"] if name in FINGERS else 0)
        assert np.linalg.norm(difference[:, LOCOMOTION.index(name)] - dropped, axis=-1).max() < 1e-3, name
    thorax = asf.bone("thorax").length * asfamc.metres_per_unit(asf)
    wrist = max(asf.bone("lwrist").length, asf.bone("rwrist").length) * asfamc.metres_per_unit(asf)
    body = [LOCOMOTION.index(n) for n in UPPER_BODY if n not in FINGERS]
    assert np.linalg.norm(difference[:, body], axis=-1).max() <= thorax + 1e-3
    fingers = [LOCOMOTION.index(n) for n in FINGERS]
    assert np.linalg.norm(difference[:, fingers], axis=-1).max() <= thorax + wrist + 1e-3


@requires_asfamc
def test_cmu_clip_loads_like_a_bvh_clip():
    from motionlab import data
    clip = asfamc.load_clip(SHARED / "16_15.amc", fps=20)
    reference = data.load_bvh(CMU_DIR / "16_15.bvh", fps=20, drop_tpose=False)
    assert clip.name == "16_15" and clip.fps == 20
    assert clip.positions.shape == reference.positions.shape
    below_thorax = [LOCOMOTION.index(n) for n in asfamc.LOCOMOTION_BELOW_THORAX]
    assert np.abs(clip.positions - reference.positions)[:, below_thorax].max() < 1e-3
    hips_height = clip.positions[:, LOCOMOTION.index("Hips"), 1]
    assert 0.8 < np.median(hips_height) < 1.1                       # metres
    assert re.search(r"16_15\.amc$", clip.source)


# --------------------------------------------------------------------------- malformed and variant files
# (the same on real CMU files: tests/test_malformed_files.py)

@pytest.mark.parametrize("old, new, where, message", [
    ("length 2\n", "length nan\n", "length nan", r"bad number 'nan' for length: not a finite number"),
    ("length 3\n", "length -3\n", "length -3", r"length must be >= 0, got -3"),
    ("direction 1 0 0", "direction 0 0 0", "direction 0 0 0", r"direction 0 0 0 has length zero"),
    ("direction 0 1 0", "direction 0 1e400 0", "1e400", r"bad number '1e400' for direction"),
    ("axis 0 0 90 XYZ", "axis 0 inf 90 XYZ", "axis 0 inf", r"bad number 'inf' for axis"),
    ("(-10.0 170.0)", "(nan 170.0)", "(nan 170.0)", r"bad number 'nan' for a limit"),
    ("position 0 0 0", "position 0 nan 0", "position 0 nan", r"bad number 'nan' for root position"),
])
def test_non_finite_and_degenerate_asf_values_name_file_and_line(tmp_path, old, new, where, message):
    assert old in ASF_TEXT
    text = ASF_TEXT.replace(old, new, 1)
    with pytest.raises(ValueError, match=rf"chain\.asf:{line_of(text, where)}: {message}"):
        asfamc.read_asf(write(tmp_path, "chain.asf", text))


def test_asf_keywords_in_upper_case_inf_limits_and_a_byte_order_mark(tmp_path):
    upper = re.sub(r"(?m)^(\s*)(:\w+|begin|end|id|name|direction|length|axis|dof|limits|mass|angle|order|"
                   r"position|orientation)\b", lambda m: m.group(1) + m.group(2).upper(), ASF_TEXT)
    upper = "\ufeff" + upper.replace("(-10.0 170.0)", "(-inf inf)").replace("root upper", "ROOT upper")
    asf, amc = chain(tmp_path, asf_text=upper)
    assert asf.bone("lower").limits.tolist() == [[-np.inf, np.inf]]
    assert np.allclose(asfamc.world_positions(asf, amc)[0], EXPECTED)


@pytest.mark.parametrize("text, message", [
    ("", r"chain_01\.amc: no frames: the file is empty"),
    (":FULLY-SPECIFIED\n:DEGREES\n", r"chain_01\.amc:2: no frames: the file has only a header"),
    (AMC_TEXT.replace("upper 90 0\n", "upper 90 nan\n"),
     r"chain_01\.amc:14: bad number 'nan' for bone upper: not a finite number"),
    (AMC_TEXT.replace("\n5\n", f"\n{10**20}\n"),
     r"chain_01\.amc:19: frame number 100000000000000000000 is too large"),
    ("#!OML:ASF chain.asf\n<!DOCTYPE html>\n<html></html>\n",
     r"chain_01\.amc:2: this line starts like HTML or XML .*, not AMC"),
])
def test_empty_non_finite_and_html_amc_files_name_file_and_line(tmp_path, text, message):
    asf = asfamc.read_asf(write(tmp_path, "chain.asf", ASF_TEXT))
    with pytest.raises(ValueError, match=message):
        asfamc.read_amc(write(tmp_path, "chain_01.amc", text), asf)


def test_amc_cut_short_loses_its_last_frame_with_a_warning(tmp_path):
    cut = AMC_TEXT[:AMC_TEXT.rindex("upper 0 0")]              # frame 6 ends after its root line
    asf = asfamc.read_asf(write(tmp_path, "chain.asf", ASF_TEXT))
    with pytest.warns(UserWarning, match=r"chain_01\.amc:\d+: the last frame \(6\) is incomplete"):
        amc = asfamc.read_amc(write(tmp_path, "chain_01.amc", cut), asf)
    assert amc.n_frames == 5
    assert np.allclose(asfamc.world_positions(asf, amc)[0], EXPECTED[:5])


def test_load_checks_frame_rates_and_finds_an_uppercase_skeleton(tmp_path):
    amc_path = write(tmp_path, "16_15.amc", AMC_TEXT)
    write(tmp_path, "16.ASF", ASF_TEXT)
    assert asfamc.skeleton_path(amc_path).name == "16.ASF"
    for bad in (0, -120, float("nan"), 1e9):
        with pytest.raises(ValueError, match=r"^fps: "):
            asfamc.load_locomotion(amc_path, fps=bad)
        with pytest.raises(ValueError, match=r"^fps: "):
            asfamc.load_clip(amc_path, fps=bad)
        with pytest.raises(ValueError, match=r"^source_fps: "):
            asfamc.load_clip(amc_path, source_fps=bad)
