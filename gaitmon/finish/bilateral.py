"""Bilateral sessions: both legs' units in one file, with their clock fits.

A bilateral recording is written as two ordinary, crash-safe single-unit recordings beside the
target (``FILE.L.partial``, ``FILE.R.partial``: :mod:`.parts`) and combined into ``FILE`` at
the stop (:mod:`.combine`): each part's whole layout under ``/units/<side>``, and under
``/sync/<side>`` the fit of that unit's clock against the host clock
(``gaitmon.dsp.clock_fit``) with the session's common time base. ``docs/file-format.md``
("Bilateral sessions") is the reference, ``docs/bilateral.md`` the measures.

Reading: ``open_session(FILE, side="L")`` gives one leg as an ordinary :class:`Session`
(rooted at its group); :func:`open_bilateral` gives both legs and the clock mapping. Both
recover and combine left-over parts first (the process died before the combine).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from gaitmon.dsp.clock_fit import ClockFit
from gaitmon.finish.combine import combine_parts
from gaitmon.finish.session import Session, open_combined_h5, open_session
from gaitmon.io.session.h5file import _short_error
from gaitmon.io.session.header import SessionError
from gaitmon.io.session.parts import (
    BOTH_LEGS,
    PROBE_ERRORS,
    SIDE_NAMES,
    SIDES,
    is_bilateral,
    part_path,
    parts_of,
)
from gaitmon.io.session.series import AttrValue, _py, attr_text

# under this share of the shorter leg, the legs were recorded together "briefly": said wherever
# the two-leg measures are shown (:func:`caveats`)
TOGETHER_SHARE = 0.9
# ... and by more than about a stride apart: a 1-s recording's parts 0.2 s apart (one file's
# opening, its crude 1-s clock fits) lose no stride
TOGETHER_APART_S = 1.0

__all__ = [
    "SIDES",
    "TOGETHER_SHARE",
    "Bilateral",
    "Caveat",
    "caveats",
    "combine_parts",
    "is_bilateral",
    "missing_legs",
    "missing_lines",
    "open_bilateral",
    "part_path",
    "parts_of",
    "pick_side_message",
]


def _read_fit(g: h5py.Group) -> ClockFit:
    seg = g["segments"][()]
    return ClockFit(
        np.asarray(seg["unit_start_s"], np.float64), np.asarray(seg["unit_stop_s"], np.float64),
        np.asarray(seg["host_s"], np.float64), np.asarray(seg["host_s_per_unit_s"], np.float64),
        float(g.attrs.get("residual_p50_ms", np.nan)),
        float(g.attrs.get("residual_p95_ms", np.nan)),
    )  # fmt: skip


@dataclass
class Bilateral:
    """A bilateral session: both units (ordinary :class:`Session` s, by side) and the clock
    mapping. ``common_s(side, unit_s)`` maps a unit's own time (``/timeline/t_s``, e.g. at an
    event's row) onto the session's common time line: ``(host(unit_s) - host_t0_s) /
    host_s_per_common_s`` (0 = the first sample of the unit that started first)."""

    path: Path
    units: dict[str, Session]
    sync: dict[str, ClockFit]
    host_t0_s: float
    host_s_per_common_s: float
    attrs: dict[str, AttrValue]  # the file's root attributes
    # why the clock fits may be off ("" if they agreed: ``finish.combine._agreed``)
    clock_warning: str = ""
    _caveats: tuple[Caveat, ...] | None = field(default=None, init=False, repr=False)

    @property
    def sides(self) -> tuple[str, ...]:
        return tuple(self.units)

    def unit(self, side: str) -> Session:
        if side not in self.units:
            raise SessionError(f"{self.path.name} has no {SIDE_NAMES.get(side, side)} leg")
        return self.units[side]

    def common_s(self, side: str, unit_s: np.ndarray | float) -> np.ndarray:
        host = self.sync[side].host_at(unit_s)
        return np.asarray((host - self.host_t0_s) / self.host_s_per_common_s)

    def span_s(self, side: str) -> tuple[float, float]:
        """(first, last) row of that leg on the common time line (NaN for a leg of no rows)."""
        u = self.unit(side)
        n = u.n_samples
        if not n:
            return float("nan"), float("nan")
        t = [u.read_range(i, i + 1, ["timeline/t_s"])["timeline/t_s"][0] for i in (0, n - 1)]
        first, last = self.common_s(side, np.asarray(t, np.float64))
        return float(first), float(last)

    def together_s(self) -> float:
        """Seconds of the common time line that every leg recorded (<= 0: none; one leg: its
        own). Each part holds its own duration from its own first row; `gaitmon record` starts
        both once both units stream, so they are offset by one file's opening at 1x (at a
        simulator's speed on a busy machine, by how far each engine is behind its unit)."""
        return _together({s: self.span_s(s) for s in self.sides})

    def caveats(self) -> tuple[Caveat, ...]:
        """What a reader of this session's two-leg measures must be told (:func:`caveats`),
        decided once per open file: info, the report, review and every export ask for them."""
        if self._caveats is None:
            self._caveats = caveats(self)
        return self._caveats

    @property
    def missing(self) -> dict[str, str]:
        """The legs missing from the file (a part that could not be recovered), and why."""
        return missing_of(self.attrs)

    @property
    def complete(self) -> bool:
        return bool(self.attrs.get("complete", False))

    @property
    def recovered(self) -> bool:
        return bool(self.attrs.get("recovered", False))

    def close(self) -> None:
        for u in self.units.values():
            u.close()

    def __enter__(self) -> Bilateral:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass(frozen=True)
class Caveat:
    """Something a reader of a two-leg session's measures must be told, said the same way by
    ``gaitmon info`` (a line labelled ``key``), the report and review (``sentence``) and the
    exports' metadata (``key``'s fields)."""

    key: str  # "warning" (the clock fits disagreed) | "together" (recorded together briefly)
    text: str  # info's wording: lower case, no full stop
    together_s: float = float("nan")  # "together": seconds both legs were recorded together

    @property
    def sentence(self) -> str:
        """``text`` as a sentence (capital first letter, full stop)."""
        return self.text[:1].upper() + self.text[1:] + "."


def caveats(b: Bilateral) -> tuple[Caveat, ...]:
    """The one place that decides and words what may make a two-leg session's relative timing
    or its measures misleading: the clock fits' warning (``/sync``'s, ``finish.combine.
    _agreed``), then, when both legs were recorded together for less than
    :data:`TOGETHER_SHARE` of the shorter leg and more than :data:`TOGETHER_APART_S` short of
    it (the second unit's recording started late, e.g. a file of a version that started each
    part as its unit connected; at a simulator's --speed F, F times its delay), how long and
    how late: the measures of both legs come from that stretch alone. Empty when there is
    nothing to say."""
    out = [Caveat("warning", b.clock_warning)] if b.clock_warning else []
    if len(b.sides) != 2:
        return tuple(out)
    spans = {s: b.span_s(s) for s in b.sides}
    together = _together(spans)
    shorter = min(last - first for first, last in spans.values())
    # (NaN: a leg of no rows says so elsewhere)
    if together < TOGETHER_SHARE * shorter and shorter - together > TOGETHER_APART_S:
        early, late = sorted(b.sides, key=lambda s: spans[s][0])
        out.append(Caveat(
            "together",
            f"both legs recorded together for {max(together, 0.0):.1f} s only: the "
            f"{SIDE_NAMES[late]} unit's recording started "
            f"{spans[late][0] - spans[early][0]:.1f} s after the {SIDE_NAMES[early]} unit's; "
            "the measures of both legs come from that stretch",
            max(together, 0.0),
        ))  # fmt: skip
    return tuple(out)


def _together(spans: Mapping[str, tuple[float, float]]) -> float:
    return min(b for _, b in spans.values()) - max(a for a, _ in spans.values())


def open_bilateral(
    path: str | os.PathLike[str], *, progress: Callable[[float], bool | None] | None = None
) -> Bilateral:
    """Open a bilateral session (recovering and combining its parts first if the recording
    was interrupted). ``SessionError`` with one line for anything else."""
    path = Path(path)
    f = open_combined_h5(path, progress)
    try:
        if not bool(f.attrs.get("bilateral", False)):
            raise SessionError(f"{path.name} holds one unit, not both legs")
        sides = [s for s in str(f.attrs.get("sides", "")).split() if s in SIDES]
        if not sides or any(f"sync/{s}/segments" not in f for s in sides):
            raise SessionError(f"{path.name} is damaged: its units' clock fits are missing")
        sync = {s: _read_fit(f[f"sync/{s}"]) for s in sides}
        t0 = float(f["sync"].attrs["host_t0_s"])
        scale = float(f["sync"].attrs["host_s_per_common_s"])
        warning = attr_text(f["sync"].attrs.get("warning", ""))
        attrs = {k: _py(v) for k, v in f.attrs.items()}
    except SessionError:
        raise
    except PROBE_ERRORS as e:  # (a clock fit of another shape: IndexError)
        raise SessionError(f"{path.name} is damaged ({_short_error(e)})") from e
    finally:
        f.close()
    if not (np.isfinite(scale) and scale > 0 and np.isfinite(t0)):
        raise SessionError(f"{path.name} is damaged: its common time base is {t0}, {scale}")
    units: dict[str, Session] = {}
    try:
        for s in sides:  # one file handle per unit: each closes its own
            units[s] = open_session(path, side=s)
    except Exception:
        for u in units.values():
            with contextlib.suppress(Exception):
                u.close()
        raise
    return Bilateral(path, units, sync, t0, scale, attrs, warning)


def missing_of(attrs: Mapping[str, object]) -> dict[str, str]:
    """``{side: why}`` of a bilateral file's root attributes (``missing``, ``missing_<side>``)."""
    sides = attr_text(attrs.get("missing", "")).split()
    return {s: attr_text(attrs.get(f"missing_{s}", "")) for s in sides if s in SIDES}


def missing_lines(path: str | os.PathLike[str], missing: dict[str, str]) -> list[str]:
    """One line per missing leg, naming it and saying where its bytes are."""
    name = Path(path).name
    return [f"{name}: the {SIDE_NAMES[s]} leg ({s}) is missing: {why}" for s, why in
            missing.items()]  # fmt: skip


def missing_legs(path: str | os.PathLike[str]) -> list[str]:
    """:func:`missing_lines` of a combined file (none if it cannot be read)."""
    try:
        with h5py.File(path, "r") as f:
            return missing_lines(path, missing_of(f.attrs))
    except PROBE_ERRORS:
        return []


def pick_side_message(path: str | os.PathLike[str]) -> str:
    """The one line for a command that handles one unit and was given both legs."""
    return BOTH_LEGS.format(name=Path(path).name)
