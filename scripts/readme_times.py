"""Write each notebook's run time into the README's course table, from the notebook itself.

    python scripts/readme_times.py          # rewrite README.md's "ready (… s" figures
    python scripts/readme_times.py --check  # exit 1 if the README disagrees with the notebooks

A committed notebook keeps, in each code cell's metadata, when the kernel started and
finished it (Jupyter's ``execution`` timestamps, written by JupyterLab and by
``jupyter nbconvert --execute``). A notebook's time is the sum over its cells: the time a
student waits for Run All on the machine that last ran it, without starting the kernel.
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from datetime import datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ROW = re.compile(r"^(\| \[(?P<name>\d\d_\w+)\]\(notebooks/(?P=name)\.ipynb\).*\| ready \()(?P<time>[^;)]+)(?P<rest>[;)].*)$")


def _when(stamp: str) -> datetime:
    return datetime.fromisoformat(stamp.replace("Z", "+00:00"))


def notebook_seconds(path: Path) -> float:
    """The seconds the kernel spent running ``path``'s code cells, from their metadata.
    Raises ValueError naming the notebook and cell when a code cell has no timing."""
    try:
        cells = json.loads(Path(path).read_text(encoding="utf-8"))["cells"]
    except (OSError, ValueError, KeyError) as error:
        raise ValueError(f"{path}: not a readable notebook ({error})") from None
    total = 0.0
    for index, cell in enumerate(cells):
        if cell.get("cell_type") != "code" or not "".join(cell.get("source", "")).strip():
            continue
        timing = cell.get("metadata", {}).get("execution", {})
        try:
            total += (_when(timing["shell.execute_reply"]) - _when(timing["iopub.execute_input"])).total_seconds()
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"{path}: code cell {index} has no execution timing (run the notebook "
                             "in Jupyter or with nbconvert --execute)") from None
    return total


def spoken(seconds: float) -> str:
    """``seconds`` as the README writes it: ``48 s``, ``2 min 5 s``."""
    seconds = round(seconds)
    return f"{seconds} s" if seconds < 60 else f"{seconds // 60} min {seconds % 60} s"


def updated(readme: str, notebooks: Path) -> str:
    """``readme`` with each course-table row's time replaced by its notebook's."""
    lines, seen = [], set()
    for line in readme.splitlines(keepends=True):
        match = ROW.match(line.rstrip("\n"))
        if match:
            name = match["name"]
            seen.add(name)
            line = f"{match[1]}{spoken(notebook_seconds(notebooks / f'{name}.ipynb'))}{match['rest']}\n"
        lines.append(line)
    missing = {p.stem for p in notebooks.glob("[0-9][0-9]_*.ipynb")} - seen
    if missing:
        raise ValueError(f"README.md: no course-table row with a 'ready (…)' time for {sorted(missing)}")
    return "".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare only; exit 1 on a difference")
    args = parser.parse_args(argv)
    readme = ROOT / "README.md"
    old = readme.read_text(encoding="utf-8")
    new = updated(old, ROOT / "notebooks")
    if args.check:
        if new != old:
            print("README.md's notebook times differ from the notebooks': run python scripts/readme_times.py")
            return 1
        return 0
    readme.write_text(new, encoding="utf-8")
    for name in sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb")):
        print(f"{name.stem}: {spoken(notebook_seconds(name))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
