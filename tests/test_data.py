import numpy as np
import pytest
import torch

from motionlab import bvh, data
from motionlab.representation import mirror_features, reverse_features
from motionlab.skeleton import CMU_JOINTS, CMU_PARENTS

from conftest import walker


def clips_for_tests(n=10, fps=20.0):
    return [data.Clip(f"c{i:02d}", walker(frames=60 + 10 * i, fps=fps, speed=0.5 + 0.3 * i,
                                          turn_rate=0.1 * (i - 5)), fps, f"gen/c{i:02d}")
            for i in range(n)]


def cmu_like_bvh(path, frames=30, tpose=False):
    """A 31-joint CMU-named BVH with small random rotations (and optionally a T-pose frame 0)."""
    rng = np.random.default_rng(0)
    offsets = rng.normal(0, 1, (31, 3))
    offsets[0] = 0
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")] + \
        [("Zrotation", "Yrotation", "Xrotation")] * 30
    motion = rng.normal(0, 10, (frames, 96))
    motion[:, :3] = [0, 17, 0] + np.arange(frames)[:, None] * [0, 0, 0.2]
    if tpose:
        motion[0] = 0
        motion[0, 1], motion[0, 9] = 16, -21
    clip = bvh.BVH(list(CMU_JOINTS), CMU_PARENTS, offsets, channels, motion, 1 / 120)
    bvh.write(path, clip)
    return clip


def test_cut_windows_lengths_and_short_clips():
    x = np.arange(100)[:, None] * np.ones((1, 3))
    w = data.cut_windows(x, 40, 20)
    assert w.shape == (4, 40, 3) and w[1, 0, 0] == 20 and w[-1, -1, 0] == 99
    assert data.cut_windows(x[:30], 40, 20).shape == (0, 40, 3)
    with pytest.raises(ValueError, match="stride"):
        data.cut_windows(x, 40, 0)


def test_split_is_by_clip_disjoint_and_seeded():
    clips = clips_for_tests(10)
    s = data.split_clips(clips, (0.8, 0.1, 0.1), seed=0)
    names = [[c.name for c in s[k]] for k in ("train", "val", "test")]
    assert [len(n) for n in names] == [8, 1, 1]
    assert len(set(sum(names, []))) == 10
    assert names == [[c.name for c in data.split_clips(clips, seed=0)[k]] for k in ("train", "val", "test")]
    assert names != [[c.name for c in data.split_clips(clips, seed=1)[k]] for k in ("train", "val", "test")]
    with pytest.raises(ValueError, match="fractions"):
        data.split_clips(clips, (0.5, 0.1, 0.1))
    with pytest.raises(ValueError, match="too few"):
        data.split_clips(clips[:2], (0.0, 0.5, 0.5))


def test_augmentation_copies_and_identities():
    f = clips_for_tests(1)[0].features()
    copies = data.augment(f, 20)
    assert len(copies) == 4
    assert np.array_equal(copies[1], mirror_features(f))
    assert np.allclose(copies[3], reverse_features(mirror_features(f), 20))
    assert np.array_equal(mirror_features(copies[1]), f)
    assert np.allclose(reverse_features(copies[2], 20), f, atol=1e-12)
    assert len(data.augment(f, 20, ("mirror",))) == 2 and len(data.augment(f, 20, ())) == 1
    with pytest.raises(ValueError, match="unknown kinds"):
        data.augment(f, 20, ("rotate",))


def test_normalizer_fit_apply_save_load(tmp_path):
    rng = np.random.default_rng(0)
    x = rng.normal(3, 2, (500, 4))
    x[:, 2] = 7.0                                            # a constant feature
    norm = data.Normalizer.fit(x)
    z = norm.normalize(x)
    assert np.allclose(z.mean(0), 0, atol=1e-9) and np.allclose(z[:, [0, 1, 3]].std(0), 1)
    assert np.all(np.isfinite(z)) and norm.std[2] == 1.0
    t = torch.as_tensor(x, dtype=torch.float32)
    assert torch.allclose(norm.denormalize(norm.normalize(t)), t, atol=1e-5)
    norm.save(tmp_path / "norm.json")
    again = data.Normalizer.load(tmp_path / "norm.json")
    assert np.array_equal(again.mean, norm.mean) and np.array_equal(again.std, norm.std)
    with pytest.raises(ValueError, match="last dimension 4"):
        norm.normalize(np.zeros((3, 5)))
    (tmp_path / "bad.json").write_text("{nope")
    with pytest.raises(ValueError, match="bad.json: not a saved Normalizer"):
        data.Normalizer.load(tmp_path / "bad.json")
    with pytest.raises(ValueError, match="missing 'std'"):
        data.Normalizer.from_state_dict({"mean": [0.0]})


def test_prepare_builds_normalised_datasets():
    clips = clips_for_tests(10) + [data.Clip("tiny", walker(frames=20), 20.0, "gen/tiny")]
    md = data.prepare(clips, window_s=2.0, stride_s=1.0, seed=0)
    assert md.fps == 20 and md.description["window_frames"] == 40
    assert md.description["dropped_short"] == ["tiny"]
    x = md.train[0]
    assert x.shape == (40, 66) and x.dtype == torch.float32
    train_names = set(md.description["clips"]["train"])
    assert train_names.isdisjoint(md.description["clips"]["test"])
    n_train_windows = sum(len(data.cut_windows(c.features(), 40, 20)) for c in md.clips["train"])
    assert len(md.train) == 4 * n_train_windows                 # mirror x reverse
    all_train = md.train.windows.numpy().reshape(-1, 66)
    assert np.allclose(all_train.mean(0), 0, atol=1e-4)
    assert "train" in md.summary() and "dropped" in md.summary()
    batch = next(iter(torch.utils.data.DataLoader(md.train, batch_size=8)))
    assert batch.shape == (8, 40, 66)
    with pytest.raises(ValueError, match="shorter than a 40-frame window: tiny"):
        data.prepare(clips, window_s=2.0, short_clips="error")
    with pytest.raises(ValueError, match="one frame rate"):
        data.prepare(clips + [data.Clip("fast", walker(fps=30), 30.0)], window_s=2.0)


def test_load_bvh_maps_to_21_joints_resamples_and_drops_tpose(tmp_path):
    cmu_like_bvh(tmp_path / "a.bvh", frames=121)
    cmu_like_bvh(tmp_path / "b.bvh", frames=121, tpose=True)
    a = data.load_bvh(tmp_path / "a.bvh")
    b = data.load_bvh(tmp_path / "b.bvh")
    assert a.positions.shape == (121, 21, 3) and a.fps == pytest.approx(120, rel=1e-4)
    assert b.n_frames == 120                                   # T-pose frame dropped
    assert data.load_bvh(tmp_path / "b.bvh", drop_tpose=False).n_frames == 121
    assert a.positions[0, 0, 1] == pytest.approx(17 * data.CMU_UNIT_M)
    clips = data.load(tmp_path, fps=20)
    assert [c.name for c in clips] == ["a", "b"] and clips[0].n_frames == 21 and clips[0].fps == 20
    assert len(data.load(tmp_path / "a.bvh")) == 1


def test_load_errors_name_the_problem(tmp_path):
    with pytest.raises(ValueError, match="neither .synthetic., a folder nor a file"):
        data.load(tmp_path / "missing")
    with pytest.raises(ValueError, match="no .bvh or .amc files"):
        data.load(tmp_path)
    clip = cmu_like_bvh(tmp_path / "x.bvh")
    clip.joint_names[4] = "LeftAnkle"
    bvh.write(tmp_path / "renamed.bvh", clip)
    with pytest.raises(ValueError, match="renamed.bvh: not a CMU-style skeleton, missing joints LeftFoot"):
        data.load_bvh(tmp_path / "renamed.bvh")


def test_a_folder_of_asf_amc_loads_like_a_folder_of_bvh(tmp_path):
    from conftest import CMU_DIR
    asfamc_dir = CMU_DIR.parent / "cmu_asfamc"
    if not (asfamc_dir / "16.asf").is_file():
        pytest.skip(f"CMU ASF/AMC files not found in {asfamc_dir}")
    import shutil
    for name in ("16.asf", "16_15.amc", "16_35.amc"):
        shutil.copy(asfamc_dir / name, tmp_path / name)
    from_amc = data.load(tmp_path, fps=20)
    from_bvh = data.load([CMU_DIR / "16_15.bvh", CMU_DIR / "16_35.bvh"], fps=20)
    assert [c.name for c in from_amc] == ["16_15", "16_35"]
    legs = [0, 1, 2, 3, 4, 5, 6, 7, 8]
    for a, b in zip(from_amc, from_bvh):
        assert a.positions.shape == b.positions.shape and a.fps == b.fps
        assert np.abs(a.positions[:, legs] - b.positions[:, legs]).max() < 1e-3
    shutil.copy(CMU_DIR / "16_15.bvh", tmp_path / "16_15.bvh")
    with pytest.raises(ValueError, match=r"trials in two formats \(16_15\)"):
        data.load(tmp_path)


# --------------------------------------------------------------------------- argument checks

BAD_RATES = [0, -20, float("nan"), float("inf"), 1e9, "20", True]


@pytest.mark.parametrize("bad", BAD_RATES + [None])
def test_load_checks_fps_and_names_it(tmp_path, bad):
    cmu_like_bvh(tmp_path / "a.bvh")
    for source in (tmp_path, tmp_path / "a.bvh", "synthetic"):
        with pytest.raises(ValueError, match=r"^fps: "):
            data.load(source, fps=bad)


@pytest.mark.parametrize("bad", BAD_RATES)
def test_every_frame_rate_argument_is_checked_and_named(tmp_path, bad):
    cmu_like_bvh(tmp_path / "a.bvh")
    with pytest.raises(ValueError, match=r"^fps: "):
        data.load_bvh(tmp_path / "a.bvh", fps=bad)
    clip = clips_for_tests(1)[0]
    with pytest.raises(ValueError, match=r"^fps: "):
        clip.resampled(bad)
    with pytest.raises(ValueError, match=r"^fps: "):
        data.augment(clip.features(), bad)


@pytest.mark.parametrize("argument, bad", [
    ("n_clips", 0), ("n_clips", 2.5), ("n_clips", -1), ("duration_s", 0), ("duration_s", float("nan")),
    ("duration_s", float("inf")), ("seed", -1), ("seed", 1.5),
])
def test_synthetic_load_checks_counts_and_durations(argument, bad):
    with pytest.raises(ValueError, match=rf"^{argument}: "):
        data.load("synthetic", **{argument: bad})


def test_load_bvh_checks_unit_and_tpose_arguments(tmp_path):
    cmu_like_bvh(tmp_path / "a.bvh")
    for bad in (0, -1, float("nan")):
        with pytest.raises(ValueError, match=r"^unit_m: "):
            data.load_bvh(tmp_path / "a.bvh", unit_m=bad)
    with pytest.raises(ValueError, match=r"^drop_tpose: "):
        data.load_bvh(tmp_path / "a.bvh", drop_tpose="yes")


@pytest.mark.parametrize("argument, bad", [
    ("window_s", 0), ("window_s", -2.0), ("window_s", float("nan")), ("window_s", float("inf")),
    ("window_s", "2"), ("stride_s", 0), ("stride_s", float("nan")), ("stride_s", -1.0),
    ("window_s", 0.01), ("stride_s", 0.001), ("seed", -3),
])
def test_prepare_checks_durations_and_names_them(argument, bad):
    clips = clips_for_tests(4)
    with pytest.raises(ValueError, match=rf"^{argument}: "):
        data.prepare(clips, **{"window_s": 2.0, argument: bad})


def test_a_window_longer_than_every_clip_says_so():
    clips = clips_for_tests(4)                       # 60 to 90 frames at 20 fps
    with pytest.raises(ValueError, match=r"^window_s: a window of 10 s \(200 frames at 20 fps\) is "
                                         r"longer than every clip; the longest, c03, has 90 frames"):
        data.prepare(clips, window_s=10.0)


@pytest.mark.parametrize("length, stride, name", [(40, 0, "stride"), (40, -5, "stride"), (40, 2.5, "stride"),
                                                  (0, 10, "length"), (40.0, 10, "length")])
def test_cut_windows_checks_length_and_stride(length, stride, name):
    with pytest.raises(ValueError, match=rf"^{name}: "):
        data.cut_windows(np.zeros((100, 3)), length, stride)


def test_split_fractions_must_be_finite():
    with pytest.raises(ValueError, match="fractions"):
        data.split_clips(clips_for_tests(5), (float("nan"), 0.5, 0.5))


def test_locomotion_joints_use_the_root_when_no_joint_is_called_hips(tmp_path):
    clip = cmu_like_bvh(tmp_path / "hips.bvh")
    clip.joint_names[0] = "pelvis"
    bvh.write(tmp_path / "pelvis.bvh", clip)
    assert np.array_equal(data.load_bvh(tmp_path / "pelvis.bvh").positions,
                          data.load_bvh(tmp_path / "hips.bvh").positions)
    assert data.locomotion_joints(bvh.read(tmp_path / "pelvis.bvh"))[0] == 0
