"""Heel strike and toe off from the foot gyro, to cross-check (or stand in for) the force sensors.

The foot's sagittal rate (rad/s, + = toe up, gaitmon.dsp.channels) has one large positive peak per
stride in mid-swing, while the foot swings forward and dorsiflexes. Around it:

* toe off: the foot plantarflexes hard as it leaves the ground: the deepest minimum in the
  ``search_s`` before the mid-swing peak;
* heel strike: the foot rotates down onto the ground after contact: the first minimum below zero
  in the ``search_s`` after the peak (the window's minimum if there is none).

The rule is *local*, so that the streaming detector (:class:`GyroEventDetector`, used by the
pipeline) finds exactly the events of the offline function (:func:`gyro_gait_events`):

1. the rate is smoothed by a zero-phase 9-tap Hann FIR (``SMOOTH_TAPS``; ~10 Hz at 100 Hz);
2. a mid-swing peak is a sample >= ``peak_min_rad_s`` that is the maximum of the smoothed rate
   within +-``min_stride_s`` / 2 and above the sample before it;
3. the minima are looked for in the ``search_s`` either side of each peak (windows of
   neighbouring strides overlap only above ~150 steps/min);
4. each event is moved by a fixed offset, the lag between the gyro minimum and the contact
   change measured on the simulator's truth (heel strike -40 ms, toe off +50 ms; docs/filters.md).
   It is a property of the simulated foot; a real foot may need other values.

An event is decided once ``latency`` samples after its peak have been seen (the streaming delay:
``min_stride_s / 2 + search_s`` plus the smoothing's half-width, 0.74 s at the defaults).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitmon.dsp.windows import sliding_max

HS_OFFSET_S = -0.04
TO_OFFSET_S = 0.05
SMOOTH_TAPS = 9


@dataclass(frozen=True)
class GyroEventRule:
    """The rule's parameters (module doc)."""

    fs_hz: float = 100.0
    peak_min_rad_s: float = 1.5
    min_stride_s: float = 0.6
    search_s: float = 0.4
    hs_offset_s: float = HS_OFFSET_S
    to_offset_s: float = TO_OFFSET_S

    def __post_init__(self) -> None:
        for name in ("fs_hz", "peak_min_rad_s", "min_stride_s", "search_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value}")

    @property
    def half_window(self) -> int:
        return max(1, round(self.min_stride_s * self.fs_hz / 2))

    @property
    def search(self) -> int:
        return max(2, round(self.search_s * self.fs_hz))

    @property
    def latency(self) -> int:
        """Samples after a peak needed to decide it and its events."""
        return max(self.half_window, self.search) + SMOOTH_TAPS // 2 + 1

    @property
    def lookback(self) -> int:
        """Samples before a peak its decision reads."""
        return max(self.half_window, self.search) + SMOOTH_TAPS // 2 + 1


_TAPS = np.hanning(SMOOTH_TAPS + 2)[1:-1]
_TAPS = _TAPS / _TAPS.sum()


def _smooth(g: np.ndarray) -> np.ndarray:
    """'valid' zero-phase Hann FIR: output j is centred on input j + SMOOTH_TAPS // 2."""
    return np.convolve(g, _TAPS, mode="valid")


def _events_in(
    gf: np.ndarray, lo: int, hi: int, rule: GyroEventRule
) -> tuple[list[int], list[int], list[int]]:
    """(peaks, heel strikes, toe offs) for the peaks p in [lo, hi) of the smoothed rate gf.

    Reads gf only within [p - lookback, p + latency]: the caller guarantees that range.
    """
    n = len(gf)
    w, s = rule.half_window, rule.search
    hi = min(hi, n)
    if hi <= lo or gf[lo:hi].max() < rule.peak_min_rad_s:
        return [], [], []
    a0, b0 = max(0, lo - w), min(n, hi + w)
    local_max = sliding_max(gf[a0:b0], 2 * w + 1, mode="constant", cval=-np.inf)
    prev = gf[max(lo - 1, 0) : hi - 1] if lo > 0 else np.concatenate([[-np.inf], gf[: hi - 1]])
    pk = np.flatnonzero(
        (gf[lo:hi] >= rule.peak_min_rad_s)
        & (gf[lo:hi] == local_max[lo - a0 : hi - a0])
        & (gf[lo:hi] > prev)  # the first sample of a flat top
    ) + lo
    if len(pk) == 0:
        return [], [], []
    peaks = [int(p) for p in pk]
    # toe off: the minimum of the search_s before each peak (window rows, +inf outside the data)
    idx = pk[:, None] + np.arange(-s, 0)[None, :]
    before = np.where(idx >= 0, gf[np.clip(idx, 0, n - 1)], np.inf)
    ok_to = (idx >= 0).sum(axis=1) >= 2
    to = list((idx[np.arange(len(pk)), np.argmin(before, axis=1)])[ok_to])
    # heel strike: the first strict local minimum below zero after the peak, else the minimum
    idx = pk[:, None] + np.arange(1, s + 1)[None, :]
    inside = idx < n
    after = np.where(inside, gf[np.clip(idx, 0, n - 1)], np.inf)
    nxt = np.concatenate([after[:, 1:], np.full((len(pk), 1), np.inf)], axis=1)
    prv = np.concatenate([np.full((len(pk), 1), np.inf), after[:, :-1]], axis=1)
    # argrelmin's rule: strictly below both neighbours, and not at the window's ends
    is_min = (after < prv) & (after < nxt) & (after < 0) & inside
    is_min[:, 0] = False
    last = inside.sum(axis=1) - 1
    is_min[np.arange(len(pk)), np.clip(last, 0, s - 1)] = False
    first = np.where(is_min.any(axis=1), np.argmax(is_min, axis=1), np.argmin(after, axis=1))
    ok_hs = inside.sum(axis=1) >= 2
    hs = list((pk + 1 + first)[ok_hs])
    return peaks, hs, to


def gyro_gait_events(
    foot_gyro_y_rad_s: np.ndarray, fs_hz: float, *, rule: GyroEventRule | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(heel_strike_idx, toe_off_idx), int64 sample indices, from one foot's gyro (module doc)."""
    g = np.asarray(foot_gyro_y_rad_s, dtype=np.float64)
    if g.ndim != 1:
        raise ValueError(f"expected a 1-D foot gyro array, got shape {g.shape}")
    r = rule or GyroEventRule(fs_hz=fs_hz)
    if r.fs_hz != fs_hz:
        r = GyroEventRule(fs_hz, r.peak_min_rad_s, r.min_stride_s, r.search_s,
                          r.hs_offset_s, r.to_offset_s)  # fmt: skip
    return GyroEventDetector(r).process(g, final=True)


class GyroEventDetector:
    """The streaming form of :func:`gyro_gait_events`: gyro blocks in, decided events out.

    ``process(foot_gyro)`` returns the (heel strike, toe off) absolute indices decided with this
    block; ``flush()`` decides the rest at the end of a record (the offline function does).
    Any chunking gives the same events.
    """

    def __init__(self, rule: GyroEventRule | None = None) -> None:
        self.rule = rule or GyroEventRule()
        self.reset()

    def reset(self) -> None:
        self._raw = np.empty(0)  # raw rate kept from absolute index self._raw_start
        self._raw_start = 0
        self._next_peak = 0  # absolute index of the first peak candidate not yet decided
        self._seen = 0

    def process(self, foot_gyro_rad_s: np.ndarray, *, final: bool = False) -> tuple[
        np.ndarray, np.ndarray
    ]:  # fmt: skip
        g = np.nan_to_num(np.asarray(foot_gyro_rad_s, dtype=np.float64).reshape(-1))
        self._raw = np.concatenate([self._raw, g])
        self._seen += len(g)
        r = self.rule
        half = SMOOTH_TAPS // 2
        empty = np.empty(0, dtype=np.int64)
        if len(self._raw) < SMOOTH_TAPS:
            return empty, empty
        gf = _smooth(self._raw)  # gf[j] is centred on absolute index raw_start + half + j
        off = self._raw_start + half
        end_abs = self._seen if final else self._seen - half - r.latency
        lo = max(self._next_peak, off) - off
        hi = end_abs - off
        hs: list[int] = []
        to: list[int] = []
        if hi > lo:
            _, h, t = _events_in(gf, lo, hi, r)
            hs = [i + off for i in h]
            to = [i + off for i in t]
            self._next_peak = end_abs
        # keep what the next decisions read (their look-back), drop the rest
        keep_from = max(self._raw_start, self._next_peak - r.lookback - half - 1)
        self._raw = self._raw[keep_from - self._raw_start :]
        self._raw_start = keep_from
        hs_idx = np.asarray(hs, dtype=np.int64) + round(r.hs_offset_s * r.fs_hz)
        to_idx = np.asarray(to, dtype=np.int64) + round(r.to_offset_s * r.fs_hz)
        hs_idx = hs_idx[(hs_idx >= 0) & (hs_idx < self._seen)] if len(hs) else empty
        to_idx = to_idx[(to_idx >= 0) & (to_idx < self._seen)] if len(to) else empty
        return np.sort(hs_idx), np.sort(to_idx)

    def flush(self) -> tuple[np.ndarray, np.ndarray]:
        """Decide the events still pending at the end of a record."""
        return self.process(np.empty(0), final=True)


def match_events(
    detected_idx: np.ndarray, true_idx: np.ndarray, tolerance: int
) -> tuple[np.ndarray, np.ndarray]:
    """Signed errors (detected - true, samples) of each true event's nearest detection within
    ``tolerance``, and a boolean mask of the true events that have one."""
    det = np.sort(np.asarray(detected_idx, dtype=np.int64))
    tru = np.asarray(true_idx, dtype=np.int64)
    if len(det) == 0 or len(tru) == 0:
        return np.empty(0, dtype=np.int64), np.zeros(len(tru), dtype=bool)
    pos = np.searchsorted(det, tru)
    left = det[np.clip(pos - 1, 0, len(det) - 1)] - tru
    right = det[np.clip(pos, 0, len(det) - 1)] - tru
    best = np.where(np.abs(left) <= np.abs(right), left, right)
    ok = np.abs(best) <= tolerance
    return best[ok], ok
