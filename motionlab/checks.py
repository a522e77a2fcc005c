"""Argument checks shared by the whole library: one clear ``ValueError`` per bad input.

Every public function that takes a frame rate, a duration or an array checks it here, so
that a wrong call fails at once with a message naming the argument and what was expected,
instead of deep inside numpy with an ``IndexError`` or, worse, silently with NaN::

    fps = checks.rate(fps, "fps")                                # 0 < fps <= MAX_FPS, finite
    features = checks.array(features, "features", (..., "frames", 66))

Shapes are tuples whose entries are a whole number (that size exactly), a string (any size
of at least 1, named in the message) or ``...`` (any number of leading dimensions, first
entry only).
"""
from __future__ import annotations

import math
from numbers import Integral, Real

import numpy as np

MAX_FPS = 2000.0
"""Highest frame rate accepted anywhere (motion capture runs at 30-480 fps; a higher rate
is almost surely a unit error, and resampling to it could allocate gigabytes)."""

MAX_SECONDS = 24 * 3600.0
"""Longest duration accepted for a window, stride or clip: a day."""


def _is_number(value) -> bool:
    return isinstance(value, (Real, np.floating, np.integer)) and not isinstance(value, bool)


def positive(value, name: str, maximum: float | None = None) -> float:
    """``value`` as a float if it is a finite number ``> 0`` (and ``<= maximum``), else ``ValueError``."""
    if not _is_number(value):
        raise ValueError(f"{name}: expected a positive number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name}: {value:g} is larger than the largest accepted value, {maximum:g}")
    return value


def non_negative(value, name: str, maximum: float = math.inf) -> float:
    """``value`` as a float if it is a number from 0 to ``maximum`` (for smoothing widths and
    tolerances, where 0 means "none"), else ``ValueError``."""
    if _is_number(value) and 0 <= value <= maximum:
        return float(value)
    raise ValueError(f"{name}: expected a number from 0 to {maximum:g}, got {value!r}")


def rate(value, name: str = "fps") -> float:
    """A frame rate in frames per second: finite, ``> 0`` and at most :data:`MAX_FPS`."""
    return positive(value, name, MAX_FPS)


def seconds(value, name: str) -> float:
    """A duration in seconds: finite, ``> 0`` and at most :data:`MAX_SECONDS`."""
    return positive(value, name, MAX_SECONDS)


def whole(value, name: str, minimum: int = 1) -> int:
    """``value`` as an int if it is a whole number ``>= minimum`` (bools are refused)."""
    if isinstance(value, bool) or not isinstance(value, (Integral, np.integer)):
        raise ValueError(f"{name}: expected a whole number >= {minimum}, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name}: expected a whole number >= {minimum}, got {value}")
    return int(value)


def finite(value, name: str) -> float:
    """``value`` as a float if it is a finite number (of either sign), else ``ValueError``."""
    if not _is_number(value) or not math.isfinite(float(value)):
        raise ValueError(f"{name}: expected a finite number, got {value!r}")
    return float(value)


def config(obj, *, positive_fields=(), non_negative_fields=(), probability_fields=(), fraction_fields=(),
           zero_allowed=()) -> None:
    """Check every field of a config dataclass by its annotation, in place; ``ValueError``
    naming the field otherwise. Called first in each config's ``__post_init__``.

    * ``int`` fields: whole numbers ``>= 1`` (``>= 0`` for the names in ``zero_allowed``);
      bools, floats (``2.5``, ``64.0``) and NaN are refused; numpy integers become ``int``.
    * ``float`` fields: finite numbers (ints become floats), and ``fps`` a frame rate
      (:func:`rate`); the names in ``positive_fields`` must be ``> 0``, in
      ``non_negative_fields`` ``>= 0``, in ``probability_fields`` in ``[0, 1)`` and in
      ``fraction_fields`` in ``[0, 1]``.
    * ``bool`` fields: ``True`` or ``False``; ``str`` fields: strings.
    * ``X | None``: ``None``, or as ``X``. Other annotations (tuples) are the config's own
      to check.
    """
    import dataclasses
    for field in dataclasses.fields(obj):
        name, value = field.name, getattr(obj, field.name)
        kinds = {kind.strip() for kind in str(field.type).split("|")}
        if value is None and "None" in kinds:
            continue
        if "bool" in kinds:
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"{name}: expected True or False, got {value!r}")
            value = bool(value)
        elif "int" in kinds:
            value = whole(value, name, 0 if name in zero_allowed else 1)
        elif "float" in kinds:
            if name == "fps":
                value = rate(value, name)
            elif name in positive_fields:
                value = positive(value, name)
            else:
                value = finite(value, name)
                if name in non_negative_fields and value < 0:
                    raise ValueError(f"{name}: expected a number >= 0, got {value!r}")
                if name in probability_fields and not 0 <= value < 1:
                    raise ValueError(f"{name}: expected a probability, 0 <= p < 1, got {value!r}")
                if name in fraction_fields and not 0 <= value <= 1:
                    raise ValueError(f"{name}: expected a number from 0 to 1, got {value!r}")
        elif "str" in kinds:
            if not isinstance(value, str):
                raise ValueError(f"{name}: expected a string, got {value!r}")
        else:
            continue
        object.__setattr__(obj, name, value)


def _shape_text(shape) -> str:
    return "(" + ", ".join("..." if s is Ellipsis else str(s) for s in shape) + ")"


def array(value, name: str, shape=None, finite: bool = True, dtype=np.float64) -> np.ndarray:
    """``value`` as a numpy array, checked.

    Args:
        value: anything ``np.asarray`` takes (a torch tensor on the CPU works too).
        name: the argument's name, for the message.
        shape: the expected shape (see the module docstring), or ``None`` for any non-empty.
        finite: refuse NaN and infinite values.
        dtype: convert to this type (``None``: keep).

    Raises:
        ValueError: naming ``name``, the expected shape and the shape it got.
    """
    try:
        result = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name}: expected an array of numbers, got {type(value).__name__} ({err})") from None
    if shape is not None:
        want = list(shape)
        leading = bool(want) and want[0] is Ellipsis
        if leading:
            want = want[1:]
        got = result.shape[result.ndim - len(want):] if leading and result.ndim >= len(want) else result.shape
        fits = (result.ndim >= len(want) if leading else result.ndim == len(want)) and all(
            (size >= 1 if isinstance(w, str) else size == w) for w, size in zip(want, got))
        if not fits:
            raise ValueError(f"{name}: expected shape {_shape_text(shape)}, got {tuple(result.shape)}")
    if result.size == 0:
        raise ValueError(f"{name}: is empty (shape {tuple(result.shape)})")
    if finite and result.dtype.kind in "fc" and not np.isfinite(result).all():
        bad = int((~np.isfinite(result)).sum())
        raise ValueError(f"{name}: contains {bad} NaN or infinite value{'s' if bad > 1 else ''}")
    return result
