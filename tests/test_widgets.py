import matplotlib.pyplot as plt
import pytest
import torch

from motionlab import data, widgets


@pytest.fixture(scope="module")
def clips():
    return data.load("synthetic", fps=20, n_clips=2, duration_s=3)


def test_clip_browser_renders_headless_and_follows_its_widgets(clips, monkeypatch):
    browser = widgets.ClipBrowser(clips)
    fig = browser.figure("synthetic_001", frame=10)
    assert "synthetic_001, frame 10" in fig.axes[0].get_title()
    plt.close(fig)
    assert browser.frame.max == 59
    drawn = []
    real_figure = browser.figure
    monkeypatch.setattr(browser, "figure", lambda *a: drawn.append(
        (browser.picker.value, browser.frame.value)) or real_figure(*a))
    browser.frame.value = 30
    browser.picker.value = "synthetic_001"                  # the callbacks redraw
    assert drawn == [("synthetic_000", 30), ("synthetic_001", 30)]
    with pytest.raises(ValueError, match="no clip 'nope'"):
        browser.figure("nope")
    with pytest.raises(ValueError, match="nothing to browse"):
        widgets.ClipBrowser([])


def test_latent_sliders_map_probabilities_and_render_headless(clips):
    decoded = []

    def decode(z):
        decoded.append(z.clone())
        return clips[0].features()[None].repeat(len(z), axis=0)

    sliders = widgets.LatentSliders(decode, latent=6, axes=[1, 4], fps=20)
    z = sliders.latent_vector([0.1, 0.9], sample=2)
    assert z.shape == (6,) and z[1] == pytest.approx(-1.2816, abs=1e-4) and z[4] == pytest.approx(1.2816, abs=1e-4)
    assert torch.equal(z[[0, 2, 3, 5]], sliders.latent_vector([0.5, 0.5], sample=2)[[0, 2, 3, 5]])
    fig = sliders.figure([0.3, 0.7], sample=1)
    plt.close(fig)
    sliders.sliders[0].value = 0.2                        # the callback decodes and redraws
    assert len(decoded) == 2 and decoded[-1][0, 1] == pytest.approx(-0.8416, abs=1e-3)
    # decoded once per move, and the canvas got the window's frames to play (63 numbers each)
    assert len(sliders.player.clip) == len(clips[0].features()) and len(sliders.player.clip[0]) == 63
    assert sliders.player.title.startswith("sample 0: z[1]=-0.84 (u=0.20), z[4]=+0.00 (u=0.50)")
    with pytest.raises(ValueError, match="axes"):
        widgets.LatentSliders(decode, latent=6, axes=[6], fps=20)
    with pytest.raises(ValueError, match="probabilities: expected 2 values"):
        sliders.latent_vector([0.5])


def test_control_panel_builds_controls_and_renders_headless(monkeypatch):
    import numpy as np
    from motionlab import representation as rep
    from motionlab import synthetic

    calls = []

    def generate(control, seed):
        # a stand-in model: the synthetic walker itself, following the control
        calls.append((control.copy(), seed))
        return rep.to_features(synthetic.generate(control, 20.0).positions, 20.0)

    panel = widgets.ControlPanel(generate, fps=20.0, duration_s=3.0, walked=False)
    sliders = panel.control(preset="sliders", forward=2.0, sideways=0.0, turning=0.5)
    assert sliders.shape == (60, 3)
    assert np.allclose(sliders[0], 0.0) and np.allclose(sliders[-1], [2.0, 0.0, 0.5])
    assert np.allclose(panel.control(preset="backwards")[-1], [-0.8, 0.0, 0.0])
    fig = panel.figure(preset="circle", seed=3)
    assert len(fig.axes) == 2 and calls[-1][1] == 3
    plt.close(fig)
    # the widgets drive the same figure
    redraws = []
    monkeypatch.setattr(panel, "redraw", lambda: redraws.append(panel.preset.value))
    panel.preset.value = "run"
    assert redraws == ["run"]
    monkeypatch.undo()
    panel.preset.value = "circle"                          # generated once, played on the canvas
    assert len(panel.player.clip) == 60 and panel.player.title == "circle, seed 0"
    walked = widgets.ControlPanel(generate, fps=20.0, duration_s=3.0).control(preset="walk")
    assert walked[-20:, 1].std() > 0.02 > sliders[-20:, 1].std()      # the walker's sway, not a flat line
    anim = panel.animation(preset="stand still", step=4)
    assert anim is not None
    plt.close(anim._fig)
    with pytest.raises(ValueError, match="duration_s"):
        widgets.ControlPanel(generate, fps=20.0, duration_s=0)


def test_a_displayed_panel_leaves_a_still_picture_below_it(clips, monkeypatch):
    shown = []
    monkeypatch.setattr(widgets, "display", lambda obj: shown.append(obj))
    browser = widgets.ClipBrowser(clips)
    browser._ipython_display_()
    # the redraw into the panel's output, then the panel, the caption and the still figure
    assert shown[-3] is browser.widget
    assert [type(obj).__name__ for obj in shown[-2:]] == ["Markdown", "Figure"]
    assert widgets.SNAPSHOT_NOTE in shown[-2].data
    assert "synthetic_000, frame 0" in shown[-1].axes[0].get_title()
