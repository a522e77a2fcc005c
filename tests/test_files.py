"""motionlab.files: a file's SHA-256, and files written whole or not at all."""
import hashlib

import pytest

from motionlab import files


def test_sha256_matches_hashlib_across_blocks(tmp_path):
    path = tmp_path / "big.bin"
    payload = bytes(range(256)) * 9000                          # over two 1 MB blocks
    path.write_bytes(payload)
    assert files.sha256_of(path) == hashlib.sha256(payload).hexdigest()


def test_replacing_writes_the_whole_file_and_leaves_nothing_beside_it(tmp_path):
    path = tmp_path / "state.json"
    path.write_text("old")
    with files.replacing(path) as partial:
        assert partial.parent == tmp_path and partial != path
        partial.write_text("new")
        assert path.read_text() == "old"                          # not yet replaced
    assert path.read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["state.json"]


def test_a_failed_write_leaves_the_old_file_and_no_partial_one(tmp_path):
    path = tmp_path / "cache.npz"
    path.write_text("old")
    with pytest.raises(RuntimeError):
        with files.replacing(path, suffix=".npz") as partial:
            assert partial.name.endswith(".npz")
            partial.write_text("half")
            raise RuntimeError("stopped half-way")
    assert path.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache.npz"]
