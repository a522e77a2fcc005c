"""Data sets: load motion capture, resample, cut windows, split, augment, normalise.

The path from a folder of files to batches a model can train on::

    clips = load("synthetic", fps=20)                     # or a folder of CMU BVH files
    data = prepare(clips, window_s=4.0)                   # split by clip, augment, normalise
    batch = next(iter(torch.utils.data.DataLoader(data.train, batch_size=32)))
    batch.shape                                           # (32, 80, 66), normalised features

Every clip becomes world positions of the 21-joint locomotion skeleton in metres (y up,
floor at y = 0) first; :mod:`motionlab.representation` turns those into features.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np
import torch

from . import asfamc, checks
from . import files as files_
from . import bvh as bvh_io
from .clip import CMU_UNIT_M, Clip  # noqa: F401  (CMU_UNIT_M: the unit, re-exported for data.load_bvh callers)
from .representation import FACING_SMOOTHING_S, POSE, mirror_features, reverse_features, to_positions
from .skeleton import LOCOMOTION, LOCOMOTION_JOINTS

LOCOMOTION_FROM_CMU = LOCOMOTION_JOINTS                  # the CMU names of the 21 joints, in their order

MOTION_SUFFIXES = (".bvh", ".amc")
"""File types :func:`load` reads from a folder (in any letter case: ``.BVH`` too)."""


load_bvh = bvh_io.load_clip
"""A CMU-style BVH file as a 21-joint :class:`Clip`: :func:`motionlab.bvh.load_clip`."""
has_tpose_frame, locomotion_joints = bvh_io.has_tpose_frame, bvh_io.locomotion_joints


def load(source: str | Path | Iterable[str | Path] = "synthetic", fps: float = 20.0,
         n_clips: int = 40, duration_s: float = 12.0, seed: int = 0,
         cache: str | Path | None | bool = True) -> list[Clip]:
    """Load clips: ``"synthetic"``, a folder of motion capture, one file, or a list of files.

    * ``"synthetic"`` generates ``n_clips`` clips of ``duration_s`` seconds with
      :mod:`motionlab.synthetic` (seeded by ``seed``): the built-in data every notebook
      uses when no motion capture is given.
    * A folder is read for CMU-style ``.bvh`` files and CMU ``.amc`` files (each next to
      its subject's ``.asf``, as :func:`motionlab.download.download_cmu` leaves them); one trial must not be
      there in both formats.

    Files come back sorted by name, resampled to ``fps``; file extensions may be in any
    letter case (``.BVH``). Either way the result is world positions, and everything after
    this goes through the same code. Bad arguments and malformed files raise ``ValueError``
    naming the argument or the file (and line).

    Files are read once per frame rate: the clips are kept in a cache (``cache``: a folder;
    ``True``, the default, is :data:`CLIP_CACHE`; ``False`` or ``None`` reads every file).
    An entry is used only while its file (and, for ``.amc``, the subject's ``.asf``) has
    the same size and SHA-256, and :data:`LOADER_VERSION` is unchanged. A load of many
    files shows a progress bar.
    """
    fps = checks.rate(fps, "fps")
    source = _checked_source(source)
    if isinstance(source, str) and source == "synthetic":
        from . import synthetic
        n_clips = checks.whole(n_clips, "n_clips")
        duration_s = checks.seconds(duration_s, "duration_s")
        seed = checks.whole(seed, "seed", minimum=0)
        return [Clip(name, motion.positions, fps, "synthetic")
                for name, motion in synthetic.dataset(n_clips, duration_s, fps, seed)]
    if isinstance(source, (str, os.PathLike)):
        path = Path(source)
        if path.is_dir():
            files = sorted(f for f in path.iterdir() if f.suffix.lower() in MOTION_SUFFIXES and f.is_file())
            if not files:
                raise ValueError(f"{path}: no .bvh or .amc files")
        elif path.is_file():
            files = [path]
        else:
            raise ValueError(f"source: {str(source)!r} is neither 'synthetic', a folder nor a file")
    else:
        files = sorted(Path(f) for f in source)
    stems = [f.stem for f in files]
    twice = sorted({stem for stem in stems if stems.count(stem) > 1})
    if twice:
        raise ValueError(f"source: trials in two formats ({', '.join(twice)}): keep one format per trial")
    if cache is None or cache is False:
        return [_load_file(f, fps) for f in _progress(files)]
    return _load_cached(files, fps, CLIP_CACHE if cache is True else Path(cache))


_SOURCES = ("'synthetic', a folder or a file (a str or a path), or a list of files")


def _checked_source(source):
    """``source`` of :func:`load` as given, or a list of paths; ``ValueError`` naming the
    argument for anything else (a number, bytes, an empty list, a list of non-paths)."""
    if isinstance(source, (str, os.PathLike)):
        return source
    if isinstance(source, (bytes, bytearray, dict)) or not isinstance(source, Iterable):
        raise ValueError(f"source: expected {_SOURCES}, got {type(source).__name__} {source!r:.60}")
    files = list(source)
    if not files:
        raise ValueError(f"source: the list of files is empty; expected {_SOURCES}")
    bad = [f for f in files if not isinstance(f, (str, os.PathLike))]
    if bad:
        raise ValueError(f"source: expected a list of file paths, got {type(bad[0]).__name__} {bad[0]!r:.60} in it")
    return files


LOADER_VERSION = 1
"""Bumped whenever reading, forward kinematics or resampling changes what a file loads as;
it invalidates every cached clip (:func:`load`)."""

CLIP_CACHE = files_.cache() / "clips"
"""The default cache of loaded clips, in the course's cache (:func:`motionlab.files.cache`: the
repository's ignored ``data/cache`` in a checkout). Not beside the data: motion capture
folders are often shared or read-only."""


def _progress(files: list[Path]):
    from tqdm.auto import tqdm
    return tqdm(files, desc="reading motion files", unit="file", disable=len(files) < 20, leave=False)


def _file_key(path: Path) -> str:
    """What identifies a file's loaded clip: the loader version, and the size and SHA-256
    of the file (and of its subject's ``.asf`` for an ``.amc``). Hashing reads a file far
    faster than parsing it."""
    parts = [path] + ([asfamc.skeleton_path(path)] if path.suffix.lower() == ".amc" else [])
    stamps = [f"{Path(part).name}:{Path(part).stat().st_size}:{files_.sha256_of(part)}" if Path(part).is_file()
              else f"{Path(part).name}:missing" for part in parts]
    return f"v{LOADER_VERSION}|" + "|".join(stamps)


def _cache_file(files: list[Path], fps: float, folder: Path) -> Path:
    import hashlib
    where = sorted({str(f.resolve().parent) for f in files})
    digest = hashlib.sha256("\n".join(where).encode()).hexdigest()[:16]
    return folder / f"{Path(where[0]).name}-{digest}-{fps:g}fps.npz"


def _load_cached(files: list[Path], fps: float, folder: Path) -> list[Clip]:
    """:func:`load` of ``files`` through the cache file for their folder(s) and ``fps``."""
    path = _cache_file(files, fps, folder)
    cached: dict[str, tuple[str, np.ndarray]] = {}
    if path.exists():
        try:
            with np.load(path, allow_pickle=False) as saved:
                names, saved_keys = list(saved["names"]), list(saved["keys"])
                ends = np.cumsum(saved["lengths"])
                positions = saved["positions"]
                if len(names) == len(saved_keys) == len(ends) and (not len(ends) or ends[-1] == len(positions)) \
                        and positions.ndim == 3 and positions.shape[1:] == (LOCOMOTION.n_joints, 3) \
                        and np.isfinite(positions).all():
                    for name, key, start, end in zip(names, saved_keys, np.concatenate([[0], ends[:-1]]), ends):
                        cached[str(name)] = (str(key), positions[start:end])
        except (OSError, ValueError, KeyError):         # a damaged cache is rebuilt, never trusted
            cached = {}
    clips, keys, changed = [], [], False
    for f in _progress(files):
        key = _file_key(f)
        keys.append(key)
        hit = cached.get(str(f.resolve()))
        if hit is not None and hit[0] == key and len(hit[1]) >= 2:
            clips.append(Clip(f.stem, np.array(hit[1], dtype=np.float64), fps, str(f)))
        else:
            clips.append(_load_file(f, fps))
            changed = True
    if changed or len(cached) != len(files):
        folder.mkdir(parents=True, exist_ok=True)
        with files_.replacing(path, suffix=".npz") as partial:
            np.savez(partial, names=np.array([str(f.resolve()) for f in files]),
                     keys=np.array(keys),
                     lengths=np.array([c.n_frames for c in clips]),
                     positions=np.concatenate([c.positions for c in clips]).astype(np.float64))
    return clips


def _load_file(path: Path, fps: float) -> Clip:
    if path.suffix.lower() == ".amc":
        return asfamc.load_clip(path, fps=fps)
    if path.suffix.lower() == ".bvh":
        return bvh_io.load_clip(path, fps=fps)
    raise ValueError(f"{path}: unknown motion file type (expected .bvh or .amc)")


def split_clips(clips: Sequence[Clip], fractions: tuple[float, float, float] = (0.8, 0.1, 0.1),
                seed: int = 0) -> dict[str, list[Clip]]:
    """Split clips (never windows) into ``train``/``val``/``test`` by ``fractions``.

    A shuffled, seeded assignment; every split with a non-zero fraction gets at least one
    clip when there are enough clips. Splitting by clip keeps overlapping windows of one
    take out of both training and evaluation.
    """
    fractions = tuple(float(f) for f in fractions)
    if len(fractions) != 3 or not all(0 <= f <= 1 for f in fractions) or abs(sum(fractions) - 1) > 1e-6:
        raise ValueError(f"fractions: expected three non-negative numbers summing to 1, got {fractions}")
    n = len(clips)
    order = np.random.default_rng(seed).permutation(n)
    n_val = int(round(fractions[1] * n))
    n_test = int(round(fractions[2] * n))
    if n >= 3:
        n_val = max(n_val, 1 if fractions[1] > 0 else 0)
        n_test = max(n_test, 1 if fractions[2] > 0 else 0)
    n_train = n - n_val - n_test
    if n_train < 1:
        raise ValueError(f"clips: {n} clips are too few to split by {fractions}")
    pick = lambda idx: [clips[i] for i in sorted(idx)]  # noqa: E731
    return {"train": pick(order[:n_train]), "val": pick(order[n_train:n_train + n_val]),
            "test": pick(order[n_train + n_val:])}


def cut_windows(features: np.ndarray, length: int, stride: int) -> np.ndarray:
    """Cut ``(frames, D)`` into overlapping windows ``(n, length, D)``.

    Windows start every ``stride`` frames; a tail shorter than ``length`` is left out. A
    clip shorter than ``length`` gives ``(0, length, D)``. ``length`` and ``stride`` must
    be whole numbers >= 1.
    """
    length = checks.whole(length, "length")
    stride = checks.whole(stride, "stride")
    features = np.asarray(features)
    if features.shape[0] < length:
        return np.zeros((0, length) + features.shape[1:], dtype=features.dtype)
    view = np.lib.stride_tricks.sliding_window_view(features, length, axis=0)[::stride]
    return np.moveaxis(view, -1, 1).copy()


def augment(features: np.ndarray, fps: float, kinds: Sequence[str] = ("mirror", "reverse")) -> list[np.ndarray]:
    """The clip and its augmented copies (MoGlow §5.1): mirrored, time-reversed, or both.

    Returns ``[original, ...]``: 2 copies for one kind, 4 for ``("mirror", "reverse")``.
    """
    fps = checks.rate(fps, "fps")
    unknown = set(kinds) - {"mirror", "reverse"}
    if unknown:
        raise ValueError(f"augment: unknown kinds {sorted(unknown)}; use 'mirror' and/or 'reverse'")
    copies = [np.asarray(features)]
    if "mirror" in kinds:
        copies += [mirror_features(c) for c in copies]
    if "reverse" in kinds:
        copies += [reverse_features(c, fps) for c in copies]
    return copies


class Normalizer:
    """Per-feature standardisation ``(x - mean) / std``, fitted on training data only.

    Features that never vary (such as the hips' root-local ``x`` and ``z``, always 0) get
    ``std = 1`` so nothing is divided by zero. Works on numpy arrays and torch tensors of
    shape ``(..., D)``.
    """

    def __init__(self, mean: np.ndarray, std: np.ndarray):
        mean, std = np.asarray(mean, dtype=np.float64), np.asarray(std, dtype=np.float64)
        if mean.shape != std.shape or mean.ndim != 1:
            raise ValueError(f"mean and std must be (D,) arrays, got {mean.shape} and {std.shape}")
        if not (np.isfinite(mean).all() and np.isfinite(std).all() and (std > 0).all()):
            raise ValueError("std must be positive and mean and std finite")
        self.mean, self.std = mean, std

    @classmethod
    def fit(cls, data: np.ndarray, min_std: float = 1e-4, shared: slice | None = None) -> "Normalizer":
        """Fit on ``data`` ``(..., D)``; a std below ``min_std`` counts as constant.

        ``shared``: columns that get one common std, the mean of their stds (Holden et al.
        do this for all joint coordinates, so that distances between poses keep their
        meaning and barely-moving joints are not blown up, noise and all).
        """
        data = np.asarray(data, dtype=np.float64).reshape(-1, np.shape(data)[-1])
        if len(data) == 0:
            raise ValueError("data: cannot fit a Normalizer on no frames")
        std = data.std(axis=0)
        if shared is not None:
            std[shared] = std[shared].mean()
        return cls(data.mean(axis=0), np.where(std < min_std, 1.0, std))

    def _cast(self, x, value: np.ndarray):
        if isinstance(x, torch.Tensor):
            return torch.as_tensor(value, dtype=x.dtype, device=x.device)
        return value

    def _check(self, x) -> None:
        if x.shape[-1] != len(self.mean):
            raise ValueError(f"x: expected last dimension {len(self.mean)}, got shape {tuple(x.shape)}")

    def normalize(self, x):
        self._check(x)
        return (x - self._cast(x, self.mean)) / self._cast(x, self.std)

    def denormalize(self, x):
        self._check(x)
        return x * self._cast(x, self.std) + self._cast(x, self.mean)

    def state_dict(self) -> dict[str, list[float]]:
        return {"mean": self.mean.tolist(), "std": self.std.tolist()}

    @classmethod
    def from_state_dict(cls, state: dict) -> "Normalizer":
        try:
            return cls(np.asarray(state["mean"]), np.asarray(state["std"]))
        except KeyError as err:
            raise ValueError(f"state: missing {err.args[0]!r}") from None

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.state_dict()))

    @classmethod
    def load(cls, path: str | Path) -> "Normalizer":
        try:
            return cls.from_state_dict(json.loads(Path(path).read_text()))
        except (json.JSONDecodeError, OSError) as err:
            raise ValueError(f"{path}: not a saved Normalizer ({err})") from None


class MotionDataset(torch.utils.data.Dataset):
    """Windows of normalised features as a torch data set; items are ``(frames, D)`` float32."""

    def __init__(self, windows: np.ndarray):
        self.windows = torch.as_tensor(np.asarray(windows), dtype=torch.float32)

    def __len__(self) -> int:
        return len(self.windows)

    def __getitem__(self, i: int) -> torch.Tensor:
        return self.windows[i]


@dataclass
class MotionData:
    """Everything a model trains on: normalised window data sets and how they were made.

    Attributes:
        train, val, test: :class:`MotionDataset` of ``(window_frames, 66)`` items.
        normalizer: fitted on the (augmented) training windows.
        clips: the clips of each split, by split name.
        description: the settings that made the data, for checkpoints and reports.
    """

    train: MotionDataset
    val: MotionDataset
    test: MotionDataset
    normalizer: Normalizer
    clips: dict[str, list[Clip]]
    description: dict = field(default_factory=dict)

    @property
    def fps(self) -> float:
        return self.description["fps"]

    def in_data_units(self, windows) -> np.ndarray:
        """Normalised windows ``(..., frames, 66)`` (tensor or array) -> features in the data's
        units (m, m/s, rad/s), a float64 array."""
        if isinstance(windows, torch.Tensor):
            windows = windows.detach().cpu().numpy()
        return self.normalizer.denormalize(np.asarray(windows, dtype=np.float64))

    def world(self, windows) -> np.ndarray:
        """Normalised windows ``(..., frames, 66)`` -> world joint positions ``(..., frames,
        21, 3)`` in metres, each window from the origin facing ``+z``
        (:func:`motionlab.representation.to_positions`)."""
        return to_positions(self.in_data_units(windows), self.fps)

    def summary(self) -> str:
        """A few lines that say what the data is."""
        d = self.description
        rows = [f"source: {d['source']}, {d['fps']:g} fps, windows of {d['window_frames']} frames "
                f"(stride {d['stride_frames']}), augmentation: {', '.join(d['augment']) or 'none'}"]
        for split in ("train", "val", "test"):
            rows.append(f"{split:>5}: {len(d['clips'][split]):3d} clips, "
                        f"{len(getattr(self, split)):5d} windows")
        if d["dropped_short"]:
            rows.append(f"dropped (shorter than a window): {', '.join(d['dropped_short'])}")
        return "\n".join(rows)


def _describe_sources(clips: Sequence[Clip]) -> str:
    """``"synthetic"``, the folder the files came from, or ``"clips"``."""
    sources = {c.source for c in clips}
    if len(sources) == 1 and not Path(next(iter(sources))).suffix:
        return next(iter(sources)) or "clips"
    folders = {str(Path(s).parent) for s in sources if s}
    return folders.pop() if len(folders) == 1 else "clips"


def _whole_frames(seconds: float, fps: float, name: str) -> int:
    """``seconds`` as a whole number of frames at ``fps``; ``ValueError`` naming ``name``
    when that is less than one frame."""
    frames = int(round(seconds * fps))
    if frames < 1:
        raise ValueError(f"{name}: {seconds:g} s is less than one frame at {fps:g} fps")
    return frames


def prepare(clips: Sequence[Clip], window_s: float = 4.0, stride_s: float | None = None,
            fractions: tuple[float, float, float] = (0.8, 0.1, 0.1),
            augment_with: Sequence[str] = ("mirror", "reverse"), seed: int = 0,
            short_clips: str = "drop", source: str = "",
            facing_smoothing_s: float = FACING_SMOOTHING_S,
            normalization: str = "per_feature") -> MotionData:
    """Turn clips into normalised train/validation/test window data sets.

    Clips are split by clip (:func:`split_clips`), converted to features, augmented
    (training split only), cut into windows of ``window_s`` seconds every ``stride_s``
    seconds (default half a window), and normalised with statistics of the training
    windows: ``normalization="per_feature"`` standardises every feature on its own (Motegi
    §II, MoGlow), ``"shared_pose"`` gives all 63 pose coordinates one common std (Holden).
    A clip shorter than one window is dropped and listed in
    ``description["dropped_short"]`` (``short_clips="drop"``) or raises ``ValueError``
    (``short_clips="error"``); so does a ``window_s`` longer than every clip, naming the
    longest. ``window_s`` and ``stride_s`` must be finite, positive and at least one frame.
    """
    window_s = checks.seconds(window_s, "window_s")
    if stride_s is not None:
        stride_s = checks.seconds(stride_s, "stride_s")
    seed = checks.whole(seed, "seed", minimum=0)
    if not clips:
        raise ValueError("clips: no clips to prepare")
    if normalization not in ("per_feature", "shared_pose"):
        raise ValueError(f"normalization: expected 'per_feature' or 'shared_pose', got {normalization!r}")
    if short_clips not in ("drop", "error"):
        raise ValueError(f"short_clips: expected 'drop' or 'error', got {short_clips!r}")
    fps_values = {c.fps for c in clips}
    if len(fps_values) != 1:
        raise ValueError(f"clips: all clips need one frame rate, got {sorted(fps_values)}; "
                         "resample them first (Clip.resampled)")
    fps = checks.rate(fps_values.pop(), "the clips' fps")
    length = _whole_frames(window_s, fps, "window_s")
    stride = (_whole_frames(stride_s, fps, "stride_s") if stride_s is not None
              else max(1, int(round(window_s / 2 * fps))))
    short = [c.name for c in clips if c.n_frames < length]
    if short and short_clips == "error":
        raise ValueError(f"clips shorter than a {length}-frame window: {', '.join(short)}")
    usable = [c for c in clips if c.n_frames >= length]
    if not usable:
        longest = max(clips, key=lambda c: c.n_frames)
        raise ValueError(f"window_s: a window of {window_s:g} s ({length} frames at {fps:g} fps) "
                         f"is longer than every clip; the longest, {longest.name}, has "
                         f"{longest.n_frames} frames ({longest.duration_s:.3g} s). Use a shorter window_s")
    splits = split_clips(usable, fractions, seed)

    windows = {}
    for split, members in splits.items():
        per_clip = []
        for clip in members:
            feats = clip.features(facing_smoothing_s)
            copies = augment(feats, fps, augment_with) if split == "train" else [feats]
            per_clip += [cut_windows(c, length, stride) for c in copies]
        windows[split] = (np.concatenate(per_clip) if per_clip
                          else np.zeros((0, length, feats.shape[1])))
    normalizer = Normalizer.fit(windows["train"], shared=POSE if normalization == "shared_pose" else None)
    datasets = {s: MotionDataset(normalizer.normalize(w)) for s, w in windows.items()}
    description = {
        "source": source or _describe_sources(clips),
        "fps": fps, "window_frames": length, "stride_frames": stride,
        "augment": list(augment_with), "seed": seed, "fractions": list(fractions),
        "facing_smoothing_s": facing_smoothing_s, "normalization": normalization,
        "skeleton": list(LOCOMOTION.names),
        "clips": {s: [c.name for c in m] for s, m in splits.items()},
        "dropped_short": short,
    }
    return MotionData(datasets["train"], datasets["val"], datasets["test"], normalizer,
                      splits, description)
