"""Find figures typed into a notebook's prose that are not listed as facts.

    python scripts/notebook_prose.py notebooks/03_vae_latent_traversal.ipynb   # or no argument: all

A trained or sampled figure (a loss, an error in cm, a ratio to the data's, a share of
frames, a speed a model reached) changes whenever a model is retrained, so the course never
types one into a Markdown cell: a code cell prints it, or renders the sentence from the
measured value (``display(Markdown(f"..."))``). What the prose may state are facts: the
paper's numbers, thresholds, definitions, settings. A notebook lists the figure-like ones
it uses (decimals, percentages, ratios, amounts with a unit) in its metadata,
``metadata["motionlab"]["facts"]``; this script reports every figure-like token of the
prose that is not on that list (and every listed fact the prose no longer uses).
tests/test_notebook_text.py runs it on every notebook.
"""
from __future__ import annotations

import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
UNITS = r"%|×|cm/s|cm|mm|m/s²|m/s|ms|min|s|bits|nats|px|fps|Hz|GB|MB|kB"
NUMBER = re.compile(rf"(?<![\w.§/])[-−+]?\d[\d,]*(?:\.\d+)?(?:[ \u00a0]?(?:{UNITS})(?![\w/]))?")
IGNORED = [re.compile(p, re.S) for p in (
    r"\$\$.*?\$\$", r"\$[^$\n]*\$",                  # LaTeX: the paper's equations
    r"```.*?```", r"`[^`\n]*`",                      # code
    r"\]\([^)]*\)", r"<[^>\n]*>",                    # link targets, HTML tags
    r"§\s?\d[\d.]*(?:[–-]\d[\d.]*)?",                # section numbers
)]


def figures(markdown: str) -> list[str]:
    """The figure-like tokens of ``markdown``: numbers with a decimal point, a unit, a
    percent or a times sign (plain integers are counts, years, indices: not figures)."""
    for pattern in IGNORED:
        markdown = pattern.sub(" ", markdown)
    found = []
    for match in NUMBER.finditer(markdown):
        token = re.sub(r"[ \u00a0]", " ", match.group()).rstrip(",").replace("−", "-")
        if "." in token or re.search(rf"(?:{UNITS})$", token):
            found.append(token)
    return found


def facts(notebook: dict) -> list[str]:
    return [f.replace("−", "-") for f in notebook.get("metadata", {}).get("motionlab", {}).get("facts", [])]


def check(path: Path) -> tuple[list[tuple[int, str]], list[str]]:
    """``(unlisted, unused)``: each ``(cell index, token)`` of the prose that is not a listed
    fact, and each listed fact that no Markdown cell uses."""
    try:
        notebook = json.loads(Path(path).read_text(encoding="utf-8"))
        cells = notebook["cells"]
    except (OSError, ValueError, KeyError) as error:
        raise ValueError(f"{path}: not a readable notebook ({error})") from None
    allowed, used, unlisted = set(facts(notebook)), set(), []
    for index, cell in enumerate(cells):
        if cell.get("cell_type") != "markdown":
            continue
        for token in figures("".join(cell.get("source", ""))):
            (used.add(token) if token in allowed else unlisted.append((index, token)))
    return unlisted, sorted(allowed - used)


def main(argv: list[str] | None = None) -> int:
    paths = [Path(p) for p in (argv if argv is not None else sys.argv[1:])] or \
        sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
    bad = 0
    for path in paths:
        unlisted, unused = check(path)
        for index, token in unlisted:
            print(f"{path.name}: cell {index}: {token!r} is neither rendered from a value nor a listed fact")
        for token in unused:
            print(f"{path.name}: fact {token!r} is listed but no Markdown cell uses it")
        bad += len(unlisted) + len(unused)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
