"""The committed course reads without a kernel.

A student first meets the notebooks on GitHub, nbviewer or as static HTML (``make html``),
where no JavaScript runs and no widget has a kernel. These tests read the committed
notebooks as they are (nothing is executed) and check that every animation and widget
panel leaves a picture, that every training run leaves a finished one-line summary, and
that each notebook is built the same way: a paper reference with a link at the top, "Try
this" exercises with folded answers and a link onward at the end, and a size a repository
can carry. The last test renders the pages with nbconvert and opens them in headless
Chromium with the notebooks' scripts removed (skipped where Chromium is not installed).
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("[0-9][0-9]_*.ipynb"))
WIDGET = "application/vnd.jupyter.widget-view+json"
MAX_NOTEBOOK_MB, MAX_FOLDER_MB = 5.0, 20.0


def cells(path: Path) -> list[dict]:
    return json.loads(path.read_text())["cells"]


def text_of(output: dict) -> str:
    if output.get("output_type") == "stream":
        return "".join(output.get("text", ""))
    return "".join(output.get("data", {}).get("text/plain", ""))


def is_player(output: dict) -> bool:
    """A JavaScript animation player (``viz.to_html``)."""
    return "_anim_img" in "".join(output.get("data", {}).get("text/html", ""))


def is_progress_bar(output: dict) -> bool:
    """A training loop's bar (``motionlab.progress``; tqdm's widget in older notebooks)."""
    return bool(re.search(r"\d+%\|", text_of(output)))


def is_panel(output: dict) -> bool:
    return WIDGET in output.get("data", {}) and not is_progress_bar(output)


def test_the_course_has_its_notebooks():
    assert [p.name[:2] for p in NOTEBOOKS] == ["01", "02", "03", "04", "05", "06", "07", "08"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name[:2])
def test_every_animation_and_panel_leaves_a_picture(path):
    """Below every JS player and every widget panel, in the same cell, a PNG; every player
    also shows its first frame before Play (its <img> has a src)."""
    for index, cell in enumerate(cells(path)):
        outputs = cell.get("outputs", [])
        for k, output in enumerate(outputs):
            if is_player(output) or is_panel(output):
                after = outputs[k + 1:]
                assert any("image/png" in o.get("data", {}) for o in after), \
                    f"{path.name} cell {index}: an animation or panel with no picture below it"
            if is_player(output):
                html = "".join(output["data"]["text/html"])
                assert re.search(r'<img id="_anim_img\w+" src="data:image/', html), \
                    f"{path.name} cell {index}: the player shows nothing until Play"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name[:2])
def test_every_training_run_leaves_a_summary(path):
    """Beside each saved progress bar, the loop's finished summary ("... 1200 steps in
    20.5 s, final loss ..."): the figures a reader looks for, in plain text."""
    for index, cell in enumerate(cells(path)):
        outputs = cell.get("outputs", [])
        bars = [o for o in outputs if is_progress_bar(o)]
        summaries = [line for o in outputs for line in text_of(o).splitlines()
                     if re.search(r": \d+ steps in [\d.]+ s", line)]
        assert len(summaries) >= len(bars), f"{path.name} cell {index}: {len(bars)} progress bars, " \
                                            f"{len(summaries)} summaries"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name[:2])
def test_each_notebook_opens_with_its_paper_and_ends_with_exercises(path):
    markdown = ["".join(c["source"]) for c in cells(path) if c["cell_type"] == "markdown"]
    assert re.search(r"https://(arxiv\.org|doi\.org|www\.ijmo\.org)/", markdown[0]), \
        f"{path.name}: the first cell names no paper with a link"
    text = "\n".join(markdown)
    assert "## What you learned" in text, f"{path.name}: no summary of what was learned"
    exercises = [m for m in markdown if m.lstrip().startswith("## Try this")]
    assert len(exercises) == 1, f"{path.name}: expected one 'Try this' cell"
    bullets = re.findall(r"^\* ", exercises[0], re.M)
    folded = re.findall(r"<details><summary>(Hint|Answer)</summary>\n\n.+?\n\n</details>", exercises[0], re.S)
    assert bullets and len(folded) == len(bullets), \
        f"{path.name}: {len(bullets)} exercises, {len(folded)} folded hints or answers"
    following = NOTEBOOKS[NOTEBOOKS.index(path) + 1].name if path != NOTEBOOKS[-1] else "../README.md"
    assert f"]({following})" in markdown[-1], f"{path.name}: the last cell does not link to {following}"
    for m in markdown:     # nothing a student cannot see
        assert "../shared" not in m and not re.search(r"\bour (issue|copy)\b", m), path.name


def test_notebooks_are_small_enough_to_commit():
    sizes = {p.name: p.stat().st_size / 2 ** 20 for p in NOTEBOOKS}
    assert max(sizes.values()) < MAX_NOTEBOOK_MB, sizes
    assert sum(sizes.values()) < MAX_FOLDER_MB, sizes


# Chromium, given the pages with every script taken out (what a reader with JavaScript off
# sees), reports for each notebook how many pictures there are and how many decoded and
# take up room (the badges, remote images, are left out: no network here).
PROBE = """<script>
window.addEventListener("load", () => {
  const counts = [...document.querySelectorAll("section[data-notebook]")].map(section => {
    const images = [...section.querySelectorAll("img")].filter(i => i.src.startsWith("data:"));
    const shown = images.filter(i => i.complete && i.naturalWidth > 0 && i.getBoundingClientRect().height > 0);
    return section.dataset.notebook + ":" + images.length + ":" + shown.length;
  });
  document.body.setAttribute("data-counts", counts.join(" "));
});
</script>"""


def chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


@pytest.mark.skipif(chromium() is None, reason="headless Chromium is not installed (Debian: apt-get install chromium)")
def test_static_html_shows_every_picture_in_chromium(tmp_path):
    """``make html``'s pages (nbconvert, nothing run), scripts removed, in headless Chromium:
    every figure, every animation's still frames and first frame and every panel's snapshot
    decodes and takes up room on the page. (All seven pages are opened as one, to start
    Chromium once.)"""
    from nbconvert import HTMLExporter
    exporter = HTMLExporter()
    expected, sections, head = {}, [], ""
    for path in NOTEBOOKS:
        expected[path.stem] = sum(("image/png" in o.get("data", {})) + is_player(o)
                                  for c in cells(path) for o in c.get("outputs", []))
        html, _ = exporter.from_filename(str(path))
        html = re.sub(r"<script\b.*?</script>", "", html, flags=re.S | re.I)
        head = head or re.search(r"<head>.*?</head>", html, re.S).group(0)
        body = re.search(r"<body[^>]*>(.*)</body>", html, re.S).group(1)
        sections.append(f'<section data-notebook="{path.stem}">{body}</section>')
    page = tmp_path / "course.html"
    page.write_text(f"<!DOCTYPE html><html>{head}<body>{''.join(sections)}{PROBE}</body></html>")
    dom = subprocess.run([chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-extensions",
                          "--disable-background-networking", "--disable-sync", "--no-first-run",
                          f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=30000",
                          "--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=300).stdout
    found = re.search(r'<body[^>]*data-counts="([^"]*)"', dom)
    assert found, "Chromium did not load the page"
    counts = {name: (int(images), int(shown)) for name, images, shown in
              (item.split(":") for item in found.group(1).split())}
    assert set(counts) == set(expected)
    for name, (images, shown) in counts.items():
        assert images >= expected[name], f"{name}: {images} pictures on the page, {expected[name]} in the notebook"
        assert shown == images, f"{name}: {images - shown} of {images} pictures do not show"
