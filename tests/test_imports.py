"""The library's modules import each other without cycles, and the readers never import
the loader (:mod:`motionlab.data`).

Every ``from . import x`` / ``from .x import y`` (and ``from ..x``, in ``motionlab/models``)
counts, at the top of a module or inside a function (a function-level import only hides a
cycle). Model files are named ``models.<file>``.
"""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "motionlab"
FILES = {("models." if p.parent.name == "models" else "") + p.stem: p
         for p in sorted(PACKAGE.glob("*.py")) + sorted((PACKAGE / "models").glob("*.py"))}
MODULES = sorted(name for name in FILES if not name.endswith("__init__"))


def _resolve(package: str, name: str) -> str | None:
    """``package`` + relative ``name`` (``"models"``, ``"base.Generated"``) -> the module of
    :data:`MODULES` it names (``"models.base"``), or ``None``."""
    full = ".".join(p for p in (package, name) if p)
    while full:
        if full in MODULES:
            return full
        full = full.rpartition(".")[0]
    return None


def imported_modules(module: str) -> set[str]:
    """The ``motionlab`` modules (of :data:`MODULES`) that ``motionlab.<module>`` imports."""
    here = module.rpartition(".")[0]                     # "models" or ""
    found = set()
    for node in ast.walk(ast.parse(FILES[module].read_text())):
        if isinstance(node, ast.ImportFrom) and node.level >= 1:
            package = here if node.level == 1 else ""
            targets = [node.module] if node.module else [a.name for a in node.names]
            if node.module:                               # from .x import y: y may be a module of x
                targets += [f"{node.module}.{a.name}" for a in node.names]
            found |= {m for m in (_resolve(package, t) for t in targets) if m and m != module}
        elif isinstance(node, ast.Import):
            found |= {m for m in (_resolve("", a.name[len("motionlab."):]) for a in node.names
                                  if a.name.startswith("motionlab.")) if m}
    return found


GRAPH = {module: imported_modules(module) for module in MODULES}


def find_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One import cycle as ``[a, b, ..., a]``, or ``[]`` when there is none (depth first)."""
    state = {}                                           # module -> "open" or "done"

    def visit(module: str, path: list[str]) -> list[str]:
        state[module] = "open"
        for other in sorted(graph[module]):
            if state.get(other) == "open":
                return path[path.index(other):] + [other]
            if other not in state:
                cycle = visit(other, path + [other])
                if cycle:
                    return cycle
        state[module] = "done"
        return []

    for module in sorted(graph):
        if module not in state:
            cycle = visit(module, [module])
            if cycle:
                return cycle
    return []


def test_the_parser_sees_imports_at_any_depth():
    assert {"bvh", "asfamc", "clip", "checks"} <= GRAPH["data"]
    assert "synthetic" in GRAPH["data"]                  # imported inside data.load
    assert "representation" in GRAPH["bvh"]              # imported inside bvh.from_positions
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles():
    assert find_cycle(GRAPH) == []


@pytest.mark.parametrize("reader", ["asfamc", "bvh", "clip"])
def test_readers_never_import_the_loader(reader):
    assert "data" not in GRAPH[reader]


def test_clip_and_the_cmu_unit_live_in_one_place():
    from motionlab import asfamc, clip, data
    assert data.Clip is clip.Clip and data.CMU_UNIT_M is clip.CMU_UNIT_M
    assert asfamc.INCH_M is clip.INCH_M
    assert "clip" in GRAPH["asfamc"]


def test_model_files_never_import_the_course_code():
    for module in MODULES:
        if module.startswith("models."):
            assert not GRAPH[module] & {"training", "pretrained", "experiments", "synthetic", "data"}, module


def test_rotations_depend_on_nothing_else_in_the_library():
    assert GRAPH["rotations"] == set()
