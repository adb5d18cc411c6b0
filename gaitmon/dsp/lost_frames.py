"""Lost frames, by the unit's sequence counter (docs/gaps-and-time.md).

A row carries ``lost_before``: the frames lost just before it. Short losses are bridged: the
stateful stages see the lost frames filled in, linear between the rows around them, so that
time stays the unit's (``fill_lost``); longer ones restart the filters (``restart_rows``). The
pipeline (gaitmon.dsp.pipeline), the smoother's first pass (gaitmon.dsp.smoother), the
smoother itself (gaitmon.finish.smoothed) and the stride lengths (gaitmon.dsp.stride_length)
decide and fill alike, from here.
"""

from __future__ import annotations

import numpy as np

# Losses up to this long are bridged (a frame or two on a noisy link); longer ones restart the
# filters. The same limit decides which gaps a stride may cross (gaitmon.analysis).
BRIDGE_MAX_S = 0.05


def bridge_max_samples(fs_hz: float) -> int:
    """The longest loss (in frames) the pipeline bridges without restarting."""
    return round(BRIDGE_MAX_S * fs_hz)


def restart_rows(lost_before: np.ndarray, fs_hz: float) -> np.ndarray:
    """Rows where the pipeline restarts: the first row after a loss longer than the bridge."""
    lost = np.asarray(lost_before, dtype=np.int64)
    return np.flatnonzero(lost > bridge_max_samples(fs_hz)).astype(np.int64)


def bridged_fill(lost_before: np.ndarray, fs_hz: float) -> np.ndarray:
    """(N,) int64: the frames filled in just before each row of a record processed from row 0:
    every loss the pipeline bridges (none before row 0, nothing to fill from), 0 elsewhere (no
    loss, or one so long the filters restart after it)."""
    lost = np.asarray(lost_before, dtype=np.int64)
    fill = np.where((lost > 0) & (lost <= bridge_max_samples(fs_hz)), lost, 0)
    if len(fill):
        fill[0] = 0
    return fill


def bridged_losses(lost_before: np.ndarray, fs_hz: float) -> dict[int, int]:
    """{row: frames filled in just before it} of a record processed from row 0
    (:func:`bridged_fill`, its non-zero rows)."""
    fill = bridged_fill(lost_before, fs_hz)
    return {int(r): int(fill[r]) for r in np.flatnonzero(fill)}


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
