"""The clip cache of data.load: a folder is read once per frame rate; an entry is used only
while its file is unchanged."""
import shutil

import numpy as np
import pytest

from motionlab import bvh, data, synthetic


def write_clips(folder, n=3, seconds=2.0):
    folder.mkdir()
    for k in range(n):
        motion = synthetic.random_motion(duration_s=seconds, fps=60, seed=k)
        bvh.write(folder / f"{k:02d}_01.bvh", bvh.from_positions(motion.positions, 60, unit_m=data.CMU_UNIT_M))
    return folder


def test_a_second_load_reads_no_file_and_gives_the_same_clips(tmp_path, monkeypatch):
    folder, cache = write_clips(tmp_path / "clips"), tmp_path / "cache"
    first = data.load(folder, fps=20, cache=cache)
    assert len(list(cache.glob("*.npz"))) == 1
    monkeypatch.setattr(data, "_load_file", lambda *a: pytest.fail("read a file the cache holds"))
    second = data.load(folder, fps=20, cache=cache)
    for a, b in zip(first, second):
        assert (a.name, a.fps, a.source) == (b.name, b.fps, b.source)
        np.testing.assert_array_equal(a.positions, b.positions)           # exactly
    monkeypatch.undo()
    uncached = data.load(folder, fps=20, cache=False)                      # reads every file
    np.testing.assert_array_equal(uncached[0].positions, first[0].positions)


def test_a_changed_file_another_frame_rate_or_a_damaged_cache_is_read_again(tmp_path, monkeypatch):
    folder, cache = write_clips(tmp_path / "clips"), tmp_path / "cache"
    data.load(folder, fps=20, cache=cache)
    read = []
    real = data._load_file
    monkeypatch.setattr(data, "_load_file", lambda path, fps: read.append(path.name) or real(path, fps))
    shutil.copy(folder / "00_01.bvh", folder / "01_01.bvh")          # same name, new content
    clips = data.load(folder, fps=20, cache=cache)
    assert read == ["01_01.bvh"]
    np.testing.assert_array_equal(clips[1].positions, clips[0].positions)
    read.clear()
    data.load(folder, fps=30, cache=cache)                             # each frame rate its own cache
    assert len(read) == 3 and len(list(cache.glob("*.npz"))) == 2
    read.clear()
    for damaged in cache.glob("*.npz"):
        damaged.write_bytes(b"not a cache")
    data.load(folder, fps=20, cache=cache)
    assert len(read) == 3
    read.clear()
    monkeypatch.setattr(data, "LOADER_VERSION", data.LOADER_VERSION + 1)  # the loader changed: all again
    data.load(folder, fps=20, cache=cache)
    assert len(read) == 3


def test_a_bad_file_is_refused_with_or_without_the_cache(tmp_path):
    folder = write_clips(tmp_path / "clips", n=1)
    data.load(folder, fps=20, cache=tmp_path / "cache")
    (folder / "00_01.bvh").write_text((folder / "00_01.bvh").read_text().replace("Frame Time", "Frame Tim"))
    with pytest.raises(ValueError, match="00_01.bvh"):
        data.load(folder, fps=20, cache=tmp_path / "cache")
