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

# samples in one padded 2-D array of a batch of spans or strides (0.5 MB of float64): the
# per-stride work runs on whole batches, with memory bounded on any record
BATCH_CELLS = 1 << 16


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


def _batches(widths: np.ndarray) -> list[np.ndarray]:
    """Indices into ``widths`` in groups of about equal widths (sorted), each group's count
    times its largest width at most BATCH_CELLS (a group of one where a single width is more):
    the rows of one padded 2-D array, so that memory stays bounded on any record."""
    cells = BATCH_CELLS
    order = np.argsort(widths, kind="stable")
    w = np.asarray(widths, dtype=np.int64)[order]
    out = []
    i = 0
    while i < len(order):
        # (the count times the width of the group's last, widest row grows with the count)
        fits = np.arange(1, len(order) - i + 1) * w[i:]
        k = max(int(np.searchsorted(fits, cells, side="right")), 1)
        out.append(order[i : i + k])
        i += k
    return out


def _window_means(
    arrays: tuple[np.ndarray, ...], first: np.ndarray, count: np.ndarray
) -> list[np.ndarray]:  # fmt: skip
    """The mean of each array over samples ``first`` .. ``first + count`` (count >= 1), each
    window's mean that of its own 1-D slice to the bit: windows of one length are stacked and
    averaged along their rows (numpy sums each row as it sums the slice)."""
    out = [np.empty(len(first)) for _ in arrays]
    order = np.argsort(count, kind="stable")
    groups = np.split(order, np.flatnonzero(np.diff(count[order])) + 1) if len(order) else []
    for g in groups:
        n = int(count[g[0]])
        idx = first[g, None] + np.arange(n)
        for o, arr in zip(out, arrays, strict=True):
            # np.mean's own sum and division (np.take: arr[idx], in less time)
            o[g] = np.add.reduce(np.take(arr, idx), axis=1) / n
    return out


@dataclass(frozen=True)
class _FootFlats:
    """One foot-flat per heel strike (module doc, step 1), or none (``found`` False: anchor -1,
    the rest NaN)."""

    found: np.ndarray  # (J,) bool
    anchor: np.ndarray  # (J,) absolute sample index
    acc_x_ms2: np.ndarray  # (J,) the accelerometer's mean there (gravity alone)
    acc_z_ms2: np.ndarray
    gyro_bias_rad_s: np.ndarray
    roll_rad_s: np.ndarray  # the gyro around the anchor (within the search: block-invariant)
    near_still: np.ndarray  # (J,) bool

    @classmethod
    def none(cls, n: int) -> _FootFlats:
        def nan() -> np.ndarray:
            return np.full(n, np.nan)

        return cls(np.zeros(n, bool), np.full(n, -1, np.int64), nan(), nan(), nan(), nan(),
                   np.zeros(n, bool))  # fmt: skip

    def take(self, i: np.ndarray) -> _FootFlats:
        return _FootFlats(self.found[i], self.anchor[i], self.acc_x_ms2[i], self.acc_z_ms2[i],
                          self.gyro_bias_rad_s[i], self.roll_rad_s[i],
                          self.near_still[i])  # fmt: skip

    def pitch_rad(self, mount_cos: np.ndarray) -> np.ndarray:
        """The board's pitch from vertical, its a_z read as mount_cos of the foot's (step 5)."""
        return np.arctan2(self.acc_z_ms2 / mount_cos, self.acc_x_ms2)

    def g_ms2(self, mount_cos: np.ndarray) -> np.ndarray:
        return np.hypot(self.acc_x_ms2, self.acc_z_ms2 / mount_cos)


def _foot_flats(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, heel_strike_idx: np.ndarray,
    spans: np.ndarray,
) -> _FootFlats:  # fmt: skip
    """The foot-flat (module doc, step 1) after each heel strike h, in samples [h, h + span)
    of the arrays given (none for a heel strike outside them), all heel strikes at once: the
    search spans padded into 2-D arrays a batch at a time (``_batches``)."""
    hs = np.asarray(heel_strike_idx, dtype=np.int64)
    n_hs, n = len(hs), len(gy)
    out = _FootFlats.none(n_hs)
    size = np.minimum(hs + spans, n) - hs
    cand = np.flatnonzero((hs >= 0) & (hs < n) & (size >= MIN_STILL_SAMPLES))
    if len(cand) == 0:
        return out
    # each sample's deviation from rest (elementwise: the same numbers on the whole array as on
    # a span's slice)
    # maximum(|gy| / STILL_GYRO_RAD_S, ||a| - g| / STILL_ACC_MS2), each step in place
    dev = np.hypot(ax, az)
    dev -= STANDARD_GRAVITY_MS2
    np.abs(dev, out=dev)
    dev /= STILL_ACC_MS2
    rate = np.abs(gy)
    rate /= STILL_GYRO_RAD_S
    np.maximum(rate, dev, out=dev)
    del rate
    h = STILL_HALF_WIDTH
    for rows in _batches(size[cand] + 2 * h):
        j = cand[rows]
        start, size_j = hs[j], size[j]
        n_rows, width = len(j), int(size_j.max())
        col = np.arange(width)
        inside = col < size_j[:, None]
        # the max over +-h samples within the span: its end samples repeated past its ends
        pad = np.take(dev, start[:, None] + np.clip(np.arange(-h, width + h), 0,
                                                    size_j[:, None] - 1))  # fmt: skip
        mdev = pad[:, :width]
        for s in range(1, 2 * h + 1):
            mdev = np.maximum(mdev, pad[:, s : s + width])
        # the longest still run of each span (the first of the longest)
        edges = np.diff((mdev < 1.0) & inside, axis=1, prepend=False, append=False)
        e_row, e_col = np.nonzero(edges)  # a run's start, then its end, row by row
        r_row, r_a, r_b = e_row[0::2], e_col[0::2], e_col[1::2]
        a, b = np.zeros(n_rows, np.int64), np.zeros(n_rows, np.int64)
        if len(r_row):
            longest = np.zeros(n_rows, np.int64)
            np.maximum.at(longest, r_row, r_b - r_a)
            top = np.flatnonzero(r_b - r_a == longest[r_row])
            top = top[np.concatenate([[True], r_row[top][1:] != r_row[top][:-1]])]
            a[r_row[top]], b[r_row[top]] = r_a[top], r_b[top]
        flat = b - a >= MIN_STILL_SAMPLES
        # no still run (fast walking: a short stance in which the foot keeps rolling): the
        # stillest sample of the span's first half (the stance, not a slow moment of swing),
        # if it is nearly still
        first_half = col < np.maximum(size_j // 2, 1)[:, None]
        k = np.argmin(np.where(first_half, mdev, np.inf), axis=1)
        near = ~flat & ~(mdev[np.arange(n_rows), k] >= NEAR_STILL)
        centre = np.where(flat, (a + b - 1) // 2, k)
        # the gyro around the anchor: +-h samples (those in the span); a near-still anchor's
        # accelerometer too
        w_a, w_b = np.maximum(centre - h, 0), np.minimum(centre + h + 1, size_j)
        a, b = np.where(flat, a, w_a), np.where(flat, b, w_b)
        ok = flat | near
        mx, mz, mw = _window_means((ax, az, gy), (start + a)[ok], (b - a)[ok])
        (roll,) = _window_means((gy,), (start + w_a)[ok], (w_b - w_a)[ok])
        jo = j[ok]
        out.found[jo] = True
        out.anchor[jo] = (start + centre)[ok]
        out.acc_x_ms2[jo], out.acc_z_ms2[jo] = mx, mz
        out.gyro_bias_rad_s[jo] = np.where(near[ok], 0.0, mw)
        out.roll_rad_s[jo] = roll
        out.near_still[jo] = near[ok]
    return out


def _rate_at(w: np.ndarray, i: int) -> float:
    """The mean of w over +-STILL_HALF_WIDTH samples around w[i] (those inside w)."""
    return float(np.mean(w[max(i - STILL_HALF_WIDTH, 0) : i + STILL_HALF_WIDTH + 1]))
