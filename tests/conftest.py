"""Shared fixtures: where the real CMU data is, and a small procedural walker for unit tests."""
from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

REPO = Path(__file__).resolve().parents[1]
CMU_DIR = Path(os.environ.get("MOTIONLAB_CMU_DIR", REPO.parent / "shared" / "mocap" / "cmu"))


def cmu_files() -> list[Path]:
    return sorted(CMU_DIR.glob("*.bvh")) if CMU_DIR.is_dir() else []


requires_cmu = pytest.mark.skipif(
    not cmu_files(),
    reason=f"real CMU BVH clips not found in {CMU_DIR} (set MOTIONLAB_CMU_DIR to a folder of CMU .bvh files)")


def walker(frames: int = 80, fps: float = 20.0, speed: float = 1.2, turn_rate: float = 0.3,
           side_speed: float = 0.0) -> np.ndarray:
    """A stick figure walking a curved path, ``(frames, 21, 3)`` metres, y up.

    Not realistic (that is motionlab.synthetic's job), only distinct enough in every joint
    to test geometry: a rest pose facing +z with left at +x, legs and arms swinging,
    the whole body carried along a path with the given speed (m/s) and turn rate (rad/s).
    """
    from motionlab.representation import y_rotation
    rest = np.array([
        [0, .95, 0],                                              # Hips
        [.09, .90, 0], [.10, .50, .02], [.10, .08, -.02], [.10, .03, .12],      # left leg
        [-.09, .90, 0], [-.10, .50, .02], [-.10, .08, -.02], [-.10, .03, .12],  # right leg
        [0, 1.10, 0], [0, 1.30, 0], [0, 1.45, .01], [0, 1.60, .03],             # spine, head
        [.18, 1.40, 0], [.20, 1.12, 0], [.21, .88, .02], [.21, .80, .04],        # left arm
        [-.18, 1.40, 0], [-.20, 1.12, 0], [-.21, .88, .02], [-.21, .80, .04],    # right arm
    ])
    t = np.arange(frames) / fps
    phase = 2 * np.pi * 0.9 * t
    local = np.repeat(rest[None], frames, axis=0)
    swing = 0.15 * np.sin(phase)
    local[:, [2, 3, 4], 2] += swing[:, None] * np.array([0.5, 1, 1])
    local[:, [6, 7, 8], 2] -= swing[:, None] * np.array([0.5, 1, 1])
    local[:, [14, 15, 16], 2] -= swing[:, None]
    local[:, [18, 19, 20], 2] += swing[:, None]
    local[:, :, 1] += 0.02 * np.cos(2 * phase)[:, None]
    heading = turn_rate * t
    step = np.stack([side_speed * np.ones_like(t), np.zeros_like(t), speed * np.ones_like(t)], -1) / fps
    world_step = np.einsum("fab,fb->fa", y_rotation(heading[:-1]), step[:-1])  # t -> t+1
    root = np.concatenate([np.zeros((1, 3)), np.cumsum(world_step, axis=0)])
    return np.einsum("fab,fjb->fja", y_rotation(heading), local) + root[:, None]


@pytest.fixture(scope="session")
def benchmark_script():
    """``benchmark_script(name)``: ``benchmarks/<name>.py`` loaded as a module (its ``main``
    and helpers, without running it as a script)."""
    def load(name: str):
        path = Path(__file__).resolve().parents[1] / "benchmarks" / f"{name}.py"
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    return load


@pytest.fixture
def walk() -> np.ndarray:
    return walker()


# ----------------------------------------------------------------------------------------
# The notebooks as tests (nbval)
# ----------------------------------------------------------------------------------------

NBVAL_OUTPUT_TIMEOUT_S = 300
"""After a cell finishes, nbval waits for each of its output messages at most 5 seconds, a
value hard-coded in nbval 0.11 (nbval issues #136 and #231; ``--nbval-cell-timeout`` does
not cover it). A cell that drew many progress-bar updates can take longer than that to
deliver them on a busy 2-core machine, and the notebook then fails with "Timeout of 5
seconds exceeded waiting for output" although it ran correctly. We give it five minutes, so
that the notebooks also pass on a machine shared with other jobs. (This hook lives here,
not in notebooks/, because a second conftest.py would shadow this one for the tests'
``from conftest import ...``; it applies to every item ``pytest`` collects.)"""


def pytest_collection_modifyitems(items):
    try:
        from nbval.plugin import IPyNbCell
    except ImportError:                              # nbval not installed: no notebook items
        return
    for item in items:
        if isinstance(item, IPyNbCell):
            item.output_timeout = NBVAL_OUTPUT_TIMEOUT_S


@pytest.fixture(autouse=True, scope="session")
def _clip_cache_in_a_temporary_folder(tmp_path_factory):
    """data.load caches what it reads (data/cache/clips by default); the tests' many small
    temporary folders would pile up there, so the suite keeps its cache to itself."""
    from motionlab import data
    data.CLIP_CACHE = tmp_path_factory.mktemp("clip_cache")
    yield


# ----------------------------------------------------------------------------------------
# Where the suite's time goes: each notebook's seconds (all its cells), after the run
# ----------------------------------------------------------------------------------------

def pytest_terminal_summary(terminalreporter):
    seconds: dict[str, float] = {}
    for reports in terminalreporter.stats.values():
        for report in reports:
            if hasattr(report, "duration") and hasattr(report, "nodeid"):
                path = report.nodeid.split("::")[0]
                seconds[path] = seconds.get(path, 0.0) + report.duration
    notebooks = {path: s for path, s in seconds.items() if path.endswith(".ipynb")}
    if not notebooks:
        return
    tests = sum(s for path, s in seconds.items() if not path.endswith(".ipynb"))
    terminalreporter.write_sep("-", "seconds per notebook (setup, cells and teardown)")
    for path, s in sorted(notebooks.items()):
        terminalreporter.write_line(f"{s:7.1f} s  {path}")
    terminalreporter.write_line(f"{sum(notebooks.values()):7.1f} s  all notebooks; {tests:.1f} s the tests in tests/")
