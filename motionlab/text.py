"""How the course writes measured numbers in sentences, once, so every notebook reads alike.

A notebook renders its findings from the values it measured (``display(Markdown(...))``)
and formats them with these: percentages with a thin space before ``%`` as the library's
checks print them (``pct(0.654) == "65 %"``), negative numbers with a true minus sign
(``num(-507) == "−507"``), and lists of model names joined so that a name holding a comma
or a parenthesis stays one item (``names(["A", "B", "C"]) == "A, B and C"``).
"""
from __future__ import annotations

import math

MINUS = "\u2212"
"""The minus sign (U+2212) printed for negative numbers; the hyphen-minus is for code."""


def _finite(value, name: str) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"{name}: expected a finite number, got {value}")
    return value


def num(value, digits: int = 0, thousands: bool = False) -> str:
    """``value`` with ``digits`` decimals and a true minus sign: ``num(-3.14159, 1) ==
    "−3.1"``; ``thousands=True`` groups digits (``"12,400"``). ``-0`` prints as ``0``."""
    value = _finite(value, "value")
    if not isinstance(digits, int) or isinstance(digits, bool) or not 0 <= digits <= 10:
        raise ValueError(f"digits: expected an integer from 0 to 10, got {digits!r}")
    text = f"{abs(value):{',' if thousands else ''}.{digits}f}"
    negative = value < 0 and text.strip("0.,") != ""
    return (MINUS if negative else "") + text


def pct(fraction, digits: int = 0) -> str:
    """A fraction as a percentage, as the checks print it: ``pct(0.654) == "65 %"``,
    ``pct(0.0131, 1) == "1.3 %"``."""
    return f"{num(100 * _finite(fraction, 'fraction'), digits)} %"


def names(items, last: str = "and", none: str = "none") -> str:
    """Model names as an English list: ``"VAE-LSTM, MoGlow and MoGlow (anchored)"``; one
    name alone; ``none`` when empty. A name may not hold a comma (the list would read as
    more names than there are): ``ValueError`` then."""
    items = [str(item) for item in items]
    for item in items:
        if "," in item:
            raise ValueError(f"items: the name {item!r} holds a comma, which makes the list ambiguous")
    if not items:
        return none
    if len(items) == 1:
        return items[0]
    return f"{', '.join(items[:-1])} {last} {items[-1]}"
