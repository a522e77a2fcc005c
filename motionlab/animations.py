"""Motion as animations: :func:`animate` (one clip or several side by side, a camera that
follows each character, a view from above of every path), and what shows them.

Animations are matplotlib ``FuncAnimation`` objects: :func:`to_html` turns one into HTML that
plays in a notebook without ffmpeg (offline: its buttons are text), :func:`stills` into a
picture of a few of its frames (what :func:`show` puts below the player, for readers without
JavaScript), :func:`save_gif` writes a GIF, :func:`save_frame` one frame as a PNG. The
bodies are drawn as :mod:`motionlab.stickfigure` draws them.
"""
from __future__ import annotations

import contextlib
import re
import textwrap
from typing import Sequence

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation

from . import checks
from .skeleton import LOCOMOTION, Skeleton
from .stickfigure import (GRID_COLOR, GRID_SPACING_M, _check_poses, _equal_3d_limits, _floor_grid,
                          _move_floor_grid, _plot_xyz, _style_3d, bone_colors)

PATH_COLORS = ("tab:green", "tab:purple", "tab:orange", "tab:brown", "tab:pink", "tab:olive")
"""The colours of the clips' paths in :func:`animate`'s view from above (and of each panel's
trail then), one per clip in order."""


def animate(clips: np.ndarray | Sequence[np.ndarray], fps: float, titles: Sequence[str] | None = None,
            skeleton: Skeleton = LOCOMOTION, follow: bool = True, radius: float = 1.0,
            step: int = 1, max_frames: int | None = None, size: float = 3.5,
            overview: bool = False) -> animation.FuncAnimation:
    """Animate one clip ``(frames, joints, 3)`` or several side by side (metres).

    Args:
        clips: one array or a list of arrays; clips of different lengths hold their last
            frame once they end.
        fps: frames per second of the clips.
        titles: one title per clip.
        follow: keep each character centred (a camera that tracks the hips); otherwise
            the view covers the whole path.
        radius: half-width of the view around the character when following, metres.
        step: show every ``step``-th frame (keeps notebooks small).
        max_frames: stop after this many frames of the clip (before ``step``).
        size: inches per panel.
        overview: add a last panel that shows every clip's path (its hips) from above, in
            one world frame, each in its colour of :data:`PATH_COLORS` with a dot where it is
            at the frame shown: how far the clips drift apart, which cameras that follow
            each character hide.
    """
    clips = [clips] if getattr(clips, "ndim", None) == 3 else list(clips)   # one clip: an array or a tensor
    if len(clips) == 0:
        raise ValueError(f"clips: expected a clip (frames, {skeleton.n_joints}, 3) or a list of clips, got none")
    clips = [_check_poses(c, skeleton, f"clips[{i}]") for i, c in enumerate(clips)]
    if titles is not None and len(titles) != len(clips):
        raise ValueError(f"titles: expected {len(clips)} titles, got {len(titles)}")
    fps = checks.rate(fps, "fps")
    step = checks.whole(step, "step")
    radius, size = checks.positive(radius, "radius"), checks.positive(size, "size")
    n_frames = max(len(c) for c in clips)
    if max_frames is not None:
        n_frames = min(n_frames, checks.whole(max_frames, "max_frames"))
    frames = list(range(0, n_frames, step))
    n_panels = len(clips) + bool(overview)
    fig = plt.figure(figsize=(size * n_panels, size))
    panels = [_character_panel(fig.add_subplot(1, n_panels, i + 1, projection="3d"), clip, skeleton, follow,
                               radius, PATH_COLORS[i % len(PATH_COLORS)] if overview else "tab:green",
                               textwrap.fill(titles[i], max(12, int(10 * size))) if titles else None)
              for i, clip in enumerate(clips)]
    fig.tight_layout(rect=(0.02, 0.04, 0.95, 0.93))       # room for the tick labels and a time label
    # tight_layout leaves a placeholder layout engine behind, and with any engine set every
    # saved frame is drawn twice (once to lay it out): the layout is done, so drop it
    fig.set_layout_engine(None)
    if overview:
        _overview_panel(fig, panels, n_panels, size, titles)

    def draw(frame: int):
        return [artist for p in panels for artist in _draw_panel(p, frame, skeleton, follow, radius, overview)]

    anim = animation.FuncAnimation(fig, draw, frames=frames, interval=1000 * step / fps, blit=False)
    anim.motion_frames, anim.motion_fps = frames, fps          # for stills(): which frames, at what time
    plt.close(fig)
    return anim


def _character_panel(ax, clip: np.ndarray, skeleton: Skeleton, follow: bool, radius: float, path_color,
                     title: str | None) -> dict:
    """One character's 3-D panel of :func:`animate`: its empty lines, trail and floor, as a dict
    that :func:`_draw_panel` fills in frame by frame."""
    _style_3d(ax, title)                # a title wider than its panel is wrapped to it by the caller
    grid = []
    if follow:
        # a moving camera's axes would show numbers that change every frame; without
        # them (and their panes) a frame also draws about twice as fast. The floor grid
        # moves under the character: its lines are made once, enough for any centre.
        ax.set_axis_off()
        grid = [ax.plot([], [], [], color=GRID_COLOR, lw=0.6, zorder=0)[0]
                for _ in range(2 * (int(2 * radius / GRID_SPACING_M) + 1))]
    height = clip[..., 1].max() + 0.1
    if not follow:
        center = 0.5 * (clip[:, 0, [0, 2]].min(0) + clip[:, 0, [0, 2]].max(0))
        r = 0.5 * max(np.ptp(clip[:, 0, 0]), np.ptp(clip[:, 0, 2])) + 1.0
        _equal_3d_limits(ax, center, r, height)
        _floor_grid(ax, center, r)
    lines = [ax.plot([], [], [], color=c, lw=2)[0] for c in bone_colors(skeleton)]
    trail = ax.plot([], [], [], color=path_color, lw=1)[0]
    return {"ax": ax, "clip": clip, "lines": lines, "trail": trail, "grid": grid, "height": height,
            "color": path_color}


def _overview_panel(fig, panels: list[dict], n_panels: int, size: float, titles) -> None:
    """:func:`animate`'s last panel: every clip's hips from above, in one world frame."""
    # placed by hand in the last slot, after the layout of the 3-D panels: tight_layout
    # would shrink those to make room for this panel's tick labels
    left, width = (n_panels - 1 + 0.6 / size) / n_panels, (1 - 0.75 / size) / n_panels
    top = fig.add_axes((left, 0.55 / size, width, 1 - 1.05 / size))
    for i, p in enumerate(panels):
        hips = p["clip"][:, 0]
        top.plot(hips[:, 2], hips[:, 0], color=p["color"], lw=1, alpha=0.3)          # the whole path, faint
        p["walked"] = top.plot([], [], color=p["color"], lw=2,
                               label=titles[i] if titles else f"clip {i}")[0]        # so far
        p["here"] = top.plot([], [], "o", color=p["color"], ms=6)[0]
    top.set_xlabel("z (m)")
    top.set_ylabel("x (m)")
    top.set_title("seen from above: the paths")
    top.set_aspect("equal", adjustable="datalim")
    top.grid(True, color="0.9")
    top.legend(fontsize=8, loc="best")


def _draw_panel(p: dict, frame: int, skeleton: Skeleton, follow: bool, radius: float, overview: bool) -> list:
    """Pose one panel of :func:`animate` at ``frame`` (a clip that has ended holds its last
    frame); returns the artists it changed."""
    clip, ax = p["clip"], p["ax"]
    t = min(frame, len(clip) - 1)
    pose = clip[t]
    if follow:
        center = pose[0, [0, 2]]
        _move_floor_grid(p["grid"], center, radius)
        _equal_3d_limits(ax, center, radius, p["height"])
    for (parent, child), line in zip(skeleton.bones, p["lines"]):
        line.set_data_3d(*_plot_xyz(pose[[parent, child]]))
    path = clip[: t + 1, 0] * np.array([1.0, 0.0, 1.0])
    if follow:                                 # the trail ends at the edge of the floor shown
        path[np.abs(path[:, [0, 2]] - pose[0, [0, 2]]).max(axis=1) > radius] = np.nan
    p["trail"].set_data_3d(*_plot_xyz(path))
    artists = p["lines"] + [p["trail"]]
    if overview:
        p["walked"].set_data(clip[: t + 1, 0, 2], clip[: t + 1, 0, 0])
        p["here"].set_data(clip[t:t + 1, 0, 2], clip[t:t + 1, 0, 0])
        artists += [p["walked"], p["here"]]
    return artists


STILL_PANEL_PX = 320
"""The height of one row of :func:`stills`, pixels: a body standing in a panel of
:func:`animate` is then about 125 px tall, readable where no player runs."""


def stills(anim: animation.FuncAnimation, n: int = 4, dpi: float | None = None) -> np.ndarray:
    """The static companion of an animation made by :func:`animate`: ``n`` of its frames,
    evenly spaced from the first to the last, stacked top to bottom, each labelled with its
    time. Returns an RGB image ``(height, width, 3)``, ``uint8`` (``n`` rows of the
    animation's figure at ``dpi``; default: the dpi that makes a row :data:`STILL_PANEL_PX`
    tall, whatever the panels' size).

    A reader without a running kernel (GitHub, nbviewer, an HTML export with JavaScript off)
    sees no frame of the JavaScript player; :func:`show` puts this picture below it."""
    n = checks.whole(n, "n")
    frames = getattr(anim, "motion_frames", None)
    if frames is None:
        raise ValueError("anim: expected an animation made by viz.animate (it records its frames)")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    fig = anim._fig
    dpi = STILL_PANEL_PX / fig.get_size_inches()[1] if dpi is None else checks.positive(dpi, "dpi")
    fig.set_dpi(dpi)
    canvas = FigureCanvasAgg(fig)                      # animate() closed its figure: draw off-screen
    picks = [frames[round(k)] for k in np.linspace(0, len(frames) - 1, min(n, len(frames)))]
    label = fig.text(0.005, 0.995, "", va="top", fontsize=14, weight="bold")   # readable at the stills' dpi
    rows = []
    for frame in picks:
        anim._func(frame)
        label.set_text(f"t = {frame / anim.motion_fps:.1f} s")
        canvas.draw()
        rows.append(np.asarray(canvas.buffer_rgba())[..., :3].copy())
    label.remove()
    return np.concatenate(rows, axis=0)


class Shown:
    """What :func:`show` returns: in a notebook, the JavaScript player and below it the
    still frames (:func:`stills`) as a PNG, two outputs a saved notebook keeps."""

    def __init__(self, html: str, png: bytes, rows: int = 1):
        self.html, self.png, self.rows = html, png, rows

    def _ipython_display_(self):
        from IPython.display import HTML, Image, display
        display(HTML(self.html))
        display(Image(data=self.png, format="png", metadata={"motionlab": {"rows": self.rows}}))


def to_html(anim: animation.FuncAnimation, dpi: int = 72, frame_format: str = "jpeg") -> str:
    """HTML with a play bar (matplotlib's ``to_jshtml``): works in notebooks, no ffmpeg, and
    offline (its buttons are text, not a web font from a CDN).

    Frames are embedded as ``frame_format`` images at ``dpi``; JPEG at 72 dpi keeps a
    100-frame, three-panel animation near 1 MB, small enough to commit in a notebook.
    """
    anim._fig.set_dpi(dpi)
    with matplotlib.rc_context({"animation.embed_limit": 50.0, "savefig.dpi": dpi,
                                "animation.frame_format": frame_format}), _drawn_once(anim):
        html = anim.to_jshtml(default_mode="loop")
    # The player's <img> gets its picture from JavaScript once the page has run its script;
    # give it the first frame up front, so it shows before Play (and where scripts are off).
    first = re.search(r'frames\[0\] = "(data:image/[a-z]+;base64,[^"]+)"', html)
    if first:
        src = first.group(1).replace("\\\n", "")              # the JS string's line continuations
        html = re.sub(r'<img id="(_anim_img\w+)">', lambda m: f'<img id="{m.group(1)}" src="{src}">', html, count=1)
    return _offline(html)


@contextlib.contextmanager
def _drawn_once(anim: animation.FuncAnimation):
    """While an animation is saved, each frame is drawn once, by the writer that saves it.

    After grabbing a frame, matplotlib asks the figure's canvas to draw itself again
    (``draw_idle``, for a window on screen). Once :func:`stills` has given the figure an
    off-screen canvas, that canvas does so at once: every frame was drawn twice, half of the
    time :func:`show` spent. The saved frames are the same, byte for byte."""
    canvas = anim._fig.canvas
    canvas.draw_idle = lambda *args, **kwargs: None          # the instance's, over the class's
    try:
        yield
    finally:
        del canvas.draw_idle


# The player's buttons, drawn with text instead of the Font Awesome web font matplotlib's
# player loads from a CDN (offline its buttons would be blank squares).
PLAYER_GLYPHS = {"fa fa-minus": "\u2212", "fa fa-plus": "+", "fa fa-fast-backward": "|\u25c0\u25c0",
                 "fa fa-step-backward": "|\u25c0", "fa fa-play fa-flip-horizontal": "\u25c0",
                 "fa fa-pause": "\u2016", "fa fa-play": "\u25b6", "fa fa-step-forward": "\u25b6|",
                 "fa fa-fast-forward": "\u25b6\u25b6|"}


def _offline(html: str) -> str:
    """``html`` of ``to_jshtml`` with nothing fetched from the network: the stylesheet link
    removed and each icon replaced by its :data:`PLAYER_GLYPHS` text."""
    html = re.sub(r'<link rel="stylesheet"\s+href="[^"]*font-awesome[^"]*">', "", html)
    return re.sub(r'<i class="(fa [^"]+)"></i>',
                  lambda m: PLAYER_GLYPHS.get(m.group(1), m.group(0)), html)


def show(anim: animation.FuncAnimation, dpi: int = 72, still_frames: int = 4) -> Shown:
    """Display an animation of :func:`animate` in a notebook cell: the player (:func:`to_html`)
    and, below it, ``still_frames`` of its frames as one picture (:func:`stills`), which
    shows wherever the player cannot run."""
    import io
    buffer = io.BytesIO()
    picture = stills(anim, still_frames)
    plt.imsave(buffer, picture, format="png")
    return Shown(to_html(anim, dpi=dpi), buffer.getvalue(), rows=min(still_frames, len(anim.motion_frames)))


def save_gif(anim: animation.FuncAnimation, path: str, fps: float | None = None, dpi: int = 72) -> None:
    """Save an animation as a GIF with Pillow (ships with matplotlib); no ffmpeg needed."""
    interval_fps = 1000.0 / anim._interval if fps is None else checks.rate(fps, "fps")
    with _drawn_once(anim):
        anim.save(path, writer=animation.PillowWriter(fps=interval_fps), dpi=dpi)


def save_frame(anim: animation.FuncAnimation, frame: int, path: str, dpi: int = 80) -> None:
    """Render one frame of an animation to a PNG (to look at it without a notebook)."""
    anim._func(frame)
    anim._fig.savefig(path, dpi=dpi)
