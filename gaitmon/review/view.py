"""What the review timeline reads for the rows in view, and the readout at its cursor (Qt-free).

A change of the detail range becomes a :class:`ViewRequest`; :func:`load_view` answers it on the
timeline's worker from each source's :class:`gaitmon.io.overview.SessionOverview` (raw rows when
few, min/max decimated otherwise) as a :class:`ViewData`. :func:`readout_html` is the line of
values at the cursor, read from the current series at the exact row (numbers through
:func:`gaitmon.text.num`: never a "-0.0°").

Gait phases are shown on the events' time base (docs/gaps-and-time.md): the phase drawn and read
out at row ``i`` is the recorded (causal) phase of row ``i + phase_lag`` (see
``PipelineConfig.phase_lag_samples``), so a heel-strike line and its loading band start together.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from gaitmon.dsp.channels import JOINTS, SEGMENTS
from gaitmon.dsp.gait import PHASE_NAMES
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.errors import Cancelled
from gaitmon.io.overview import PeakWindow
from gaitmon.jobs import Ticket
from gaitmon.review.model import JOINT, Document, ReviewSource
from gaitmon.text import num

PHASE = "processed/phase"


@functools.lru_cache(maxsize=16)
def _lag(config: PipelineConfig) -> int:
    return config.phase_lag_samples


def phase_lag(doc: Document, src: ReviewSource) -> int:
    """Rows by which ``src``'s phases lag its events (0 for the unit's own contacts)."""
    return _lag(src.config) if doc.session.mode == "raw" else 0


def phase_on_event_time(doc: Document, src: ReviewSource, start: int, stop: int) -> np.ndarray:
    """The phase of rows [start, stop) on the events' time base; -1 where not known (the end)."""
    lag = phase_lag(doc, src)
    out = np.full(max(0, stop - start), -1, dtype=np.int8)
    a, b = start + lag, min(stop + lag, src.n_rows)
    if b > a:
        out[: b - a] = src.read_rows(PHASE, a, b)[:, 0]
    return out


@dataclass(frozen=True)
class ViewRequest:
    start: int
    stop: int
    max_points: int
    series: tuple[tuple[str, str], ...]  # (source key, series name)
    phase: bool


@dataclass(frozen=True, eq=False)
class ViewData:
    """The answer to one :class:`ViewRequest` of one document."""

    request_id: int
    request: ViewRequest
    doc: Document
    windows: dict[tuple[str, str], PeakWindow]  # (source key, series name) -> rows drawn
    phase: np.ndarray | None  # gait phase of every row in view (when asked for)


def answers_quickly(req: ViewRequest, sources: Mapping[str, ReviewSource]) -> bool:
    """Whether every series of ``req`` is answered without a long read: from its rows when the
    range holds at most ``max_points`` of them (a few decoded chunks, mostly cached), or from
    a pyramid already built. Those the timeline answers at once, on its own thread; the rest
    (a direct decimation of up to ``DIRECT_FACTOR * max_points`` rows, a pyramid to build) go
    to its worker."""
    if req.stop - req.start <= req.max_points:
        return True
    return all(sources[key].overview.has_pyramid(name) for key, name in req.series) and (
        not req.phase)


def load_view(
    request_id: int,
    req: ViewRequest,
    doc: Document,
    sources: Mapping[str, ReviewSource],
    current: ReviewSource,
    ticket: Ticket | None,
) -> ViewData:
    """Read the request's series (raises :class:`Cancelled` once the request is overtaken);
    ``ticket`` None: read now, on the caller's thread (see :func:`answers_quickly`)."""
    windows: dict[tuple[str, str], PeakWindow] = {}
    for key, name in req.series:
        if ticket is not None and not ticket.wanted:
            raise Cancelled("overtaken by a newer view")
        windows[(key, name)] = sources[key].overview.window(
            name, req.start, req.stop, req.max_points,
            progress=None if ticket is None else ticket.progress,
        )
    phase = phase_on_event_time(doc, current, req.start, req.stop) if req.phase else None
    return ViewData(request_id, req, doc, windows, phase)


def gap_at(doc: Document, t_s: float) -> tuple[float, float, str] | None:
    """The gap the time ``t_s`` falls in, as (last time before it, first time after it, what
    it was), or None when a recorded row is the nearest sample: inside a gap the nearest
    *frame* is a lost one once the cursor is more than half a sample from the rows either
    side (so a readout there shows no data, never the row across the gap)."""
    t = doc.t_s
    n = len(t)
    if n == 0 or not math.isfinite(t_s):
        return None
    half = 0.5 / doc.fs_hz if doc.fs_hz > 0 else 0.0
    rows, _lost = doc.gaps
    after = int(np.searchsorted(t, t_s, side="right"))  # first row later than t_s
    if 0 < after < n:
        k = int(np.searchsorted(rows, after))
        if k < len(rows) and rows[k] == after:
            t0, t1 = float(t[after - 1]), float(t[after])
            if t0 + half < t_s < t1 - half:
                return t0, t1, _gap_reason(doc, after)
        return None
    if after >= n and t_s > float(t[-1]) + half:  # an outage the recording ended in
        for g in doc.session.gaps:
            if g.sample_idx >= n:
                t0 = float(t[-1])
                if t_s < t0 + g.duration_s:
                    return t0, t0 + g.duration_s, g.reason
    return None


def _gap_reason(doc: Document, row: int) -> str:
    return next((g.reason for g in doc.session.gaps if g.sample_idx == row), "")


def _gap_words(reason: str) -> str:
    return "link gap" if reason.startswith("link") else "gap: frames lost"


def readout_html(doc: Document, cursor_t_s: float, segment: int) -> str:
    """The time and the values at the cursor, read from the current series (exact row);
    inside a gap, the time and that there is no data there (no row from either side)."""
    if not math.isfinite(cursor_t_s):
        return ""
    gap = gap_at(doc, cursor_t_s)
    if gap is not None:
        t0, t1, reason = gap
        return (f"<b>t {num(cursor_t_s, 2)} s</b> — no data ({_gap_words(reason)} "
                f"{num(t0, 1)}–{num(t1, 1)} s)")
    i = doc.row_at(cursor_t_s)
    src = doc.current
    t = float(doc.t_s[i])
    h, rem = divmod(t, 3600)
    m, s = divmod(rem, 60)
    clock = f"{int(h)}:{int(m):02d}:{s:06.3f}" if h else f"{int(m)}:{s:06.3f}"
    parts = [f"<b>t {num(t, 2)} s</b> ({clock}, row {i})"]
    if src.has(JOINT):
        j = src.read_rows(JOINT, i, i + 1)[0]
        parts.append(" · ".join(f"{n} {num(v, 1, sign=True)}°" for n, v in
                                zip(JOINTS, j, strict=True)))  # fmt: skip
    if src.has("processed/tilt_deg"):
        v = src.read_rows("processed/tilt_deg", i, i + 1)[0, segment]
        parts.append(f"{SEGMENTS[segment]} tilt {num(v, 1, sign=True)}°")
    if src.has("processed/fsr_counts"):
        f = src.read_rows("processed/fsr_counts", i, i + 1)[0]
        parts.append(f"heel {num(f[0], 0)} · toe {num(f[1], 0)}")
    if src.has(PHASE):
        ph = int(phase_on_event_time(doc, src, i, i + 1)[0])
        if 0 <= ph < len(PHASE_NAMES):
            parts.append(PHASE_NAMES[ph])
    if src is not doc.recorded:
        parts.append("<i>reprocessed</i>")
    return " &nbsp;|&nbsp; ".join(parts)
