"""Where the course opens besides a laptop: the Colab and Binder badges, and the setup cell.

Every notebook starts with two badges (Open in Colab, launch on Binder) and, as its first
code cell, :data:`SETUP_CELL`. On Google Colab that cell clones the course from GitHub (code
and shipped checkpoints come from one commit, so they always match) and installs it; on
any other machine it does nothing. The repository and the branch or tag are named once,
here (:data:`REPOSITORY`, :data:`REF`); in a fork, or for a release tag, change them and run::

    python -m motionlab.colab            # rewrite every notebook's badges and setup cell
    python -m motionlab.colab --check    # what tests/test_colab.py checks

This module imports nothing heavy: the setup cell itself runs before motionlab exists on
the machine, so it is plain Python that only uses the standard library.
"""
from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

REPOSITORY = "motionlab/motionlab"
"""``owner/name`` of the course on GitHub."""

REF = "main"
"""The branch or tag the badges open and the setup cell clones. A release tag (``v0.2.0``)
pins the notebook, the library and the checkpoints to one commit for good."""

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"

_SETUP = '''# Google Colab only: fetch the course from GitHub ({repository}, {ref}: the library and its
# trained checkpoints from one commit), install it, and work in its notebooks folder.
# On any other machine this cell does nothing. (Written by python -m motionlab.colab.)
import sys
if "google.colab" in sys.modules:
    import os
    import subprocess
    COURSE = "/content/motionlab"
    if not os.path.isdir(COURSE):
        subprocess.run(["git", "clone", "--quiet", "--depth", "1", "--branch", "{ref}",
                        "https://github.com/{repository}", COURSE], check=True)
        # --no-deps: Colab already has torch (with CUDA), numpy, matplotlib, ipywidgets, tqdm;
        # anywidget (the live panels' canvas) is installed on its own
        subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "anywidget"], check=True)
        subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "-e", COURSE], check=True)
    sys.path.insert(0, COURSE)       # importable now, without restarting the runtime
    os.chdir(os.path.join(COURSE, "notebooks"))
    from google.colab import output
    output.enable_custom_widget_manager()      # Colab shows third-party widgets (anywidget) only then'''


def setup_cell(repository: str = REPOSITORY, ref: str = REF) -> str:
    """The source of every notebook's first code cell."""
    _check(repository, ref)
    return _SETUP.format(repository=repository, ref=ref)


def badges(notebook: str, repository: str = REPOSITORY, ref: str = REF) -> str:
    """The Colab and Binder badges (markdown, one line) for ``notebook`` (a file name in
    ``notebooks/``, e.g. ``"01_preprocessing.ipynb"``)."""
    _check(repository, ref)
    if not re.fullmatch(r"[0-9]{2}_\w+\.ipynb", notebook):
        raise ValueError(f"notebook: expected a file name like '01_preprocessing.ipynb', got {notebook!r}")
    colab = f"https://colab.research.google.com/github/{repository}/blob/{ref}/notebooks/{notebook}"
    binder = f"https://mybinder.org/v2/gh/{repository}/{ref}?urlpath=lab/tree/notebooks/{notebook}"
    return (f"[![Open In Colab](https://colab.research.google.com/assets/colab-badge.svg)]({colab}) "
            f"[![Binder](https://mybinder.org/badge_logo.svg)]({binder})")


def _check(repository: str, ref: str) -> None:
    if not re.fullmatch(r"[A-Za-z0-9_.-]+/[A-Za-z0-9_.-]+", str(repository)):
        raise ValueError(f"repository: expected 'owner/name' as on GitHub, got {repository!r}")
    if not re.fullmatch(r"[A-Za-z0-9_./-]+", str(ref)) or ".." in ref:
        raise ValueError(f"ref: expected a branch or tag name, got {ref!r}")


_BADGE_LINE = re.compile(r"^\[!\[Open In Colab\].*\n\n?", re.M)


def _apply(notebook: dict, name: str, repository: str, ref: str) -> dict:
    """``notebook`` (parsed JSON) with its badges under the title and its setup cell first."""
    cells = notebook["cells"]
    title = "".join(cells[0]["source"])
    heading, _, rest = _BADGE_LINE.sub("", title).partition("\n")
    cells[0]["source"] = f"{heading}\n\n{badges(name, repository, ref)}\n{rest}".splitlines(keepends=True)
    source = setup_cell(repository, ref).splitlines(keepends=True)
    first_code = next(i for i, c in enumerate(cells) if c["cell_type"] == "code")
    if "".join(cells[first_code]["source"]).startswith("# Google Colab only"):
        cells[first_code]["source"] = source
    else:
        cells.insert(1, {"cell_type": "code", "execution_count": None, "id": "colab-setup",
                         "metadata": {}, "outputs": [], "source": source})
    return notebook


def check(repository: str = REPOSITORY, ref: str = REF) -> list[str]:
    """What is out of date: a line per notebook whose badges or setup cell differ from this
    module's (empty when all agree)."""
    problems = []
    for path in sorted(NOTEBOOKS.glob("[0-9][0-9]_*.ipynb")):
        cells = json.loads(path.read_text())["cells"]
        if badges(path.name, repository, ref) not in "".join(cells[0]["source"]):
            problems.append(f"{path.name}: no badges for {repository}@{ref} in the first cell")
        code = [c for c in cells if c["cell_type"] == "code"]
        if not code or "".join(code[0]["source"]) != setup_cell(repository, ref):
            problems.append(f"{path.name}: the first code cell is not the setup cell")
    return problems


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=f"Write (or --check) every notebook's Colab/Binder badges and "
                                                 f"setup cell for {REPOSITORY}@{REF} (edit REPOSITORY, REF in {__file__}).")
    parser.add_argument("--check", action="store_true", help="only report what is out of date")
    args = parser.parse_args(argv)
    if args.check:
        problems = check()
        print("\n".join(problems) or "every notebook has its badges and setup cell")
        raise SystemExit(1 if problems else 0)
    for path in sorted(NOTEBOOKS.glob("[0-9][0-9]_*.ipynb")):
        notebook = _apply(json.loads(path.read_text()), path.name, REPOSITORY, REF)
        path.write_text(json.dumps(notebook, indent=1, ensure_ascii=False) + "\n")
        print(f"{path.name}: badges and setup cell for {REPOSITORY}@{REF}")


if __name__ == "__main__":
    main()
