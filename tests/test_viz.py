import base64
import io
import re

import matplotlib.pyplot as plt
import numpy as np
import pytest
from PIL import Image

from motionlab import viz

from conftest import walker


def test_plot_axes_are_a_rotation_not_a_mirror():
    basis = np.eye(3)
    mapped = np.stack(viz._plot_xyz(basis), axis=-1)           # rows: world x, y, z in plot axes
    assert np.linalg.det(mapped) == pytest.approx(1.0)


def test_static_plots_render(tmp_path):
    walk = walker()
    fig = plt.figure(figsize=(8, 4))
    ax = viz.plot_skeleton(walk[::20], ax=fig.add_subplot(1, 2, 1, projection="3d"), title="walk")
    assert len(ax.lines) >= 4 * 20
    viz.plot_trajectory(walk, 20, ax=fig.add_subplot(1, 2, 2), label="path")
    fig.savefig(tmp_path / "plots.png", dpi=50)
    plt.close(fig)
    assert Image.open(tmp_path / "plots.png").size[0] > 100
    with pytest.raises(ValueError, match="poses: expected"):
        viz.plot_skeleton(np.zeros((5, 3)))


def test_bone_colours_mark_sides():
    colors = viz.bone_colors()
    assert colors.count(viz.LEFT_COLOR) == colors.count(viz.RIGHT_COLOR) == 8
    assert colors.count(viz.CENTER_COLOR) == 4


def test_animation_html_gif_and_frames(tmp_path):
    walk, run = walker(frames=12), walker(frames=8, speed=3.0)
    anim = viz.animate([walk, run], fps=20, titles=["walk", "run"], step=2)
    html = viz.to_html(anim)
    assert "<script" in html and "animation" in html.lower()
    # offline: nothing fetched (no web font from a CDN), every button labelled with text
    assert "http" not in html and "<link" not in html and 'class="fa' not in html
    assert all(glyph in html for glyph in viz.PLAYER_GLYPHS.values())
    # the player shows its first frame before any script runs (JupyterLab before Play, nbviewer)
    first = re.search(r'frames\[0\] = "(data:image/jpeg;base64,[^"]+)"', html).group(1)
    src = re.search(r'<img id="_anim_img\w+" src="([^"]+)"', html).group(1)
    assert src == first.replace("\\\n", "") and re.fullmatch(r"data:image/jpeg;base64,[A-Za-z0-9+/=]+", src)
    Image.open(io.BytesIO(base64.b64decode(src.split(",", 1)[1]))).verify()      # a whole JPEG
    long_title = "forward +1.3 m/s, left +0.0 m/s, turn +0.0 rad/s, seed 0"
    wrapped = viz.animate(walk, fps=20, titles=[long_title], size=3.0)._fig.axes[0].get_title()
    assert "\n" in wrapped and wrapped.replace("\n", " ") == long_title       # wrapped to its panel, not cut
    viz.save_gif(anim, str(tmp_path / "a.gif"))
    gif = Image.open(tmp_path / "a.gif")
    assert gif.n_frames == 6
    viz.save_frame(viz.animate(walk, fps=20, follow=False), 5, str(tmp_path / "f.png"))
    assert (tmp_path / "f.png").stat().st_size > 1000
    with pytest.raises(ValueError, match="titles"):
        viz.animate([walk, run], fps=20, titles=["one"])


def test_animation_overview_shows_every_path_from_above():
    walk, curve = walker(frames=20), walker(frames=20, turn_rate=1.0)
    anim = viz.animate([walk, curve], fps=20, titles=["walk", "curve"], step=5, overview=True)
    top = anim._fig.axes[-1]
    assert len(anim._fig.axes) == 3 and top.name == "rectilinear"          # two 3-D panels, then the view from above
    assert [t.get_text() for t in top.get_legend().get_texts()] == ["walk", "curve"]
    anim._func(10)
    here = [line for line in top.lines if line.get_marker() == "o"]
    assert [tuple(np.ravel(line.get_xydata())) for line in here] == \
        [(walk[10, 0, 2], walk[10, 0, 0]), (curve[10, 0, 2], curve[10, 0, 0])]   # each hips' (z, x) at frame 10
    plain = viz.animate([walk, curve], fps=20, step=5)
    assert [ax.get_position().height for ax in plain._fig.axes] == \
        pytest.approx([ax.get_position().height for ax in anim._fig.axes[:2]], rel=0.05)   # 3-D panels not shrunk
    plt.close("all")


def test_joints_compared_and_labelled_filmstrip():
    walk = walker(frames=10)
    moved = walk[5].copy()
    moved[[15, 16]] += [0.0, 0.0, 0.1]                                        # left hand and finger 10 cm forward
    fig = viz.plot_joints_compared({"original": walk[5], "moved": moved}, [15, 16], title="a hand")
    assert "10.0 cm from the original" in fig.axes[1].get_title()
    assert fig.axes[0].get_title() == "original" and fig._suptitle.get_text() == "a hand"
    with pytest.raises(ValueError, match="poses: expected a dict"):
        viz.plot_joints_compared({"one": walk[5]}, [15])
    with pytest.raises(ValueError, match="joints"):
        viz.plot_joints_compared({"original": walk[5], "moved": moved}, [21])
    ax = viz.plot_filmstrip(walk, n=3, labels=["a", "b", "c"], fontsize=11, title="strip")
    assert [t.get_text() for t in ax.texts] == ["a", "b", "c"] and ax.title.get_fontsize() == 11
    with pytest.raises(ValueError, match="labels: expected one per pose"):
        viz.plot_filmstrip(walk, n=3, labels=["a"])
    plt.close("all")


def test_control_and_frame_plots(tmp_path):
    from motionlab.representation import to_features
    walk = walker()
    axes = viz.plot_controls(to_features(walk, 20), 20, label="walk")
    assert len(axes) == 3 and axes[0].get_legend() is not None
    fig = viz.plot_frame(walk, 40, 20)
    fig.savefig(tmp_path / "frame.png", dpi=40)
    plt.close("all")
    with pytest.raises(ValueError, match="frame: expected 0..79"):
        viz.plot_frame(walk, 80, 20)
    with pytest.raises(ValueError, match="control: expected"):
        viz.plot_controls(np.zeros((5, 4)), 20)


@pytest.mark.slow
def test_show_leaves_still_frames_beside_the_player():
    import io
    walk, run = walker(frames=40), walker(frames=30, speed=3.0)
    anim = viz.animate([walk, run], fps=20, titles=["walk", "run"], step=2)
    rows = viz.stills(anim, n=4, dpi=40)
    width, height = anim._fig.get_size_inches() * 40
    assert rows.dtype == np.uint8 and rows.shape == (4 * round(height), round(width), 3)
    assert rows.std() > 0                                           # something is drawn
    shown = viz.show(anim, still_frames=3)
    assert "<script" in shown.html
    still = Image.open(io.BytesIO(shown.png))
    assert still.format == "PNG" and still.size[1] == 3 * viz.STILL_PANEL_PX and shown.rows == 3
    with pytest.raises(ValueError, match="viz.animate"):
        viz.stills(object.__new__(type(anim)))


def test_saving_an_animation_draws_each_frame_once(tmp_path):
    """The player and the GIF draw each of the animation's frames once, after the stills too
    (they give the figure a canvas that draws: matplotlib's redraw after each grabbed frame,
    for a window on screen, then drew every frame twice), and the canvas is as it was after."""
    anim = viz.animate([walker(frames=12), walker(frames=12, speed=3.0)], fps=20, step=2)
    viz.stills(anim, n=2)                                           # as viz.show does first
    fig, drawn = anim._fig, []
    fig.draw = lambda renderer, draw=fig.draw: (drawn.append(1), draw(renderer))[1]
    html = viz.to_html(anim)
    assert len(re.findall(r"frames\[\d+\] = ", html)) == 6 and len(drawn) == 6
    drawn.clear()
    viz.save_gif(anim, str(tmp_path / "walk.gif"))
    assert Image.open(tmp_path / "walk.gif").n_frames == 6 and len(drawn) == 6
    assert "draw_idle" not in vars(fig.canvas)                    # the canvas's own method again


def test_bone_length_plot_draws_a_growing_shin_and_the_datas():
    from motionlab import representation as rep
    from motionlab.skeleton import LOCOMOTION
    walk = walker()
    grown = walk.copy()
    knee, ankle, toe = (LOCOMOTION.index(n) for n in ("RightLeg", "RightFoot", "RightToeBase"))
    stretch = (0.5 * np.arange(len(walk)) / len(walk))[:, None] * (walk[:, ankle] - walk[:, knee])
    grown[:, ankle] += stretch
    grown[:, toe] += stretch
    features = {name: rep.to_features(p, 20.0)[None] for name, p in (("rigid", walk), ("grown", grown))}
    ax = viz.plot_bone_length(features, 20.0, "RightFoot", data=features["rigid"])
    rigid, growing = (line.get_ydata() for line in ax.lines[:2])
    shin = 100 * np.linalg.norm(walk[:, ankle] - walk[:, knee], axis=-1)    # cm, measured here
    np.testing.assert_allclose(rigid, shin, atol=1e-6)
    np.testing.assert_allclose(growing, shin * (1 + 0.5 * np.arange(len(walk)) / len(walk)), atol=1e-6)
    assert ax.lines[2].get_ydata()[0] == pytest.approx(shin.mean())        # the data's, dashed
    assert "RightLeg → RightFoot" in ax.get_ylabel()
    plt.close(ax.figure)
    with pytest.raises(ValueError, match="joint"):
        viz.plot_bone_length(features, 20.0, "Hips")
