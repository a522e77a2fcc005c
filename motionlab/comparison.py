"""Every shipped generative model on one test set, with one set of measures (notebook 08).

None of the four papers compares these families on the same data with the same measures.
Here each model is loaded with :func:`motionlab.pretrained.load` and asked through the one
``generate`` contract (:mod:`motionlab.models.base`) for what it can do:

* :data:`ENTRIES`: which models, what each conditions on (nothing, a control path, a
  prefix of real frames, or both) and the temperature it samples at (the notebooks').
* :func:`evaluation_windows`: the test set: 4-s windows of held-out built-in clips, or of every
  clip in a folder of real motion capture (the shipped models never saw real data).
* :func:`respond`: one call that gives a model the control and/or the prefix it reads.
* :func:`held_out_samples` and :func:`table_rows`: on held-out built-in windows (4 s),
  every model continues or follows each window; the table's measures (stepping, leg swing,
  skating, bone drift, pose error at 1 and 3 s, test NLL where the model has one or the
  VAEs' bound on it) beside the data's own row.
* :func:`speed_following`: constant forward speeds commanded for 10 s; how fast the feet
  step, against the data's bodies on the same paths.
* :func:`long_run`: 30 s along a circle: pose spread, bone drift and diversity over time.
* :func:`generation_speed`: frames per second, one stream and 64 at once.

``benchmarks/quality.py`` prints the same table from the same functions.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch

from . import contacts, data, experiments, metrics, pretrained, synthetic
from .models.moglow import MoGlowConfig
from .representation import N_POSE, to_positions

FPS = 20.0
PREFIX_FRAMES = 10                     # 0.5 s of real frames for the models that continue motion
TEST_WINDOW = 80                       # 4-s held-out windows: 0.5 s prefix, 3.5 s judged
SPEEDS = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0)
"""Forward speeds (m/s) commanded in :func:`speed_following`."""


@dataclass(frozen=True)
class Entry:
    """A model of the comparison: its checkpoint, what it conditions on, its temperature."""

    name: str                          # pretrained.load name
    label: str
    paper: str
    control: bool                      # does it follow a control path?
    prefix: bool                       # does it continue real frames?
    temperature: float
    window: int | None = None          # draws whole windows of this many frames (None: any length)
    stochastic: bool = True            # False: the same answer for every seed (the LSTM)

    @property
    def conditions(self) -> str:
        return {(False, False): "nothing", (True, False): "control", (False, True): "prefix",
                (True, True): "prefix + control"}[(self.control, self.prefix)]


ENTRIES = (Entry("vae", "VAE", "Motegi 2018", control=False, prefix=False, temperature=1.0, window=80),
           Entry("lstm_control", "LSTM-3LR", "Habibie 2017 (baseline)", control=True, prefix=True, temperature=1.0,
                 stochastic=False),
           Entry("vae_lstm", "VAE-LSTM", "Habibie 2017", control=True, prefix=False, temperature=1.0),
           Entry("vae_lstm_gated", "VAE-LSTM (gated)", "Habibie 2017, feet gated", control=True, prefix=False,
                 temperature=1.0),
           Entry("glow", "Glow", "Henter 2020 §3", control=True, prefix=False, temperature=0.5, window=80),
           Entry("glow_contacts", "Glow (contacts)", "Henter 2020 §3, contact head", control=True, prefix=False,
                 temperature=0.5, window=80),
           Entry("moglow", "MoGlow", "Henter 2020 §4", control=True, prefix=True, temperature=0.3),
           Entry("moglow_foot_anchor", "MoGlow (anchored)", "Henter 2020 §4, feet anchored", control=True, prefix=True,
                 temperature=0.3),
           Entry("moglow_contacts", "MoGlow (contacts)", "Henter 2020 §4, contact head", control=True, prefix=True,
                 temperature=0.3),
           Entry("dfn", "DFN", "Chen 2020", control=False, prefix=True, temperature=1.0))
"""The models compared, in the course's order. Temperatures are the notebooks': MoGlow 0.3
(notebook 06), Glow 0.5 (notebook 05), the others their model's own (1; the LSTM is
deterministic). "MoGlow (anchored)" is MoGlow trained with its ankles modelled relative to
where they would be had they stayed planted, its toes and knees relative to the leg
(``MoGlowConfig.foot_anchor``, ``leg_anchor``, ``anchor_conditioning``: an exact likelihood
still), the shipped recipe otherwise. "Glow (contacts)" is Glow's recipe with a contact head
(``GlowConfig.contact_head``: the feet's contacts drawn first, then the pose given them;
its test NLL is the joint one at the data's contacts, a bound on the pose's); "MoGlow
(contacts)" the same for MoGlow, each frame's contacts drawn from its conditioning, so that
they stream (``MoGlowConfig.contact_head``). "VAE-LSTM (gated)" is the VAE-LSTM's recipe with
gated feet on a skeleton (``VAELSTMConfig.foot_gate``, ``skeleton``): its decoder holds the feet
it says are planted where they landed, and every bone keeps one length."""


def evaluation_windows(source: str = "synthetic", stride_s: float = 1.0) -> np.ndarray:
    """The comparison's test set: features ``(windows, TEST_WINDOW, 66)`` in data units.

    ``"synthetic"``: :func:`motionlab.experiments.held_out_windows` (built-in clips seeded
    from 10,000, which no shipped model was trained on). A folder of motion capture (``.bvh``
    / ``.amc``, read by :func:`motionlab.data.load` at :data:`FPS`): every clip of at least
    4 s cut into 4-s windows starting every ``stride_s`` seconds. All of a folder's clips
    are test clips here, because the shipped checkpoints were trained on built-in clips
    only. Raises ``ValueError`` when no clip is long enough."""
    if source == "synthetic":
        return experiments.held_out_windows(TEST_WINDOW, FPS)
    if not (isinstance(stride_s, (int, float)) and 0 < stride_s <= 60):
        raise ValueError(f"stride_s: expected seconds in (0, 60], got {stride_s!r}")
    stride = max(1, round(stride_s * FPS))
    clips = data.load(source, fps=FPS)
    windows = [data.cut_windows(clip.features(), TEST_WINDOW, stride) for clip in clips]
    windows = [w for w in windows if len(w)]
    if not windows:
        longest = max(len(clip.features()) for clip in clips) / FPS
        raise ValueError(f"{source}: no clip lasts the {TEST_WINDOW / FPS:g} s of a test window "
                         f"(the longest: {longest:.2f} s)")
    return np.concatenate(windows).astype(np.float64)


def load_models(entries=ENTRIES) -> dict[str, tuple[Entry, object]]:
    """``{label: (entry, model)}`` for every entry whose checkpoint is shipped."""
    shipped = set(pretrained.available())
    return {e.label: (e, pretrained.load(e.name)) for e in entries if e.name in shipped}


def respond(entry: Entry, model, control: np.ndarray, prefix: np.ndarray | None = None, n: int = 1,
            seed: int = 0, whole: bool = False):
    """What ``model`` generates for ``control`` ``(frames, 3)`` or ``(n, frames, 3)`` and
    ``prefix`` ``(n, k, 66)`` (data units), reading only what it conditions on: features
    ``(n, frames, 66)`` (``whole``: the whole :class:`~motionlab.models.base.Generated`, with
    the contacts a contact head drew). A model that draws whole windows (``entry.window``) is
    asked for ``frames`` only when that is its window."""
    control = np.asarray(control, dtype=np.float64)
    frames = control.shape[-2]
    if entry.window is not None and frames != entry.window:
        raise ValueError(f"control: {entry.label} draws windows of {entry.window} frames, got {frames}")
    kwargs = {"n": n, "seed": seed, "temperature": entry.temperature}
    if entry.control:
        kwargs["control"] = control
    elif entry.window is None:
        kwargs["frames"] = frames
    if entry.prefix:
        if prefix is None:
            raise ValueError(f"prefix: {entry.label} continues real frames; give (n, k, 66) of them")
        kwargs["prefix"] = prefix
    generated = model.generate(**kwargs)
    return generated if whole else generated.features


SCORED_POSE = tuple(i for i in range(N_POSE) if i not in MoGlowConfig().constant_features)
"""The pose values every likelihood in the table is on: the flows' 61 (the hips' root-local
``x`` and ``z`` are always 0 and left out)."""


def held_out_nll(model, windows: np.ndarray) -> tuple[float, str]:
    """Test NLL of held-out ``windows`` ``(n, frames, 66)`` (data units) in bits per frame,
    data units, and what it is: ``"exact"`` (the flows), ``"bound, with contacts"`` (a flow
    with a contact head: its joint NLL of pose and contacts at the data's own contacts),
    ``"bound"`` (the VAE-LSTM's negative ELBO, on the same pose values given the control),
    ``"bound, conv features"`` (Motegi's VAE: its negative ELBO bounds its conv features,
    not the frames), or NaN and ``""`` (no likelihood)."""
    if model.normalizer is None:
        return float("nan"), ""
    normalised = torch.tensor(model.normalizer.normalize(windows), dtype=torch.float32)
    normalised[..., [i for i in range(N_POSE) if i not in SCORED_POSE]] = 0.0   # exactly 0
    if hasattr(model, "nll"):
        return model.nll(normalised, model.normalizer)["bits/frame"], getattr(model, "nll_is", "exact")
    if hasattr(model, "conv_ae"):
        return model.nll_bound(normalised)["bits/frame"], "bound, conv features"
    if hasattr(model, "nll_bound"):
        return model.nll_bound(normalised, model.normalizer, scored=SCORED_POSE)["bits/frame"], "bound"
    return float("nan"), ""


FINISHED = " + lock"
"""Suffix of a model's finished row: its samples with every bone back to one length and the
feet locked (:func:`motionlab.contacts.finish`), what a character would show."""


def table_rows(models: dict, windows: np.ndarray, seed: int = 0, finish: bool = True) -> dict[str, dict[str, float]]:
    """The comparison table on held-out windows ``(n, TEST_WINDOW, 66)`` (data units).

    Every model generates one sample per window: a model with a prefix continues the
    window's first :data:`PREFIX_FRAMES` frames, a controlled one follows the window's
    control, an unconditional one draws freely. Frames after the prefix are judged (3.5 s),
    against the windows' own frames: ``stepping (m/s)``, ``leg swing (cm)``,
    ``foot skating (cm/s)``, ``bone drift (%)`` (:func:`metrics.locomotion_report`, the
    data's planted foot heights), ``pose error 1 s (cm)`` and ``pose error 3 s (cm)``
    (root frame, :func:`metrics.errors_by_frame`; NaN for a model that sees neither control
    nor prefix), ``test NLL (bits/frame)`` and ``test NLL is`` (what it is: see :func:`held_out_nll`),
    ``parameters`` and ``training (min)`` of the shipped checkpoint, ``skating ratio``
    (:func:`metrics.skating_ratio`, GMD's) and ``foot acceleration (m/s²)`` (99th
    percentile). The data's own row comes first. With ``finish``, each model's row is
    followed by its finished row (label + :data:`FINISHED`): the same samples through
    :func:`motionlab.contacts.finish` (bones, then feet locked, a contact head's drawn
    contacts held as well as the detected ones; the same measures, and
    ``out of reach``: the share of contacts the lock let go for reach); both then have
    ``planted speed (cm/s)`` (:func:`motionlab.contacts.planted_speed` over the contacts
    detected on the raw samples), and so has the data's row (its own contacts)."""
    windows = np.asarray(windows, dtype=np.float64)
    judged = windows[:, PREFIX_FRAMES:]
    rest = metrics.foot_rest_heights(to_positions(judged, FPS))

    def row(features) -> dict[str, float]:
        r = metrics.locomotion_report(features, FPS, rest)
        positions = to_positions(features, FPS)
        return {"stepping (m/s)": r["stepping (m/s)"], "leg swing (cm)": 100 * r["leg swing (m)"],
                "foot skating (cm/s)": 100 * r["foot skating (m/s)"], "bone drift (%)": 100 * r["bone drift"],
                "skating ratio": metrics.skating_ratio(positions, FPS, rest),
                "foot acceleration (m/s²)": metrics.foot_acceleration(positions, FPS)}

    rows = {"data": {**row(judged), "pose error 1 s (cm)": 0.0, "pose error 3 s (cm)": 0.0}}
    if finish:
        data_positions = to_positions(judged, FPS)
        rows["data"]["planted speed (cm/s)"] = 100 * contacts.planted_speed(
            data_positions, FPS, contacts.detect(data_positions, FPS, rest))
    drawn = {}
    for label, out in held_out_samples(models, windows, seed, drawn).items():
        entry, model = models[label]
        pose_error = metrics.errors_by_frame(out, judged, FPS)[0]
        seen = entry.control or entry.prefix
        rows[label] = {**row(out),
                       "pose error 1 s (cm)": 100 * pose_error[int(FPS) - 1] if seen else float("nan"),
                       "pose error 3 s (cm)": 100 * pose_error[int(3 * FPS) - 1] if seen else float("nan"),
                       **dict(zip(("test NLL (bits/frame)", "test NLL is"), held_out_nll(model, windows))),
                       "parameters": float(weights(model)),
                       "training (min)": _training_minutes(model)}
        if finish:
            done = contacts.finish(out, FPS, planted_height_m=rest, drawn=drawn.get(label))
            positions = to_positions(out, FPS)
            labels = contacts.detect(positions, FPS, rest)
            rows[label]["planted speed (cm/s)"] = 100 * contacts.planted_speed(positions, FPS, labels)
            rows[label + FINISHED] = {**row(done.features), "out of reach": done.lock.out_of_reach,
                                      "planted speed (cm/s)": 100 * contacts.planted_speed(done.positions, FPS, labels)}
    return rows


def weights(model) -> int:
    """How many weights (parameters) a model has, all its parts counted."""
    return sum(w.numel() for m in _modules(model) for w in m.parameters())


def held_out_samples(models: dict, windows: np.ndarray, seed: int = 0, drawn: dict | None = None) -> dict[str, np.ndarray]:
    """One sample per held-out window ``(n, TEST_WINDOW, 66)`` from every model, as
    :func:`table_rows` judges them: ``{label: features (n, TEST_WINDOW - PREFIX_FRAMES, 66)}``,
    the frames after the prefix (a model with a prefix continues the window's first
    :data:`PREFIX_FRAMES` frames; the others draw the whole window, given its control if
    they take one). Given a dict ``drawn``, the contacts a contact head drew for the same
    frames go into it, by label."""
    windows = np.asarray(windows, dtype=np.float64)
    control, prefix = windows[..., N_POSE:], windows[:, :PREFIX_FRAMES]
    samples = {}
    for label, (entry, model) in models.items():
        if entry.prefix:                                    # it continues the prefix: generate the rest
            out = respond(entry, model, control[:, PREFIX_FRAMES:], prefix, n=len(windows), seed=seed, whole=True)
            judged = slice(None)
        else:                                               # whole windows: judge the same frames
            out = respond(entry, model, control, n=len(windows), seed=seed, whole=True)
            judged = slice(PREFIX_FRAMES, None)
        samples[label] = out.features[:, judged]
        if drawn is not None and out.contacts is not None:
            drawn[label] = out.contacts[:, judged]
    return samples


def _modules(model) -> list:
    """The torch modules that hold a model's weights (Motegi's VAE is two: conv AE + VAE)."""
    return [model.conv_ae, model.vae] if hasattr(model, "conv_ae") else [model]


def _training_minutes(model) -> float:
    """Minutes the shipped checkpoint trained: for Motegi's VAE, its conv AE's and its own."""
    histories = [getattr(m, "history", None) for m in ([model] + _modules(model))]
    seconds = {id(h): h.seconds for h in histories if h is not None}
    return sum(seconds.values()) / 60 if seconds else float("nan")


def _ramped(speed: float, seconds: float) -> np.ndarray:
    """A straight path ``(frames + 1, 3)`` at ``speed`` m/s forward, from standing, reached
    over :data:`experiments.RAMP_S` (the walk preset scaled)."""
    walk = synthetic.preset_control("walk", seconds + 1.0 / FPS, FPS, ramp_s=experiments.RAMP_S)
    return walk * (speed / walk[-1, 0])


def speed_following(models: dict, speeds=SPEEDS, seconds: float = 10.0, n: int = 4,
                    seed: int = 0) -> dict[str, np.ndarray]:
    """Commanded forward speed against stepping: for each speed, ``n`` held-out bodies walk
    a straight path at that speed (after :data:`PREFIX_FRAMES` frames of standing), and each
    model gets the same path as they walked it (and their standing frames as its prefix).
    Returns ``{"data": ..., label: ...}``, the stepping speed (m/s) from the 2nd second to the
    end, averaged over the samples, ``(len(speeds),)``. A model that draws windows gets the
    path's first window."""
    result = {"data": []} | {label: [] for label in models}
    for speed in speeds:
        walks = experiments.walks(_ramped(speed, seconds), FPS, n, lead_frames=PREFIX_FRAMES)
        prefix, truth = walks[:, :PREFIX_FRAMES], walks[:, PREFIX_FRAMES:]
        result["data"].append(_late_stepping(truth))
        for label, (entry, model) in models.items():
            control = truth[0, :, N_POSE:] if entry.window is None else truth[0, :entry.window, N_POSE:]
            result[label].append(_late_stepping(respond(entry, model, control, prefix, n=n, seed=seed)))
    return {label: np.array(values) for label, values in result.items()}


def _late_stepping(features: np.ndarray) -> float:
    return float(metrics.stepping_by_second(features, FPS)[:, 1:].mean())


def long_run(models: dict, seconds: float = 30.0, n: int = 4, chunk_s: float = 5.0,
             seed: int = 0) -> dict[str, dict[str, np.ndarray]]:
    """``seconds`` along the circle preset (walking at 1.2 m/s, turning), ``n`` samples,
    for the models that generate any length (not those that draw windows), beside ``n``
    held-out bodies on the same path. Per model and for ``"data"``, per ``chunk_s`` s:
    ``"pose spread (m)"`` (:func:`metrics.pose_spread`, mean over samples), ``"bone drift
    (%)"``; per frame ``"diversity (m)"`` (:func:`metrics.diversity` of the samples); and the
    ``"samples"`` themselves, features ``(n, seconds * fps + 1, 66)``."""
    walks = experiments.preset_walks("circle", seconds, FPS, n, lead_frames=PREFIX_FRAMES)
    prefix, truth = walks[:, :PREFIX_FRAMES], walks[:, PREFIX_FRAMES:]
    runs = {"data": truth}
    for label, (entry, model) in models.items():
        if entry.window is None:
            runs[label] = respond(entry, model, truth[0, :, N_POSE:], prefix, n=n, seed=seed)
    chunk = int(chunk_s * FPS)
    result = {}
    for label, features in runs.items():
        positions = to_positions(features, FPS)
        pieces = range(0, features.shape[1] - chunk + 1, chunk)
        result[label] = {
            "pose spread (m)": np.array([metrics.pose_spread(features[:, s:s + chunk]).mean() for s in pieces]),
            "bone drift (%)": np.array([100 * metrics.bone_length_drift(positions[:, s:s + chunk]) for s in pieces]),
            "diversity (m)": metrics.diversity(positions), "samples": features}
    return result


def walk_turn_stop(seconds: float = 10.0) -> np.ndarray:
    """A drawn path ``(seconds * fps + 1, 3)``: walk off to 1.3 m/s over the first second,
    turn left at 0.7 rad/s from 3 to 6 s, slow to a stop between 7 and 8.5 s."""
    t = np.arange(int(round(seconds * FPS)) + 1) / FPS

    def ramp(start, end):                                   # 0 -> 1 between two times
        return np.clip((t - start) / (end - start), 0.0, 1.0)
    return np.stack([1.3 * ramp(0, 1) * (1 - ramp(7, 8.5)), 0 * t, 0.7 * ramp(3, 3.5) * (1 - ramp(5.5, 6))], axis=1)


def steer_all(models: dict, path: np.ndarray, seed: int = 0) -> dict[str, np.ndarray]:
    """One held-out body walks the drawn ``path`` ``(frames, 3)`` after
    :data:`PREFIX_FRAMES` frames of standing, and every model that follows a control and
    runs for any length is given the path as the body walked it (and the standing frames
    as its prefix). Returns ``{"data": ..., label: ...}``, features ``(frames, 66)``."""
    body = experiments.walks(np.asarray(path, dtype=np.float64), FPS, n=1, lead_frames=PREFIX_FRAMES)
    prefix, truth = body[:, :PREFIX_FRAMES], body[0, PREFIX_FRAMES:]
    result = {"data": truth}
    for label, (entry, model) in models.items():
        if entry.control and entry.window is None:
            result[label] = respond(entry, model, truth[:, N_POSE:], prefix, seed=seed)[0]
    return result


def generation_speed(models: dict, frames: int = 80, streams=(1, 64), seed: int = 0) -> dict[str, dict[int, float]]:
    """Frames per second in all streams together, generating ``frames`` frames (the model's
    window where it draws windows) for each number of ``streams``: best of two timings."""
    walks = experiments.held_out_windows(PREFIX_FRAMES + frames, FPS, n_clips=2)[:1]
    result = {}
    for label, (entry, model) in models.items():
        length = entry.window or frames
        control, prefix = walks[0, PREFIX_FRAMES:PREFIX_FRAMES + length, N_POSE:], walks[:, :PREFIX_FRAMES]
        result[label] = {}
        for n in streams:
            times = []
            for _ in range(2):
                began = time.perf_counter()
                respond(entry, model, control, np.repeat(prefix, n, axis=0), n=n, seed=seed)
                times.append(time.perf_counter() - began)
            result[label][n] = n * length / min(times)
    return result


def _cell(value, digits: int = 1) -> str:
    return "n/a" if value is None or not np.isfinite(value) else f"{value:,.{digits}f}"


def _likelihood_cell(row: dict) -> str:
    """The test NLL as the table prints it: a bound is marked ``≤``, and one that is not on
    the frames says what it is on."""
    value, kind = _cell(row["test NLL (bits/frame)"], 0), row.get("test NLL is", "")
    if kind.startswith("bound"):
        return f"≤ {value}" + (f" ({kind.split(', ', 1)[1]})" if ", " in kind else "")
    return value


def late_diversity(run: dict, seconds: float = 5.0) -> float:
    """The mean of a :func:`long_run` entry's ``"diversity (m)"`` over its last ``seconds``, cm."""
    return 100 * float(run["diversity (m)"][-int(seconds * FPS):].mean())


def table(models: dict, rows: dict, long: dict, speed: dict, data_label: str = "held-out windows") -> str:
    """The comparison as one Markdown table, the data's row first (``data_label`` says
    which windows): :func:`table_rows`, the last 5 s of :func:`long_run` (pose spread
    against the data's: the built-in bodies on the same circle, hence 1 in the data's row;
    diversity of the samples, :func:`late_diversity`) and :func:`generation_speed`. A
    finished row (:data:`FINISHED`) fills only the measured columns."""
    late_data = long["data"]["pose spread (m)"][-1]
    lines = ["| | conditions on | weights | training (min) | test NLL (bits/frame) | pose error 1 s / 3 s (cm) "
             "| stepping (m/s) | leg swing (cm) | foot skating (cm/s) | skating ratio (GMD) | bone drift (%) "
             "| 30-s run: pose spread, last 5 s / data's | 30-s run: diversity, last 5 s (cm) "
             "| frames/s, 1 stream | frames/s, 64 streams |",
             "|" + "---|" * 15]
    for label, r in rows.items():
        measured = (f"| {r['stepping (m/s)']:.2f} | {r['leg swing (cm)']:.1f} | {r['foot skating (cm/s)']:.1f} "
                    f"| {r['skating ratio']:.3f} | {r['bone drift (%)']:.2f} ")
        if label == "data":
            lines.append(f"| **data** ({data_label}) | | | | | {measured}| 1 | {late_diversity(long['data']):.1f} | | |")
            continue
        if label.endswith(FINISHED):
            lines.append(f"| {label} | | | | | {measured}| | | | |")
            continue
        entry = models[label][0]
        spread = long[label]["pose spread (m)"][-1] / late_data if label in long else None
        diversity = late_diversity(long[label]) if label in long else None
        lines.append(f"| **{label}** | {entry.conditions} | {r['parameters'] / 1e3:,.0f}k "
                     f"| {_cell(r['training (min)'])} | {_likelihood_cell(r)} "
                     f"| {_cell(r['pose error 1 s (cm)'])} / {_cell(r['pose error 3 s (cm)'])} {measured}"
                     f"| {_cell(spread, 2)} | {_cell(diversity)} | {speed[label][1]:,.0f} | {speed[label][64]:,.0f} |")
    return "\n".join(lines)
