"""Lost frames, by the unit's sequence counter (docs/gaps-and-time.md).

A row carries ``lost_before``: the frames lost just before it. Short losses are bridged: the
stateful stages see the lost frames filled in, linear between the rows around them, so that
time stays the unit's (``fill_lost``); longer ones restart the filters (``restart_rows``). The
pipeline (gaitmon.dsp.pipeline), the smoother's first pass (gaitmon.dsp.smoother), the
smoother itself (gaitmon.finish.smoothed) and the stride lengths (gaitmon.dsp.stride_length)
decide and fill alike, from here.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

# Losses up to this long are bridged (a frame or two on a noisy link); longer ones restart the
# filters. The same limit decides which gaps a stride may cross (gaitmon.analysis).
BRIDGE_MAX_S = 0.05

# After a restart the gait-aware filter's angle converges with its exact start-up gain: measured
# on the simulator, the joint-angle error after a 3 s outage is at its walking level after 3 s
# (benchmarks/gap_settling.py, docs/gaps-and-time.md).
SETTLE_S = 3.0


def settling_ranges(
    restarts: Sequence[int] | np.ndarray, fs_hz: float, n_rows: int | None = None
) -> list[tuple[int, int]]:
    """[start, stop) rows during which the filters settle after each restart row (row 0, the
    start, included when given). Overlapping ranges are merged."""
    k = round(SETTLE_S * fs_hz)
    out: list[tuple[int, int]] = []
    for r in sorted(int(x) for x in restarts):
        b = r + k if n_rows is None else min(r + k, n_rows)
        if out and r <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((r, b))
    return out


def bridge_max_samples(fs_hz: float) -> int:
    """The longest loss (in frames) the pipeline bridges without restarting."""
    return round(BRIDGE_MAX_S * fs_hz)


class Losses(NamedTuple):
    """The frames lost before a record's rows, sparse: ``rows`` (sorted, distinct) and the
    frames lost just before each (``n_lost``); every other row lost none. What the restarts
    and the bridged losses are decided from without a value per row (which grows with the
    record's length: finishing a recording holds none, issue 26)."""

    rows: np.ndarray
    n_lost: np.ndarray

    @classmethod
    def of(cls, lost_before: np.ndarray) -> Losses:
        """The losses of a per-row ``lost_before``."""
        lost = np.asarray(lost_before, dtype=np.int64)
        rows = np.flatnonzero(lost).astype(np.int64)
        return cls(rows, lost[rows])


def restart_rows(lost_before: np.ndarray | Losses, fs_hz: float) -> np.ndarray:
    """Rows where the pipeline restarts: the first row after a loss longer than the bridge
    (``lost_before``: per row, or :class:`Losses`)."""
    rows, lost = lost_before if isinstance(lost_before, Losses) else Losses.of(lost_before)
    return rows[lost > bridge_max_samples(fs_hz)].astype(np.int64)


def bridged_fill(lost_before: np.ndarray, fs_hz: float) -> np.ndarray:
    """(N,) int64: the frames filled in just before each row of a record processed from row 0:
    every loss the pipeline bridges (none before row 0, nothing to fill from), 0 elsewhere (no
    loss, or one so long the filters restart after it)."""
    lost = np.asarray(lost_before, dtype=np.int64)
    fill = np.zeros(len(lost), dtype=np.int64)
    rows, k = bridged_rows(Losses.of(lost), fs_hz)
    fill[rows] = k
    return fill


def bridged_losses(lost_before: np.ndarray | Losses, fs_hz: float) -> dict[int, int]:
    """{row: frames filled in just before it} of a record processed from row 0
    (:func:`bridged_fill`, its non-zero rows; ``lost_before``: per row, or :class:`Losses`)."""
    losses = lost_before if isinstance(lost_before, Losses) else Losses.of(lost_before)
    rows, k = bridged_rows(losses, fs_hz)
    return {int(r): int(n) for r, n in zip(rows, k, strict=True)}


def bridged_rows(losses: Losses, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(rows, frames filled in before each) of the losses the pipeline bridges."""
    rows, lost = losses
    keep = (lost > 0) & (lost <= bridge_max_samples(fs_hz)) & (rows > 0)
    return rows[keep], lost[keep]


def fill_lost(
    phys: np.ndarray, fill: np.ndarray, prev: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Rows (N, C) with ``fill[i]`` lost frames filled in before row ``i``, linear between
    the row before (``prev`` for row 0) and row ``i`` at the lost frames' times; and where
    the rows are among the samples (None, and ``phys`` itself, when nothing is filled in).
    The pipeline, the smoother's first pass (gaitmon.dsp.smoother) and the smoother itself
    (gaitmon.finish.smoothed) fill alike."""
    if not len(phys) or not fill.any():
        return phys, None
    pos = np.arange(len(phys)) + np.cumsum(fill)  # each row's place among the samples
    ext = np.empty((len(phys) + int(fill.sum()), phys.shape[1]))
    ext[pos] = phys
    for i in np.flatnonzero(fill):
        k = int(fill[i])
        before = phys[i - 1] if i else prev
        if before is None:
            raise ValueError("lost frames before the first row: nothing to fill them from")
        w = (np.arange(1, k + 1, dtype=np.float64) / (k + 1))[:, None]
        ext[pos[i] - k : pos[i]] = before + w * (phys[i] - before)
    return ext, pos


class SamplePositions:
    """Where each of a record's ``n_rows`` rows is among the samples once the bridged losses
    are filled in (``np.arange(n_rows) + np.cumsum(bridged_fill(lost_before))``) without that
    per-row array: from the rows the frames are filled in before (a finished recording's close
    holds nothing that grows with its length, issue 26)."""

    def __init__(self, losses: Losses, n_rows: int, fs_hz: float) -> None:
        rows, k = bridged_rows(losses, fs_hz)
        inside = rows < n_rows
        self.n_rows = int(n_rows)
        self._rows = rows[inside]
        self._cum = np.cumsum(k[inside])  # frames filled in at or before each of _rows
        # the position of the first frame filled in before each of _rows
        self._starts = self._rows + np.concatenate([[0], self._cum[:-1]]).astype(np.int64)

    def _offset(self, r: np.ndarray) -> np.ndarray:
        i = np.searchsorted(self._rows, r, side="right") - 1
        return np.where(i >= 0, self._cum[np.maximum(i, 0)] if len(self._cum) else 0, 0)

    def samples_of(self, rows: np.ndarray) -> np.ndarray:
        """Each row's sample (rows past the end lie as far past the last sample)."""
        r = np.asarray(rows, dtype=np.int64)
        return (r + self._offset(r)).astype(np.int64)

    def first_row_at(self, sample: int) -> int:
        """``np.searchsorted(positions, sample, side="left")``: the first row whose sample
        is at or after ``sample`` (``n_rows`` if none). The frames filled in before fill row
        ``f`` (positions ``f + cum_before`` up to ``f + cum``) map to ``f``."""
        x = int(sample)
        k = int(np.searchsorted(self._starts, x, side="right")) - 1  # the last fill at or before
        if k < 0:
            r = x
        elif x < int(self._rows[k]) + int(self._cum[k]):
            r = int(self._rows[k])
        else:
            r = x - int(self._cum[k])
        return int(min(max(r, 0), self.n_rows))
