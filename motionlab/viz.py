"""Pictures of motion: stick figures, top-down trajectories, animations.

Motion data is ``y`` up; matplotlib's 3-D axes are ``z`` up. Every function here draws
world ``(x, y, z)`` at plot coordinates ``(z, x, y)``: a cyclic swap of axes, so the
picture is rotated, never mirrored (a left foot stays a left foot). Left-side bones are
drawn in blue, right-side bones in red, the spine and head in black.

Animations come back as matplotlib ``FuncAnimation`` objects: :func:`to_html` turns one
into HTML that plays in a notebook without ffmpeg, :func:`stills` into a picture of a few of
its frames (what :func:`show` puts below the player, for readers without JavaScript),
:func:`save_gif` writes a GIF.
"""
from __future__ import annotations

import re
import textwrap
from typing import Sequence

import matplotlib
import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np
from matplotlib import animation

from . import checks
from .representation import N_FEATURES, root_trajectory
from .skeleton import LOCOMOTION, Skeleton

GRID_COLOR, GRID_SPACING_M = "0.8", 0.5
"""The floor grid's grey and the distance between its lines (metres)."""

LEFT_COLOR, RIGHT_COLOR, CENTER_COLOR = "tab:blue", "tab:red", "black"


def _plot_xyz(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World ``(..., 3)`` -> matplotlib 3-D coordinates (x_plot, y_plot, z_plot) = (z, x, y)."""
    return points[..., 2], points[..., 0], points[..., 1]


def bone_colors(skeleton: Skeleton = LOCOMOTION) -> list[str]:
    """One colour per bone of ``skeleton.bones``: blue left, red right, black centre."""
    colors = []
    for _, child in skeleton.bones:
        name = skeleton.names[child]
        colors.append(LEFT_COLOR if name.startswith("Left") else
                      RIGHT_COLOR if name.startswith("Right") else CENTER_COLOR)
    return colors


def _check_poses(poses: np.ndarray, skeleton: Skeleton, name: str = "poses") -> np.ndarray:
    """One pose ``(joints, 3)`` or several ``(n, joints, 3)`` as a float64 array ``(n, joints, 3)``."""
    if np.ndim(poses) not in (2, 3):
        raise ValueError(f"{name}: expected shape ({skeleton.n_joints}, 3) or (n, {skeleton.n_joints}, 3), "
                         f"got {np.shape(poses)}")
    poses = checks.array(poses, name, (..., skeleton.n_joints, 3))
    return poses[None] if poses.ndim == 2 else poses


def _equal_3d_limits(ax, center: np.ndarray, radius: float, height: float) -> None:
    """World-space box around ``center`` (x, z) with equal scales; floor at y = 0."""
    height = max(height, 1.0)
    ax.set_xlim(center[1] - radius, center[1] + radius)     # plot x = world z
    ax.set_ylim(center[0] - radius, center[0] + radius)     # plot y = world x
    ax.set_zlim(0, height)
    ax.set_box_aspect((2 * radius, 2 * radius, height), zoom=1.1)


def _grid_segments(center: np.ndarray, radius: float, spacing: float) -> list[tuple[list, list]]:
    """The floor grid's lines within ``radius`` of ``center`` (world x, z), each as its
    plotted (z, x) end points."""
    lo_z, hi_z = center[1] - radius, center[1] + radius
    lo_x, hi_x = center[0] - radius, center[0] + radius
    segments = [([z, z], [lo_x, hi_x]) for z in np.arange(np.ceil(lo_z / spacing), np.floor(hi_z / spacing) + 1) * spacing]
    segments += [([lo_z, hi_z], [x, x]) for x in np.arange(np.ceil(lo_x / spacing), np.floor(hi_x / spacing) + 1) * spacing]
    return segments


def _floor_grid(ax, center: np.ndarray, radius: float, spacing: float = GRID_SPACING_M) -> list:
    return [ax.plot(z, x, [0, 0], color=GRID_COLOR, lw=0.6, zorder=0)[0]
            for z, x in _grid_segments(center, radius, spacing)]


def _move_floor_grid(lines: list, center: np.ndarray, radius: float, spacing: float = GRID_SPACING_M) -> None:
    """Lay the lines of a following camera's floor grid (made once, enough for any centre)
    around ``center``; the ones not needed there are hidden."""
    segments = _grid_segments(center, radius, spacing)
    for k, line in enumerate(lines):
        z, x = segments[k] if k < len(segments) else ([np.nan] * 2, [np.nan] * 2)
        line.set_data_3d(np.asarray(z, dtype=float), np.asarray(x, dtype=float), np.zeros(2))


def _style_3d(ax, title: str | None) -> None:
    ax.set_xlabel("z (m)")
    ax.set_ylabel("x (m)")
    ax.set_zlabel("y (m)")
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):        # few ticks: at the front corner they would collide
        axis.set_major_locator(matplotlib.ticker.MaxNLocator(4))
    ax.view_init(elev=12, azim=-35)
    if title:
        ax.set_title(title)


def plot_skeleton(poses: np.ndarray, ax=None, skeleton: Skeleton = LOCOMOTION,
                  title: str | None = None, alpha: Sequence[float] | None = None):
    """Draw one pose ``(joints, 3)`` or several ``(n, joints, 3)`` (metres) on a floor grid.

    Several poses share one box with equal axes, e.g. every 10th frame of a walk to show
    its path. ``alpha`` gives each pose's opacity (default: later poses darker).
    Returns the axes.
    """
    poses = _check_poses(poses, skeleton)
    if ax is None:
        ax = plt.figure(figsize=(5, 5)).add_subplot(projection="3d")
    if alpha is None:
        alpha = np.linspace(0.35, 1.0, len(poses)) if len(poses) > 1 else [1.0]
    center = 0.5 * (poses[..., [0, 2]].min(axis=(0, 1)) + poses[..., [0, 2]].max(axis=(0, 1)))
    radius = 0.5 * max(np.ptp(poses[..., 0]), np.ptp(poses[..., 2]), 1.0) + 0.3
    _floor_grid(ax, center, radius)
    colors = bone_colors(skeleton)
    for pose, a in zip(poses, alpha):
        for (parent, child), color in zip(skeleton.bones, colors):
            ax.plot(*_plot_xyz(pose[[parent, child]]), color=color, lw=2, alpha=a)
    _equal_3d_limits(ax, center, radius, poses[..., 1].max() + 0.1)
    _style_3d(ax, title)
    return ax


def plot_trajectory(positions: np.ndarray, fps: float, ax=None, arrow_every_s: float = 0.5,
                    skeleton: Skeleton = LOCOMOTION, label: str | None = None, color: str = "tab:green"):
    """Top-down view of a clip ``(frames, joints, 3)``: the root's path and facing arrows.

    Seen from above with world ``z`` to the right and world ``x`` up (the un-mirrored view
    from ``+y``). A dot marks the start; arrows show the smoothed facing direction every
    ``arrow_every_s`` seconds. Returns the axes.
    """
    fps = checks.rate(fps, "fps")
    arrow_every_s = checks.seconds(arrow_every_s, "arrow_every_s")
    root = root_trajectory(positions, fps, skeleton=skeleton)
    if ax is None:
        ax = plt.figure(figsize=(5, 5)).add_subplot()
    x, z, heading = root[:, 0], root[:, 1], root[:, 2]
    ax.plot(z, x, color=color, label=label)
    ax.plot(z[:1], x[:1], "o", color=color)
    step = max(1, int(round(arrow_every_s * fps)))
    length = 0.1 * max(np.ptp(z), np.ptp(x), 1.0)
    u, v = length * np.cos(heading[::step]), length * np.sin(heading[::step])
    ax.quiver(z[::step], x[::step], u, v, color=color, angles="xy", scale_units="xy", scale=1, width=0.005)
    ax.update_datalim(np.c_[z[::step] + u, x[::step] + v])     # the arrow tips inside the axes too
    ax.autoscale_view()
    ax.set_xlabel("z (m)")
    ax.set_ylabel("x (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, color="0.9")
    if label:
        ax.legend()
    return ax


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
                                "animation.frame_format": frame_format}):
        html = anim.to_jshtml(default_mode="loop")
    # The player's <img> gets its picture from JavaScript once the page has run its script;
    # give it the first frame up front, so it shows before Play (and where scripts are off).
    first = re.search(r'frames\[0\] = "(data:image/[a-z]+;base64,[^"]+)"', html)
    if first:
        src = first.group(1).replace("\\\n", "")              # the JS string's line continuations
        html = re.sub(r'<img id="(_anim_img\w+)">', lambda m: f'<img id="{m.group(1)}" src="{src}">', html, count=1)
    return _offline(html)


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
    anim.save(path, writer=animation.PillowWriter(fps=interval_fps), dpi=dpi)


def save_frame(anim: animation.FuncAnimation, frame: int, path: str, dpi: int = 80) -> None:
    """Render one frame of an animation to a PNG (to look at it without a notebook)."""
    anim._func(frame)
    anim._fig.savefig(path, dpi=dpi)


def plot_controls(control: np.ndarray, fps: float, axes=None, label: str | None = None, **style):
    """The three control signals ``(frames, 3)`` (or full features ``(frames, 66)``) against time.

    One panel each for forward velocity (m/s), sideways velocity (m/s, left +) and
    turning velocity (rad/s, left +). Returns the three axes.
    """
    from .representation import CONTROL_NAMES
    control = checks.array(control, "control", ("frames", "columns"), dtype=None)
    if control.shape[1] not in (3, N_FEATURES):
        raise ValueError(f"control: expected (frames, 3) or (frames, {N_FEATURES}), got {control.shape}")
    fps = checks.rate(fps, "fps")
    control = control[:, -3:]
    if axes is None:
        axes = plt.figure(figsize=(9, 5)).subplots(3, 1, sharex=True)
    t = np.arange(len(control)) / fps
    for k, (ax, name) in enumerate(zip(axes, CONTROL_NAMES)):
        ax.plot(t, control[:, k], label=label, **style)
        ax.set_ylabel(name.replace(" (", "\n("), fontsize=9)
        ax.axhline(0, color="0.8", lw=0.8)
    axes[-1].set_xlabel("time (s)")
    if label:
        axes[0].legend(loc="upper right", fontsize=8)
    return axes


def plot_frame(positions: np.ndarray, frame: int, fps: float, fig=None, title: str | None = None,
               skeleton: Skeleton = LOCOMOTION):
    """One frame of a clip ``(frames, joints, 3)``: the pose in 3-D beside the path from above.

    The path shows where the character has been (solid) and will go (faint), with a
    marker at ``frame``. This is the figure the notebook widgets redraw. Returns the figure.
    """
    positions = checks.array(positions, "positions", ("frames", skeleton.n_joints, 3), dtype=None)
    fps = checks.rate(fps, "fps")
    if checks.whole(frame, "frame", 0) >= len(positions):
        raise ValueError(f"frame: expected 0..{len(positions) - 1}, got {frame}")
    fig = fig or plt.figure(figsize=(10, 4))
    ax3d = fig.add_subplot(1, 2, 1, projection="3d")
    plot_skeleton(positions[frame], ax=ax3d, skeleton=skeleton,
                  title=title or f"frame {frame} ({frame / fps:.2f} s)")
    ax = fig.add_subplot(1, 2, 2)
    plot_trajectory(positions, fps, ax=ax, skeleton=skeleton, color="0.75")
    root = positions[: frame + 1, 0]
    ax.plot(root[:, 2], root[:, 0], color="tab:green")
    ax.plot(root[-1:, 2], root[-1:, 0], "o", color="tab:orange", ms=8)
    ax.set_title("path from above")
    ax.yaxis.tick_right()                          # clear of the 3-D axes' height label on the left
    ax.yaxis.set_label_position("right")
    return fig


def plot_history(history, keys: Sequence[str] = ("loss",), ax=None, log: bool = True):
    """Training curves from a :class:`motionlab.training.History`: every step (faint),
    the mean of each epoch (solid) and validation after each epoch (dashed)."""
    if ax is None:
        ax = plt.figure(figsize=(7, 3.5)).add_subplot()
    for k, key in enumerate(keys):
        color = f"C{k}"
        steps, values = history.series(key, "train")
        ax.plot(steps, values, color=color, alpha=0.25, lw=0.7)
        epochs = np.array([row["epoch"] for row in history.train if key in row])
        ends = [steps[epochs == e].max() for e in np.unique(epochs)]
        means = [values[epochs == e].mean() for e in np.unique(epochs)]
        ax.plot(ends, means, color=color, label=f"{key} (training)")
        if history.val and any(key in row for row in history.val):
            vsteps, vvalues = history.series(key, "val")
            ax.plot(vsteps, vvalues, "--", color=color, label=f"{key} (validation)")
    ax.set_xlabel("step")
    if log:
        ax.set_yscale("log")
    ax.legend()
    ax.grid(True, color="0.92")
    return ax


def plot_conv_filters(weight, feature_names: Sequence[str], n: int = 6, fps: float | None = None):
    """The ``n`` strongest filters of a temporal convolution, ``weight`` ``(filters, features, width)``,
    as heat maps of feature (rows) against time offset (columns), each divided by its own
    largest absolute weight (red positive, blue negative; one colour bar). Filters are ranked
    by the sum of their absolute weights, strongest first (left), and the figure's title
    says so. Rows are labelled once per joint on the left (its rows between thin lines, and
    each of them by its coordinate, ``x``, ``y`` or ``z``, on the right) and once per other
    feature.
    Returns the figure."""
    weight = weight.detach().cpu() if hasattr(weight, "detach") else weight
    weight = checks.array(weight, "weight", ("filters", len(feature_names), "width"), dtype=None)
    n = checks.whole(n, "n")
    fps = None if fps is None else checks.rate(fps, "fps")
    order = np.argsort(-np.abs(weight).sum(axis=(1, 2)))[:n]
    # about 14 px a row at 100 dpi: each row can carry its own label, x, y or z
    fig, axes = plt.subplots(1, len(order), figsize=(1.9 * len(order) + 3.5, 0.15 * len(feature_names) + 1.8),
                             sharey=True)
    axes = np.atleast_1d(axes)
    width = weight.shape[2]
    offsets = np.arange(width) - width // 2
    groups: list[tuple[str, int, int]] = []            # (name, first row, last row): "Hips.x".."Hips.z" -> Hips
    for row, name in enumerate(feature_names):
        base = name.split(".")[0]
        if groups and groups[-1][0] == base and "." in name:
            groups[-1] = (base, groups[-1][1], row)
        else:
            groups.append((base, row, row))
    for rank, (ax, index) in enumerate(zip(axes, order)):
        w = weight[index] / max(np.abs(weight[index]).max(), 1e-12)
        image = ax.imshow(w, aspect="auto", cmap="RdBu_r", vmin=-1, vmax=1,
                          extent=(offsets[0] - 0.5, offsets[-1] + 0.5, len(feature_names) - 0.5, -0.5))
        for _, first, _ in groups[1:]:
            ax.axhline(first - 0.5, color="0.5", lw=0.5)
        ax.set_title(f"#{rank + 1}: filter {index}", fontsize=11)
        ax.tick_params(axis="x", labelsize=10)
    fig.supxlabel("time offset, frames" if fps is None else f"time offset, frames ({1000 / fps:.0f} ms each)",
                  fontsize=11)
    fig.suptitle(f"the {len(order)} strongest filters (largest sum of |weight|), strongest first; "
                 "each joint's three rows: its x, y, z", fontsize=12)
    axes[0].set_yticks([(first + last) / 2 for _, first, last in groups])
    axes[0].set_yticklabels([name for name, _, _ in groups], fontsize=10)
    coordinates = axes[-1].secondary_yaxis("right")                  # each row's own label
    coordinates.set_yticks(range(len(feature_names)),
                           [name.split(".")[1] if "." in name else "" for name in feature_names], fontsize=9)
    coordinates.tick_params(length=2, pad=1)
    fig.tight_layout()
    fig.colorbar(image, ax=list(axes), shrink=0.6, pad=0.06, label="weight / the filter's largest |weight|")
    return fig


def plot_filmstrip(motion: np.ndarray, ax=None, n: int = 6, spacing: float = 0.45,
                   skeleton: Skeleton = LOCOMOTION, title: str | None = None,
                   labels: Sequence[str] | None = None, fontsize: float = 8):
    """A motion as a strip of ``n`` poses, seen from the side, left to right in time.

    ``motion`` is features ``(frames, 3 * joints + 3)`` or root-local poses ``(frames,
    joints, 3)``: every pose is drawn in its own root frame (facing right), shifted by
    ``spacing`` metres per step, so what moves is the body, not the path. ``labels``: one
    text per pose, written under it; ``fontsize``: of the title and the labels. The small
    multiples of notebook 03 are made of these. Returns the axes.
    """
    n_pose = 3 * skeleton.n_joints
    shape = ("frames", n_pose + 3) if np.ndim(motion) == 2 else ("frames", skeleton.n_joints, 3)
    motion = checks.array(motion, "motion", shape, dtype=None)
    if motion.ndim == 2:
        motion = motion[:, :n_pose].reshape(len(motion), skeleton.n_joints, 3)
    n = checks.whole(n, "n")
    if labels is not None and len(labels) != n:
        raise ValueError(f"labels: expected one per pose ({n}), got {len(labels)}")
    fontsize = checks.positive(fontsize, "fontsize")
    if ax is None:
        ax = plt.figure(figsize=(0.8 * n + 0.5, 2.2)).add_subplot()
    frames = np.linspace(0, len(motion) - 1, n).round().astype(int)
    for k, t in enumerate(frames):
        pose = motion[t]
        for (parent, child), color in zip(skeleton.bones, bone_colors(skeleton)):
            ax.plot(pose[[parent, child], 2] + k * spacing, pose[[parent, child], 1], color=color, lw=1.2)
    ax.axhline(0, color="0.8", lw=0.8)
    for k, label in enumerate(labels or []):
        ax.text(motion[frames[k], 0, 2] + k * spacing, -0.05, label, ha="center", va="top", fontsize=fontsize)
    ax.set_aspect("equal")
    ax.set_xticks([]), ax.set_yticks([])
    for side in ("top", "right", "left", "bottom"):
        ax.spines[side].set_visible(False)
    if title:
        ax.set_title(title, fontsize=fontsize)
    return ax


def plot_joints_compared(poses: dict, joints: Sequence[int], skeleton: Skeleton = LOCOMOTION,
                         margin: float = 0.25, title: str | None = None):
    """Root-frame poses ``{title: (joints, 3)}`` (metres) side by side, seen from the
    body's left (facing left; the left side's bones nearest, drawn on top), zoomed onto
    ``joints`` and the bones around them: the first pose is the reference, its ``joints``'
    bones are drawn as a dashed grey ghost in every other panel, and each other panel's
    title adds how far its ``joints`` lie from the reference's (mean distance, cm). The
    bones that end in ``joints`` are drawn thick, ``margin`` metres of the body shown
    around them; ``title`` goes above the panels. Returns the figure."""
    if not isinstance(poses, dict) or len(poses) < 2:
        raise ValueError(f"poses: expected a dict of at least two poses, got {type(poses).__name__}")
    poses = {title: _check_poses(pose, skeleton, f"poses[{title!r}]")[0] for title, pose in poses.items()}
    joints = [checks.whole(j, "joints", minimum=0) for j in joints]
    if not joints or max(joints) >= skeleton.n_joints:
        raise ValueError(f"joints: expected joint indices 0..{skeleton.n_joints - 1}, got {joints}")
    margin = checks.positive(margin, "margin")
    reference_title, reference = next(iter(poses.items()))
    shown = sorted(set(joints) | {int(skeleton.parents[j]) for j in joints if skeleton.parents[j] >= 0})
    points = np.concatenate([pose[shown][:, [2, 1]] for pose in poses.values()])       # side view: (z, y)
    low, high = points.min(0) - margin, points.max(0) + margin
    half = 0.5 * max(high - low)
    center = 0.5 * (low + high)
    fig, axes = plt.subplots(1, len(poses), figsize=(4.2 * len(poses), 4.6), sharex=True, sharey=True)
    thick = {(int(skeleton.parents[j]), j) for j in joints}
    for ax, (name, pose) in zip(axes, poses.items()):
        if pose is not reference:
            for parent, child in sorted(thick):
                ax.plot(reference[[parent, child], 2], reference[[parent, child], 1], "--", color="0.55", lw=2.5,
                        zorder=1.5, label=reference_title if (parent, child) == min(thick) else None)
            off = 100 * np.linalg.norm(pose[joints] - reference[joints], axis=-1).mean()
            name = f"{name}\n{off:.1f} cm from the {reference_title} (mean over {len(joints)} joints)"
        for (parent, child), color in zip(skeleton.bones, bone_colors(skeleton)):
            depth = {RIGHT_COLOR: 1, CENTER_COLOR: 2, LEFT_COLOR: 3}[color]     # the far side first
            ax.plot(pose[[parent, child], 2], pose[[parent, child], 1], color=color,
                    lw=4 if (parent, child) in thick else 1.5, zorder=depth, solid_capstyle="round")
        ax.plot(pose[joints, 2], pose[joints, 1], "o", color="k", ms=4, zorder=4)
        ax.set_title(name, fontsize=11)
        ax.set_xlim(center[0] - half, center[0] + half)
        ax.set_ylim(center[1] - half, center[1] + half)
        ax.set_aspect("equal")
        ax.set_xlabel("← z, forward (m)", fontsize=10)
        ax.grid(True, color="0.92")
    axes[0].invert_xaxis()                            # forward to the left: seen from the body's left, not mirrored
    axes[0].set_ylabel("y, up (m)", fontsize=10)
    axes[1].legend(fontsize=9, loc="lower right")
    if title:
        fig.suptitle(title, fontsize=12)
    fig.tight_layout(rect=(0, 0, 1, 0.94 if title else 1))
    return fig


def plot_motion(features: np.ndarray, fps: float, fig=None, title: str | None = None, n: int = 8):
    """One window of features ``(frames, 66)`` at a glance: a side-view filmstrip of the
    body and, beside it, the path it walks seen from above. Returns the figure."""
    from .representation import to_positions
    features = checks.array(features, "features", ("frames", N_FEATURES), dtype=None)
    fps = checks.rate(fps, "fps")
    fig = fig or plt.figure(figsize=(12, 3.8))        # bodies about 250 px tall at 100 dpi, titles readable
    grid = fig.add_gridspec(1, 4)
    side = "side view in the body's own frame (facing right); where it goes: the path"
    plot_filmstrip(features, ax=fig.add_subplot(grid[0, :3]), n=n, spacing=0.6, fontsize=11,
                   title=f"{title}\n{side}" if title else side)
    plot_trajectory(to_positions(features, fps), fps, ax=fig.add_subplot(grid[0, 3])).set_title("path from above",
                                                                                              fontsize=11)
    fig.tight_layout()
    return fig


def plot_contacts(positions: np.ndarray, fps: float, contacts, joint: int = 1, axes=None,
                  planted_height_m=None, thresholds: tuple[float, float] | None = None, label: str | None = None,
                  body_fraction: float | None = None):
    """One foot joint's height above its planted height and its horizontal speed over time,
    contact frames shaded: two axes (made if ``axes`` is None). ``positions`` ``(frames, 21,
    3)``; ``contacts`` ``(frames, 4)`` booleans (``motionlab.contacts.detect``); ``joint``
    indexes ``FEET`` (0 left ankle, 1 left toe, 2 right ankle, 3 right toe);
    ``thresholds`` ``(height m, speed m/s)`` are drawn as dotted lines; with
    ``body_fraction`` the speed threshold is drawn as ``contacts.detect`` applies it: the
    larger of the speed and that fraction of the hips' speed. Returns the axes."""
    from .contacts import planted_heights
    from .skeleton import FEET
    positions = checks.array(positions, "positions", ("frames", LOCOMOTION.n_joints, 3))
    fps = checks.rate(fps, "fps")
    contacts = np.asarray(contacts)
    if contacts.shape != (len(positions), len(FEET)):
        raise ValueError(f"contacts: expected ({len(positions)}, {len(FEET)}), got {contacts.shape}")
    if checks.whole(joint, "joint", minimum=0) >= len(FEET):
        raise ValueError(f"joint: expected 0-3 (an index into FEET), got {joint}")
    if axes is None:
        axes = plt.subplots(2, 1, figsize=(10, 4), sharex=True)[1]
    j = FEET[joint]
    floor = (planted_heights(positions) if planted_height_m is None else
             np.broadcast_to(planted_height_m, (len(FEET),)))[joint]
    t = np.arange(len(positions)) / fps
    speed = np.linalg.norm(np.gradient(positions[:, j, [0, 2]], axis=0), axis=-1) * fps
    axes[0].plot(t, 100 * (positions[:, j, 1] - floor), label=label)
    axes[1].plot(t, speed, label=label)
    kind = ("ankle", "toe")[joint % 2]                                  # FEET: ankle, toe, ankle, toe
    axes[0].set_ylabel(f"{LOCOMOTION.names[j]} ({kind})\nheight above\nplanted (cm)")
    axes[1].set_ylabel(f"{kind}'s horizontal\nspeed (m/s)")
    axes[1].set_xlabel("time (s)")
    for ax in axes:
        ax.fill_between(t, 0, 1, where=contacts[:, joint], transform=ax.get_xaxis_transform(), color="0.88",
                        label="contact" if ax is axes[0] else None)
    if thresholds is not None:
        axes[0].axhline(100 * thresholds[0], color="k", ls=":", lw=1, label="height threshold")
        limit = np.full(len(t), float(thresholds[1]))
        if body_fraction is not None:
            hips = np.linalg.norm(np.gradient(positions[:, 0, [0, 2]], axis=0), axis=-1) * fps
            limit = np.maximum(limit, checks.non_negative(body_fraction, "body_fraction") * hips)
        axes[1].plot(t, limit, color="k", ls=":", lw=1, label="speed threshold")
        axes[1].legend(fontsize=8, loc="upper right")
    axes[0].legend(fontsize=8, loc="upper right")
    return axes


def plot_footprints(motions: dict, contacts: dict | None = None, ax=None, every: int = 1):
    """Seen from above (world ``z`` right, ``x`` up, as :func:`plot_trajectory`), the path
    of each toe of every motion in ``motions`` ``{label: (frames, 21, 3)}``, with a dot at
    each frame where ``contacts[label]`` ``(frames, 4)`` says the toe is down: a planted
    foot leaves one tight cluster of dots, a sliding one a smear. The sides differ by line
    and marker (left: solid line, dots; right: dashed line, triangles); one motion alone is
    also coloured by side as the skeletons are (blue left, red right). Returns the axes."""
    from .skeleton import FEET
    if ax is None:
        ax = plt.figure(figsize=(10, 3.5)).add_subplot()
    for k, (label, positions) in enumerate(motions.items()):
        positions = checks.array(positions, f"motions[{label!r}]", ("frames", LOCOMOTION.n_joints, 3))
        for side, joint in ((0, 1), (1, 3)):
            color = (LEFT_COLOR, RIGHT_COLOR)[side] if len(motions) == 1 else f"C{k}"
            toe = positions[::every, FEET[joint]]
            ax.plot(toe[:, 2], toe[:, 0], color=color, lw=0.8, alpha=0.6, ls="-" if side == 0 else "--",
                    label=f"{label}: {'left' if side == 0 else 'right'} toe")
            if contacts is not None and label in contacts:
                down = np.asarray(contacts[label])[::every, joint]
                ax.plot(toe[down, 2], toe[down, 0], "o" if side == 0 else "^", ms=3, color=color, alpha=0.8)
    ax.set_xlabel("z (m)")
    ax.set_ylabel("x (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, color="0.9")
    ax.legend(fontsize=7, ncol=2)
    return ax


def plot_leg(before: np.ndarray, after: np.ndarray, leg: int = 0, ax=None, target=None):
    """A leg (hip, knee, ankle, toe) from the side (world ``z`` right, ``y`` up) before and
    after two-bone IK: ``before`` and ``after`` are poses ``(21, 3)``; ``leg`` 0 left, 1
    right; ``target``, the ankle's target ``(3,)``, drawn as a cross. Returns the axes."""
    from .contacts import LEGS
    if ax is None:
        ax = plt.figure(figsize=(4, 4)).add_subplot()
    chain = list(LEGS[leg])
    for pose, style, label in ((before, "--", "before"), (after, "-", "after IK")):
        pose = checks.array(pose, "pose", (LOCOMOTION.n_joints, 3))
        ax.plot(pose[chain, 2], pose[chain, 1], style, marker="o", lw=2, label=label)
    if target is not None:
        ax.plot(target[2], target[1], "kx", ms=10, mew=2, label="ankle's target")
    ax.axhline(0, color="0.5", lw=1)
    ax.set_xlabel("z (m)")
    ax.set_ylabel("height (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    return ax


def plot_live_run(run: dict, fps: float, n: int = 4, title: str | None = None):
    """The still of a steered live run (:func:`motionlab.live.record`): ``n`` poses in the
    panel's three-quarter view, evenly spaced in time and each labelled with its time and
    what was held down, and the path seen from above with the footprints the toes left and
    where each pose stood. Returns the figure (about 1600×400 px at 100 dpi)."""
    positions = checks.array(run.get("positions"), "run['positions']", ("frames", LOCOMOTION.n_joints, 3))
    fps = checks.rate(fps, "fps")
    n = checks.whole(n, "n")
    picks = np.linspace(0, len(positions) - 1, n).round().astype(int)
    fig = plt.figure(figsize=(3.0 * n + 4.0, 4.0))
    for k, frame in enumerate(picks):
        ax = fig.add_subplot(1, n + 1, k + 1, projection="3d")
        held = run.get("intents", [()] * len(positions))[frame]
        plot_skeleton(positions[frame], ax=ax, title=f"t = {frame / fps:.1f} s\n{' + '.join(held) or 'let go'}")
        ax.view_init(elev=20, azim=-60)
        ax.set_axis_off()          # the floor grid (0.5 m squares) gives the scale; ticks only crowd it
    ax = fig.add_subplot(1, n + 1, n + 1)
    hips = positions[:, 0]
    ax.plot(hips[:, 2], hips[:, 0], color="tab:green", lw=1.5, label="path")
    prints = np.array(run.get("footprints") or np.zeros((0, 2)), dtype=float).reshape(-1, 2)
    ax.plot(prints[:, 1], prints[:, 0], "s", ms=4, color="0.35", label=f"footprints ({len(prints)})")
    ax.plot(hips[picks, 2], hips[picks, 0], "o", color="k", ms=5, label="poses shown")
    ax.set_xlabel("z (m)")
    ax.set_ylabel("x (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, color="0.9")
    ax.set_title("seen from above")
    ax.legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title, fontsize=15, fontweight="bold")   # the model: the largest text
    fig.tight_layout(rect=(0, 0, 1, 0.92 if title else 1))
    return fig
