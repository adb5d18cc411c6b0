"""A unit's sample clock against the host clock: the one line fit, used live and offline.

A unit stamps nothing; the host knows only when each sample's bytes arrived. A delay on the link
(Bluetooth's retries, a busy reader, several frames collected by one read) only ever *adds* to
a receive time, so the receive times lie on or above the line "host time when the sample was
taken (plus the link's shortest delay)": the line is the **lower envelope** of the points
(unit time x, host receive time y).

:func:`envelope_line` fits it: the line under all the points that is closest to them (an
edge of their lower convex hull), so only the points read soonest count. The engine's markers
(``engine.markers.RecentEnvelope``) use it on the last 30 s live, the sample clock
(``dsp.sample_clock.SampleClock``, the LSL outlets' timestamps) its :func:`hull_slope`;
:func:`fit_clock` uses it offline along the whole recording: one segment per minute of the
unit's clock, each fitted over three minutes centred on it, so a slow wander of the crystal with
temperature is followed too. Two types: :class:`ClockLine` (one line, in sample periods) and
:class:`ClockFit` (a recording's fit, one line per segment, in the unit's seconds).
Pure numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# a fit needs this much of the unit's clock (in x units * fs); before that the nominal slope
MIN_FIT_SPAN_S = 1.0
WINDOW_S = 60.0  # offline: one segment per this much of the unit's clock
CONTEXT = 1  # ... fitted over its window and this many windows either side (3 minutes)
# Two units' crystals differ by tens of ppm (a real unit's is within +-50 ppm); two fits of one
# session that differ by more were bent by receive times late for much of the recording
# (a host that fell behind the link: a busy machine, a simulator many times faster than real
# time): :func:`pair_disagreement_ppm`, ``finish.combine``
MAX_PAIR_PPM = 1000.0
# ... judged only on fits over this much of the unit's clock (too few strides for two-leg
# measures below it): a shorter one's slope is set by its first reads, and a recording's start
# is its slowest (the file opened, the reader catching up): two 1-s fits at 1x differed by
# 2e5 ppm with both links working
MIN_JUDGED_SPAN_S = 10.0
# the quickest reads of a link sit up to this far above the true line at either end of a fit
# (Bluetooth's bursts, a loaded host's scheduling): two fits over T s of the host's clock can
# differ by 2 * 2 * this / T from it alone, which the limit adds (:func:`bent_pair_ppm`)
READ_FLOOR_S = 0.02
_BIN = 8  # points per bin of which only the quickest can be on the envelope (long fits)


def lower_hull(x: list[float], y: list[float]) -> list[int]:
    """Indices of the lower convex hull of points with strictly increasing x (Andrew's
    monotone chain; plain lists: the loop is ~20x faster than on numpy scalars)."""
    hull: list[int] = []
    for i in range(len(x)):
        while len(hull) >= 2:
            o, a = hull[-2], hull[-1]
            # a is not below the segment o -> i: drop it
            if (x[a] - x[o]) * (y[i] - y[o]) - (y[a] - y[o]) * (x[i] - x[o]) <= 0:
                hull.pop()
            else:
                break
        hull.append(i)
    return hull


def hull_slope(x: list[float], y: list[float], hull: list[int], mean_x: float) -> float:
    """The slope of the lower envelope: the linear programme's optimum is the hull's edge
    spanning the points' mean x. That edge can be short, two near-floor points a tenth of a
    second apart whose slope is their noise over 0.1 s (a busy host makes these): then the
    chord over the neighbouring hull vertices, widened about the mean until it spans an eighth
    of the points, is taken instead. It keeps off the first and last points, which are on the
    hull whatever their delay (the newest may end a stall's backlog). NaN with < 2 vertices."""
    if len(hull) < 2:
        return float("nan")
    span = x[hull[-1]] - x[hull[0]]
    j = 1
    while j < len(hull) - 1 and x[hull[j]] < mean_x:
        j += 1
    ia, ib = j - 1, j
    while x[hull[ib]] - x[hull[ia]] < span / 8:
        can_a, can_b = ia > 1, ib < len(hull) - 2
        if not (can_a or can_b):
            break
        left = mean_x - x[hull[ia - 1]] if can_a else math.inf
        right = x[hull[ib + 1]] - mean_x if can_b else math.inf
        if left <= right:
            ia -= 1
        else:
            ib += 1
    a, b = hull[ia], hull[ib]
    return (y[b] - y[a]) / (x[b] - x[a])


def envelope_line(
    x: np.ndarray, y: np.ndarray, nominal_slope: float, min_span: float
) -> tuple[float, float]:
    """(a, b) of the lower-envelope line y = a + b x through the points (module doc).

    The line lies under every point and, among such lines, is the closest to them on average
    (it minimises the summed heights of the points above it): an edge of the points' lower
    convex hull, the one spanning their mean x (the linear-programming estimate of clock skew
    of Moon, Skelly and Towsley, 1999; :func:`hull_slope`, which the LSL clock uses too). Only
    the points read soonest matter; how late the others were does not. With points spanning
    less than ``min_span`` of x (or a slope that is not positive), the slope is
    ``nominal_slope`` and only the offset is fitted. Give x relative to a point near the data
    (``x - x[-1]``) on long sessions: no precision is lost.
    """
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    b = float(nominal_slope)
    if len(x) >= 2 and x.max() - x.min() >= min_span:
        order = np.lexsort((y, x))
        xs, ys = x[order], y[order]
        first = np.ones(len(xs), bool)  # of equal x only the lowest point can be on the hull
        first[1:] = xs[1:] != xs[:-1]
        xs, ys = xs[first], ys[first]
        if len(xs) > _BIN * 32:
            # only the quickest point of a few neighbours can be a hull vertex (to within the
            # slope's error over a bin): keep those, so the hull's loop runs over 1/_BIN of them
            rough = (ys[-1] - ys[0]) / (xs[-1] - xs[0])
            r = ys - rough * xs
            n = len(xs) // _BIN * _BIN
            pick = np.argmin(r[:n].reshape(-1, _BIN), axis=1) + np.arange(0, n, _BIN)
            pick = np.concatenate([pick, np.arange(n, len(xs))])
            xs, ys = xs[pick], ys[pick]
        xl, yl = xs.tolist(), ys.tolist()
        slope = hull_slope(xl, yl, lower_hull(xl, yl), float(x.mean()))
        if slope > 0:
            b = float(slope)
    a = float(np.min(y - b * x))  # down to the envelope: the samples read soonest
    return a, b


@dataclass(frozen=True)
class ClockLine:
    """One line of a unit's clock against the host's: ``host_s = offset_s + period_s * (k - k0)``
    (``k`` the unit's sample periods; the live sample clock's map and fit,
    :class:`gaitmon.dsp.sample_clock.SampleClock`)."""

    k0: float
    offset_s: float
    period_s: float

    def at(self, k: np.ndarray | float) -> np.ndarray:
        return self.offset_s + self.period_s * (np.asarray(k, dtype=np.float64) - self.k0)


@dataclass(frozen=True)
class ClockFit:
    """A unit's clock fit over a recording: host time = ``host_s[i] + slope[i] (x - x0[i])``
    on segment i, x in [x0[i], x1[i]] (the unit's own seconds, ``/timeline/t_s``).

    ``residual_*_ms``: the receive times above the line (the link's extra delays), median and
    95th percentile, over all points.
    """

    x0_s: np.ndarray
    x1_s: np.ndarray
    host_s: np.ndarray  # host time at x0
    slope: np.ndarray  # host seconds per unit second
    residual_p50_ms: float
    residual_p95_ms: float

    def host_at(self, x_s: np.ndarray | float) -> np.ndarray:
        """Host time of unit time ``x_s``: by the segment holding it (the nearest one outside),
        each segment's line reaching to the middle between it and the next."""
        x = np.asarray(x_s, np.float64)
        if not len(self.x0_s):
            return np.full(x.shape, np.nan)
        edges = (self.x1_s[:-1] + self.x0_s[1:]) / 2.0
        i = np.searchsorted(edges, x, side="right")
        return np.asarray(self.host_s[i] + self.slope[i] * (x - self.x0_s[i]))

    @property
    def span_s(self) -> float:
        """Seconds of the unit's clock the fit covers (0 with no segment)."""
        return float(self.x1_s[-1] - self.x0_s[0]) if len(self.x0_s) else 0.0

    @property
    def mean_slope(self) -> float:
        """Host seconds per unit second over the whole fit (weighted by the segments' span)."""
        span = self.x1_s - self.x0_s
        if not len(span) or span.sum() <= 0:
            return float(self.slope.mean()) if len(self.slope) else float("nan")
        return float(np.sum(self.slope * span) / span.sum())


def fit_clock(
    x_s: np.ndarray, host_s: np.ndarray, *, window_s: float = WINDOW_S, context: int = CONTEXT,
    slope_s_per_s: float | None = None,
) -> ClockFit:
    """Fit host receive times ``host_s`` against the unit's clock ``x_s`` (seconds, ascending):
    one segment per ``window_s`` of the unit's clock (the last window takes up a remainder
    shorter than half a window), each the lower-envelope line of its window and ``context``
    windows either side (its centre is the window's: the fit is best there), used over its own
    window. Points whose host time is not finite are skipped. ``slope_s_per_s``: every
    segment's slope (host s per unit s, e.g. the other leg's rate), only the offsets fitted."""
    x = np.asarray(x_s, np.float64)
    h = np.asarray(host_s, np.float64)
    ok = np.isfinite(x) & np.isfinite(h)
    x, h = x[ok], h[ok]
    empty = np.empty(0)
    if not len(x):
        return ClockFit(empty, empty, empty, empty, float("nan"), float("nan"))
    n_win = max(1, round((x[-1] - x[0]) / window_s))
    bounds = x[0] + (x[-1] - x[0]) * np.arange(n_win + 1) / n_win
    cut = np.searchsorted(x, bounds, side="left")
    cut[-1] = len(x)
    x0, x1, a0, sl = [], [], [], []
    resid = []
    slope = float((h[-1] - h[0]) / (x[-1] - x[0])) if x[-1] > x[0] else 1.0
    if not slope > 0:  # every row read at once (a short recording's one burst): no rate seen
        slope = 1.0
    min_span = MIN_FIT_SPAN_S
    if slope_s_per_s is not None:
        slope, min_span = float(slope_s_per_s), math.inf
    for w in range(n_win):
        own = slice(cut[w], cut[w + 1])
        if cut[w + 1] <= cut[w]:
            continue
        near = slice(cut[max(0, w - context)], cut[min(n_win, w + 1 + context)])
        ref_x, ref_h = float(x[own][0]), float(h[own][0])
        a, b = envelope_line(x[near] - ref_x, h[near] - ref_h, slope, min_span)
        x0.append(ref_x)
        x1.append(float(x[own][-1]))
        a0.append(ref_h + a)
        sl.append(b)
        resid.append(h[own] - (ref_h + a + b * (x[own] - ref_x)))
    r = np.concatenate(resid) * 1e3
    return ClockFit(
        np.array(x0), np.array(x1), np.array(a0), np.array(sl),
        float(np.median(r)), float(np.percentile(r, 95)),
    )  # fmt: skip


def pair_disagreement_ppm(a: ClockFit, b: ClockFit) -> float:
    """How much faster ``a``'s unit runs than ``b``'s by their fits, in ppm (two units of one
    session: tens of ppm; beyond :func:`bent_pair_ppm` a fit is bent). NaN if either has no
    rate."""
    sa, sb = a.mean_slope, b.mean_slope
    if not (sa > 0 and sb > 0):  # (NaN: no segment)
        return math.nan
    return (sb / sa - 1.0) * 1e6


def bent_pair_ppm(a: ClockFit, b: ClockFit) -> float:
    """The disagreement (ppm) beyond which one of two units' fits is bent (NaN: too short to
    judge, under :data:`MIN_JUDGED_SPAN_S` of a unit's clock): two crystals'
    :data:`MAX_PAIR_PPM` plus what the reads' floor (:data:`READ_FLOOR_S`) can tilt two fits
    over the shorter one's span of host time (a simulator at --speed F: 1/F of its own)."""
    if not min(a.span_s, b.span_s) >= MIN_JUDGED_SPAN_S:
        return math.nan
    host_span = min(a.span_s * a.mean_slope, b.span_s * b.mean_slope)
    return MAX_PAIR_PPM + 4.0 * READ_FLOOR_S / host_span * 1e6
