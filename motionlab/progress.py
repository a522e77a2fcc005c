"""Progress bars whose saved form shows how the run ended.

In a terminal :func:`bar` is tqdm's text bar. In a notebook, tqdm's widget saves a text
fallback written when the bar was created (``0%| 0/1200``), so every view without widgets
(GitHub, VS Code without them, nbconvert to Markdown) shows a bar stuck at zero. The
notebook bar here is one display output that is *updated in place* (IPython's display
handle, a few times a second and at the end): an HTML ``<progress>`` element and tqdm's
text line, both rewritten each time, so the saved notebook keeps the finished state in
every view, and no widget library is needed.
"""
from __future__ import annotations

import html
import time

from tqdm import tqdm

REFRESH_S = 0.25
"""How often the notebook bar redraws, seconds (each redraw is one message to the browser)."""


def in_notebook() -> bool:
    """True inside a Jupyter kernel (JupyterLab, Notebook, VS Code, Colab, nbclient)."""
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})


class NotebookBar:
    """tqdm's counting (``update``, ``set_postfix``, ``close``, ``n``) drawn as one display
    output that each redraw replaces: see the module text."""

    def __init__(self, total: int, initial: int = 0, desc: str = "", unit: str = "it"):
        from IPython.display import display
        self.total, self.n, self.desc, self.unit = total, initial, desc, unit
        self.initial, self.postfix, self.closed = initial, "", False
        self.began = self.drawn = time.perf_counter()
        self.handle = display(self._bundle(), raw=True, display_id=True)

    def _bundle(self) -> dict:
        text = tqdm.format_meter(self.n, self.total, time.perf_counter() - self.began, prefix=self.desc,
                                 unit=self.unit, postfix=self.postfix or None, initial=self.initial, ncols=100)
        bar = (f'<progress value="{self.n}" max="{max(self.total, 1)}" style="width: 40ex"></progress> '
               f'<code>{html.escape(text)}</code>')
        return {"text/plain": text, "text/html": bar}

    def _draw(self, force: bool = False) -> None:
        now = time.perf_counter()
        if force or now - self.drawn >= REFRESH_S:
            self.drawn = now
            self.handle.update(self._bundle(), raw=True)

    def update(self, n: int = 1) -> None:
        self.n += n
        self._draw()

    def set_postfix(self, **values) -> None:
        self.postfix = ", ".join(f"{key}={value}" for key, value in values.items())
        self._draw()

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._draw(force=True)


def bar(total: int, initial: int = 0, desc: str = "", unit: str = "it", disable: bool = False):
    """A progress bar: :class:`NotebookBar` in a notebook, tqdm's text bar elsewhere (and
    tqdm's disabled bar, which draws nothing, when ``disable``)."""
    if not disable and in_notebook():
        return NotebookBar(total, initial, desc, unit)
    return tqdm(total=total, initial=initial, desc=desc, unit=unit, disable=disable)
