"""Stride length, clearance and speed of a whole record: :func:`stride_measures` (module doc).

Part of the stride-length method: the method is the module doc of
:mod:`gaitmon.dsp.stride_length` (its steps, which "module doc, step N" below refers to).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gaitmon.dsp.stride_anchors import MAX_STRIDE_S, _foot_flats, search_spans
from gaitmon.dsp.stride_first_steps import _with_first_steps
from gaitmon.dsp.stride_flags import (
    FLAG_NEAR_STILL,
    FLAG_NO_FOOT_FLAT,
    FLAG_OUT_OF_PLANE,
    FLAG_PAUSE,
    StrideMeasures,
)
from gaitmon.dsp.stride_integrate import _strides


def _check(acc_x: np.ndarray, acc_z: np.ndarray, gyro: np.ndarray, fs_hz: float) -> None:
    if not (acc_x.ndim == acc_z.ndim == gyro.ndim == 1):
        raise ValueError("stride lengths need 1-D foot acc x, acc z and gyro arrays")
    if not (len(acc_x) == len(acc_z) == len(gyro)):
        raise ValueError(
            f"foot acc x, acc z and gyro differ in length ({len(acc_x)}, {len(acc_z)}, "
            f"{len(gyro)}): pass the same samples of each"
        )
    if not fs_hz > 0:
        raise ValueError(f"sampling rate must be > 0 Hz, got {fs_hz}")


class _RowSamples:
    """Where each row is among the samples once the bridged losses are filled in (``pos``,
    increasing), and back: a filled-in frame maps to the row after it (as the pipeline maps
    its indices). Rows past the end lie as far past the last sample; negative ones stay."""

    def __init__(self, pos: np.ndarray) -> None:
        self.pos = np.asarray(pos, dtype=np.int64)
        self.extra = int(self.pos[-1]) - (len(self.pos) - 1) if len(self.pos) else 0

    def samples_of(self, rows: np.ndarray | Sequence[int]) -> np.ndarray:
        r = np.asarray(rows, dtype=np.int64)
        out = r.copy()
        inside = (r >= 0) & (r < len(self.pos))
        out[inside] = self.pos[r[inside]]
        out[r >= len(self.pos)] += self.extra
        return out

    def rows_of(self, samples: np.ndarray) -> np.ndarray:
        x = np.asarray(samples, dtype=np.int64)
        out = np.searchsorted(self.pos, x, side="left").astype(np.int64)
        past = x > (self.pos[-1] if len(self.pos) else -1)
        out[past] = x[past] - self.extra
        neg = x < 0
        out[neg] = x[neg]
        return out.reshape(x.shape)

    def measures_in_rows(self, m: StrideMeasures) -> StrideMeasures:
        """``m`` (sample indices) with its indices in rows; its times stay the samples'."""
        ff = m.foot_flat_idx
        return StrideMeasures(
            heel_strike_idx=self.rows_of(m.heel_strike_idx),
            stride_length_m=m.stride_length_m,
            foot_clearance_m=m.foot_clearance_m,
            stride_time_s=m.stride_time_s,
            foot_flat_idx=np.where(ff >= 0, self.rows_of(ff), -1),
            flag=m.flags,
        )


def _filled_in(
    rows: np.ndarray, lost_before: np.ndarray, fs_hz: float, prev: np.ndarray | None
) -> tuple[np.ndarray, _RowSamples] | None:
    """The rows (N, C) with the losses the pipeline bridges filled in as it fills them
    (``prev``: the row before the first, None: row 0 of a record, nothing filled before it),
    and the row <-> sample map; None when nothing is filled in."""
    from gaitmon.dsp.lost_frames import bridged_fill, fill_lost

    lost = np.asarray(lost_before, dtype=np.int64)
    if lost.shape != (len(rows),):
        raise ValueError(f"lost_before must have shape ({len(rows)},), got {lost.shape}")
    # a later block of a stream (``prev``): its first row is bridged from the block before
    fill = bridged_fill(lost, fs_hz) if prev is None else bridged_fill(np.r_[0, lost], fs_hz)[1:]
    ext, pos = fill_lost(rows, fill, prev)
    if pos is None:
        return None
    return ext, _RowSamples(pos)



def stride_measures(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_y_rad_s: np.ndarray, fs_hz: float,
    heel_strike_idx: np.ndarray, *, first_steps: bool = False,
    lost_before: np.ndarray | None = None,
) -> StrideMeasures:  # fmt: skip
    """Stride length, foot clearance, stride time and speed of every stride between consecutive
    heel strikes, from the foot board's samples (module doc: method and assumptions), with a
    quality flag each (``StrideMeasures.flag``).

    ``first_steps``: also the step from standing to each heel strike that opens a walk (the
    first, or one more than MAX_STRIDE_S after the one before), placed before the strides from
    that heel strike and flagged FLAG_FIRST_STEP (module doc, step 7). Its ``heel_strike_idx``
    is the last standing sample and its stride time runs from there to the heel strike.

    ``lost_before`` ((N,) frames lost just before each row; None: the rows are consecutive
    frames): the losses the pipeline bridges are filled in as it fills them
    (gaitmon.dsp.lost_frames.bridged_fill / fill_lost) before the integration, so that lost
    frames count as time; every index given and returned is a row (a filled-in frame maps to
    the row after it) and the stride times are on the true timeline."""
    ax = np.asarray(acc_x_ms2, dtype=np.float64)
    az = np.asarray(acc_z_ms2, dtype=np.float64)
    gy = np.asarray(gyro_y_rad_s, dtype=np.float64)
    _check(ax, az, gy, fs_hz)
    if lost_before is not None:
        filled = _filled_in(np.stack([ax, az, gy], axis=1), lost_before, fs_hz, None)
        if filled is not None:
            ext, rows = filled
            hs_s = rows.samples_of(heel_strike_idx)
            m = stride_measures(ext[:, 0], ext[:, 1], ext[:, 2], fs_hz, hs_s,
                                first_steps=first_steps)  # fmt: skip
            return rows.measures_in_rows(m)
    hs = np.asarray(heel_strike_idx, dtype=np.int64)
    if hs.ndim != 1 or np.any(np.diff(hs) <= 0):
        raise ValueError("heel strikes must be a 1-D increasing array of sample indices")
    n_strides = max(len(hs) - 1, 0)
    spans = search_spans(hs)
    # every heel strike's foot-flat, then every stride between two of them, a batch at a time
    flats = _foot_flats(ax, az, gy, hs, spans)
    f0, f1 = flats.take(np.arange(n_strides)), flats.take(np.arange(1, n_strides + 1))
    anchors = np.stack([f0.anchor, f1.anchor], axis=1).reshape(n_strides, 2)
    found = f0.found & f1.found
    # (the same foot-flat for both heel strikes: no stride between them)
    gap = f1.anchor - f0.anchor
    pause = found & ~((gap > 0) & (gap <= MAX_STRIDE_S * fs_hz))
    ok = np.flatnonzero(found & ~pause)
    length = np.full(n_strides, np.nan)
    clearance = np.full(n_strides, np.nan)
    flag = np.where(found, np.where(pause, FLAG_PAUSE, 0), FLAG_NO_FOOT_FLAT).astype(np.int64)
    length[ok], clearance[ok], out_of_plane = _strides(ax, az, gy, fs_hz, f0.take(ok),
                                                       f1.take(ok))  # fmt: skip
    flag[ok] = np.where(out_of_plane, FLAG_OUT_OF_PLANE, 0) | np.where(
        f0.near_still[ok] | f1.near_still[ok], FLAG_NEAR_STILL, 0)  # fmt: skip
    m = StrideMeasures(
        heel_strike_idx=hs[:n_strides],
        stride_length_m=length,
        foot_clearance_m=clearance,
        stride_time_s=np.diff(hs).astype(np.float64) / fs_hz,
        foot_flat_idx=anchors,
        flag=flag,
    )
    return _with_first_steps(ax, az, gy, fs_hz, hs, spans, flats, m) if first_steps else m
