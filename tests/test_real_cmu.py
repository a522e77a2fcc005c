"""Checks on every real CMU clip in ../shared/mocap/cmu (skipped where it is absent)."""
import numpy as np
import pytest

from motionlab import bvh, data, metrics, representation as rep
from motionlab.skeleton import CMU, FEET

from conftest import CMU_DIR, cmu_files, requires_cmu

pytestmark = requires_cmu

FILES = cmu_files()
IDS = [f.stem for f in FILES]

# Cruising speed (90th percentile of forward speed, m/s) by the CMU description of each
# trial. Slow walks are listed apart: 17_03 is "walk stealthily"; 29_01 is a slow walk
# with a pause. Clips not listed (09_12, the forward/backward/sideways navigation) are
# checked by the other tests only.
WALKS = ["02_01", "03_01", "12_01", "16_11", "16_13", "16_15", "16_16", "16_17", "16_19", "16_21",
         "16_24", "16_26", "16_27", "16_30", "16_31", "16_32", "16_33", "16_58"]
SLOW_WALKS = ["17_03", "29_01"]
RUNS = ["02_03", "09_01", "09_02", "09_03", "09_04", "09_05", "09_06", "09_08", "09_09", "09_11",
        "16_08", "16_35", "16_36", "16_37", "16_39", "16_41", "16_43", "16_45", "16_46", "16_48",
        "16_49", "16_51", "16_53", "16_55", "16_57", "127_03", "127_04", "127_05", "127_06",
        "127_09", "127_11", "127_13", "127_15", "127_17"]


@pytest.fixture(scope="module")
def clips20():
    return {c.name: c for c in data.load(CMU_DIR, fps=20)}


def test_every_clip_is_covered_by_these_tests():
    assert len(FILES) >= 50
    assert set(WALKS + SLOW_WALKS + RUNS + ["09_12"]) == set(IDS)


@pytest.mark.parametrize("path", FILES, ids=IDS)
def test_reads_with_constant_bone_lengths_and_feet_on_the_floor(path):
    clip = bvh.read(path)
    assert clip.joint_names == list(CMU.names) and clip.fps == 120
    positions = clip.world_positions(include_end_sites=True) * data.CMU_UNIT_M
    parents = list(clip.parents) + list(clip.end_sites)
    child = np.arange(1, len(parents))
    lengths = np.linalg.norm(positions[:, child] - positions[:, np.array(parents)[child]], axis=-1)
    real = lengths.mean(0) > 1e-6                               # skip zero-length helper bones
    relative = np.abs(lengths[:, real] - lengths[:1, real]) / lengths[:1, real]
    assert relative.max() < 1e-6
    lowest_foot = (clip.world_positions() * data.CMU_UNIT_M)[:, [4, 5, 9, 10], 1].min(axis=1)
    assert -0.02 < lowest_foot.min() < 0.06, "some foot joint comes within a few cm of y = 0"
    if path.stem != "03_01":                                    # 03_01 steps over obstacles
        assert np.median(lowest_foot) < 0.07


@pytest.mark.parametrize("fps", [120, 20])
def test_representation_round_trip_within_a_millimetre(fps):
    worst = 0.0
    for path in FILES:
        clip = data.load_bvh(path, fps=fps)
        features = clip.features()
        back = rep.to_positions(features, fps, start=rep.root_start(clip.positions, fps))
        worst = max(worst, np.abs(back - clip.positions).max())
    assert worst < 1e-3


def test_cgspeed_tpose_frame_is_dropped():
    raw = bvh.read(CMU_DIR / "12_01.bvh")
    assert data.has_tpose_frame(raw) and raw.n_frames == 524
    assert data.load_bvh(CMU_DIR / "12_01.bvh").n_frames == 523
    assert not data.has_tpose_frame(bvh.read(CMU_DIR / "16_15.bvh"))


def test_walking_and_running_speeds(clips20):
    def cruising(name):
        return np.percentile(np.abs(clips20[name].features()[:, rep.CONTROL][:, 0]), 90)
    for name in WALKS:
        assert 0.8 <= cruising(name) <= 2.0, name
    for name in SLOW_WALKS:
        assert 0.3 <= cruising(name) < 0.8, name
    for name in RUNS:
        assert 2.0 <= cruising(name) <= 5.0, name


def test_navigation_clip_walks_backwards(clips20):
    forward = clips20["09_12"].features()[:, 63]
    assert forward.max() > 0.8 and forward.min() < -0.8


def test_body_faces_forward_in_the_root_frame(clips20):
    for name, clip in clips20.items():
        pose = clip.features()[:, rep.POSE].reshape(-1, 21, 3).mean(0)
        assert pose[1, 0] > 0.05 and pose[5, 0] < -0.05, name  # left hip at +x, right at -x
        assert pose[4, 2] > pose[3, 2], name                   # toes ahead of the ankle


def test_mirrored_and_reversed_clips_stay_valid(clips20):
    clip = clips20["16_17"]
    f = clip.features()
    for augmented in data.augment(f, 20):
        world = rep.to_positions(augmented, 20)
        assert metrics.bone_length_drift(world) < 0.01
        assert np.abs(world[:, list(FEET), 1].min()) < 0.06


def test_real_clip_metrics_are_in_a_sane_range(clips20):
    skating = np.array([metrics.foot_skating(c.positions, 20) for c in clips20.values()])
    drift = np.array([metrics.bone_length_drift(c.positions) for c in clips20.values()])
    assert np.median(skating) < 0.10                               # m/s (6 cm/s: planted feet count fully)
    assert drift.max() < 0.005                                    # resampling to 20 fps
