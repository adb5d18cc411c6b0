"""How numbers, counts and the common notes read for people (Qt-free, standard library only).

One place for the wording every surface shares (``gaitmon info``, the review window, the
report, the live window), so they cannot drift apart:

* :func:`num` - a number with a fixed number of decimals that never prints a negative zero
  ("-0.0°" was shown for a value of -0.02); a dash for NaN;
* :func:`count` - "1 gap", "2 gaps" (never "1 gaps");
* :func:`no_gait_events` - why a recording in a mode without foot-sensor data has no strides;
* :func:`side_text` - the leg measured as entered ("left", "right", "not recorded"): never
  guessed from the unit's own idea of its side;
* :func:`duration_text` - a recording's duration ("63.5 s"), the same in every window;
* :func:`clean_label` - a marker label (or any free text from outside: an LSL sample, an XDF
  file, an old journal) made safe to store and show: control characters escaped visibly,
  at most :data:`MAX_LABEL_CHARS` characters;
* :func:`spreadsheet_cell` - a CSV/TSV text cell a spreadsheet cannot run as a formula.
"""

from __future__ import annotations

import math
import unicodedata

__all__ = [
    "DASH",
    "MAX_LABEL_CHARS",
    "TRUNCATED",
    "clean_label",
    "count",
    "duration_text",
    "no_gait_events",
    "num",
    "plural",
    "side_text",
    "spreadsheet_cell",
]

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


MAX_LABEL_CHARS = 256  # a marker label's length once cleaned, the truncation mark included
TRUNCATED = "…(truncated)"
# Unicode categories written as escapes: controls (NUL, ESC, line breaks), format characters
# (bidi overrides that reorder what is shown), lone surrogates (not UTF-8 encodable: h5py
# refuses them), line and paragraph separators
_ESCAPED_CATEGORIES = frozenset({"Cc", "Cf", "Cs", "Zl", "Zp"})
_KEPT_FORMAT = frozenset({"\u200c", "\u200d"})  # zero-width (non-)joiners: inside emoji, harmless


def _escape(ch: str) -> str:
    code = ord(ch)
    if code < 0x100:
        return f"\\x{code:02x}"
    return f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}"


def clean_label(value: object) -> str:
    """``value`` as a label that is safe to store in a session file and to show anywhere.

    Control and format characters (NUL, ESC and ANSI escape sequences, tabs and line breaks,
    bidi overrides, lone surrogates) become visible escapes (``\\x00``, ``\\x1b``,
    ``\\u202e``): HDF5 strings cannot hold a NUL, and a terminal or a table must never be
    steered by a label. A label longer than :data:`MAX_LABEL_CHARS` characters is cut to
    that length, ending in :data:`TRUNCATED`. Idempotent: a cleaned label comes back
    unchanged. The one function every way in for markers uses (the engine, the session
    writer, the journal recovery, the XDF import, the session reader for old files)."""
    text = value if isinstance(value, str) else str(value)
    if len(text) > 4 * MAX_LABEL_CHARS:  # bound the work: the rest is cut anyway
        text = text[: 4 * MAX_LABEL_CHARS]
    if not text.isprintable():  # fast path: most labels have nothing to escape
        text = "".join(
            _escape(c)
            if unicodedata.category(c) in _ESCAPED_CATEGORIES and c not in _KEPT_FORMAT
            else c
            for c in text
        )
    if len(text) > MAX_LABEL_CHARS:
        text = text[: MAX_LABEL_CHARS - len(TRUNCATED)] + TRUNCATED
    return text


_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def spreadsheet_cell(text: str) -> str:
    """A CSV/TSV text cell that no spreadsheet runs as a formula (OWASP's CSV injection
    advice): one that starts with ``= + - @``, a tab or a carriage return gets a leading
    single quote (``'=HYPERLINK(...)``). A number stays a number (``-12.5``, ``+3``,
    ``-inf``), and so does a lone sign or dash (the strides table's "no value"): neither
    can hold a formula."""
    if len(text) < 2 or not text.startswith(_FORMULA_START):
        return text
    try:
        float(text)
    except ValueError:
        return "'" + text
    return text
