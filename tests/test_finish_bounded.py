"""Finishing a recording holds nothing per row of the whole record (issue 26 item 10): the
frames lost before the rows are kept sparse (:class:`gaitmon.dsp.lost_frames.Losses`) where
the close derives ``/smoothed`` and ``/strides``, with the same numbers as the per-row
arrays they replace."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from gaitmon.dsp.lost_frames import (
    Losses,
    SamplePositions,
    bridge_max_samples,
    bridged_fill,
    bridged_losses,
    restart_rows,
)

FS = 100.0


def _lost(n: int, seed: int) -> np.ndarray:
    """Per-row losses: bridged ones, long ones (restarts), one at row 0 and at the last row."""
    rng = np.random.default_rng(seed)
    lost = np.zeros(n, dtype=np.int64)
    rows = rng.choice(n, size=n // 50, replace=False)
    lost[rows] = rng.integers(1, 3 * bridge_max_samples(FS), size=len(rows))
    lost[0] = 2
    lost[-1] = 1
    return lost


@pytest.mark.parametrize("seed", range(5))
def test_sparse_losses_decide_as_the_per_row_array(seed: int) -> None:
    n = 5_000
    lost = _lost(n, seed)
    sparse = Losses.of(lost)
    assert np.array_equal(restart_rows(sparse, FS), np.flatnonzero(lost > bridge_max_samples(FS)))
    fill = np.where((lost > 0) & (lost <= bridge_max_samples(FS)), lost, 0)
    fill[0] = 0  # nothing to fill from before row 0
    assert np.array_equal(bridged_fill(lost, FS), fill)
    assert bridged_losses(sparse, FS) == {int(r): int(fill[r]) for r in np.flatnonzero(fill)}

    pos = np.arange(n, dtype=np.int64) + np.cumsum(fill)  # the per-row map it replaces
    where = SamplePositions(sparse, n, FS)
    rows = np.arange(-3, n + 5)
    want = rows.copy()
    inside = (rows >= 0) & (rows < n)
    want[inside] = pos[rows[inside]]
    want[rows >= n] += pos[-1] - (n - 1)
    assert np.array_equal(where.samples_of(rows), want)
    for x in range(-2, int(pos[-1]) + 4):
        assert where.first_row_at(x) == int(np.searchsorted(pos, x, side="left")), x


def test_stride_measures_from_sparse_losses_equal_the_per_row_ones() -> None:
    """Blocks of a few strides (boundaries falling mid-stride, losses inside strides and on
    block edges) give bit for bit the measures of the per-row losses."""
    from gaitmon.dsp.stride_streaming import record_stride_measures

    rng = np.random.default_rng(7)
    n = 6_000
    t = np.arange(n) / FS
    ax = 9.81 * np.sin(2 * np.pi * t) + rng.normal(0, 0.3, n)
    az = 9.81 + rng.normal(0, 0.3, n)
    gy = 3 * np.sin(2 * np.pi * t + 0.3) + rng.normal(0, 0.1, n)
    hs = np.arange(37, n - 60, 103, dtype=np.int64)
    lost = np.zeros(n, dtype=np.int64)
    lost[hs[3:40:4] + 11] = 2  # bridged, mid-stride
    lost[hs[5]] = 1  # on a heel strike
    lost[hs[20] + 50] = 40  # a restart

    def read(a: int, b: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return ax[a:b], az[a:b], gy[a:b]

    for per in (1, 3, 7):
        dense = record_stride_measures(read, n, FS, hs, strides_per_block=per, lost_before=lost)
        sparse = record_stride_measures(read, n, FS, hs, strides_per_block=per,
                                        lost_before=Losses.of(lost))  # fmt: skip
        for name in ("heel_strike_idx", "stride_length_m", "foot_clearance_m", "stride_time_s",
                     "foot_flat_idx", "flags"):  # fmt: skip
            np.testing.assert_array_equal(getattr(sparse, name), getattr(dense, name), name)


def test_strides_stamp_hashed_in_blocks_equals_the_whole(monkeypatch: pytest.MonkeyPatch) -> None:
    """``/strides``'s ``computed_from`` is what it was when the whole per-row fill was hashed
    (a stored ``/strides`` stays valid), whatever the block."""
    import json

    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import DEFAULT_TABLE
    from gaitmon.finish import strides

    n = 10_007
    lost = _lost(n, 3)
    fill = bridged_fill(lost, FS)
    old = {"filled_frames": int(fill.sum()),
           "filled_sha1": hashlib.sha1(fill.astype("<i8").tobytes()).hexdigest()}  # fmt: skip
    cal = Calibration.identity()
    for block in (1_000, 4_096, 1 << 20):
        monkeypatch.setattr(strides, "_STAMP_BLOCK_ROWS", block)
        for given in (lost, Losses.of(lost)):
            got = json.loads(strides.StrideInputs(n, FS, DEFAULT_TABLE, cal, [], given).stamp())
            assert {k: got[k] for k in old} == old
