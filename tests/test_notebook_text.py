"""What a reader of the committed notebooks sees: prose that states only facts (measured
figures come from cells), stills large enough to read, progress bars saved finished, and
the README's run times taken from the notebooks."""
from __future__ import annotations

import base64
import dataclasses
import importlib
import io
import json
import pkgutil
import re
import sys
from pathlib import Path

import pytest
from PIL import Image

from motionlab import viz

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import notebook_prose  # noqa: E402
import readme_times  # noqa: E402

NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
MIN_FIGURE_PX = (300, 200)          # width, height of any committed picture


def outputs(path: Path):
    for index, cell in enumerate(json.loads(path.read_text(encoding="utf-8"))["cells"]):
        for output in cell.get("outputs", []):
            yield index, output


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_prose_types_no_measured_figure(path):
    unlisted, unused = notebook_prose.check(path)
    assert not unlisted, (f"{path.name}: figures typed into Markdown (render them from the measured value, "
                          f"or list a fact in metadata.motionlab.facts): {unlisted}")
    assert not unused, f"{path.name}: facts listed but not in the prose any more: {unused}"


def test_prose_check_catches_a_planted_figure(tmp_path):
    notebook = json.loads(NOTEBOOKS[0].read_text(encoding="utf-8"))
    notebook["cells"].append({"cell_type": "markdown", "metadata": {},
                              "source": ["The model slides its feet 2.37× as much as the data, 14 % of frames."]})
    planted = tmp_path / "planted.ipynb"
    planted.write_text(json.dumps(notebook), encoding="utf-8")
    unlisted, _ = notebook_prose.check(planted)
    assert [token for _, token in unlisted][-2:] == ["2.37×", "14 %"]
    # what is not a figure: equations, code, section numbers, counts, years, link targets
    assert notebook_prose.figures("§5.3 of Henter 2020: $\\tau = 0.7$, `lr=3e-3`, 4 layers, "
                                  "[a](https://x.org/1.5), 21 joints") == []
    assert notebook_prose.figures("1.5 m/s, 20 fps, −165 bits, 0.25 s, 3,000 s") == \
        ["1.5 m/s", "20 fps", "-165 bits", "0.25 s", "3,000 s"]
    with pytest.raises(ValueError, match="not a readable notebook"):
        notebook_prose.check(tmp_path / "missing.ipynb")


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_pictures_are_large_enough_to_read(path):
    for index, output in outputs(path):
        png = output.get("data", {}).get("image/png")
        if png is None:
            continue
        width, height = Image.open(io.BytesIO(base64.b64decode(png))).size
        rows = output.get("metadata", {}).get("motionlab", {}).get("rows")
        if rows:                     # viz.show's stills: each row one frame of the animation
            assert height / rows >= viz.STILL_PANEL_PX, f"{path.name} cell {index}: stills rows {height / rows:.0f} px"
        assert width >= MIN_FIGURE_PX[0] and height >= MIN_FIGURE_PX[1], \
            f"{path.name} cell {index}: a {width}×{height} px picture is too small to read"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_figure_drawn_is_saved(path):
    """A cell that shows a matplotlib figure keeps it as a PNG (a notebook executed with
    ``MPLBACKEND=Agg`` saves none: its kernel draws off-screen)."""
    for index, cell in enumerate(json.loads(path.read_text(encoding="utf-8"))["cells"]):
        source = "".join(cell.get("source", ""))
        if cell.get("cell_type") == "code" and re.search(r"\bplt\.show\(\)|display\(fig\)", source):
            assert any("image/png" in o.get("data", {}) for o in cell.get("outputs", [])), \
                f"{path.name} cell {index}: draws a figure but saved no picture"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_progress_bars_are_saved_finished(path):
    for index, output in outputs(path):
        text = output.get("data", {}).get("text/plain", "") or output.get("text", "")
        text = "".join(text) if isinstance(text, list) else text
        for percent in re.findall(r"(\d+)%\|", text):       # tqdm's text line: "Model: 100%|####| 1200/1200"
            assert percent == "100", f"{path.name} cell {index}: a bar saved at {percent} %: {text[:80]!r}"


def test_readme_times_are_the_notebooks(tmp_path):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert readme_times.updated(readme, ROOT / "notebooks") == readme, \
        "README.md's run times differ from the notebooks': run python scripts/readme_times.py"
    stale = re.sub(r"(\| ready \()\d+ s", r"\g<1>1 s", readme, count=1)
    assert readme_times.updated(stale, ROOT / "notebooks") != stale
    notebook = json.loads(NOTEBOOKS[0].read_text(encoding="utf-8"))
    for cell in notebook["cells"]:
        cell.get("metadata", {}).pop("execution", None)
    untimed = tmp_path / "untimed.ipynb"
    untimed.write_text(json.dumps(notebook), encoding="utf-8")
    with pytest.raises(ValueError, match="untimed.ipynb: code cell \\d+ has no execution timing"):
        readme_times.notebook_seconds(untimed)
    assert readme_times.spoken(59.4) == "59 s" and readme_times.spoken(125) == "2 min 5 s"


def config_classes() -> dict:
    """Every config dataclass of ``motionlab.models`` and ``motionlab.training``, by name."""
    import motionlab.models
    modules = [importlib.import_module(f"motionlab.models.{m.name}")
               for m in pkgutil.iter_modules(motionlab.models.__path__)]
    modules.append(importlib.import_module("motionlab.training"))
    return {name: obj for module in modules for name, obj in vars(module).items()
            if name.endswith("Config") and dataclasses.is_dataclass(obj)}


def printed_configs(text: str) -> list[tuple[str, list[str]]]:
    """``(class name, field names)`` of each config's repr in ``text``, e.g. ``GlowConfig(a=1, b=(0, 2))``."""
    found = []
    for match in re.finditer(r"\b(\w+Config)\(", text):
        depth, names, start = 1, [], match.end()
        for i in range(start, len(text)):
            depth += {"(": 1, "[": 1, ")": -1, "]": -1}.get(text[i], 0)
            if depth == 0:
                break
        body = text[start:i]
        level, token = 0, ""
        for char in body + ",":                 # the top-level "name=value" pairs only
            level += {"(": 1, "[": 1, ")": -1, "]": -1}.get(char, 0)
            if char == "," and level == 0:
                names.append(token.split("=")[0].strip())
                token = ""
            else:
                token += char
        found.append((match.group(1), names))
    return found


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_printed_configs_have_todays_fields(path):
    # a committed config printout names every field the config has now, and no other:
    # a field added since the notebook last ran would otherwise be missing from what it shows
    classes = config_classes()
    for index, output in outputs(path):
        text = output.get("data", {}).get("text/plain", "") or output.get("text", "")
        for name, fields in printed_configs("".join(text) if isinstance(text, list) else text):
            if name in classes:
                today = [f.name for f in dataclasses.fields(classes[name])]
                assert fields == today, f"{path.name} cell {index}: {name} printed with {fields}, has {today} now"


def test_the_printed_config_reader():
    assert printed_configs("x GlowConfig(a=1, b=(0, 2), c='de', f=[1, 2]) y") == [("GlowConfig", ["a", "b", "c", "f"])]
    assert {"GlowConfig", "MoGlowConfig", "DFNConfig", "TrainConfig"} <= set(config_classes())
