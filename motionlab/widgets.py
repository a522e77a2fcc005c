"""Interactive panels for notebooks, built on :mod:`motionlab.viz`.

Each panel draws its figure with a ``viz`` function, so ``panel.figure(...)`` renders the
same picture without a browser (for tests, or to save a PNG); the widgets only choose
what to draw.
"""
from __future__ import annotations

from typing import Callable, Sequence

import ipywidgets as widgets
import matplotlib.pyplot as plt
import numpy as np
import torch
from IPython.display import clear_output, display

from . import viz


class _Panel:
    """Base of the panels: each has a ``widget``, an ``output`` area and a ``figure()``
    method; :meth:`redraw` puts the figure in the output whenever a widget changes."""

    widget: widgets.Widget
    output: widgets.Output

    def redraw(self) -> None:
        with self.output:
            clear_output(wait=True)
            fig = self.figure()
            display(fig)
            plt.close(fig)

    def _ipython_display_(self) -> None:
        self.redraw()
        display(self.widget)


class ClipBrowser(_Panel):
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

    def _on_clip(self, change) -> None:
        self.frame.max = self.clips[change["new"]].n_frames - 1
        self.frame.value = min(self.frame.value, self.frame.max)
        self.redraw()


class LatentSliders(_Panel):
    """Sliders over chosen latent axes of a generative model (Motegi §V).

    Each slider sets one axis as a cumulative probability of the prior N(0, 1), from 0.1
    to 0.9 as in the paper, mapped through the inverse normal CDF; the other axes come from
    a random sample picked by ``sample``. The figure is :func:`viz.plot_motion` of the
    decoded motion.

    Args:
        decode: latents ``(n, latent)`` -> motion features ``(n, frames, 66)``.
        latent: number of latent dimensions.
        axes: the axes that get a slider.
        fps: frames per second of the decoded motion.
    """

    def __init__(self, decode: Callable[[torch.Tensor], np.ndarray], latent: int,
                 axes: Sequence[int], fps: float, sample: int = 0):
        if not axes or not all(0 <= a < latent for a in axes):
            raise ValueError(f"axes: expected latent axes in 0..{latent - 1}, got {list(axes)}")
        self.decode, self.latent, self.axes, self.fps = decode, latent, list(axes), fps
        self.sliders = [widgets.FloatSlider(value=0.5, min=0.1, max=0.9, step=0.05,
                                            description=f"z[{a}]", continuous_update=False)
                        for a in self.axes]
        self.sample = widgets.BoundedIntText(value=sample, min=0, max=10 ** 6, description="sample")
        self.output = widgets.Output()
        for control in [*self.sliders, self.sample]:
            control.observe(lambda change: self.redraw(), names="value")
        self.widget = widgets.VBox([widgets.HBox([self.sample]),
                                    widgets.GridBox(self.sliders, layout=widgets.Layout(
                                        grid_template_columns="repeat(3, 33%)")), self.output])

    def latent_vector(self, probabilities: Sequence[float] | None = None,
                      sample: int | None = None) -> torch.Tensor:
        """The latent ``(latent,)`` for slider values ``probabilities`` (default: the sliders')."""
        probabilities = [s.value for s in self.sliders] if probabilities is None else list(probabilities)
        if len(probabilities) != len(self.axes):
            raise ValueError(f"probabilities: expected {len(self.axes)} values, got {len(probabilities)}")
        sample = self.sample.value if sample is None else sample
        z = torch.randn(self.latent, generator=torch.Generator().manual_seed(sample))
        z[self.axes] = torch.distributions.Normal(0.0, 1.0).icdf(torch.tensor(probabilities, dtype=torch.float32))
        return z

    def figure(self, probabilities: Sequence[float] | None = None, sample: int | None = None):
        """The decoded motion for these slider values (headless: pass them in)."""
        z = self.latent_vector(probabilities, sample)
        motion = self.decode(z[None])[0]
        values = ", ".join(f"z[{a}]={v:+.2f}" for a, v in zip(self.axes, z[self.axes].tolist()))
        return viz.plot_motion(motion, self.fps, title=f"sample {self.sample.value if sample is None else sample}: {values}")
