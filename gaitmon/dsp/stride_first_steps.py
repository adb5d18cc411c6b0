"""The first step from standing before a heel strike that opens a walk (module doc, step 7).

Part of the stride-length method: the method is the module doc of
:mod:`gaitmon.dsp.stride_length` (its steps, which "module doc, step N" below refers to).
"""

from __future__ import annotations

import numpy as np

from gaitmon.dsp.channels import STANDARD_GRAVITY_MS2
from gaitmon.dsp.stride_anchors import (
    MAX_STRIDE_S,
    MIN_STILL_SAMPLES,
    STILL_ACC_MS2,
    STILL_GYRO_RAD_S,
    STILL_HALF_WIDTH,
    _FootFlats,
    _moving_max,
    _rate_at,
)
from gaitmon.dsp.stride_flags import (
    FLAG_FIRST_STEP,
    FLAG_NEAR_STILL,
    FLAG_OUT_OF_PLANE,
    StrideMeasures,
)
from gaitmon.dsp.stride_integrate import _strides

STANDING_S = 0.3  # a first step's standing: still at least this long
STANDING_SEARCH_S = 1.5  # ... and ending within this before the step's heel strike


def _standing(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, start: int, stop: int, fs_hz: float
) -> tuple[int, float, float, float, float] | None:
    """The end of the last standing (still for STANDING_S) in samples [start, stop): the anchor
    of a first step (module doc, step 7), as (anchor, acc x, acc z, gyro bias, roll) of its
    foot-flat."""
    start, stop = max(start, 0), min(stop, len(gy))
    if stop - start < MIN_STILL_SAMPLES:
        return None
    x, z, w = ax[start:stop], az[start:stop], gy[start:stop]
    dev = np.maximum(np.abs(w) / STILL_GYRO_RAD_S,
                     np.abs(np.hypot(x, z) - STANDARD_GRAVITY_MS2) / STILL_ACC_MS2)  # fmt: skip
    still = _moving_max(dev, STILL_HALF_WIDTH) < 1.0
    edges = np.diff(np.concatenate([[0], still.astype(np.int8), [0]]))
    runs_a, runs_b = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    n_min = max(MIN_STILL_SAMPLES, round(STANDING_S * fs_hz))
    long_runs = np.flatnonzero(runs_b - runs_a >= n_min)
    if len(long_runs) == 0:
        return None
    b = int(runs_b[long_runs[-1]])
    a = b - n_min
    return (start + b - 1, float(np.mean(x[a:b])), float(np.mean(z[a:b])),
            float(np.mean(w[a:b])), _rate_at(w, b - 1))



def _with_first_steps(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, fs_hz: float, hs: np.ndarray,
    spans: np.ndarray, flats: _FootFlats, m: StrideMeasures,
) -> StrideMeasures:  # fmt: skip
    """``m`` with the first step from standing before each heel strike opening a walk."""
    gap = MAX_STRIDE_S * fs_hz
    opens = [j for j in range(len(hs))
             if (j == 0 or hs[j] - hs[j - 1] > gap) and flats.found[j]]  # fmt: skip
    at, standing = [], []
    for j in opens:
        lo = int(hs[j] - STANDING_SEARCH_S * fs_hz)
        if j > 0:
            lo = max(lo, int(hs[j - 1] + spans[j - 1]))
        f0 = _standing(ax, az, gy, lo, int(hs[j]), fs_hz)
        if f0 is None or not 0 < flats.anchor[j] - f0[0] <= MAX_STRIDE_S * fs_hz:
            continue
        at.append(j)
        standing.append(f0)
    if not at:
        return m
    pos = np.asarray(at, dtype=np.int64)
    s = list(zip(*standing, strict=True))
    n = len(pos)
    f0s = _FootFlats(np.ones(n, bool), np.asarray(s[0], dtype=np.int64), np.asarray(s[1]),
                     np.asarray(s[2]), np.asarray(s[3]), np.asarray(s[4]),
                     np.zeros(n, bool))  # fmt: skip
    f1s = flats.take(pos)
    length, clearance, out_of_plane = _strides(ax, az, gy, fs_hz, f0s, f1s)
    fl = FLAG_FIRST_STEP | np.where(out_of_plane, FLAG_OUT_OF_PLANE, 0) | np.where(
        f1s.near_still, FLAG_NEAR_STILL, 0)  # fmt: skip

    def ins(old: np.ndarray, new: np.ndarray) -> np.ndarray:
        return np.insert(old, pos, new, axis=0)

    return StrideMeasures(
        heel_strike_idx=ins(m.heel_strike_idx, f0s.anchor),
        stride_length_m=ins(m.stride_length_m, length),
        foot_clearance_m=ins(m.foot_clearance_m, clearance),
        stride_time_s=ins(m.stride_time_s, (hs[pos] - f0s.anchor).astype(np.float64) / fs_hz),
        foot_flat_idx=ins(m.foot_flat_idx, np.stack([f0s.anchor, f1s.anchor], axis=1)),
        flag=ins(m.flags, fl.astype(np.int64)),
    )
