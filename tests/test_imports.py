"""The library's modules import each other without cycles, and the readers never import
the loader (:mod:`motionlab.data`).

Every ``from . import x`` / ``from .x import y`` (and ``from ..x``, in ``motionlab/models``)
counts, at the top of a module or inside a function (a function-level import only hides a
cycle). Model files are named ``models.<file>``, the training package's ``training.<file>`` (its
``__init__`` is ``training``).
"""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "motionlab"
FILES = {("" if p.parent == PACKAGE else f"{p.parent.name}.") + p.stem: p
         for p in sorted(PACKAGE.glob("*.py")) + sorted(PACKAGE.glob("*/*.py"))}
FILES["training"] = FILES.pop("training.__init__")    # the package re-exports its modules' names
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
    # the package the module is in: "models", "training" (its modules and itself) or ""
    here = module if FILES[module].name == "__init__.py" else module.rpartition(".")[0]
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
    course = {"training", "checkpoints", "pretrained", "experiments", "synthetic", "data"}
    for module in MODULES:
        if module.startswith("models."):
            assert not {m.partition(".")[0] for m in GRAPH[module]} & course, module


def test_the_training_package_and_checkpoints():
    """The loop never needs checkpoints; checkpoints build on the loop (``train_or_load``) and
    the package gives their names too, looked up on first use (importing them there would be
    a cycle)."""
    assert {"training.config", "training.loop"} <= GRAPH["checkpoints"]
    assert not any("checkpoints" in GRAPH[m] for m in MODULES if m.startswith("training."))
    assert {"training.config", "training.loop", "training.parallel", "training.state"} <= GRAPH["training"]
    from motionlab import checkpoints, training
    for name in ("Checkpoint", "CheckpointMismatch", "load_checkpoint", "save_checkpoint", "train_or_load",
                 "register_model", "registered_models", "CHECKPOINT_FORMAT"):
        assert getattr(training, name) is getattr(checkpoints, name) and name in dir(training)


def test_rotations_depend_on_nothing_else_in_the_library():
    assert GRAPH["rotations"] == set()
