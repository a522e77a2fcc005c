"""A skeleton drawn in matplotlib's 3-D axes: what every picture of a body shares.

Motion data is ``y`` up; matplotlib's 3-D axes are ``z`` up. World ``(x, y, z)`` is drawn at
plot coordinates ``(z, x, y)`` (:func:`_plot_xyz`): a cyclic swap of axes, so the picture is
rotated, never mirrored (a left foot stays a left foot). Left-side bones are blue, right-side
bones red, the spine and head black (:func:`bone_colors`); a floor grid gives the scale. One
pose or several on it: :func:`plot_skeleton`. :mod:`motionlab.viz` (static figures) and
:mod:`motionlab.animations` (players, GIFs) draw with these.
"""
from __future__ import annotations

from typing import Sequence

import matplotlib
import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np

from . import checks
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
