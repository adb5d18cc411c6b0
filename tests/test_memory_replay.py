"""The replay of a long record (``gaitmon process``, recovery) holds one chunk at a time and
nothing per row of the whole record (issue 28: 8-h ``process`` and recovery in <= 250 MiB).

The pipeline's block of a chunk holds every stage's series (~740 bytes a row); the replay
let it live on while the next chunk was computed (twice the block at every step), and the
frames lost before the rows were a per-row int64 array (23 MB for 8 hours). Checked without
timing: weak references to the arrays of each chunk must be dead when the next is computed,
and the sparse losses give the per-row array's slices exactly."""

from __future__ import annotations

import weakref
from pathlib import Path

import numpy as np
import pytest
from helpers import killed_recording

from gaitmon.dsp.lost_frames import Losses
from gaitmon.io.session.rows import LostRows, losses_from_gaps, lost_before_from_gaps


@pytest.mark.parametrize("seed", range(4))
def test_lost_rows_slices_equal_the_per_row_array(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 3_000
    per_row = np.zeros(n, np.int64)
    rows = rng.choice(n, size=40, replace=False)
    per_row[rows] = rng.integers(1, 900, size=len(rows))
    per_row[0], per_row[-1] = 3, 7
    lost = LostRows(Losses.of(per_row), n)
    assert len(lost) == n
    for a, b in [(0, n), (0, 1), (n - 1, n), (5, 5), (17, 2_500), (2_900, n + 50),
                 *(sorted(rng.integers(0, n, 2)) for _ in range(30))]:  # fmt: skip
        got = lost[a:b]
        assert got.dtype == np.int64
        np.testing.assert_array_equal(got, per_row[a:b])
    # rows outside the record are not the record's
    out = LostRows(Losses(np.array([-1, 4, n + 3]), np.array([9, 2, 5])), n)
    np.testing.assert_array_equal(out[0:n], np.where(np.arange(n) == 4, 2, 0))


def test_lost_rows_of_a_gap_table_equal_lost_before_from_gaps(gap_recording: Path) -> None:
    import h5py

    with h5py.File(gap_recording, "r") as f:
        gaps, n = f["gaps"][()], f["raw/adc"].shape[0]
    lost = LostRows(losses_from_gaps(gaps, n), n)
    want = lost_before_from_gaps(gaps, n)
    assert want.any()
    for a in range(0, n, 700):
        np.testing.assert_array_equal(lost[a : a + 700], want[a : a + 700])


class _ChunkWatch:
    """Weak references to every replayed block's arrays and every chunk's ``/processed`` rows;
    at each ``Pipeline.process`` call, those of the chunks before must be dead (the caller
    has written them)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        import gaitmon.finish.replay as rec
        from gaitmon.dsp.pipeline import Pipeline

        self.calls = 0
        self.alive: list[str] = []
        self._refs: list[tuple[int, str, weakref.ref[np.ndarray]]] = []
        process, to_rows = Pipeline.process, rec.rows_from_pipeline

        def watched_process(pipe: Pipeline, *a: object, **kw: object) -> object:
            self._check()
            self.calls += 1
            blk = process(pipe, *a, **kw)  # type: ignore[arg-type]
            for name in ("tilt_acc_rad", "tilt_gyro_rad", "joint_kalman_rad", "acc_ms2"):
                self._refs.append((self.calls, f"block.{name}", weakref.ref(getattr(blk, name))))
            return blk

        def watched_rows(blk: object, only: object = None) -> dict[str, np.ndarray]:
            rows = to_rows(blk, only)  # type: ignore[arg-type]
            for name, arr in rows.items():
                self._refs.append((self.calls, name, weakref.ref(arr)))
            return rows

        monkeypatch.setattr(Pipeline, "process", watched_process)
        monkeypatch.setattr(rec, "rows_from_pipeline", watched_rows)

    def _check(self) -> None:
        # every chunk made so far has been handed over and written: none is held while the
        # next is computed
        self.alive += [f"chunk {k}: {name}" for k, name, ref in self._refs if ref() is not None]
        self._refs = []


def test_process_replay_holds_one_chunk_at_a_time(gap_recording, tmp_path, monkeypatch):
    import gaitmon.finish.reprocess as rp
    from gaitmon.finish import open_session

    monkeypatch.setattr(rp, "REPLAY_CHUNK_ROWS", 500)
    watch = _ChunkWatch(monkeypatch)
    with open_session(gap_recording) as s:
        config = s.config
    rp.rewrite_processed(gap_recording, tmp_path / "new.h5", config)
    assert watch.calls >= 6
    assert not watch.alive, watch.alive[:5]


def test_recovery_replay_holds_one_chunk_at_a_time(tmp_path, monkeypatch):
    """A recording killed (SIGKILL) before its close, recovered in chunks of 500 rows."""
    import gaitmon.finish.recovery as rec
    from gaitmon.finish import open_session
    from gaitmon.io.journal import journal_path

    src = killed_recording(tmp_path)
    monkeypatch.setattr(rec, "RECOVERY_REPLAY_ROWS", 500)
    watch = _ChunkWatch(monkeypatch)
    with open_session(src) as s:
        assert s.recovered and s.n_samples == 6_000
    assert not journal_path(src).exists()
    assert watch.calls >= 10
    assert not watch.alive, watch.alive[:5]


@pytest.mark.parametrize("seed", range(4))
def test_stride_positions_from_the_filled_rows_equal_the_per_row_cumsum(seed: int) -> None:
    """``info`` and the report place the stored strides on the true timeline from the rows
    that lost frames, not from four per-row arrays of the whole record."""
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import DEFAULT_TABLE
    from gaitmon.finish.strides import StrideInputs

    rng = np.random.default_rng(seed)
    n = 4_000
    per_row = np.zeros(n, np.int64)
    per_row[rng.choice(n, size=60, replace=False)] = rng.integers(1, 400, size=60)
    per_row[0] = 2
    rows = np.sort(rng.choice(n, size=300, replace=False)).astype(np.int64)
    for lost in (per_row, Losses.of(per_row), None):
        inputs = StrideInputs(n, 100.0, DEFAULT_TABLE, Calibration.identity(), [], lost)
        want = (np.arange(n, dtype=np.int64) + np.cumsum(inputs.filled()))[rows]
        got = inputs.positions(rows)
        assert got.dtype == np.int64
        np.testing.assert_array_equal(got, want)
