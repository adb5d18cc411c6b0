"""How numbers, counts and the common notes read for people (Qt-free, standard library only).

One place for the wording every surface shares (``gaitmon info``, the review window, the
report, the live window), so they cannot drift apart:

* :func:`num` - a number with a fixed number of decimals that never prints a negative zero
  ("-0.0°" was shown for a value of -0.02); a dash for NaN;
* :func:`count` - "1 gap", "2 gaps" (never "1 gaps");
* :func:`no_gait_events` - why a recording in a mode without foot-sensor data has no strides;
* :func:`side_text` - the leg measured as entered ("left", "right", "not recorded"): never
  guessed from the unit's own idea of its side;
* :func:`duration_text` - a recording's duration ("63.5 s"), the same in every window.
"""

from __future__ import annotations

import math

__all__ = ["DASH", "count", "duration_text", "no_gait_events", "num", "plural", "side_text"]

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


def implausible_text(n: int) -> str:
    """"" or "3 implausible frames, " for a link line beside its CRC failures: CRC-valid frames
    dropped because their sequence number jumped further than the time allowed (the decoder's
    ``implausible_frames``; a false CRC accept). Shown only when there are some."""
    return f"{count(n, 'implausible frame')}, " if n else ""


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


NO_SIDE = "not recorded"


def side_text(side: str) -> str:
    """The leg measured, as the session's ``side`` (``SessionMeta.side``) says: "left",
    "right", or "not recorded" when nobody entered one. ``gaitmon info``, the report and
    ``compare`` all show this; the unit's IDENTITY side is the unit's, not the patient's."""
    return {"L": "left", "R": "right"}.get(side.strip().upper(), NO_SIDE)


def duration_text(seconds: float) -> str:
    """A recording's duration, to a tenth of a second ("63.5 s"): ``gaitmon info``, the
    report, the review window, ``compare`` and the live window's saved line all print it
    this way, so one recording never reads 63.5 s in one place and 64 s in another."""
    return f"{num(seconds, 1)} s"
