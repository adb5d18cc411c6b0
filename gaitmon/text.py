"""How numbers, counts and the common notes read for people (Qt-free, standard library only).

One place for the wording every surface shares (``gaitmon info``, the review window, the
report, the live window), so they cannot drift apart:

* :func:`num` - a number with a fixed number of decimals that never prints a negative zero
  ("-0.0°" was shown for a value of -0.02); a dash for NaN;
* :func:`count` - "1 gap", "2 gaps" (never "1 gaps");
* :func:`no_gait_events` - why a recording in a mode without foot-sensor data has no strides.
"""

from __future__ import annotations

import math

__all__ = ["DASH", "count", "no_gait_events", "num", "plural"]

DASH = "–"  # a value that does not exist (NaN), never "nan"

_IRREGULAR = {"analysis": "analyses", "is": "are", "was": "were"}


def num(value: float, decimals: int = 1, *, sign: bool = False, minus: str = "-") -> str:
    """``value`` with ``decimals`` decimals; ``sign=True`` writes "+" on positive values.

    A value that rounds to zero prints as zero without a sign ("0.0", never "-0.0" or
    "+0.0"). ``minus`` is the minus character (the report typesets a true "−"). NaN and
    infinities print as a dash.
    """
    v = float(value)
    if not math.isfinite(v):
        return DASH
    text = f"{v:.{decimals}f}"
    if float(text) == 0.0:  # -0.02 -> "-0.0" -> "0.0"
        return text.lstrip("-")
    if sign and v > 0:
        text = "+" + text
    return text.replace("-", minus) if minus != "-" else text


def plural(n: int, word: str, many: str | None = None) -> str:
    """``word`` or its plural for ``n`` items ("gap" / "gaps"); ``many`` for irregular ones."""
    if n == 1:
        return word
    if many is not None:
        return many
    if word in _IRREGULAR:
        return _IRREGULAR[word]
    if word.endswith(("s", "x", "ch", "sh")):
        return word + "es"
    return word + "s"


def count(n: int, word: str, many: str | None = None) -> str:
    """"1 gap", "3 gaps", "0 strides" (the number and the word agreeing)."""
    return f"{n} {plural(n, word, many)}"


def no_gait_events(mode: str) -> str:
    """Why a recording in ``mode`` has no gait events, or "" when the mode has them.

    By the protocol the unit's tilt mode sends segment tilts only: no foot-sensor (FSR)
    values and no gait phase, so there are no heel strikes, strides or phases to show."""
    if mode == "tilt":
        return (
            "the unit's tilt mode sends no foot-sensor data, so this recording has no gait "
            "events (no heel strikes, strides or gait phases)"
        )
    return ""
