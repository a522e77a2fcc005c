"""The live panel as a student uses it: JupyterLab (and Notebook 7, where installed) in
headless Chromium, driven by selenium.

Runs where Chromium, its driver and selenium are installed (Debian: ``apt-get install
chromium chromium-driver``; ``pip install selenium``), else skips. Checks behaviour, not
speed (the speeds are printed by ``benchmarks/live.py --browser``): frames arrive, the
keyboard steers (held forward, the body steps like the data at that speed; a turn held
turns it; let go, it stops: ``claims.follows_keys``), another cell runs while it streams,
and running the cell again leaves no thread.
"""
from __future__ import annotations

import re
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import lab_browser  # noqa: E402

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(lab_browser.available() is not None, reason=str(lab_browser.available()))]

PANEL = "from motionlab import live\npanel = live.SteeringPanel()\npanel"
OTHER = "total = sum(i * i for i in range(2 * 10**6))\nprint('another cell ran:', total > 0)"
MEASURE = """from motionlab import claims, experiments
print(claims.follows_keys(panel.steered(), experiments.preset_walks("walk", 4.0, 20.0, n=4), 20.0))"""
THREADS = "import threading\nprint('live threads:', sum(t.name == 'motionlab-live' for t in threading.enumerate()))"
RECORD = "return document.querySelector('.motionlab-live').motionlab.arrivals.length"
SHOWN = "return document.querySelector('.motionlab-live').motionlab.shown.length"   # drawn by the playout buffer


def notebook7() -> bool:
    import importlib.util
    return importlib.util.find_spec("notebook") is not None


FILES = {f"live_{app}.ipynb": [PANEL, OTHER, MEASURE, THREADS] for app in ("lab", "notebook")}


@pytest.fixture(scope="module")
def lab():
    """One Jupyter server and one browser for both apps (starting them is a third of a test's
    time); each app steers in a file, and so a kernel, of its own."""
    with lab_browser.Lab(FILES, app="lab") as lab:
        yield lab


@pytest.mark.parametrize("app", ["lab", pytest.param("notebook", marks=pytest.mark.skipif(
    not notebook7(), reason="Notebook 7 is not installed (pip install notebook)"))])
def test_a_student_steers_the_character(lab, app):
    lab.open(f"live_{app}.ipynb", app)
    lab.run_cells(1)
    lab.wait_idle()
    d = lab.driver
    lab.start_panel()
    lab.keys(down=["ARROW_UP"])
    time.sleep(1.5)
    lab.keys(down=["ARROW_LEFT"])                          # turning changes the heading
    time.sleep(2.0)
    lab.keys(up=["ARROW_LEFT"])
    time.sleep(1.5)
    lab.keys(up=["ARROW_UP"])
    before, shown = d.execute_script(RECORD), d.execute_script(SHOWN)
    lab.run_cell(1)                           # another cell, while the character streams
    lab.wait_idle()
    assert "another cell ran: True" in lab.outputs(1)
    time.sleep(2.0)
    assert d.execute_script(RECORD) > before + 20       # frames kept coming
    assert d.execute_script(SHOWN) > shown + 20         # and were drawn
    lab.run_cell(2)                           # what the keys made
    lab.wait_idle()
    report = lab.outputs(2)
    assert "held forward it walks, let go it stops: holds" in report, report
    # the panel's cell run again: the old view goes, its loop stops; no thread is left
    lab.run_cell(0)
    lab.wait_idle()
    lab.run_cell(3)
    lab.wait_idle()
    assert re.search(r"live threads: 0", lab.outputs(3)), lab.outputs(3)
