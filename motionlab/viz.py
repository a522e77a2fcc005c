"""Pictures of motion: stick figures, top-down trajectories, animations.

Motion data is ``y`` up; matplotlib's 3-D axes are ``z`` up. Every function here draws
world ``(x, y, z)`` at plot coordinates ``(z, x, y)``: a cyclic swap of axes, so the
picture is rotated, never mirrored (a left foot stays a left foot). Left-side bones are
drawn in blue, right-side bones in red, the spine and head in black.

Animations come back as matplotlib ``FuncAnimation`` objects: :func:`to_html` turns one
into HTML that plays in a notebook without ffmpeg, :func:`stills` into a picture of a few of
its frames (what :func:`show` puts below the player, for readers without JavaScript),
:func:`save_gif` writes a GIF.

The static figures are drawn here; the drawing basics (the axis swap, colours, floor grid,
:func:`plot_skeleton`) are in :mod:`motionlab.stickfigure` and the animations in
:mod:`motionlab.animations`, and every name of theirs is importable from here.
"""
from __future__ import annotations

from typing import Sequence

import matplotlib.pyplot as plt
import numpy as np

from . import checks, metrics
from .animations import (PATH_COLORS, PLAYER_GLYPHS, STILL_PANEL_PX, Shown, animate, save_frame, save_gif,
                         show, stills, to_html)
from .representation import N_FEATURES, root_trajectory, to_positions
from .skeleton import LOCOMOTION, Skeleton
from .stickfigure import (CENTER_COLOR, GRID_COLOR, GRID_SPACING_M, LEFT_COLOR, RIGHT_COLOR, _check_poses,
                          _plot_xyz, bone_colors, plot_skeleton)

__all__ = ["CENTER_COLOR", "GRID_COLOR", "GRID_SPACING_M", "LEFT_COLOR", "PATH_COLORS", "PLAYER_GLYPHS",
           "RIGHT_COLOR", "STILL_PANEL_PX", "Shown", "animate", "bone_colors", "plot_bone_length",
           "plot_conv_filters", "plot_contacts", "plot_controls", "plot_filmstrip", "plot_footprints", "plot_frame",
           "plot_history", "plot_joints_compared", "plot_leg", "plot_live_run", "plot_motion", "plot_skeleton",
           "plot_trajectory", "save_frame", "save_gif", "show", "stills", "to_html", "_plot_xyz"]
"""The drawing basics live in :mod:`motionlab.stickfigure`, the animations in
:mod:`motionlab.animations`; their names are here too (``_plot_xyz``, the axis swap, for the
tests)."""


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
    from .contacts import horizontal_speed, planted_heights
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
    moving = horizontal_speed(positions[:, [0, j]], fps)                # as contacts.detect measures it
    speed = moving[:, 1]
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
            hips = moving[:, 0]
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


def plot_bone_length(motions: dict, fps: float, joint: str = "RightFoot", data=None, ax=None):
    """The length over time of the bone that ends in ``joint`` (``"RightFoot"``: the right
    shin, knee to ankle), in cm, for every motion of ``motions`` ``{label: features (n,
    frames, 66)}`` (data units; the mean over its ``n`` samples, with their spread shaded),
    and the mean of ``data``'s (same layout) as a dashed line. A rigid body draws flat lines;
    a model whose feet drift from its body draws a bone that grows. Returns the axes."""
    fps = checks.rate(fps, "fps")
    curves = {label: 100 * metrics.bone_length(to_positions(checks.array(
        features, f"motions[{label!r}]", ("n", "frames", N_FEATURES)), fps), joint) for label, features in motions.items()}
    if ax is None:
        ax = plt.figure(figsize=(9, 3.2)).add_subplot()
    for k, (label, lengths) in enumerate(curves.items()):                     # (n, frames), cm
        t = np.arange(lengths.shape[1]) / fps
        ax.plot(t, lengths.mean(0), color=f"C{k}", label=label)
        ax.fill_between(t, lengths.min(0), lengths.max(0), color=f"C{k}", alpha=0.15, lw=0)
    if data is not None:
        data = checks.array(data, "data", ("n", "frames", N_FEATURES))
        ax.axhline(100 * metrics.bone_length(to_positions(data, fps), joint).mean(), color="k", ls="--", lw=1,
                   label="the data's bodies")
    parent = LOCOMOTION.names[LOCOMOTION.parents[LOCOMOTION.index(joint)]]
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{parent} → {joint} (cm)")
    ax.legend(fontsize=8)
    ax.grid(True, color="0.9")
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
