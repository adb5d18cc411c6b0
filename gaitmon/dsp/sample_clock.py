"""The sample clock: a unit's sample counter mapped onto the host's clock, live (``SampleClock``),
a fit of host receive time against the counter, so that the jitter of the link never reaches a
timestamp. Pure (numpy only). The LSL outlets stamp their samples with it; its lines are
``gaitmon.dsp.clock_fit.ClockLine``, fitted by that module's lower envelope.

What is fitted. ``k`` counts the unit's sample periods since its first sample, lost frames
included (the engine's ``t_s * fs``); ``host_s`` is ``time.monotonic()`` when the bytes of
that sample were read. Every sample is read *after* it was made, so

    host_s = a + b * k + delay,   delay >= d_min >= 0

where ``b`` is the unit's sample period on the host's clock (1 / fs, off by the crystal's
rate error, or 1 / (fs * speed) for a simulator running faster than real time) and the delay
is the link's: the Bluetooth stack's buffering (several ms of jitter), frames that arrive in
bursts and share one read time, a stalled link that delivers a second of backlog at once.
The delays are one-sided and far from Gaussian, so an ordinary least-squares line through all
the points would be pulled up and tilted by every burst and stall.

The choice: the **lower envelope** (Moon, Skelly & Towsley, "Estimation and removal of clock
skew from network delay measurements", 1999, the method NTP-style skew estimators use). The
line ``a + b k`` that lies below every point and is as high as possible on average
(linear programming: maximise ``sum(a + b k_i)`` subject to ``a + b k_i <= host_s_i``) is the
edge of the points' lower convex hull that spans their mean ``k``. It rests on the samples
that met the least delay, which every burst of a Bluetooth link contains (the last frame of a
burst waited least), and ignores by construction every sample that was held up: a stall or a
backlog moves nothing. Its offset is the smallest delay seen (``d_min``, the constant part of
the link's latency, which no receiver can tell from the unit's own delay and which cannot be
removed: it is reported, not hidden, see ``docs/lsl.md``). A least-squares or recursive fit
with outlier rejection was the alternative; it needs a threshold for "outlier" that depends on
the link, and still averages the delays it keeps. The hull needs no threshold. One change
to the LP's exact optimum: when the edge at the mean is short (two near-floor samples a tenth
of a second apart, whose slope is their noise over 0.1 s; a busy host makes these), the slope
is taken over the chord of the neighbouring hull vertices, widened about the mean until it
spans an eighth of the window, keeping off the window's first and last samples (always on
the hull, whatever their delay); the line is then placed as high as that slope allows.

Window. The samples of the last ``window_s`` (default 60 s; the crystal's rate changes
slowly with temperature) are kept; a refit takes the least-delayed sample of each of at most
``max_points`` buckets (only such a sample can be on the hull; while the window is short,
every sample) and is made every ``refit_s`` of samples, and at once when a sample arrives
below the line (news: less delay than any before). The window grows while the session is
young, then slides.

The first seconds. Until the points span ``trust_s`` (10 s) of samples the line is refitted
with every block, and its rate is held within ``rate_prior_ppm`` (1000 ppm, a crystal's
tolerance) of the nominal one, unless the fit is more than 10 % off it (a simulator running
faster than real time): a short span says little about the rate. Before two samples with
different receive times (a link that opens on a backlog reads every frame of it at one
moment), the fit is the nominal rate through the least-delayed sample, refitted with each
block like any fit: the backlog's later frames pull the map down (they were all made before
that moment), instead of the map running on at the nominal rate above them (it ran 1.3 s
ahead on a 1.3-s backlog, and at speed 4 took 1,100 samples to come back).

The map. Timestamps must not jump when the fit changes: the map in force (``map``) is a line
that, at each refit, starts from its own value at the last sample stamped and meets the new
fit some time later (a slew, never a step), unless the fit is more than ``step_s`` ahead
(or it is the first fit, or a restart), when it takes the fit at once. The stamps never go
back (an XDF reader drops a sample stamped before its predecessor): a slew back advances at
a tenth of the sample period at least (``_MIN_ADVANCE``; half of it took seconds to undo a
map that was far ahead). Down (a sample met less delay
than any before: certain, delays are never negative) the slew takes 0.1 s while the rate is
being learnt; up (no sample came near the line for a while: the floor may have moved, or the
host was busy) 0.5 s; once the rate is learnt, ``horizon_s`` (2 s) either way.

Gaps and reconnects. Lost frames are gaps in ``k``, nothing more: the fit needs no sample at
every ``k``. A reconnect in the same session keeps the unit's counter, and the points after
it fall on the same line (later, never earlier): nothing changes. A unit that restarted, or a
counter that jumped, shows as samples that arrive *before* the line says they could have been
made (more than ``step_s`` below it), or that stay more than ``late_s`` above it for
``late_for_s``: then the fit starts again from those samples (``restarts`` counts it) and
keeps the rate it had learnt (the same crystal), and the map steps once.
"""

from __future__ import annotations

import numpy as np

from gaitmon.dsp.clock_fit import ClockLine, hull_slope, lower_hull

# a fitted rate this far from the nominal one is taken as it is even from a short span (a
# simulator running at another speed than real time): no prior holds it
_FREE_BEYOND = 0.1
# a sample this far below the line is news worth a refit at once (less is left to the next
# scheduled one: a refit costs ~1 ms, and near-floor samples graze the line all the time)
_NEWS_S = 50e-6
# a map that must come back (it stamps samples later than they were read) still advances at
# this fraction of the sample period: the stamps increase, and it is back within a few periods
_MIN_ADVANCE = 0.1


class SampleClock:
    """The sample counter -> host time map of one unit; see the module doc.

    ``update(k, host_s)`` with each block (``k`` increasing), then ``map(k)`` for the
    timestamps of its samples or of events at earlier samples."""

    def __init__(
        self,
        fs_hz: float,
        *,
        window_s: float = 60.0,
        max_points: int = 256,
        refit_s: float = 0.25,
        horizon_s: float = 2.0,
        step_s: float = 0.005,
        late_s: float = 0.25,
        late_for_s: float = 2.0,
        trust_s: float = 10.0,
        rate_prior_ppm: float = 1000.0,
    ) -> None:
        if not fs_hz > 0:
            raise ValueError(f"fs_hz must be > 0, got {fs_hz}")
        self.fs_hz = float(fs_hz)
        self._window_k = max(2.0, window_s * fs_hz)
        self._max_points = max(4, int(max_points))
        self._refit_k = max(1.0, refit_s * fs_hz)
        self._horizon_k = max(1.0, horizon_s * fs_hz)
        self.step_s = float(step_s)
        self.late_s = float(late_s)
        self._late_for_k = late_for_s * fs_hz
        # points spanning less than this say little about the rate: before, the rate is held
        # near the nominal one (at the start) or kept as learnt (after a restart)
        self._trust_k = trust_s * fs_hz
        self._min_span_k = self._trust_k
        self._prior = rate_prior_ppm * 1e-6
        self.restarts = 0
        self.fit: ClockLine | None = None  # the last fitted line (None before two buckets)
        self._map: ClockLine | None = None
        self._restarted = False
        self._reset_points()

    def _reset_points(self) -> None:
        # the window's samples: rows [_p0, _p1) of two growing arrays (k, host_s); and the
        # candidates of the last refit: the least-delayed sample of each bucket, k increasing
        self._pk = np.zeros(1024)
        self._ph = np.zeros(1024)
        self._p0 = self._p1 = 0
        self._bk = np.zeros(0)
        self._bh = np.zeros(0)
        self._k_last: float | None = None
        self._k_refit: float | None = None
        self._aim_k: float | None = None  # where the slew under way meets the fit
        self._aim_down = False  # and whether it goes down
        self._late_since_k: float | None = None

    # -- input ----------------------------------------------------------------------------

    def update(self, k: np.ndarray, host_s: np.ndarray) -> None:
        """Add a block's samples: ``k`` (sample periods since the first sample, increasing)
        and the host time each was received."""
        k = np.asarray(k, dtype=np.float64)
        h = np.asarray(host_s, dtype=np.float64)
        if not len(k):
            return
        if self._k_last is not None and k[0] <= self._k_last:
            # the counter went back: a new unit (or a restarted one) on the same clock map
            self._restart()
        if self._trusted() and self._inconsistent(k, h):
            self._restart()
        # a sample below the line is news (less delay than any before): refit at once
        news = self._map is None or float((h - self._map.at(k)).min()) < -_NEWS_S
        self._add_points(k, h)
        # the map changes from the last sample already stamped (the previous block's last)
        k_anchor = float(k[0]) if self._k_last is None else self._k_last
        k_now = float(k[-1])
        self._k_last = k_now
        young = self._span() < self._trust_k  # the rate still being learnt: every block
        if news or young or self._k_refit is None or k_now - self._k_refit >= self._refit_k:
            self._refit(k_anchor, k_now)

    def restart(self) -> None:
        """Forget the points (keep the learnt rate): the counter no longer continues the
        old one. ``update`` finds this by itself; a caller that knows may say it."""
        self._restart()

    def _restart(self) -> None:
        if self._map is not None:
            self.restarts += 1
        self._reset_points()
        self._restarted = self._map is not None

    def _trusted(self) -> bool:
        """A fit on points spanning long enough to judge new samples against it."""
        return (
            self.fit is not None
            and self._map is not None
            and not self._restarted
            and self._span() >= self._min_span_k
        )

    def _span(self) -> float:
        if self._p1 == self._p0:
            return 0.0
        return float(self._pk[self._p1 - 1] - self._pk[self._p0])

    def _inconsistent(self, k: np.ndarray, h: np.ndarray) -> bool:
        assert self._map is not None
        r = h - self._map.at(k)
        if float(r.min()) < -self.step_s:
            return True  # received before it could have been made on this map
        if float(r.min()) > self.late_s:
            if self._late_since_k is None:
                self._late_since_k = float(k[0])
            return float(k[-1]) - self._late_since_k >= self._late_for_k
        self._late_since_k = None
        return False

    def _add_points(self, k: np.ndarray, h: np.ndarray) -> None:
        n = len(k)
        if self._p1 + n > len(self._pk):  # move the window to the front; grow if it is full
            size = self._p1 - self._p0
            cap = max(len(self._pk), 2 * (size + n))
            pk, ph = np.zeros(cap), np.zeros(cap)
            pk[:size], ph[:size] = self._pk[self._p0 : self._p1], self._ph[self._p0 : self._p1]
            self._pk, self._ph, self._p0, self._p1 = pk, ph, 0, size
        self._pk[self._p1 : self._p1 + n] = k
        self._ph[self._p1 : self._p1 + n] = h
        self._p1 += n
        # slide: drop the samples older than the window (keep at least two)
        cut = float(k[-1]) - self._window_k
        first = int(np.searchsorted(self._pk[self._p0 : self._p1], cut))
        self._p0 += min(first, self._p1 - self._p0 - 2) if first > 0 else 0

    def _candidates(self) -> None:
        """The least-delayed sample of each of at most ``max_points`` buckets of the window
        (only such a sample can be on the lower hull), judged against the current slope so
        that a bucket's choice does not depend on the unknown true rate. Short windows keep
        every sample: the first blocks' fit has every point it can get."""
        k = self._pk[self._p0 : self._p1]
        h = self._ph[self._p0 : self._p1]
        width = max(1.0, np.ceil((k[-1] - k[0] + 1) / self._max_points))
        bucket = ((k - k[0]) // width).astype(np.int64)
        period = self._map.period_s if self._map is not None else 1.0 / self.fs_hz
        r = h - period * (k - k[0])
        starts = np.flatnonzero(np.r_[True, np.diff(bucket) != 0])  # k is sorted
        lows = np.minimum.reduceat(r, starts)
        at_low = np.flatnonzero(r == np.repeat(lows, np.diff(np.r_[starts, len(r)])))
        _, first = np.unique(bucket[at_low], return_index=True)
        pick = at_low[first]
        self._bk, self._bh = k[pick], h[pick]

    # -- fitting ----------------------------------------------------------------------------

    def _refit(self, k_anchor: float, k_now: float) -> None:
        self._k_refit = k_now
        self._candidates()
        if self._restarted and self._span() >= self._min_span_k:
            self._restarted = False
        # after a restart, until the new points span enough to trust their own rate
        fit = self._learnt_rate_fit() if self._restarted else self._envelope()
        if fit is not None:
            self.fit = fit
        else:  # no rate yet (every sample read at one time: a backlog): the nominal rate
            period = 1.0 / self.fs_hz
            i = int(np.argmin(self._bh - period * self._bk))
            fit = ClockLine(float(self._bk[i]), float(self._bh[i]), period)
        m = self._map
        now = float(m.at(k_anchor)) if m is not None else 0.0
        err = float(fit.at(k_anchor)) - now
        # a step, once: the first fit, a restart (a new counter: its times may well go back),
        # or a fit far ahead. Never a step back otherwise: a regular stream's timestamps must
        # increase (an XDF reader drops a sample stamped before its predecessor)
        if m is None or (abs(err) > self.step_s and (self._restarted or err > 0)):
            self._map = fit
            return
        # slew: from where the map was at the last stamped sample to where the fit will be a
        # horizon later; a refit during a slew keeps its meeting point, so every slew ends in
        # time. Down (a sample met less delay than any before: certain, delays are never
        # negative) it takes 0.1 s while the rate is being learnt; up (no sample has come
        # near the line for a while: maybe the floor moved, maybe the host was busy) 0.5 s;
        # once the rate is learnt, 2 s either way
        down = float(fit.at(k_now)) < float(m.at(k_now))
        if self._aim_k is None or self._aim_k <= k_now or down != self._aim_down:
            young = self._span() < self._trust_k
            horizon = (0.1 if down else 0.5) * self.fs_hz if young else self._horizon_k
            self._aim_k, self._aim_down = k_now + horizon, down
        k_aim = self._aim_k
        period = (float(fit.at(k_aim)) - now) / (k_aim - k_anchor)
        # going back, the stamps still advance at half the sample period at least
        self._map = ClockLine(k_anchor, now, max(period, _MIN_ADVANCE * fit.period_s))

    def _learnt_rate_fit(self) -> ClockLine:
        """The rate learnt before a restart, through the new points' least-delayed one."""
        assert self._map is not None
        period = self._map.period_s if self.fit is None else self.fit.period_s
        k, h = self._bk, self._bh
        i = int(np.argmin(h - period * k))
        return ClockLine(float(k[i]), float(h[i]), period)

    def _envelope(self) -> ClockLine | None:
        """The lower envelope of the candidates (see the module doc)."""
        n = len(self._bk)
        if n < 2:
            return None
        k0 = float(self._bk[0])
        x_arr, h_arr = self._bk - k0, self._bh
        x: list[float] = x_arr.tolist()  # plain floats: the hull's loop is ~20x faster
        h: list[float] = h_arr.tolist()
        # the slope: gaitmon.dsp.clock_fit's, the one lower-envelope fit (the bilateral
        # sessions' clock mapping uses it too): the hull's edge spanning the mean k, widened
        # to an eighth of the window when short, kept off the window's first and last samples
        period = hull_slope(x, h, lower_hull(x, h), float(x_arr.mean()))
        if not period > 0:
            return None
        # the line as high as it can be with that slope: touching the hull at one sample
        a = int(np.argmin(h_arr - period * x_arr))
        nominal = 1.0 / self.fs_hz
        if x[-1] < self._trust_k and abs(period / nominal - 1.0) < _FREE_BEYOND:
            # a short span says little about the rate (the least delays it met differ by a
            # fraction of a ms, over a second or two): hold it within a crystal's tolerance
            # of the nominal rate, with the line as high as that slope allows
            lo, hi = nominal * (1.0 - self._prior), nominal * (1.0 + self._prior)
            if not lo <= period <= hi:
                period = min(max(period, lo), hi)
                i = int(np.argmin(h_arr - period * x_arr))
                return ClockLine(k0, h[i] - period * x[i], period)
        return ClockLine(k0, h[a] - period * x[a], period)

    # -- output -------------------------------------------------------------------------

    @property
    def ready(self) -> bool:
        return self._map is not None

    @property
    def current(self) -> ClockLine | None:
        """The map in force (None before the first sample)."""
        return self._map

    def map(self, k: np.ndarray | float) -> np.ndarray:
        """Host time (``time.monotonic`` seconds) of the samples at counter values ``k``."""
        if self._map is None:
            raise RuntimeError("no sample has been seen yet")
        return self._map.at(k)

    @property
    def rate_error_ppm(self) -> float:
        """The unit's clock against the host's: + = the unit runs fast (NaN before a fit)."""
        if self.fit is None:
            return float("nan")
        return (1.0 / (self.fit.period_s * self.fs_hz) - 1.0) * 1e6
