"""The foot-flat (anchor) search after each heel strike (module doc, step 1).

Part of the stride-length method: the method is the module doc of
:mod:`gaitmon.dsp.stride_length` (its steps, which "module doc, step N" below refers to).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitmon.dsp.channels import STANDARD_GRAVITY_MS2
from gaitmon.dsp.stride_method import MAX_STRIDE_S as MAX_STRIDE_S
from gaitmon.dsp.stride_method import MIN_STILL_SAMPLES as MIN_STILL_SAMPLES
from gaitmon.dsp.stride_method import NEAR_STILL as NEAR_STILL
from gaitmon.dsp.stride_method import SEARCH_FRACTION as SEARCH_FRACTION
from gaitmon.dsp.stride_method import STILL_ACC_MS2 as STILL_ACC_MS2
from gaitmon.dsp.stride_method import STILL_GYRO_RAD_S as STILL_GYRO_RAD_S
from gaitmon.dsp.stride_method import STILL_HALF_WIDTH as STILL_HALF_WIDTH


def search_spans(heel_strike_idx: np.ndarray) -> np.ndarray:
    """(J,) samples after each heel strike searched for its foot-flat: SEARCH_FRACTION of the
    stride before it (of the stride after it for the first)."""
    hs = np.asarray(heel_strike_idx, dtype=np.int64)
    if len(hs) < 2:
        return np.zeros(len(hs), dtype=np.int64)
    d = np.diff(hs)
    before = np.concatenate([[d[0]], d])
    return np.maximum(np.round(SEARCH_FRACTION * before).astype(np.int64), 1)


def stride_data_end(heel_strike_idx: np.ndarray, j: int) -> int:
    """Exclusive end of the samples stride j (heel strike j to j + 1) needs: the end of both
    its foot-flat searches (after a long stride, heel strike j's reaches past j + 1's)."""
    hs = np.asarray(heel_strike_idx, dtype=np.int64)
    spans = search_spans(hs)
    return int(max(hs[j] + spans[j], hs[j + 1] + spans[j + 1]))


def _moving_max(x: np.ndarray, half: int) -> np.ndarray:
    n = len(x)
    out = x.copy()
    for s in range(1, half + 1):
        out[s:] = np.maximum(out[s:], x[: n - s])
        out[: n - s] = np.maximum(out[: n - s], x[s:])
    return out


@dataclass(frozen=True)
class _FootFlat:
    anchor: int  # absolute sample index
    acc_x_ms2: float  # the accelerometer's mean there (gravity alone)
    acc_z_ms2: float
    gyro_bias_rad_s: float
    roll_rad_s: float  # the gyro around the anchor (within the search: block-invariant)
    near_still: bool = False

    def pitch_rad(self, mount_cos: float = 1.0) -> float:
        """The board's pitch from vertical, its a_z read as mount_cos of the foot's (step 5)."""
        return float(np.arctan2(self.acc_z_ms2 / mount_cos, self.acc_x_ms2))

    def g_ms2(self, mount_cos: float = 1.0) -> float:
        return float(np.hypot(self.acc_x_ms2, self.acc_z_ms2 / mount_cos))


def _foot_flat(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, start: int, stop: int
) -> _FootFlat | None:
    """The foot-flat (module doc, step 1) in samples [start, stop) of the arrays given."""
    stop = min(stop, len(gy))
    if stop - start < MIN_STILL_SAMPLES:
        return None
    x, z, w = ax[start:stop], az[start:stop], gy[start:stop]
    dev = np.maximum(np.abs(w) / STILL_GYRO_RAD_S,
                     np.abs(np.hypot(x, z) - STANDARD_GRAVITY_MS2) / STILL_ACC_MS2)  # fmt: skip
    mdev = _moving_max(dev, STILL_HALF_WIDTH)
    still = mdev < 1.0
    if still.any():
        edges = np.diff(np.concatenate([[0], still.astype(np.int8), [0]]))
        runs_a, runs_b = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        k = int(np.argmax(runs_b - runs_a))
        a, b = int(runs_a[k]), int(runs_b[k])
    else:
        a = b = 0
    if b - a < MIN_STILL_SAMPLES:
        # no still run (fast walking: a short stance in which the foot keeps rolling): the
        # stillest sample of the span's first half (the stance, not a slow moment of swing),
        # if it is nearly still
        k = int(np.argmin(mdev[: max(len(mdev) // 2, 1)]))
        if mdev[k] >= NEAR_STILL:
            return None
        a, b = max(k - STILL_HALF_WIDTH, 0), min(k + STILL_HALF_WIDTH + 1, len(w))
        return _FootFlat(
            anchor=start + k,
            acc_x_ms2=float(np.mean(x[a:b])),
            acc_z_ms2=float(np.mean(z[a:b])),
            gyro_bias_rad_s=0.0,
            roll_rad_s=_rate_at(w, k),
            near_still=True,
        )
    mx, mz = float(np.mean(x[a:b])), float(np.mean(z[a:b]))
    return _FootFlat(
        anchor=start + (a + b - 1) // 2,
        acc_x_ms2=mx,
        acc_z_ms2=mz,
        gyro_bias_rad_s=float(np.mean(w[a:b])),
        roll_rad_s=_rate_at(w, (a + b - 1) // 2),
    )



def _rate_at(w: np.ndarray, i: int) -> float:
    """The mean of w over +-STILL_HALF_WIDTH samples around w[i] (those inside w)."""
    return float(np.mean(w[max(i - STILL_HALF_WIDTH, 0) : i + STILL_HALF_WIDTH + 1]))
