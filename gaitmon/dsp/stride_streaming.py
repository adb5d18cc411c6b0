"""Stride measures a block at a time: of a long record (:func:`record_stride_measures`) and live
(:class:`StrideLengthTracker`).

Part of the stride-length method: the method is the module doc of
:mod:`gaitmon.dsp.stride_length` (its steps, which "module doc, step N" below refers to).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.dsp.stride_anchors import MAX_STRIDE_S, search_spans, stride_data_end
from gaitmon.dsp.stride_flags import StrideMeasures
from gaitmon.dsp.stride_zupt import _check, _filled_in, stride_measures

if TYPE_CHECKING:
    from gaitmon.dsp.lost_frames import Losses

# strides computed at a time over a long record (~37 minutes of walking; a few MB of samples)
STRIDES_PER_BLOCK = 2048


def record_stride_measures(
    read_foot: Callable[[int, int], tuple[np.ndarray, np.ndarray, np.ndarray]],
    n_rows: int, fs_hz: float, heel_strike_idx: np.ndarray,
    strides_per_block: int = STRIDES_PER_BLOCK, lost_before: np.ndarray | Losses | None = None,
) -> StrideMeasures:  # fmt: skip
    """:func:`stride_measures` of a record of ``n_rows`` samples read a block of strides at a
    time: ``read_foot(a, b)`` gives the foot board's acc x, acc z and gyro of rows [a, b). The
    same numbers as :func:`stride_measures` over the whole record (each stride sees the same
    samples: from the heel strike before its first, which sets that one's search span, to the
    end of the last foot-flat search), with memory bounded by the block instead of the record.
    ``lost_before`` ((n_rows,), or the rows with losses: :class:`~gaitmon.dsp.lost_frames.Losses`):
    as :func:`stride_measures`'s, the bridged losses filled in."""
    hs = np.asarray(heel_strike_idx, dtype=np.int64)
    if hs.ndim != 1 or np.any(np.diff(hs) <= 0):
        raise ValueError("heel strikes must be a 1-D increasing array of sample indices")
    if strides_per_block < 1:
        raise ValueError(f"strides_per_block must be >= 1, got {strides_per_block}")
    n_strides = max(len(hs) - 1, 0)
    if n_strides == 0:
        empty = np.empty(0)
        return stride_measures(empty, empty, empty, fs_hz, hs)
    from gaitmon.dsp.lost_frames import Losses, SamplePositions

    if lost_before is not None and not isinstance(lost_before, Losses):
        dense = np.asarray(lost_before, dtype=np.int64)
        if dense.shape != (n_rows,):
            raise ValueError(f"lost_before must have shape ({n_rows},), got {dense.shape}")
        lost_before = Losses.of(dense)
    losses = lost_before if lost_before is not None and len(lost_before.rows) else None
    # each row's place among the samples, the bridged losses filled in (without an array of
    # every row's: finishing a recording holds none, issue 26)
    rows = SamplePositions(losses or Losses(np.empty(0, np.int64), np.empty(0, np.int64)),
                           n_rows, fs_hz)  # fmt: skip
    hs_s = rows.samples_of(hs)
    spans = search_spans(hs_s)
    parts: list[StrideMeasures] = []
    for j0 in range(0, n_strides, strides_per_block):
        j1 = min(n_strides, j0 + strides_per_block)  # strides j0 .. j1 - 1: heel strikes j0 .. j1
        lo = max(j0 - 1, 0)  # the heel strike before sets j0's search span
        sub = hs[lo : j1 + 1]
        a = min(max(int(sub[0]), 0), n_rows)
        # the rows holding the samples before the searches' end (a frame filled in needs the
        # row after it)
        end_s = int(np.max(hs_s[j0 : j1 + 1] + spans[j0 : j1 + 1]))
        b = max(a, min(n_rows, rows.first_row_at(end_s - 1) + 1))
        lost = None if losses is None else _block(losses, a, b)
        m = stride_measures(*read_foot(a, b), fs_hz, sub - a, lost_before=lost)
        keep = slice(j0 - lo, None)
        ff = m.foot_flat_idx[keep]
        parts.append(StrideMeasures(
            heel_strike_idx=m.heel_strike_idx[keep] + a,
            stride_length_m=m.stride_length_m[keep],
            foot_clearance_m=m.foot_clearance_m[keep],
            stride_time_s=m.stride_time_s[keep],
            foot_flat_idx=np.where(ff >= 0, ff + a, -1),
            flag=m.flags[keep],
        ))  # fmt: skip
    return StrideMeasures(
        heel_strike_idx=hs[:n_strides],
        stride_length_m=np.concatenate([p.stride_length_m for p in parts]),
        foot_clearance_m=np.concatenate([p.foot_clearance_m for p in parts]),
        stride_time_s=np.concatenate([p.stride_time_s for p in parts]),
        foot_flat_idx=np.concatenate([p.foot_flat_idx for p in parts]),
        flag=np.concatenate([p.flags for p in parts]),
    )




def _block(losses: Losses, a: int, b: int) -> np.ndarray:
    """(b - a,) the frames lost before rows a:b."""
    out = np.zeros(b - a, dtype=np.int64)
    lo, hi = np.searchsorted(losses.rows, [a, b])
    out[losses.rows[lo:hi] - a] = losses.n_lost[lo:hi]
    return out


class StrideLengthTracker:
    """Strides as the samples come (the live Gait panel's gait speed).

    ``push`` takes the foot board's next rows, the frames lost before each (``lost_before``:
    the losses the pipeline bridges are filled in, as :func:`stride_measures` fills them) and
    the heel strikes known so far (absolute row indices; repeats are ignored), and returns the
    strides whose samples are all in (``stride_data_end``): the same numbers
    :func:`stride_measures` gives on the whole record, every index a row; ``finish`` gives the
    last ones at the record's end. It keeps only the samples from the oldest stride still to
    come.
    """

    def __init__(self, fs_hz: float) -> None:
        if not fs_hz > 0:
            raise ValueError(f"sampling rate must be > 0 Hz, got {fs_hz}")
        self.fs_hz = float(fs_hz)
        self.reset()

    def reset(self) -> None:
        self._buf = np.empty((0, 3))
        self._row = np.empty(0, dtype=np.int64)  # each kept sample's row (filled: the next row)
        self._buf_start = 0  # absolute sample index of the first kept sample
        self._n_seen = 0  # rows
        self._n_samples = 0  # samples: the rows and the frames filled in before them
        self._last: np.ndarray | None = None  # the last row, to fill from
        self._hs: list[int] = []  # sample indices
        self._next = 0  # index into _hs of the next stride to give

    @property
    def n_seen(self) -> int:
        """Rows pushed since the last reset (the next row's index)."""
        return self._n_seen

    def push(
        self, acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_y_rad_s: np.ndarray,
        heel_strike_idx: np.ndarray | list[int] | None = None,
        lost_before: np.ndarray | None = None,
    ) -> StrideMeasures:  # fmt: skip
        x = np.asarray(acc_x_ms2, dtype=np.float64)
        z = np.asarray(acc_z_ms2, dtype=np.float64)
        g = np.asarray(gyro_y_rad_s, dtype=np.float64)
        _check(x, z, g, self.fs_hz)
        block = np.stack([x, z, g], axis=1)
        rows = np.arange(self._n_seen, self._n_seen + len(x), dtype=np.int64)
        filled = None
        if lost_before is not None and len(x):
            filled = _filled_in(block, lost_before, self.fs_hz, self._last)
        if filled is not None:
            block, where = filled
            rows = self._n_seen + where.rows_of(np.arange(len(block)))
        if len(x):
            self._last = np.array([x[-1], z[-1], g[-1]])
        self._buf = np.concatenate([self._buf, block])
        self._row = np.concatenate([self._row, rows])
        self._n_seen += len(x)
        self._n_samples += len(block)
        new = np.empty(0) if heel_strike_idx is None else heel_strike_idx
        for h in self._samples_of(np.asarray(new, dtype=np.int64).ravel()):
            if not self._hs or h > self._hs[-1]:
                self._hs.append(int(h))
        return self._give(everything=False)

    def finish(self) -> StrideMeasures:
        """At the end of the record: the strides still open whose closing heel strike is known,
        from the samples there are (as :func:`stride_measures` does at a record's end)."""
        return self._give(everything=True)

    def _samples_of(self, rows: np.ndarray) -> np.ndarray:
        """Sample indices of absolute rows (a row before the kept ones, or not come yet: as
        far from the nearest kept row as it is in rows)."""
        out = np.empty(len(rows), dtype=np.int64)
        for k, r in enumerate(rows.tolist()):
            if len(self._row) and self._row[0] <= r <= self._row[-1]:
                out[k] = self._buf_start + int(np.searchsorted(self._row, r, side="right")) - 1
            elif r >= self._n_seen or not len(self._row):
                out[k] = r + (self._n_samples - self._n_seen)
            else:
                out[k] = r + (self._buf_start - int(self._row[0]))
        return out

    def _rows_of(self, samples: np.ndarray) -> np.ndarray:
        """Absolute rows of sample indices (-1 stays -1)."""
        x = np.asarray(samples, dtype=np.int64)
        out = x - (self._n_samples - self._n_seen)  # past the kept ones
        rel = x - self._buf_start
        inside = (rel >= 0) & (rel < len(self._row))
        out[inside] = self._row[rel[inside]]
        out[x < 0] = -1
        return out

    def _give(self, everything: bool) -> StrideMeasures:
        done = []
        hs = np.asarray(self._hs, dtype=np.int64)
        while self._next + 1 < len(hs) and (
            everything or stride_data_end(hs, self._next) <= self._n_samples
        ):
            done.append(self._next)
            self._next += 1
        out = self._measure(hs, done)
        self._trim(hs)
        return out

    def _measure(self, hs: np.ndarray, done: list[int]) -> StrideMeasures:
        if not done:
            empty = np.empty(0)
            return StrideMeasures(np.empty(0, np.int64), empty, empty, empty,
                                  np.empty((0, 2), np.int64))  # fmt: skip
        # The strides' heel strikes (and the one before the first, which sets its search span),
        # with the samples they need, relative to the buffer's start.
        lo = max(done[0] - 1, 0)
        sub = hs[lo : done[-1] + 2]
        # (the first heel strike's span, taken from the stride after it, ends before the next)
        end = min(int(np.max(sub + search_spans(sub))), self._n_samples)
        m = stride_measures(*self._padded(end), self.fs_hz, sub - self._buf_start)
        keep = slice(done[0] - lo, None)
        ff = m.foot_flat_idx[keep]
        return StrideMeasures(
            heel_strike_idx=self._rows_of(m.heel_strike_idx[keep] + self._buf_start),
            stride_length_m=m.stride_length_m[keep],
            foot_clearance_m=m.foot_clearance_m[keep],
            stride_time_s=m.stride_time_s[keep],
            foot_flat_idx=np.where(ff >= 0, self._rows_of(ff + self._buf_start), -1),
            flag=m.flags[keep],
        )

    def _padded(self, end_abs: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The kept samples up to ``end_abs`` (a heel strike before them finds no foot-flat)."""
        buf = self._buf[: end_abs - self._buf_start]
        return buf[:, 0], buf[:, 1], buf[:, 2]

    def _trim(self, hs: np.ndarray) -> None:
        """Drop samples no stride still to come needs: before the heel strike of the next
        stride (and the one before it, for its search span: only its index is needed)."""
        if self._next < len(hs):
            keep_from = min(int(hs[self._next]), self._n_samples)
        else:  # no stride open: keep enough for a heel strike that is reported late
            keep_from = self._n_samples - int(MAX_STRIDE_S * self.fs_hz)
        if keep_from > self._buf_start:
            self._buf = self._buf[keep_from - self._buf_start :]
            self._row = self._row[keep_from - self._buf_start :]
            self._buf_start = keep_from
