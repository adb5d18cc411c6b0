"""Each stride's extremes of the joint angles: the peak knee flexion in swing and each joint's
range of motion (the stride table's figures, :func:`gaitmon.analysis.analyse_strides`), from the
whole record's angles or from slices of them read a group of strides at a time
(:func:`stride_extremes_sliced`: the same figures without the whole series in memory)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

SLICE_ROWS = 1 << 18  # rows of joint angles read at a time (3 MB of float32 hip/knee/ankle)


def stride_extremes(
    joint_deg: np.ndarray | None, start: np.ndarray, end: np.ndarray, toe: np.ndarray
) -> tuple[list[float], list[tuple[float, float, float]]]:
    """Per stride: the peak knee flexion from toe off to the end, and each joint's range of
    motion over [start, end] (both ends included; NaN when the stride is not in the data).
    One reduceat per figure instead of numpy calls per stride (26 000 strides in 8 hours)."""
    n = len(start)
    peak = np.full(n, np.nan)
    rom = np.full((n, 3), np.nan)
    if joint_deg is not None and n:
        # float32 angles (as read) are not copied to float64: max and min pick samples, and
        # the ranges are taken in float64 from them, so the figures are the same
        a = np.asarray(joint_deg)
        if a.dtype.kind != "f":
            a = a.astype(np.float64)
        ok = end < len(a)
        # reduceat over [s, e + 1) pairs (the odd results, from e + 1 on, are not used) needs
        # e + 1 to be a row: a stride ending on the last row is reduced on its own
        bulk = ok & (end + 1 < len(a))
        if bulk.any():
            s0, e1, t0 = start[bulk], end[bulk] + 1, toe[bulk]
            idx = np.column_stack([s0, e1]).ravel()
            hi = np.maximum.reduceat(a, idx, axis=0)[::2].astype(np.float64)
            lo = np.minimum.reduceat(a, idx, axis=0)[::2].astype(np.float64)
            rom[bulk] = (hi - lo)[:, :3]
            kidx = np.column_stack([t0, e1]).ravel()
            peak[bulk] = np.maximum.reduceat(a[:, 1], kidx)[::2]
        for k in np.flatnonzero(ok & ~bulk):
            seg = a[start[k] :]
            rom[k] = (seg.max(axis=0).astype(np.float64) - seg.min(axis=0))[:3]
            peak[k] = a[toe[k] :, 1].max()
    return peak.tolist(), [(h, k, a) for h, k, a in rom.tolist()]


def stride_extremes_sliced(
    n_rows: int, read: Callable[[int, int], np.ndarray], start: np.ndarray, end: np.ndarray,
    toe: np.ndarray, slice_rows: int | None = None,
) -> tuple[list[float], list[tuple[float, float, float]]]:
    """:func:`stride_extremes` of a record of ``n_rows`` rows whose angles ``read(a, b)`` gives
    (rows a:b), read a group of consecutive strides at a time: at most ``slice_rows``
    (:data:`SLICE_ROWS`) rows unless one stride is longer. The figures are the same: each
    stride's are the max and min of its own rows, wherever the slice ends."""
    step = slice_rows or SLICE_ROWS
    m = len(start)
    peak: list[float] = [float("nan")] * m
    rom: list[tuple[float, float, float]] = [(float("nan"),) * 3] * m
    inside = [k for k in range(m) if end[k] < n_rows]  # the others are not in the data
    i = 0
    while i < len(inside):
        lo = int(start[inside[i]])
        hi = int(end[inside[i]]) + 1
        j = i + 1
        while (j < len(inside) and start[inside[j]] >= lo
               and end[inside[j]] + 1 - lo <= step):  # fmt: skip
            hi = max(hi, int(end[inside[j]]) + 1)
            j += 1
        group = np.asarray(inside[i:j])
        part_peak, part_rom = stride_extremes(read(lo, hi), start[group] - lo, end[group] - lo,
                                              toe[group] - lo)  # fmt: skip
        for k, p, r in zip(group.tolist(), part_peak, part_rom, strict=True):
            peak[k], rom[k] = p, r
        i = j
    return peak, rom
