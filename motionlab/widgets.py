"""Interactive panels for notebooks, built on :mod:`motionlab.viz`.

Each panel draws its figure with a ``viz`` function, so ``panel.figure(...)`` renders the
same picture without a browser (for tests, or to save a PNG); the widgets only choose
what to draw.
"""
from __future__ import annotations

from typing import Sequence

import ipywidgets as widgets
import matplotlib.pyplot as plt
from IPython.display import clear_output, display

from . import viz


class ClipBrowser:
    """A clip picker and a frame slider over :func:`viz.plot_frame`.

    >>> browser = ClipBrowser(clips)      # clips: motionlab.data.Clip objects
    >>> browser                           # in a notebook: the panel
    >>> browser.figure("synthetic_003", frame=40)   # headless: a matplotlib figure
    """

    def __init__(self, clips: Sequence, start: int = 0):
        if not clips:
            raise ValueError("clips: nothing to browse")
        self.clips = {clip.name: clip for clip in clips}
        first = list(self.clips)[start]
        self.picker = widgets.Dropdown(options=list(self.clips), value=first, description="clip")
        self.frame = widgets.IntSlider(value=0, min=0, max=self.clips[first].n_frames - 1,
                                       description="frame", continuous_update=False)
        self.output = widgets.Output()
        self.picker.observe(self._on_clip, names="value")
        self.frame.observe(lambda change: self.redraw(), names="value")
        self.widget = widgets.VBox([widgets.HBox([self.picker, self.frame]), self.output])

    def figure(self, name: str | None = None, frame: int | None = None):
        """The figure for clip ``name`` at ``frame`` (default: the widgets' current values)."""
        name = self.picker.value if name is None else name
        if name not in self.clips:
            raise ValueError(f"name: no clip {name!r}; clips are {', '.join(self.clips)}")
        clip = self.clips[name]
        frame = self.frame.value if frame is None else frame
        return viz.plot_frame(clip.positions, frame, clip.fps,
                              title=f"{name}, frame {frame} ({frame / clip.fps:.2f} s)")

    def redraw(self) -> None:
        with self.output:
            clear_output(wait=True)
            fig = self.figure()
            display(fig)
            plt.close(fig)

    def _on_clip(self, change) -> None:
        self.frame.max = self.clips[change["new"]].n_frames - 1
        self.frame.value = min(self.frame.value, self.frame.max)
        self.redraw()

    def _ipython_display_(self) -> None:
        self.redraw()
        display(self.widget)
