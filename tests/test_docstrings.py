"""The library's docstrings say what code does, not how fast it ran once: a measured speed
goes stale with every machine and change, so speeds live in ``benchmarks/``, which print them."""
import ast
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "motionlab"
SPEED = re.compile(r"\d[\d,.]*\s*(?:x|×)\s+(?:faster|slower)|\d[\d,.]*\s*(?:frames/s|windows/s|GFLOP/s|it/s)"
                   r"|\d[\d,.]*\s*ms (?:per|a) (?:frame|step)", re.I)


def docstrings(path: Path):
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            text = ast.get_docstring(node)
            if text:
                yield getattr(node, "name", path.stem), text


def speeds_in(path: Path) -> list[str]:
    return [f"{path.name} {name}: {m.group(0)!r}"
            for name, text in docstrings(path) for m in SPEED.finditer(text)]


def test_no_docstring_states_a_measured_speed():
    assert [hit for path in sorted(PACKAGE.rglob("*.py")) for hit in speeds_in(path)] == []


def test_a_planted_speed_is_found(tmp_path):
    planted = tmp_path / "planted.py"
    planted.write_text('"""Streams 2,400 frames/s on a laptop, 1.3x faster than before."""\n')
    assert len(speeds_in(planted)) == 2
