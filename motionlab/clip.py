"""A motion clip as world positions, what every reader returns and every data set is made of.

Kept apart from :mod:`motionlab.data` so that the readers (:mod:`motionlab.bvh`,
:mod:`motionlab.asfamc`) can return clips without importing the loader that imports them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import checks
from .filters import resample
from .representation import FACING_SMOOTHING_S, to_features

INCH_M = 0.0254
"""Metres per inch: the Acclaim length unit is ``1 / length`` inches (ASF ``:units length``)."""

CMU_UNIT_M = INCH_M / 0.45
"""Metres per CMU length unit (the ASF ``length 0.45``: 1 unit = 1/0.45 inch = 5.644 cm);
the cgspeed BVH files use the same unit."""


@dataclass
class Clip:
    """One motion clip as world positions.

    Attributes:
        name: short name, e.g. ``"16_15"`` for ``16_15.bvh``.
        positions: ``(frames, 21, 3)`` locomotion-skeleton joint positions, metres, y up.
        fps: frames per second.
        source: where it came from (a file path, or a generator name).
    """

    name: str
    positions: np.ndarray
    fps: float
    source: str = ""

    @property
    def n_frames(self) -> int:
        return self.positions.shape[0]

    @property
    def duration_s(self) -> float:
        return self.n_frames / self.fps

    def features(self, facing_smoothing_s: float = FACING_SMOOTHING_S) -> np.ndarray:
        """The clip in the shared representation, ``(frames, 66)``."""
        return to_features(self.positions, self.fps, facing_smoothing_s)

    def resampled(self, fps: float) -> "Clip":
        """This clip at another frame rate (anti-aliased, see :func:`filters.resample`)."""
        fps = checks.rate(fps, "fps")
        if fps == self.fps:
            return self
        return Clip(self.name, resample(self.positions, self.fps, fps), fps, self.source)
