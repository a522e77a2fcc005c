"""Steer MoGlow live: a character generated one frame at a time while you steer it.

MoGlow is "causal, meaning it only depends on control and pose information from current
and previous timesteps. This makes it suitable for generating controllable motion in
real-time applications" (Henter et al. 2020, abstract and §4). This module is that
application, in three layers that each run without a browser:

* :class:`Steering` turns what is held down (``"forward"``, ``"left"``, ...) into a control
  ``(forward m/s, sideways m/s, turning rad/s)`` that eases towards its target, as a
  game's character controller does; :class:`~motionlab.synthetic.StrideWobble` adds the
  stride-by-stride sway the models read their step timing from.
* :class:`LiveCharacter` feeds each control frame to a :class:`MoGlowStream`, places the
  pose in the world (the root integrated from the control, as
  :func:`~motionlab.representation.to_positions` does) and, optionally, locks the feet with
  the causal :class:`~motionlab.contacts.FootLock` (for a model with a contact head, given
  the contacts it drew as well as the ones it detects). :meth:`LiveCharacter.tick` is one
  frame; :func:`record` runs a scripted steering sequence through it.
* :class:`Loop` calls ``tick`` at the model's frame rate on a background thread (other
  cells keep running), measures what it delivers, and stops cleanly.

:class:`SteeringPanel` (an ``anywidget``) puts them in a notebook: a canvas draws the
character, its path and footprints in the browser; the keyboard or the on-screen pad
steers; the kernel sends one frame per tick. :class:`ClipPlayer` plays a finished clip on
the same canvas (the kernel sends the frames once, the browser animates them).
"""
from __future__ import annotations

import collections
import threading
import time
import traceback
import weakref
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from . import checks, contacts, synthetic
from .representation import N_POSE
from .rotations import y_rotation
from .skeleton import FEET, LOCOMOTION

INTENTS = ("forward", "back", "left", "right", "side_left", "side_right", "run", "stop")
"""What a player can hold down. The panel maps arrows / WASD (turn with left-right, Q / E to
side-step, Shift to run, Space to stop) and its on-screen pad to these."""

VARIANTS = {"dropout": "moglow", "no dropout": "moglow_no_dropout", "feet anchored": "moglow_foot_anchor",
            "contact head": "moglow_contacts"}
"""The shipped MoGlow models that stream (recurrent couplings; ``motionlab.pretrained``
names): notebook 06's panel. The one with a contact head draws each frame's contacts, and
its character's lock holds them as well as the ones it detects. The Markov variants of
notebook 06 generate with ``MoGlow.sample`` instead, whose conditioning window is rebuilt
every frame; they are left out of the live panel."""

CONTROLLABLE = {"MoGlow": "moglow", "MoGlow (anchored)": "moglow_foot_anchor", "MoGlow (contacts)": "moglow_contacts",
                "LSTM-3LR": "lstm_control"}
"""Notebook 08's panel: every shipped model that follows a control one frame at a time
(``model.stream``). Habibie's VAE-LSTM also follows a control, but its convolutional
control encoder and canvas decoder read a whole window at once, so it cannot stream. The
MoGlow with a contact head draws each frame's contacts, and its character's lock holds them
as well as the ones it detects."""

CONTROL_RANGE = np.array([[min(a[2][0] for a in synthetic.ACTIVITIES), max(a[2][1] for a in synthetic.ACTIVITIES)],
                          [-max(a[3][1] for a in synthetic.ACTIVITIES), max(a[3][1] for a in synthetic.ACTIVITIES)],
                          [-1.5, 1.5]])
"""The built-in data's range of each control (forward m/s, sideways m/s, turning rad/s;
:data:`motionlab.synthetic.ACTIVITIES`, turning clipped at 1.5 rad/s as
:func:`~motionlab.synthetic.random_control` does). A control outside it is clamped to it
(the models never saw more) and the frame says so."""

PRIME_FRAMES = 10
"""Frames a model without a fixed history (the LSTM) reads before it streams (0.5 s)."""


@dataclass
class Steering:
    """Held-down intents -> a control frame, eased towards its target (a first-order lag
    of ``ease_s``), so a tap does not jerk the body. Speeds are the built-in presets'
    (:func:`motionlab.synthetic.preset_control`): walk 1.3 m/s, run 3.2, backwards 0.8,
    side-step 0.5; turning 0.8 rad/s."""

    fps: float = 20.0
    walk_ms: float = 1.3
    run_ms: float = 3.2
    back_ms: float = 0.8
    side_ms: float = 0.5
    turn_rads: float = 0.8
    ease_s: float = 0.25
    control: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        self.fps = checks.rate(self.fps, "fps")
        for name in ("walk_ms", "run_ms", "back_ms", "side_ms", "turn_rads", "ease_s"):
            checks.non_negative(getattr(self, name), name, 10.0)

    def target(self, intents) -> np.ndarray:
        """The control ``intents`` (a set of :data:`INTENTS`) ask for."""
        held = set(intents)
        unknown = held - set(INTENTS)
        if unknown:
            raise ValueError(f"intents: expected some of {INTENTS}, got {sorted(unknown)}")
        if "stop" in held:
            return np.zeros(3)
        forward = ((self.run_ms if "run" in held else self.walk_ms) * ("forward" in held)
                   - self.back_ms * ("back" in held))
        sideways = self.side_ms * (("side_left" in held) - ("side_right" in held))
        turning = self.turn_rads * (("left" in held) - ("right" in held))
        return np.array([forward, sideways, turning], dtype=float)

    def step(self, intents) -> np.ndarray:
        """The next control frame for ``intents``."""
        rate = 1.0 - np.exp(-1.0 / (self.fps * max(self.ease_s, 1e-6)))
        self.control = self.control + rate * (self.target(intents) - self.control)
        return self.control.copy()

    def reset(self) -> None:
        self.control = np.zeros(3)


@dataclass(frozen=True)
class Tick:
    """One delivered frame: world ``positions`` ``(21, 3)`` (feet locked when the lock is
    on), the foot joints in ``contact`` ``(4,)`` (:data:`~motionlab.skeleton.FEET` order),
    the ``control`` fed (with the stride wobble), a ``footprint`` ``(x, z)`` where a toe
    just landed (or None), the frame's index, the milliseconds generating it took, and
    whether the control asked for was outside :data:`CONTROL_RANGE` and clamped."""

    positions: np.ndarray
    contact: np.ndarray
    control: np.ndarray
    footprint: tuple | None
    frame: int
    ms: float
    clamped: bool = False


def _history(model) -> int:
    """The frames ``model``'s stream starts from: MoGlow's ``τ``, else :data:`PRIME_FRAMES`."""
    return int(getattr(model.config, "history", PRIME_FRAMES))


def standing_start(history: int, fps: float) -> np.ndarray:
    """``history`` frames of a built-in body standing still, features ``(history, 66)`` in
    data units: where a live character starts."""
    from .experiments import preset_walks
    return preset_walks("stand still", history / fps + 0.5, fps, n=1)[0, :history]


class LiveCharacter:
    """A character generated one frame at a time in the world by a model that streams.

    Args:
        model: a shipped or trained :class:`~motionlab.models.moglow.MoGlow` with recurrent
            couplings, or a ``control="given"`` :class:`~motionlab.models.lstm.MotionLSTM`
            (the LSTM-3LR), with its ``normalizer`` (``pretrained.load`` sets it): anything
            with ``model.stream(history, temperature, generator, normalizer=, weights=)``.
        temperature: the prior's standard deviation (notebook 06 samples at 0.3).
        lock_feet: lock the feet with the causal :class:`~motionlab.contacts.FootLock`.
        seed: the noise's seed (a reset starts it again).
        wobble: add the stride's sway to the control (:class:`~motionlab.synthetic.StrideWobble`);
            the models were trained on controls that sway with every step and read their
            step timing from it, so without it they take shorter steps and glide.
        start: the first ``τ`` frames, features in data units; default a body standing.
        weights: the stream's LSTM weights, ``torch.float32`` or ``torch.bfloat16``.
    """

    def __init__(self, model, fps: float = 20.0, temperature: float = 0.3, lock_feet: bool = True, seed: int = 0,
                 start: np.ndarray | None = None, weights: torch.dtype = torch.float32, wobble: bool = True):
        self.fps = checks.rate(fps, "fps")
        self.sway = bool(wobble)
        self.temperature = checks.non_negative(temperature, "temperature", 10.0)
        self.lock_feet, self.seed, self.weights = bool(lock_feet), int(seed), weights
        self.model = self._checked(model)
        tau = _history(model)
        self.start = standing_start(tau, self.fps) if start is None else \
            checks.array(start, "start", (tau, N_POSE + 3))
        self.steering = Steering(self.fps)
        self.reset()

    @staticmethod
    def _checked(model):
        if getattr(model, "normalizer", None) is None or not hasattr(model, "stream"):
            raise ValueError("model: expected a model that streams (MoGlow, the LSTM-3LR) with its normalizer "
                             "(motionlab.pretrained.load('moglow'))")
        if not getattr(model.config, "recurrent", True):
            raise ValueError("model: a live character needs recurrent (LSTM) couplings; a Markov MoGlow does not stream")
        if getattr(model.config, "control", "given") != "given":
            raise ValueError("model: the LSTM must be given the control (control='given') to be steered")
        return model

    def reset(self) -> None:
        """Back to the start: standing at the origin facing +z, fresh noise, no footprints."""
        self.generator = torch.Generator().manual_seed(self.seed)
        self.history = collections.deque(self.start, maxlen=max(len(self.start), 4 * PRIME_FRAMES))
        self._new_stream()
        self.wobble = synthetic.StrideWobble(self.fps)
        self.steering.reset()
        self.lock = contacts.FootLock(self.fps)
        self.root = np.zeros(3)                                   # x, z, heading of this frame
        self.frame = 0
        self._toe_down = np.zeros(2, dtype=bool)

    def _new_stream(self) -> None:
        history = torch.tensor(np.asarray(self.history)[-_history(self.model):], dtype=torch.float32)[None]
        self.stream = self.model.stream(history, self.temperature, self.generator,
                                        normalizer=self.model.normalizer, weights=self.weights)

    def set_model(self, model) -> None:
        """Switch models mid-walk: the new one continues from the last frames generated (its
        history ``τ``, or :data:`PRIME_FRAMES`)."""
        model = self._checked(model)
        if _history(model) > self.history.maxlen:
            raise ValueError(f"model: needs {_history(model)} frames of history, this character keeps "
                             f"{self.history.maxlen}")
        self.model = model
        self._new_stream()

    def set_temperature(self, temperature: float) -> None:
        self.temperature = checks.non_negative(temperature, "temperature", 10.0)
        self.stream.temperature = self.temperature

    def tick(self, intents=()) -> Tick:
        """One frame for what is held down now (a set of :data:`INTENTS`)."""
        began = time.perf_counter()
        asked = self.steering.step(intents)
        control = np.clip(asked, CONTROL_RANGE[:, 0], CONTROL_RANGE[:, 1])
        clamped = bool((control != asked).any())
        control = self.wobble.step(control) if self.sway else control
        with torch.inference_mode():
            features = self.stream.step(torch.tensor(control, dtype=torch.float32)[None])[0].numpy().astype(float)
        if not np.isfinite(features).all():
            raise ValueError(f"frame {self.frame}: the model generated NaN or infinite values")
        self.history.append(features)
        pose = features[:N_POSE].reshape(LOCOMOTION.n_joints, 3)
        x, z, heading = self.root
        positions = pose @ y_rotation(heading).T + np.array([x, 0.0, z])
        drawn = getattr(self.stream, "contacts", None)           # a contact head's: held from the frame they land
        locked = self.lock.step(positions, drawn=None if drawn is None else drawn[0].cpu().numpy())
        contact = self.lock.contact[0].copy()
        if self.lock_feet:
            positions = locked
        # the root moves to the next frame with this frame's control (to_positions' rule)
        step = y_rotation(heading) @ np.array([control[1], 0.0, control[0]]) / self.fps
        self.root = np.array([x + step[0], z + step[2], heading + control[2] / self.fps])
        toes = contact[[1, 3]]
        landed = np.flatnonzero(toes & ~self._toe_down)
        self._toe_down = toes
        footprint = None
        if len(landed):
            toe = positions[FEET[1 + 2 * int(landed[0])]]
            footprint = (float(toe[0]), float(toe[2]))
        self.frame += 1
        return Tick(positions, contact, control, footprint, self.frame - 1, 1000 * (time.perf_counter() - began),
                    clamped)


SCRIPT = ((2.5, ("forward",)), (2.0, ("forward", "left")), (1.5, ("forward",)), (2.0, ()))
"""A steered run for the static view and the benchmark: walk 2.5 s, walk turning left 2 s,
walk on 1.5 s, let go 2 s (the body should stop)."""


def record(character: LiveCharacter, script=SCRIPT) -> dict:
    """Run ``character`` through ``script`` (``(seconds, intents)`` pairs) with
    :meth:`LiveCharacter.tick`, the live loop's own step, without waiting for the clock.
    Returns ``{"positions": (frames, 21, 3), "contact": (frames, 4), "control": (frames, 3),
    "intents": [...], "footprints": [(x, z), ...], "ms": (frames,)}``."""
    ticks, intents = [], []
    for seconds, held in script:
        for _ in range(int(round(checks.non_negative(seconds, "script seconds", 3600.0) * character.fps))):
            ticks.append(character.tick(held))
            intents.append(tuple(held))
    if not ticks:
        raise ValueError("script: no frames to record")
    return {"positions": np.stack([t.positions for t in ticks]), "contact": np.stack([t.contact for t in ticks]),
            "control": np.stack([t.control for t in ticks]), "intents": intents,
            "clamped": np.array([t.clamped for t in ticks]),
            "footprints": [t.footprint for t in ticks if t.footprint is not None],
            "ms": np.array([t.ms for t in ticks])}


class Loop:
    """Calls ``tick()`` every ``1 / fps`` seconds on a background thread and hands each
    result to ``deliver``. An exception in ``tick`` or ``deliver``
    stops the loop and is handed to ``on_error`` (a one-line message and the traceback).

    The schedule is absolute (frame ``k`` is due at ``start + k / fps``), so small delays do
    not add up; a frame more than a period late is followed by the next at once, and the
    schedule carries on from there (no burst of frames to catch up).

    :meth:`stats` reports what was delivered: frames/s over the last ``window_s``, the
    50th / 99th percentile interval between frames, milliseconds of work and CPU time per
    frame, and the time from the last control change (:meth:`changed`) to the first frame
    generated after it.
    """

    def __init__(self, tick, deliver, fps: float, on_error=None, window_s: float = 5.0):
        self.tick, self.deliver, self.on_error = tick, deliver, on_error
        self.fps = checks.rate(fps, "fps")
        self.window = max(2, int(round(checks.positive(window_s, "window_s") * self.fps)))
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: str | None = None
        self.reset_stats()

    def reset_stats(self) -> None:
        self.times = collections.deque(maxlen=self.window)       # delivery times, s
        self.work = collections.deque(maxlen=self.window)        # ms per frame, wall
        self.cpu = collections.deque(maxlen=self.window)         # ms per frame, this thread's CPU
        self.latencies: list[float] = []                         # control change -> frame, ms
        self._changed_at: float | None = None
        self.frames = 0

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> None:
        if self.running:
            return
        self._stop.clear()
        self.error = None
        self._thread = threading.Thread(target=self._run, name="motionlab-live", daemon=True)
        self._thread.start()

    def stop(self, timeout_s: float = 2.0) -> None:
        """Stop and wait for the thread to end (at most ``timeout_s``)."""
        self._stop.set()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout_s)
        self._thread = None

    def changed(self) -> None:
        """Note that the control input changed now (a key went down or up)."""
        self._changed_at = time.perf_counter()

    def _run(self) -> None:
        period = 1.0 / self.fps
        due = time.perf_counter()
        while not self._stop.is_set():
            wait = due - time.perf_counter()
            if wait > 0:
                self._stop.wait(wait)
                continue
            changed, cpu = self._changed_at, time.thread_time()
            began = time.perf_counter()
            try:
                self.deliver(self.tick())
            except Exception as error:                     # shown in the panel, not lost
                self.error = f"{type(error).__name__}: {error}"
                if self.on_error is not None:
                    try:
                        self.on_error(self.error, traceback.format_exc())
                    except Exception:
                        pass
                break
            now = time.perf_counter()
            self.times.append(now)
            self.work.append(1000 * (now - began))
            self.cpu.append(1000 * (time.thread_time() - cpu))
            if changed is not None and changed <= began:
                self.latencies.append(1000 * (now - changed))
                if self._changed_at == changed:
                    self._changed_at = None
            self.frames += 1
            due += period
            if due < now:                                  # behind: the next frame at once, no backlog
                due = now

    def stats(self) -> dict:
        """What the loop delivered lately (see the class text)."""
        times = np.array(self.times)
        intervals = 1000 * np.diff(times) if len(times) > 1 else np.array([np.nan])
        return {"frames": self.frames,
                "fps": (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 and times[-1] > times[0] else 0.0,
                "interval p50 (ms)": float(np.percentile(intervals, 50)),
                "interval p99 (ms)": float(np.percentile(intervals, 99)),
                "ms per frame": float(np.mean(self.work)) if self.work else float("nan"),
                "cpu ms per frame": float(np.mean(self.cpu)) if self.cpu else float("nan"),
                "control to frame (ms)": float(self.latencies[-1]) if self.latencies else float("nan")}


# ------------------------------------------------------------------------------------------
# The notebook panels (anywidget: an ES module shipped in the package, no build step)
# ------------------------------------------------------------------------------------------

STATIC = Path(__file__).with_name("static")
_PANELS: "weakref.WeakSet[SteeringPanel]" = weakref.WeakSet()


def _bones() -> list:
    from .stickfigure import bone_colors
    return [[int(p), int(c), color] for (p, c), color in zip(LOCOMOTION.bones, bone_colors())]


def _rounded(positions: np.ndarray) -> list:
    return np.round(np.asarray(positions, dtype=float), 3).reshape(-1).tolist()


def _widget_base():
    try:
        import anywidget
        import traitlets
    except ImportError as error:                         # pragma: no cover - a dependency
        raise ImportError("the live panels need anywidget: pip install anywidget") from error
    return anywidget.AnyWidget, traitlets


AnyWidget, traitlets = _widget_base()


class ClipPlayer(AnyWidget):
    """A finished clip ``(frames, 21, 3)`` played on the live panel's canvas: the kernel
    sends the frames once, the browser loops them at ``fps``. ``clip`` may be replaced
    (a slider moved): the new motion starts playing at once."""

    _esm = STATIC / "live.js"
    mode = traitlets.Unicode("clip").tag(sync=True)
    bones = traitlets.List().tag(sync=True)
    clip = traitlets.List().tag(sync=True)
    fps = traitlets.Float(20.0).tag(sync=True)
    title = traitlets.Unicode("").tag(sync=True)

    def __init__(self, positions=None, fps: float = 20.0, title: str = "", **kwargs):
        super().__init__(bones=_bones(), fps=checks.rate(fps, "fps"), title=title, **kwargs)
        if positions is not None:
            self.show(positions, title)

    def show(self, positions, title: str | None = None) -> None:
        """Play ``positions`` ``(frames, 21, 3)`` (world metres) from now on."""
        positions = checks.array(positions, "positions", ("frames", LOCOMOTION.n_joints, 3))
        self.clip = [_rounded(frame) for frame in positions]
        if title is not None:
            self.title = title


class SteeringPanel(AnyWidget):
    """Steer a character live (see the module text). In a notebook cell::

        panel = SteeringPanel()          # loads the shipped MoGlow models (VARIANTS)
        panel                            # click the canvas, hold the arrows (or WASD)

    ``models`` (``{label: model}``) or ``names`` (``{label: pretrained name}``, e.g.
    :data:`CONTROLLABLE`) choose what the model menu offers; switching continues the walk.

    ``panel.loop`` is the :class:`Loop`, ``panel.character`` the :class:`LiveCharacter`;
    ``panel.close()`` (or running the cell again) stops the thread. Only one panel runs
    at a time: starting one pauses the others (there is one keyboard).
    """

    _esm = STATIC / "live.js"
    mode = traitlets.Unicode("live").tag(sync=True)
    bones = traitlets.List().tag(sync=True)
    fps = traitlets.Float(20.0).tag(sync=True)
    running = traitlets.Bool(False).tag(sync=True)
    held = traitlets.List(traitlets.Unicode()).tag(sync=True)      # intents held down in the browser
    held_seq = traitlets.Int(0).tag(sync=True)                     # counts the browser's changes of them
    temperature = traitlets.Float(0.3).tag(sync=True)
    variant = traitlets.Unicode("dropout").tag(sync=True)
    variants = traitlets.List(traitlets.Unicode()).tag(sync=True)
    lock_feet = traitlets.Bool(True).tag(sync=True)
    error = traitlets.Unicode("").tag(sync=True)

    def __init__(self, models: dict | None = None, fps: float = 20.0, temperature: float = 0.3,
                 lock_feet: bool = True, seed: int = 0, weights: torch.dtype = torch.float32,
                 names: dict | None = None):
        if models is None:
            from . import pretrained
            models = {label: pretrained.load(name) for label, name in (names or VARIANTS).items()
                      if name in pretrained.available()}
        if not models:
            raise ValueError("models: expected at least one MoGlow ({label: model})")
        self.models = dict(models)
        first = next(iter(self.models))
        self.character = LiveCharacter(self.models[first], fps, temperature, lock_feet, seed, weights=weights)
        self._guard = threading.Lock()
        self.loop = Loop(self._tick, self._deliver, fps, on_error=self._failed)
        self.recent: collections.deque = collections.deque(maxlen=int(60 * self.character.fps))
        super().__init__(bones=_bones(), fps=self.character.fps, temperature=temperature, variant=first,
                         variants=list(self.models), lock_feet=lock_feet)
        self.observe(self._on_running, "running")
        self.observe(self._on_held, "held")
        self.observe(lambda change: self._locked(self.character.set_temperature, change["new"]), "temperature")
        self.observe(lambda change: self._locked(self.character.set_model, self.models[change["new"]]), "variant")
        self.observe(lambda change: setattr(self.character, "lock_feet", bool(change["new"])), "lock_feet")
        self.on_msg(self._on_message)
        _PANELS.add(self)

    # kernel side --------------------------------------------------------------------------
    def _locked(self, function, *args):
        with self._guard:
            function(*args)

    def intents(self) -> set:
        return {k for k in self.held if k in INTENTS}

    def _tick(self) -> tuple[Tick, int]:
        with self._guard:
            seen, intents = self.held_seq, self.intents()  # the browser's changes this frame answers
            tick = self.character.tick(intents)
        self.recent.append((time.perf_counter(), tick, tuple(sorted(intents))))
        return tick, seen

    def steered(self) -> dict:
        """The last minute the panel streamed: ``{"t": (frames,) s, "positions": (frames, 21, 3),
        "control": (frames, 3), "intents": [...]}``, oldest first (what the student's keys made,
        to measure)."""
        recent = list(self.recent)
        if not recent:
            raise ValueError("panel: nothing streamed yet (press start)")
        return {"t": np.array([t for t, _, _ in recent]), "positions": np.stack([k.positions for _, k, _ in recent]),
                "control": np.stack([k.control for _, k, _ in recent]), "intents": [i for _, _, i in recent]}

    def _deliver(self, ticked: tuple[Tick, int]) -> None:
        tick, seen = ticked
        message = {"kind": "frame", "p": _rounded(tick.positions), "c": tick.contact.astype(int).tolist(),
                   "u": np.round(tick.control, 3).tolist(), "n": tick.frame, "k": seen}
        if tick.footprint is not None:
            message["fp"] = [round(v, 3) for v in tick.footprint]
        if tick.clamped:
            message["x"] = 1                               # the panel says the control was clamped
        if tick.frame % 10 == 0:
            message["stats"] = {k: (None if not np.isfinite(v) else round(float(v), 2))
                                for k, v in self.loop.stats().items()}
        self.send(message)

    def _failed(self, message: str, trace: str) -> None:
        self.send({"kind": "error", "message": message})

    def _on_running(self, change) -> None:
        if change["new"]:
            for other in list(_PANELS):
                if other is not self and other.running:
                    other.running = False
            self.error = ""
            self.loop.start()
        else:
            self.loop.stop()

    def _on_held(self, change) -> None:
        self.loop.changed()

    def _on_message(self, widget, content, buffers) -> None:
        kind = content.get("kind") if isinstance(content, dict) else None
        if kind == "reset":
            self._locked(self.character.reset)
            self.loop.reset_stats()
            self.recent.clear()
            self.send({"kind": "reset"})
        elif kind == "detached":                        # the view is gone (cell re-run, tab closed)
            self.running = False

    def close(self) -> None:
        """Stop the loop (waiting for its thread) and close the widget."""
        self.running = False
        self.loop.stop()
        super().close()

    # static view --------------------------------------------------------------------------
    def recording(self, script=SCRIPT, seed: int | None = None, label: str | None = None) -> dict:
        """:func:`record` ``script`` with a fresh character of the current model (or of the
        model ``label``) and settings (the panel's own character is left where it is)."""
        c = self.character
        if label is not None and label not in self.models:
            raise ValueError(f"label: expected one of {sorted(self.models)}, got {label!r}")
        model = c.model if label is None else self.models[label]
        fresh = LiveCharacter(model, c.fps, c.temperature, c.lock_feet, c.seed if seed is None else seed,
                              start=c.start, weights=c.weights, wobble=c.sway)
        return record(fresh, script)

    def __repr__(self) -> str:
        # what a text-only view of the notebook shows in place of the canvas
        return (f"SteeringPanel({', '.join(self.models)}; live, needs a running kernel; "
                f"{'running' if self.running else 'stopped'})")

    def title(self, label: str) -> str:
        """How the stills name the model ``label``: notebook 06's variant names read
        "MoGlow (no dropout)", notebook 08's labels are model names already."""
        return f"MoGlow ({label})" if label in VARIANTS else label

    def _ipython_display_(self) -> None:
        from IPython.display import Markdown, display
        from . import viz
        import matplotlib.pyplot as plt
        runs = {label: self.recording(label=label) for label in self.models}   # first: the panel answers once it shows
        bundle = self._repr_mimebundle_()                  # the widget (anywidget: data, metadata)
        data, metadata = bundle if isinstance(bundle, tuple) else (bundle, {})
        display(data, metadata=metadata, raw=True)
        display(Markdown("*Still pictures: each model the panel offers, steered by the same script ("
                         + ", then ".join(_describe(h, s) for s, h in SCRIPT)
                         + "), as the panel above moves when you hold the keys; drawn where no kernel runs.*"))
        for label, run in runs.items():
            fig = viz.plot_live_run(run, self.character.fps, title=self.title(label))
            display(fig)
            plt.close(fig)


def _describe(held, seconds) -> str:
    words = {"forward": "forward", "left": "turning left", "right": "turning right", "back": "backwards",
             "side_left": "side-step left", "side_right": "side-step right", "run": "running", "stop": "stop"}
    return (" + ".join(words[h] for h in held) if held else "let go") + f" {seconds:g} s"
