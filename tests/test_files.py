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


def test_the_folders_follow_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("MOTIONLAB_CHECKPOINTS", str(tmp_path / "ck"))
    monkeypatch.setenv("MOTIONLAB_CACHE", str(tmp_path / "cache"))
    assert files.checkpoints() == tmp_path / "ck" and files.cache() == tmp_path / "cache"
    monkeypatch.delenv("MOTIONLAB_CHECKPOINTS")
    monkeypatch.delenv("MOTIONLAB_CACHE")
    assert files.checkpoints() == files.PACKAGE / "checkpoints"
    assert (files.checkpoints() / "moglow_dropout.pt").is_file()           # shipped with the package
    assert files.cache() == files.PACKAGE.parent / "data" / "cache"         # in this checkout


def test_an_installed_package_uses_the_users_cache(monkeypatch, tmp_path):
    monkeypatch.delenv("MOTIONLAB_CACHE", raising=False)
    monkeypatch.setattr(files, "PACKAGE", tmp_path / "site-packages" / "motionlab")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert files.cache() == tmp_path / "xdg" / "motionlab"


@pytest.mark.slow
def test_a_non_editable_install_finds_every_shipped_model(tmp_path):
    """pip install . (not -e) into a folder of its own: that motionlab, away from the
    repository, lists and loads every shipped checkpoint from its own package data."""
    import os
    import subprocess
    import sys
    root = files.PACKAGE.parent
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
                    "--target", str(site), str(root)], check=True, cwd=tmp_path, capture_output=True)
    code = ("import motionlab, motionlab.pretrained as p; "
            f"assert motionlab.__file__.startswith({str(site)!r}), motionlab.__file__; "
            "names = p.available(); assert names == sorted(p.NAMES), names; "
            "[p.load(n) for n in names]; print(len(names), p.CACHE)")
    env = {**os.environ, "PYTHONPATH": str(site), "HOME": str(tmp_path)}
    env.pop("MOTIONLAB_CHECKPOINTS", None), env.pop("MOTIONLAB_CACHE", None), env.pop("XDG_CACHE_HOME", None)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert out.returncode == 0, out.stderr[-2000:]
    count, cache = out.stdout.split()
    assert int(count) == len(list(files.checkpoints().glob("*.pt")))
    assert cache == str(tmp_path / ".cache" / "motionlab")             # not inside the installed package
