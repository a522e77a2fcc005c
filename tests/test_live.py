"""The live steering panel: the controller, the causal stride wobble, the character, the
loop's thread, and the widget's kernel side (no browser: its messages are captured)."""
from __future__ import annotations

import shutil
import subprocess
import threading
import time

import numpy as np
import pytest

from motionlab import claims, experiments, live, metrics, pretrained, synthetic
from motionlab.representation import to_features

FPS = 20.0


@pytest.fixture(scope="module")
def moglow():
    if "moglow" not in pretrained.available():
        pytest.skip("the shipped MoGlow is not in motionlab/checkpoints")
    return pretrained.load("moglow")


def stepping_by_second(run: dict) -> np.ndarray:
    speed = metrics.stepping_speed(to_features(run["positions"], FPS), FPS, smooth_s=0.1)
    return np.array([speed[int(s * FPS):int((s + 1) * FPS)].mean() for s in range(int(np.ceil(len(speed) / FPS)))])


# -- Steering and the stride wobble ---------------------------------------------------------

def test_steering_maps_intents_and_eases_towards_them():
    steering = live.Steering(FPS)
    assert steering.target({"forward"}).tolist() == [1.3, 0.0, 0.0]
    assert steering.target({"forward", "run", "left"}).tolist() == [3.2, 0.0, 0.8]
    assert steering.target({"side_right", "back"}).tolist() == [-0.8, -0.5, 0.0]
    assert steering.target({"forward", "stop"}).tolist() == [0.0, 0.0, 0.0]
    speeds = [steering.step({"forward"})[0] for _ in range(int(FPS))]
    assert np.all(np.diff(speeds) > 0) and 0.1 < speeds[0] < 0.3 and speeds[-1] > 0.95 * 1.3
    assert [steering.step(())[0] for _ in range(int(FPS))][-1] < 0.03 * 1.3      # let go: eases to a stop
    with pytest.raises(ValueError, match="intents: expected some of"):
        steering.target({"jump"})


def test_stride_wobble_is_causal_and_sways_like_the_walker():
    control = synthetic.preset_control("walk", 12, FPS, ramp_s=0.5)
    wobble = synthetic.StrideWobble(FPS)
    made = np.stack([wobble.step(c) for c in control])
    again = synthetic.StrideWobble(FPS)
    prefix = np.stack([again.step(c) for c in control[:100]])
    assert np.array_equal(prefix, made[:100])                       # later frames change nothing before them
    assert np.array_equal(made[:, 0], control[:, 0])                # forward speed as asked
    walked = synthetic.walked_control(control, FPS)
    ours, theirs = (x[60:, 1] - control[60:, 1] for x in (made, walked))
    assert 0.7 < ours.std() / theirs.std() < 1.3                     # as much sway as the walker's
    spectrum = np.abs(np.fft.rfft(ours))
    peak = np.fft.rfftfreq(len(ours), 1 / FPS)[spectrum.argmax()]
    assert abs(peak - 0.9) < 0.15                                    # once per stride at 1.3 m/s
    standing = synthetic.StrideWobble(FPS)
    assert np.abs(np.stack([standing.step(np.zeros(3)) for _ in range(40)])).max() == 0.0
    with pytest.raises(ValueError, match="control"):
        standing.step(np.zeros(4))


# -- the character -----------------------------------------------------------------------------

@pytest.mark.slow
def test_held_forward_walks_and_letting_go_stops(moglow):
    """§5.3's measure, live (claims.follows_keys): held forward, the body steps at least
    70 % of the data's stepping at that speed; let go, it stops within a second. The same
    check fails a character nobody steers and one whose key is never let go."""
    data = experiments.preset_walks("walk", 4.0, FPS, n=4)
    run = live.record(live.LiveCharacter(moglow, FPS), ((3.0, ("forward",)), (2.0, ())))
    verdict = claims.follows_keys(run, data, FPS)
    assert verdict, verdict
    held = "held: stepping / the data's walking"
    walked = verdict.figures[held]
    assert np.isfinite(run["positions"]).all() and len(run["footprints"]) >= 4
    idle = live.record(live.LiveCharacter(moglow, FPS), ((3.0, ()), (2.0, ())))
    assert "forward was never held" in str(claims.follows_keys(idle, data, FPS))
    # a character that ignores the keys: the walk recorded above, labelled as if the key
    # had been let go after 1.5 s -- it walks on, so "let go, it stops" fails
    relabelled = {**run, "intents": [("forward",)] * 30 + [()] * (len(run["intents"]) - 30)}
    assert not claims.follows_keys(relabelled, data, FPS)
    with pytest.raises(ValueError, match="intents"):
        claims.follows_keys({**run, "intents": run["intents"][:5]}, data, FPS)
    # a turn held turns the body; a straight walk labelled as that turn fails the check
    turned = live.record(live.LiveCharacter(moglow, FPS), ((1.5, ("forward",)), (2.0, ("forward", "left")),
                                                           (1.0, ("forward",)), (2.0, ())))
    verdict = claims.follows_keys(turned, data, FPS)
    assert verdict and verdict.figures["turn held: heading turned / asked"] > 0.8, verdict
    straight = live.record(live.LiveCharacter(moglow, FPS), ((4.5, ("forward",)), (2.0, ())))
    assert not claims.follows_keys({**straight, "intents": turned["intents"], "control": turned["control"]},
                                   data, FPS)
    # without the stride's sway in the control the model steps less: it reads its step timing from the sway
    smooth = live.record(live.LiveCharacter(moglow, FPS, wobble=False), ((3.0, ("forward",)), (2.0, ())))
    assert claims.follows_keys(smooth, data, FPS).figures[held] < walked
    # §5.3 felt at the keyboard: MoGlow trained without history dropout ignores the stick
    if "moglow_no_dropout" in pretrained.available():
        deaf = live.record(live.LiveCharacter(pretrained.load("moglow_no_dropout"), FPS),
                           ((3.0, ("forward",)), (2.0, ())))
        assert not claims.follows_keys(deaf, data, FPS)


def test_the_lstm_baseline_streams_and_switches_mid_walk(moglow):
    if "lstm_control" not in pretrained.available():
        pytest.skip("the shipped LSTM-3LR is not in motionlab/checkpoints")
    lstm = pretrained.load("lstm_control")
    character = live.LiveCharacter(moglow, FPS)
    live.record(character, ((1.0, ("forward",)),))
    character.set_model(lstm)                                        # continues from the frames so far
    run = live.record(character, ((1.0, ("forward", "left")),))
    assert np.isfinite(run["positions"]).all() and character.frame == 2 * FPS
    assert np.linalg.norm(run["positions"][-1, 0, [0, 2]] - run["positions"][0, 0, [0, 2]]) > 0.5
    with pytest.raises(ValueError, match="control='given'"):
        live.LiveCharacter(pretrained.load("lstm_no_control"), FPS)


def test_character_is_repeatable_and_resets(moglow):
    character = live.LiveCharacter(moglow, FPS, seed=3)
    first = live.record(character, ((1.0, ("forward", "left")),))
    assert character.frame == int(FPS) and np.linalg.norm(character.root[:2]) > 0.05
    character.reset()
    assert character.frame == 0 and character.root.tolist() == [0.0, 0.0, 0.0]
    again = live.record(character, ((1.0, ("forward", "left")),))
    assert np.array_equal(first["positions"], again["positions"])     # same seed, same motion
    raw = live.record(live.LiveCharacter(moglow, FPS, seed=3, lock_feet=False), ((1.0, ("forward", "left")),))
    moved = np.abs(raw["positions"] - first["positions"]).max(axis=(0, 2))
    assert moved[[0, 9, 10, 11, 12]].max() == 0.0 and moved[[3, 4, 7, 8]].max() > 0   # the lock moves legs only
    character.set_temperature(0.0)
    assert character.stream.temperature == 0.0
    with pytest.raises(ValueError, match="temperature"):
        character.set_temperature(float("nan"))


def test_a_control_outside_the_data_is_clamped_and_said(moglow):
    character = live.LiveCharacter(moglow, FPS, wobble=False)
    character.steering = live.Steering(FPS, walk_ms=9.0, turn_rads=4.0, ease_s=0.0)
    tick = character.tick({"forward", "left"})
    assert tick.clamped and tick.control.tolist() == [live.CONTROL_RANGE[0, 1], 0.0, live.CONTROL_RANGE[2, 1]]
    assert not live.LiveCharacter(moglow, FPS).tick({"forward", "run"}).clamped     # the keys' own speeds fit


def test_character_rejects_what_cannot_stream(moglow):
    class NoNormalizer:
        config = moglow.config
        stream = moglow.stream
    with pytest.raises(ValueError, match="normalizer"):
        live.LiveCharacter(NoNormalizer())
    with pytest.raises(ValueError, match="start"):
        live.LiveCharacter(moglow, start=np.zeros((3, 66)))
    with pytest.raises(ValueError, match="script: no frames"):
        live.record(live.LiveCharacter(moglow), ())


# -- the loop's thread ---------------------------------------------------------------------------

def live_threads() -> list:
    return [t for t in threading.enumerate() if t.name == "motionlab-live"]


def test_loop_keeps_time_measures_and_stops():
    got = []
    loop = live.Loop(lambda: len(got), got.append, fps=50.0, window_s=10.0)
    loop.start()
    loop.start()                                                     # a second start is a no-op
    assert len(live_threads()) == 1
    time.sleep(0.5)
    loop.changed()
    time.sleep(0.5)
    loop.stop()
    assert not loop.running and not live_threads()                   # no thread left behind
    stats = loop.stats()
    assert 40 <= len(got) <= 52 and stats["frames"] == len(got)
    assert 45 < stats["fps"] < 55 and stats["interval p50 (ms)"] == pytest.approx(20, abs=5)
    assert 0 < stats["control to frame (ms)"] < 40


def test_an_error_in_the_loop_is_reported_and_stops_it():
    reported = []

    def tick():
        raise ValueError("frame 3: the model generated NaN or infinite values")
    loop = live.Loop(tick, lambda t: None, fps=50.0, on_error=lambda message, trace: reported.append((message, trace)))
    loop.start()
    for _ in range(100):
        if not loop.running:
            break
        time.sleep(0.01)
    assert not loop.running and not live_threads()
    assert reported[0][0] == loop.error == "ValueError: frame 3: the model generated NaN or infinite values"
    assert "Traceback" in reported[0][1]


# -- the widgets' kernel side --------------------------------------------------------------------

def test_steering_panel_runs_resets_and_closes(moglow, monkeypatch):
    panel = live.SteeringPanel({"dropout": moglow})
    sent = []
    monkeypatch.setattr(panel, "send", lambda content, buffers=None: sent.append(content))
    assert panel.variants == ["dropout"] and panel.mode == "live" and len(panel.bones) == 20
    panel.held = ["forward"]
    panel.running = True
    time.sleep(1.0)
    assert panel.loop.running and len(live_threads()) == 1
    frames = [m for m in sent if m["kind"] == "frame"]
    assert len(frames) >= 10 and len(frames[0]["p"]) == 63 and len(frames[0]["c"]) == 4
    assert any("stats" in m for m in frames)
    panel.running = False
    assert not live_threads()
    panel._on_message(panel, {"kind": "reset"}, [])
    assert panel.character.frame == 0 and sent[-1] == {"kind": "reset"}
    panel.running = True
    time.sleep(0.2)
    panel._on_message(panel, {"kind": "detached"}, [])               # the cell was re-run: its view is gone
    assert not panel.running and not live_threads()
    panel.temperature = 0.0
    assert panel.character.stream.temperature == 0.0
    panel.lock_feet = False
    assert panel.character.lock_feet is False
    panel.running = True
    panel.close()
    assert not live_threads()


def test_steering_panel_shows_an_error_in_the_loop(moglow, monkeypatch):
    panel = live.SteeringPanel({"dropout": moglow})
    sent = []
    monkeypatch.setattr(panel, "send", lambda content, buffers=None: sent.append(content))

    def broken(intents=()):
        raise RuntimeError("the stream broke")
    monkeypatch.setattr(panel.character, "tick", broken)
    panel.running = True
    for _ in range(100):
        if not panel.loop.running:
            break
        time.sleep(0.01)
    assert {"kind": "error", "message": "RuntimeError: the stream broke"} in sent
    panel.close()


def test_one_panel_runs_at_a_time(moglow):
    first, second = live.SteeringPanel({"dropout": moglow}), live.SteeringPanel({"dropout": moglow})
    for panel in (first, second):
        panel.send = lambda content, buffers=None: None
    first.running = True
    second.running = True
    time.sleep(0.2)
    assert not first.running and second.running and len(live_threads()) == 1
    second.close()
    first.close()
    assert not live_threads()


def test_steering_panel_text_view_and_stills_name_each_model(moglow, monkeypatch):
    panel = live.SteeringPanel({"dropout": moglow, "MoGlow (anchored)": moglow})
    text = repr(panel)
    assert text == "SteeringPanel(dropout, MoGlow (anchored); live, needs a running kernel; stopped)"
    assert "0x" not in text                                          # no memory address in a saved notebook
    assert panel.title("dropout") == "MoGlow (dropout)" and panel.title("LSTM-3LR") == "LSTM-3LR"
    assert panel.recording(label="MoGlow (anchored)")["positions"].shape[1:] == (21, 3)
    with pytest.raises(ValueError, match="label"):
        panel.recording(label="Glow")
    shown = []
    monkeypatch.setattr("IPython.display.display", lambda *args, **kwargs: shown.append(args[0]))
    panel._ipython_display_()
    figures = [item for item in shown if hasattr(item, "savefig")]
    assert [f._suptitle.get_text() for f in figures] == ["MoGlow (dropout)", "MoGlow (anchored)"]
    panel.close()


def test_clip_player_takes_a_clip_and_checks_it(walk):
    player = live.ClipPlayer(walk, fps=FPS, title="a walk")
    assert player.mode == "clip" and len(player.clip) == len(walk) and len(player.clip[0]) == 63
    player.show(walk[:10])
    assert len(player.clip) == 10
    with pytest.raises(ValueError, match="positions"):
        player.show(np.zeros((10, 20, 3)))
    with pytest.raises(ValueError, match="positions"):
        player.show(np.full((10, 21, 3), np.nan))


def test_the_panel_module_is_offline_and_parses():
    source = (live.STATIC / "live.js").read_text(encoding="utf-8")
    assert "http" not in source and "import " not in source          # nothing fetched, no dependencies
    assert "export default" in source and "stopPropagation" in source  # the notebook's shortcuts do not fire
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed: the module's syntax is checked where it is")
    checked = subprocess.run([node, "--input-type=module", "--check"], input=source, text=True, capture_output=True)
    assert checked.returncode == 0, checked.stderr
