"""What the live plots draw, prepared off the GUI thread: a frame of arrays ready to draw.

A viewer describes what it shows in a frozen :class:`DisplayRequest` (the time window, the
series of its visible traces, its visible plots and their y ranges, the phase bands, whether
the raw-sensor plots are shown). :func:`prepare_display` turns an engine :class:`Snapshot`
and that request into a :class:`DisplayFrame`: x as seconds before now, each series min/max
decimated to at most ``max_points`` rows (:func:`decimate_peak`), the gyro integration NaN
where it is off scale (:func:`on_scale`), the phase bands and the lost / settling shading as
step outlines (:func:`step_band`), the gait events and markers as vertical line pairs
(:func:`vertical_lines`), and the gait cycles' mean and SD. A GUI thread then only hands the
arrays to its curves and paints.

:class:`DisplayFeed` is an engine listener (``Engine.add_listener``) that prepares such a
frame on the engine thread right after a block, at most ``refresh_hz`` times a second on a
fixed grid, keeps the newest and tells the viewer (``on_frame``, from the engine thread).

No Qt here (the primitives are shared with the review window through ``gaitmon.ui.plots``).
"""

from __future__ import annotations

import dataclasses
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gaitmon.dsp.gait import cycle_mean_sd
from gaitmon.engine.snapshot import Snapshot
from gaitmon.engine.taps import BlockOut

STALE_S = 0.3  # no new data for longer than this: the link is down, time runs on
MAX_POINTS = 1400  # per trace; beyond this a window is min/max decimated
GYRO_SERIES = ("tilt_gyro_deg", "joint_gyro_deg")
RAW_SERIES = ("acc_ms2", "gyro_rad_s")

XY = tuple[np.ndarray, np.ndarray]


def decimate_peak(x: np.ndarray, y: np.ndarray, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Min/max decimation of (N,) x and (N, ...) y to at most ``max_points`` rows.

    Each group of f consecutive samples becomes two rows (its min and max), so short peaks
    survive; the oldest N mod f samples are dropped. Returns the inputs when no decimation
    is needed.
    """
    n = len(x)
    if n <= max_points or max_points < 2:
        return x, y
    f = math.ceil(n / (max_points // 2))
    if n < 2 * f:
        return x, y
    m = n // f
    start = n - m * f
    xs = x[start:].reshape(m, f)
    ys = y[start:].reshape(m, f, *y.shape[1:])
    out_x = np.empty(2 * m)
    out_x[0::2] = xs[:, 0]
    out_x[1::2] = xs[:, -1]
    out_y = np.empty((2 * m, *y.shape[1:]))
    out_y[0::2] = ys.min(axis=1)
    out_y[1::2] = ys.max(axis=1)
    return out_x, out_y


def step_band(
    x: np.ndarray, mask: np.ndarray, top: float, bottom: float
) -> tuple[np.ndarray, np.ndarray]:
    """A step outline that is ``top`` where ``mask`` holds and ``bottom`` elsewhere.

    Only the runs' ends become points, so a 10 s window of phases is a few dozen points.
    """
    if len(x) == 0:
        return np.empty(0), np.empty(0)
    m = np.asarray(mask, dtype=np.int8)
    change = np.flatnonzero(np.diff(m)) + 1
    starts = np.concatenate([[0], change])
    ends_x = np.concatenate([x[change], x[-1:]])
    out_x = np.empty(2 * len(starts))
    out_x[0::2] = x[starts]
    out_x[1::2] = ends_x
    out_y = np.repeat(np.where(m[starts] > 0, top, bottom), 2)
    return out_x, out_y


def step_runs(x: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The x from and to of each run where ``mask`` holds: the spans :func:`step_band` draws at
    its top (a run ends at the x of the next run's first sample, the last at ``x[-1]``)."""
    if len(x) == 0:
        return np.empty(0), np.empty(0)
    m = np.asarray(mask, dtype=np.int8)
    change = np.flatnonzero(np.diff(m)) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [len(x) - 1]])
    on = m[starts] > 0
    return x[starts[on]], x[ends[on]]


def on_scale(
    y: np.ndarray, ranges: list[tuple[float, float]]
) -> tuple[np.ndarray, np.ndarray]:
    """(N, k) angles in degrees -> (the same with NaN where a value lies outside its column's
    range or jumps by more than 180° from the previous sample (a wrap at +-180°), the newest
    off-scale value per column (NaN if none is off scale)).

    For the drifting gyro integration: a line never leaves its plot and a wrap is never drawn
    as a vertical line; the caller says that it is off scale instead.
    """
    out = np.array(y, dtype=np.float64, copy=True)
    if out.size == 0:
        return out, np.full(out.shape[1:], np.nan)
    lo = np.array([r[0] for r in ranges])
    hi = np.array([r[1] for r in ranges])
    with np.errstate(invalid="ignore"):
        off = (out < lo) | (out > hi)
        jump = np.zeros_like(off)
        jump[1:] = np.abs(np.diff(out, axis=0)) > 180.0
    last_off = np.full(out.shape[1], np.nan)
    for j in range(out.shape[1]):
        rows = np.flatnonzero(off[:, j])
        if len(rows):
            last_off[j] = out[rows[-1], j]
    out[off | jump] = np.nan
    return out, last_off


def vertical_lines(xs: np.ndarray, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Points for a ``connect='pairs'`` curve drawing one vertical line per x."""
    return np.repeat(xs, 2), np.tile(np.array([lo, hi]), len(xs))


def newest_idx(series: dict[str, np.ndarray]) -> float:
    """The engine index of the newest received sample in a snapshot's series (NaN if none)."""
    idx = series.get("idx")
    if idx is None:
        return math.nan
    real = idx[np.isfinite(idx)]
    return float(real[-1]) if len(real) else math.nan


@dataclass(frozen=True)
class PlotRequest:
    """One visible time plot: its y range and whether it draws the gait events."""

    name: str
    yrange: tuple[float, float]
    events: bool = False


@dataclass(frozen=True)
class DisplayRequest:
    """What a viewer shows; replaced whole when the user changes the view."""

    window_s: float = 10.0
    series: tuple[str, ...] = ()  # the series of the visible traces
    plots: tuple[PlotRequest, ...] = ()  # the visible plots
    # gyro series drawn on scale, with the y range of each of their columns' plots
    gyro: tuple[tuple[str, tuple[tuple[float, float], ...]], ...] = ()
    bands: tuple[tuple[int, ...], ...] = ()  # the visible phase bands: the phases each shades
    band_range: tuple[float, float] = (0.0, 1.0)  # the band's bottom and top (FSR plot)
    raw: bool = False  # the raw-sensor plots are shown
    max_points: int = MAX_POINTS


@dataclass(frozen=True)
class Curves:
    """One series as drawn: x (s before now), (n, k) y, and per column all / any finite."""

    x: np.ndarray
    y: np.ndarray
    all_finite: np.ndarray
    any_finite: np.ndarray


@dataclass(frozen=True)
class PlotFrame:
    """One plot's shading and lines (``None``: nothing to draw)."""

    lost: XY | None = None
    settling: XY | None = None
    heel_strikes: XY | None = None
    toe_offs: XY | None = None
    markers: XY | None = None


@dataclass(frozen=True)
class DisplayFrame:
    """Everything the live plots draw for one snapshot, ready to hand to the curves."""

    snap: Snapshot
    request: DisplayRequest
    t_now: float  # the time at the right edge (x = 0), on series["t_s"]
    curves: dict[str, Curves] = field(default_factory=dict)
    gyro_off: dict[str, np.ndarray] = field(default_factory=dict)  # newest off-scale value
    bands: tuple[XY, ...] = ()  # per request.bands
    plots: dict[str, PlotFrame] = field(default_factory=dict)
    fsr_missing: bool = False
    raw: dict[str, Curves] = field(default_factory=dict)  # raw plots: x before the newest row
    cycle_mean_sd: tuple[np.ndarray, np.ndarray] | None = None  # (101, 3) each
    newest_idx: float = math.nan
    empty: bool = False  # no rows at all: nothing to draw
    taken_s: float = 0.0  # time.monotonic() before the snapshot was taken


def _curves(x: np.ndarray, y: np.ndarray, max_points: int) -> Curves:
    xd, yd = decimate_peak(x, y, max_points)
    fin = np.isfinite(yd)
    return Curves(xd, yd, fin.all(axis=0), fin.any(axis=0))


def prepare_display(snap: Snapshot, req: DisplayRequest) -> DisplayFrame:
    """The frame the live plots draw for ``snap`` (see the module doc)."""
    s = snap.series
    t = s["t_s"]
    cyc = snap.gait.cycles_deg
    mean_sd = cycle_mean_sd(cyc) if len(cyc) else None
    if len(t) == 0:
        return DisplayFrame(snap, req, 0.0, cycle_mean_sd=mean_sd, empty=True)
    # while no data arrives (a cut link) the traces keep scrolling with the clock and the
    # time without data is shaded as lost, instead of freezing as if nothing had happened
    stale_s = snap.last_data_age_s if snap.last_data_age_s > STALE_S else 0.0
    t_now = float(t[-1]) + stale_s
    x_full = t - t_now
    gyro: dict[str, np.ndarray] = {}
    gyro_off: dict[str, np.ndarray] = {}
    for name, ranges in req.gyro:
        gyro[name], gyro_off[name] = on_scale(s[name], list(ranges))
    curves = {
        name: _curves(x_full, gyro.get(name, s[name]), req.max_points) for name in req.series
    }
    lo, hi = req.band_range
    ph = np.nan_to_num(s["phase"], nan=0.0)
    bands = tuple(
        step_band(x_full, ph == phases[0] if len(phases) == 1 else ph > 0, hi, lo)
        for phases in req.bands
    )
    x_lost, lost = lost_shading(x_full, s["lost"], bool(stale_s))
    settling = s["settling"] > 0
    any_lost, any_settling = bool(lost.any()), bool(settling.any())
    hs = snap.heel_strike_t_s - t_now
    to = snap.toe_off_t_s - t_now
    marker_x = np.array([m[0] - t_now for m in snap.markers], dtype=float)
    plots: dict[str, PlotFrame] = {}
    for p in req.plots:
        lo, hi = p.yrange
        plots[p.name] = PlotFrame(
            lost=step_band(x_lost, lost, hi, lo) if any_lost else None,
            settling=step_band(x_full, settling, hi, lo) if any_settling else None,
            heel_strikes=vertical_lines(hs, lo, hi) if p.events else None,
            toe_offs=vertical_lines(to, lo, hi) if p.events else None,
            markers=vertical_lines(marker_x, lo, hi),
        )
    raw: dict[str, Curves] = {}
    if req.raw:
        x_raw = t - t[-1]
        for name in RAW_SERIES:
            raw[name] = _curves(x_raw, s[name].reshape(len(t), -1), req.max_points)
    return DisplayFrame(
        snap, req, t_now, curves, gyro_off, bands, plots,
        fsr_missing=not np.isfinite(s["fsr_counts"]).any(),
        raw=raw, cycle_mean_sd=mean_sd, newest_idx=newest_idx(s),
    )  # fmt: skip


class DisplayFeed:
    """An engine listener preparing the viewer's frame on the engine thread (module doc).

    ``request`` is set by the viewer (``None`` or ``paused``-like absence: no frames) and read
    by the engine thread: one reference, replaced whole. ``take()`` hands the newest frame
    over once. ``on_frame`` is called on the engine thread after a new frame is kept; it must
    only post (a queued Qt signal, say), never draw.
    """

    def __init__(
        self,
        snapshot: Callable[[float], Snapshot],
        on_frame: Callable[[], None],
        refresh_hz: float = 30.0,
    ) -> None:
        self._snapshot = snapshot
        self._on_frame = on_frame
        self.period_s = 1.0 / refresh_hz
        self.request: DisplayRequest | None = None
        self._latest: DisplayFrame | None = None
        self._lock = threading.Lock()
        self._next_due = 0.0
        self.frames = 0  # prepared so far

    def __call__(self, out: BlockOut) -> None:
        req = self.request
        if out.last or req is None:
            return
        now = time.monotonic()
        if now < self._next_due:
            return
        # on a fixed grid (the next due time from the last one, not from now), so frames come
        # at the refresh rate on average although a block arrives a little after each due time
        self._next_due += self.period_s
        if self._next_due <= now:
            self._next_due = now + self.period_s
        frame = prepare_display(self._snapshot(req.window_s), req)
        self.publish(dataclasses.replace(frame, taken_s=now))

    def publish(self, frame: DisplayFrame) -> None:
        with self._lock:
            self._latest = frame
            self.frames += 1
        self._on_frame()

    def take(self) -> DisplayFrame | None:
        """The newest frame not taken yet (None if none)."""
        with self._lock:
            frame, self._latest = self._latest, None
        return frame


def lost_shading(
    x: np.ndarray, lost_frames: np.ndarray, stale: bool
) -> tuple[np.ndarray, np.ndarray]:
    """(x, mask) of the lost-data shading: rows that lost frames before them, and while the
    link is down (``stale``) the time from the last row up to now (x = 0) as lost too."""
    lost = np.asarray(lost_frames) > 0
    if not stale or not len(x):
        return x, lost
    return np.append(x, [x[-1] + 1e-6, 0.0]), np.append(lost, [True, True])
