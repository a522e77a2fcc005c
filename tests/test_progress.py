"""The progress bar's saved form: a notebook keeps the finished state in every view."""
from __future__ import annotations

import nbformat
import pytest
from nbclient import NotebookClient

from motionlab import progress

CELL = """
from motionlab import progress
bar = progress.bar(50, desc="Model", unit="step")
for _ in range(50):
    bar.update(1)
bar.set_postfix(loss="0.1234")
bar.close()
"""


def test_notebook_bar_saves_its_finished_state():
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(CELL)])
    NotebookClient(notebook, timeout=120, kernel_name="python3").execute()
    outputs = notebook.cells[0].outputs
    assert len(outputs) == 1, outputs                     # one output, redrawn in place
    data = outputs[0]["data"]
    text = data["text/plain"]
    assert text.startswith("Model: 100%") and "50/50" in text and "loss=0.1234" in text, text
    assert '<progress value="50" max="50"' in data["text/html"]
    assert "application/vnd.jupyter.widget-view+json" not in data   # no widget needed to read it


def test_terminal_bar_is_tqdm_and_disabled_draws_nothing(capsys):
    assert not progress.in_notebook()
    b = progress.bar(3, desc="x", disable=True)
    b.update(3)
    b.close()
    assert capsys.readouterr().err == ""
    assert type(progress.bar(3, disable=False)).__name__ == "tqdm"


@pytest.mark.parametrize("initial", [0, 7])
def test_notebook_bar_counts_like_tqdm(monkeypatch, initial):
    shown = []

    class Handle:
        def update(self, bundle, raw):
            shown.append(bundle)

    monkeypatch.setattr("IPython.display.display", lambda bundle, raw, display_id: shown.append(bundle) or Handle())
    b = progress.NotebookBar(10, initial=initial, desc="d", unit="step")
    b.update(10 - initial)
    b.close()
    b.close()                                             # a second close draws nothing more
    assert b.n == 10 and "10/10" in shown[-1]["text/plain"]
    assert sum("10/10" in s["text/plain"] for s in shown) <= 2
