import matplotlib.pyplot as plt
import pytest

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
