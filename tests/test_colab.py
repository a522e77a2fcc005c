"""The Colab setup cell and the badges (motionlab.colab): the cell is run here with a fake
``google.colab`` module, so that a change which would break it on Colab fails a test."""
import json
import os
import subprocess
import sys
import types

import pytest

from motionlab import colab

NOTEBOOKS = sorted(colab.NOTEBOOKS.glob("[0-9][0-9]_*.ipynb"))


def first_code_cell(path) -> str:
    cells = json.loads(path.read_text())["cells"]
    return "".join(next(c for c in cells if c["cell_type"] == "code")["source"])


def run_setup_cell(monkeypatch, on_colab: bool, course_exists: bool = False):
    """Execute the setup cell; returns the commands it ran, the folder it moved to and sys.path."""
    commands, moved = [], []
    if on_colab:
        google_colab, output = types.ModuleType("google.colab"), types.ModuleType("google.colab.output")
        output.enable_custom_widget_manager = lambda: commands.append(["enable_custom_widget_manager"])
        google_colab.output = output
        monkeypatch.setitem(sys.modules, "google.colab", google_colab)
        monkeypatch.setitem(sys.modules, "google.colab.output", output)
    else:
        monkeypatch.delitem(sys.modules, "google.colab", raising=False)
    monkeypatch.setattr(subprocess, "run", lambda args, check: commands.append(list(args)))
    monkeypatch.setattr(os, "chdir", moved.append)
    monkeypatch.setattr(os.path, "isdir", lambda path: course_exists)
    monkeypatch.setattr(sys, "path", list(sys.path))
    exec(compile(colab.setup_cell(), "setup cell", "exec"), {})
    return commands, moved, list(sys.path)


def test_every_notebook_starts_with_the_badges_and_the_setup_cell():
    assert len(NOTEBOOKS) == 8
    assert colab.check() == []
    for path in NOTEBOOKS:
        assert first_code_cell(path) == colab.setup_cell(), path.name
        title = "".join(json.loads(path.read_text())["cells"][0]["source"])
        assert colab.badges(path.name) in title, path.name


def test_the_readme_course_table_has_the_badges():
    readme = (colab.ROOT / "README.md").read_text()
    for path in NOTEBOOKS:
        assert colab.badges(path.name) in readme, path.name


def test_on_colab_the_cell_clones_the_badges_commit_installs_and_moves_into_the_notebooks(monkeypatch):
    commands, moved, path = run_setup_cell(monkeypatch, on_colab=True)
    clone, widgets, install, manager = commands
    assert clone[:2] == ["git", "clone"] and clone[clone.index("--branch") + 1] == colab.REF
    assert widgets[-1] == "anywidget" and manager == ["enable_custom_widget_manager"]   # the live panels show
    assert f"https://github.com/{colab.REPOSITORY}" in clone
    course = clone[-1]
    assert install[:4] == [sys.executable, "-m", "pip", "install"] and install[-2:] == ["-e", course]
    assert moved == [os.path.join(course, "notebooks")] and path[0] == course
    # the badge opens the same repository and ref the cell clones
    assert f"github/{colab.REPOSITORY}/blob/{colab.REF}/notebooks/" in colab.badges("01_preprocessing.ipynb")


def test_on_colab_a_second_run_does_not_clone_again(monkeypatch):
    commands, moved, _ = run_setup_cell(monkeypatch, on_colab=True, course_exists=True)
    assert commands == [["enable_custom_widget_manager"]] and len(moved) == 1


def test_anywhere_else_the_cell_does_nothing(monkeypatch):
    before = list(sys.path)
    commands, moved, path = run_setup_cell(monkeypatch, on_colab=False)
    assert commands == [] and moved == [] and path == before


def test_bad_repository_or_ref_is_refused():
    with pytest.raises(ValueError, match="repository"):
        colab.setup_cell("not a repository")
    with pytest.raises(ValueError, match="ref"):
        colab.setup_cell(ref="main; rm -rf /")
    with pytest.raises(ValueError, match="notebook"):
        colab.badges("../README.md")
