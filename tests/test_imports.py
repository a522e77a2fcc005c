"""The library's modules import each other without cycles, and the readers never import
the loader (:mod:`motionlab.data`).

Every ``from . import x`` / ``from .x import y`` (and ``from ..x``, in a subpackage) counts,
at the top of a module or inside a function (a function-level import only hides a cycle).
Model files are named ``models.<file>``, a subpackage's ``__init__`` by the subpackage's name.

The modules stand in layers (:data:`LAYERS`): a module imports only from its own layer and
the layers below it, so the readers never reach the data sets, the models never the
training loop, and nothing below the course reaches the notebooks' helpers.
"""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "motionlab"
FILES = {".".join(p.relative_to(PACKAGE).with_suffix("").parts).removesuffix(".__init__"): p
         for p in sorted(PACKAGE.rglob("*.py")) if p.name != "__init__.py" or p.parent != PACKAGE}
MODULES = sorted(FILES)          # "data", "models" (its __init__), "models.moglow", "engine.stream", ...


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
            package = here if node.level == 1 else here.rpartition(".")[0] if node.level == 2 else ""
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


@pytest.mark.parametrize("reader", ["asf", "amc", "asfamc", "bvh_file", "bvh", "clip", "download", "download_checks", "download_http"])
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


LAYERS = {
    "core": {"checks", "rotations", "skeleton", "files", "text", "cpu", "progress", "filters", "colab",
             "cmu_locomotion", "models.gaussian", "models.modelcard"},
    "motion": {"representation", "clip", "metrics", "contact_detection", "contacts", "gait", "synthetic", "claims"},
    "readers": {"asf", "amc", "asfamc", "bvh_file", "bvh", "download_checks", "download_http", "download"},
    "data sets": {"data"},
    "models": {"models", "models.base", "models.flows", "models.conv_ae", "models.vae", "models.skeleton_output",
               "models.vae_lstm", "models.lstm", "models.anchor", "models.bone_coordinates", "models.contact_head",
               "models.glow", "models.moglow", "models.dfn_parts",
               "models.dfn", "engine", "engine.recurrent", "engine.stream"},
    "training": {"training", "training.config", "training.schedule", "training.parallel", "training.state",
                 "training.loop", "checkpoints", "train", "pretrained", "recipes"},
    "course": {"experiments", "comparison", "stickfigure", "animations", "viz", "live", "widgets"},
}
"""The library from the bottom up: where each module stands. A new module goes in one."""

FORBIDDEN = {("data", "download")}
"""Imports the layers allow but the design does not: the loader reads files, it never fetches them."""


def layer_violations(graph: dict[str, set[str]]) -> list[str]:
    """Every import of ``graph`` that points up a layer, or is forbidden, as ``"a -> b"``."""
    rank = {module: k for k, members in enumerate(LAYERS.values()) for module in members}
    return sorted(f"{module} -> {other}" for module, imported in graph.items() for other in imported
                  if rank[other] > rank[module] or (module, other) in FORBIDDEN)


def test_every_module_stands_in_one_layer():
    placed = [module for members in LAYERS.values() for module in members]
    assert len(placed) == len(set(placed))
    assert set(placed) == set(MODULES), "place the new module in LAYERS (or remove a gone one)"


def test_imports_point_down_the_layers():
    assert layer_violations(GRAPH) == []


def test_an_import_up_a_layer_is_caught():
    planted = {**GRAPH, "bvh": GRAPH["bvh"] | {"data"}, "models.moglow": GRAPH["models.moglow"] | {"training"}}
    assert layer_violations(planted) == ["bvh -> data", "models.moglow -> training"]
    assert layer_violations({**GRAPH, "data": GRAPH["data"] | {"download"}}) == ["data -> download"]
