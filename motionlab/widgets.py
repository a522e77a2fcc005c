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


SNAPSHOT_NOTE = "Still picture of the panel as first drawn (the panel above redraws when you move its controls)."
"""The caption of the static snapshot every panel leaves below itself."""


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
        from IPython.display import Markdown
        self.redraw()
        display(self.widget)
        # A still of the panel as first drawn: a saved notebook keeps it where widgets show
        # nothing (GitHub, nbviewer, an HTML export); the panel above redraws as you move it.
        display(Markdown(f"*{SNAPSHOT_NOTE}*"))
        fig = self.figure()
        display(fig)
        plt.close(fig)


def _player(fps: float):
    """The canvas that plays a panel's motion (:class:`motionlab.live.ClipPlayer`)."""
    from .live import ClipPlayer
    return ClipPlayer(fps=fps)


def _redraw(panel, features: np.ndarray, title: str) -> None:
    """Play ``features`` on ``panel.player`` and draw their still figure in ``panel.output``
    (the motion is computed once for both)."""
    from .representation import to_positions
    panel.player.show(to_positions(features, panel.fps), title)
    with panel.output:
        clear_output(wait=True)
        fig = viz.plot_motion(features, panel.fps, title=title)
        display(fig)
        plt.close(fig)


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

    Each slider sets one axis as a quantile level ``u`` of the prior N(0, 1) (the cumulative
    probability up to its value), from 0.1 to 0.9 as in the paper, mapped through the
    inverse normal CDF, ``z = Φ⁻¹(u)``; the still's title gives each axis's value and its
    ``u`` (``z[4]=+0.00 (u=0.50)``). The other axes come from
    a random sample picked by ``sample``. When a slider moves, the decoded window plays as
    motion on the canvas of :class:`motionlab.live.ClipPlayer` (the kernel sends its frames
    once; the browser loops them) above :func:`viz.plot_motion` of it, the still figure.

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
        self.player = _player(fps)
        for control in [*self.sliders, self.sample]:
            control.observe(lambda change: self.redraw(), names="value")
        self.widget = widgets.VBox([widgets.HBox([self.sample]),
                                    widgets.GridBox(self.sliders, layout=widgets.Layout(
                                        grid_template_columns="repeat(3, 33%)")), self.player, self.output])

    def latent_vector(self, probabilities: Sequence[float] | None = None,
                      sample: int | None = None) -> torch.Tensor:
        """The latent ``(latent,)`` for slider values ``probabilities``, quantiles of the prior
        (default: the sliders')."""
        probabilities = [s.value for s in self.sliders] if probabilities is None else list(probabilities)
        if len(probabilities) != len(self.axes):
            raise ValueError(f"probabilities: expected {len(self.axes)} values, got {len(probabilities)}")
        sample = self.sample.value if sample is None else sample
        z = torch.randn(self.latent, generator=torch.Generator().manual_seed(sample))
        z[self.axes] = torch.distributions.Normal(0.0, 1.0).icdf(torch.tensor(probabilities, dtype=torch.float32))
        return z

    def motion(self, probabilities: Sequence[float] | None = None, sample: int | None = None) -> tuple:
        """``(features (frames, 66), title)`` decoded for these slider values."""
        z = self.latent_vector(probabilities, sample)
        motion = np.asarray(self.decode(z[None])[0])
        quantiles = [s.value for s in self.sliders] if probabilities is None else list(probabilities)
        values = ", ".join(f"z[{a}]={v:+.2f} (u={u:.2f})"
                           for a, v, u in zip(self.axes, z[self.axes].tolist(), quantiles))
        return motion, f"sample {self.sample.value if sample is None else sample}: {values}"

    def figure(self, probabilities: Sequence[float] | None = None, sample: int | None = None):
        """The decoded motion for these slider values (headless: pass them in)."""
        features, title = self.motion(probabilities, sample)
        return viz.plot_motion(features, self.fps, title=title)

    def redraw(self) -> None:
        _redraw(self, *self.motion())


class ControlPanel(_Panel):
    """Steer a control-driven model (MoGlow, the VAE-LSTM) and see what it makes of it.

    Pick a preset path (:data:`motionlab.synthetic.PRESETS`: stand still, walk, run, circle,
    side-step, backwards, ...) or ``"sliders"``: constant forward speed, sideways speed and
    turning rate from the three sliders, reached from standing over the first second. The
    path goes through :func:`motionlab.synthetic.walked_control` when ``walked`` is true
    (the stride wobble the models read their step timing from). Each change generates the
    motion once; it plays on the canvas of :class:`motionlab.live.ClipPlayer` (the browser
    loops it) above :func:`viz.plot_motion` of it, the still figure.

    Args:
        generate: ``generate(control, seed)``: control ``(frames, 3)`` in m/s and rad/s ->
            the generated motion's features ``(frames', 66)`` in the data's units.
        fps: frames per second of the control and the motion.
        duration_s: length of the control, seconds.
        walked: pass paths through the synthetic walker first.
    """

    def __init__(self, generate: Callable[[np.ndarray, int], np.ndarray], fps: float,
                 duration_s: float = 6.0, walked: bool = True):
        from .synthetic import PRESETS
        if duration_s <= 0 or fps <= 0:
            raise ValueError(f"duration_s and fps must be > 0, got {duration_s} and {fps}")
        self.generate, self.fps, self.duration_s, self.walked = generate, fps, duration_s, walked
        self.preset = widgets.Dropdown(options=["sliders", *PRESETS], value="walk", description="path")
        slider = dict(step=0.1, continuous_update=False)
        self.forward = widgets.FloatSlider(value=1.3, min=-1.5, max=4.0, description="forward m/s", **slider)
        self.sideways = widgets.FloatSlider(value=0.0, min=-1.0, max=1.0, description="left m/s", **slider)
        self.turning = widgets.FloatSlider(value=0.0, min=-1.5, max=1.5, description="turn rad/s", **slider)
        self.seed = widgets.BoundedIntText(value=0, min=0, max=10 ** 6, description="seed")
        self.output = widgets.Output()
        self.player = _player(fps)
        for control in (self.preset, self.forward, self.sideways, self.turning, self.seed):
            control.observe(lambda change: self.redraw(), names="value")
        self.widget = widgets.VBox([widgets.HBox([self.preset, self.seed]),
                                    widgets.HBox([self.forward, self.sideways, self.turning]), self.player,
                                    self.output])

    def control(self, preset: str | None = None, forward: float | None = None, sideways: float | None = None,
                turning: float | None = None) -> np.ndarray:
        """The control ``(frames, 3)`` for these settings (default: the widgets' values)."""
        from .synthetic import preset_control, walked_control
        preset = self.preset.value if preset is None else preset
        if preset == "sliders":
            values = [self.forward.value if forward is None else forward,
                      self.sideways.value if sideways is None else sideways,
                      self.turning.value if turning is None else turning]
            ramp = preset_control("walk", self.duration_s, self.fps)[:, :1] / 1.3      # 0 -> 1 over a second
            control = ramp * np.asarray(values, dtype=np.float64)[None]
        else:
            control = preset_control(preset, self.duration_s, self.fps)
        return walked_control(control, self.fps) if self.walked else control

    def motion(self, seed: int | None = None, **settings) -> np.ndarray:
        """The generated features ``(frames, 66)`` for these settings."""
        seed = self.seed.value if seed is None else seed
        return np.asarray(self.generate(self.control(**settings), seed))

    def _title(self, seed, settings) -> str:
        preset = settings.get("preset") or self.preset.value
        if preset == "sliders":
            values = [settings.get(k) if settings.get(k) is not None else getattr(self, k).value
                      for k in ("forward", "sideways", "turning")]
            preset = "forward {:+.1f} m/s, left {:+.1f} m/s, turn {:+.1f} rad/s".format(*values)
        return f"{preset}, seed {self.seed.value if seed is None else seed}"

    def figure(self, seed: int | None = None, **settings):
        """:func:`viz.plot_motion` of the response (headless: pass ``preset=``, ``forward=``, ...)."""
        return viz.plot_motion(self.motion(seed, **settings), self.fps, title=self._title(seed, settings))

    def animation(self, seed: int | None = None, step: int = 2, **settings):
        """The response as a ``FuncAnimation`` (:func:`viz.animate`), every ``step``-th frame."""
        from .representation import to_positions
        positions = to_positions(self.motion(seed, **settings), self.fps)
        return viz.animate(positions, self.fps, titles=[self._title(seed, settings)], step=step)

    def redraw(self) -> None:
        _redraw(self, self.motion(), self._title(None, {}))
