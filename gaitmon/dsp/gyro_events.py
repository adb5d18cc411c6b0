"""Heel strike and toe off from the foot gyro, to cross-check (or stand in for) the force sensors.

The foot's sagittal rate (rad/s, + = toe up, gaitmon.dsp.channels) has one large positive peak per
stride in mid-swing, while the foot swings forward and dorsiflexes. Around it:

* toe off: the foot plantarflexes hard as it leaves the ground, the deepest minimum in the
  ``search_s`` before the mid-swing peak;
* heel strike: the foot rotates down onto the ground (plantarflexion after contact), the first
  deep minimum in the ``search_s`` after the peak.

Rule (offline, :func:`gyro_gait_events`): the rate is low-passed (4th-order 10 Hz Butterworth,
zero phase), mid-swing peaks are the maxima above ``peak_min_rad_s`` at least ``min_stride_s``
apart, and the minima are taken in the windows around each. Each event is then moved by a fixed
``*_offset_s`` (the lag between the gyro minimum and the contact change measured on the
simulator's truth, docs/filters.md); 0 leaves the raw minima.
"""

from __future__ import annotations

import numpy as np

HS_OFFSET_S = -0.04
TO_OFFSET_S = 0.05


def gyro_gait_events(
    foot_gyro_y_rad_s: np.ndarray, fs_hz: float, *, peak_min_rad_s: float = 1.5,
    min_stride_s: float = 0.6, search_s: float = 0.4,
    hs_offset_s: float = HS_OFFSET_S, to_offset_s: float = TO_OFFSET_S,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(heel_strike_idx, toe_off_idx), int64 sample indices, from one foot's gyro (see module)."""
    from scipy import signal  # lazy: scipy only where a filter is run

    g = np.asarray(foot_gyro_y_rad_s, dtype=np.float64)
    if g.ndim != 1:
        raise ValueError(f"expected a 1-D foot gyro array, got shape {g.shape}")
    if not (np.isfinite(fs_hz) and fs_hz > 0):
        raise ValueError(f"fs_hz must be a positive number, got {fs_hz}")
    empty = np.empty(0, dtype=np.int64)
    n = len(g)
    if n < int(fs_hz):
        return empty, empty
    sos = signal.butter(4, min(10.0, 0.4 * fs_hz), fs=fs_hz, output="sos")
    gf = signal.sosfiltfilt(sos, np.nan_to_num(g))
    peaks, _ = signal.find_peaks(
        gf, height=peak_min_rad_s, distance=max(1, int(min_stride_s * fs_hz))
    )
    w = max(1, round(search_s * fs_hz))
    hs: list[int] = []
    to: list[int] = []
    for i, p in enumerate(peaks):
        lo = max(0, p - w, peaks[i - 1] + 1 if i > 0 else 0)
        hi = min(n, p + w + 1, peaks[i + 1] if i + 1 < len(peaks) else n)
        if p - lo >= 2:
            to.append(lo + int(np.argmin(gf[lo:p])))
        after = gf[p + 1 : hi]
        if len(after) >= 2:
            # the first local minimum below zero after the peak, else the window's minimum
            mins = signal.argrelmin(after)[0]
            mins = mins[after[mins] < 0]
            hs.append(p + 1 + int(mins[0] if len(mins) else np.argmin(after)))
    hs_idx = np.asarray(hs, dtype=np.int64) + round(hs_offset_s * fs_hz)
    to_idx = np.asarray(to, dtype=np.int64) + round(to_offset_s * fs_hz)
    return hs_idx[(hs_idx >= 0) & (hs_idx < n)], to_idx[(to_idx >= 0) & (to_idx < n)]


def match_events(
    detected_idx: np.ndarray, true_idx: np.ndarray, tolerance: int
) -> tuple[np.ndarray, np.ndarray]:
    """Signed errors (detected - true, samples) of each true event's nearest detection within
    ``tolerance``, and a boolean mask of the true events that have one."""
    det = np.sort(np.asarray(detected_idx, dtype=np.int64))
    tru = np.asarray(true_idx, dtype=np.int64)
    if len(det) == 0:
        return np.empty(0, dtype=np.int64), np.zeros(len(tru), dtype=bool)
    pos = np.clip(np.searchsorted(det, tru), 1, len(det) - 1) if len(det) > 1 else np.zeros(
        len(tru), dtype=np.int64
    )
    cand = np.stack([det[np.maximum(pos - 1, 0)], det[pos]], axis=1)
    err = cand - tru[:, None]
    best = err[np.arange(len(tru)), np.argmin(np.abs(err), axis=1)]
    ok = np.abs(best) <= tolerance
    return best[ok], ok
