"""Long sessions are processed in blocks (issue 14: peak memory <= 400 MB for 8 hours), and the
blocks give exactly the numbers of the whole-array computation they replaced.

Each test runs the chunked path with block sizes shrunk (so a short record spans several blocks)
beside an independent whole-array reference: the previous code's formula, written out here."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import DEFAULT_TABLE
from gaitmon.dsp.gait import Stride
from gaitmon.dsp.pipeline import Pipeline
from gaitmon.finish import close_recording, open_session
from gaitmon.io.device import SampleBlock
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
from gaitmon.io.session.chunk_write import RowWriter
from gaitmon.io.session.codec import COMPRESSION, encode
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

FS = 100.0
N = 30_000  # 5 minutes: several blocks once they are shrunk


def _calibration(k: int) -> Calibration:
    return Calibration(np.radians([1.0, -2.0, 0.5, 3.0]) * k,
                       np.array([0.01, -0.02, 0.03, 0.04]) * k)


@pytest.fixture(scope="module")
def counts() -> np.ndarray:
    return simulate(N, GaitModel(GaitConfig(seed=8)), SensorConfig(seed=8)).counts


@pytest.fixture
def small_blocks(monkeypatch):
    import gaitmon.finish.smoothed as sm

    monkeypatch.setattr(sm, "SMOOTH_BLOCK_ROWS", 7000)
    monkeypatch.setattr(sm, "SMOOTH_OVERLAP_ROWS", 1500)
    return 7000 + 2 * 1500  # the most rows a block with its context needs


@pytest.mark.parametrize("version", [1, 2])
def test_smoothed_angles_stored_block_by_block_equal_the_whole_series_written_at_once(
    counts, small_blocks, tmp_path, version
):
    """store_smoothed (the close, recovery and ``process``) writes the values, dtypes and
    chunks write_smoothed(smoothed_angles(...)) wrote, asking for one block of counts at a
    time; with a restart after a long gap and a calibration change inside a block."""
    import gaitmon.finish.smoothed as sm

    lost = np.zeros(N, np.int64)
    lost[17_123] = 500  # a 5-s gap: the smoother starts afresh there
    changes = [(9_001, _calibration(1)), (23_456, _calibration(2))]
    want = sm.smoothed_angles(counts, DEFAULT_TABLE, _calibration(0), changes, lost, FS)
    asked: list[tuple[int, int]] = []

    def rows(a: int, b: int) -> np.ndarray:
        asked.append((a, b))
        return counts[a:b]

    paths = {}
    for name in ("whole", "blocks"):
        paths[name] = tmp_path / f"{name}.h5"
        with h5py.File(paths[name], "w") as f:
            f.attrs["format_version"] = version
            if name == "whole":
                sm.write_smoothed(f, want)
            else:
                sm.store_smoothed(f, rows, N, DEFAULT_TABLE, _calibration(0), changes, lost, FS)
    assert max(b - a for a, b in asked) <= small_blocks < N
    assert len(asked) >= 5
    with h5py.File(paths["whole"]) as f, h5py.File(paths["blocks"]) as g:
        assert sorted(f["smoothed"]) == sorted(g["smoothed"])
        assert f["smoothed"].attrs["method"] == g["smoothed"].attrs["method"]
        for name in f["smoothed"]:
            a, b = f["smoothed"][name], g["smoothed"][name]
            assert a.dtype == b.dtype and a.chunks == b.chunks and a.compression == b.compression
            assert np.array_equal(a[()], b[()]), name
        if version == 2:  # the tilts quantised, as the whole array was
            assert np.array_equal(g["smoothed/tilt_deg"][()],
                                  encode("smoothed/tilt_deg", want["smoothed/tilt_deg"]))


def test_the_smoothed_angles_are_written_in_whole_chunks(monkeypatch):
    """A compressed chunk written twice is decompressed and compressed again: the writer holds
    the rows of a chunk split between two blocks until it is full."""
    import gaitmon.finish.smoothed as sm

    n, chunk = 10_000, 512
    writes: list[tuple[int, int]] = []
    write = RowWriter.write

    def recorded(self: RowWriter, start: int, data: np.ndarray) -> None:
        writes.append((start, start + len(data)))
        write(self, start, data)

    monkeypatch.setattr(RowWriter, "write", recorded)
    with h5py.File("in-memory.h5", "w", driver="core", backing_store=False) as f:
        # (float32, no resolution: written as given)
        ds = f.create_dataset("smoothed/joint_deg", shape=(n, 2), dtype=np.float32,
                              chunks=(chunk, 2), **COMPRESSION)  # fmt: skip
        w = sm._AlignedWriter(ds, encoded=False)
        want = np.arange(2 * n, dtype=np.float32).reshape(n, 2)
        for a, b in [(0, 700), (700, 1024), (1024, 5000), (5000, 5001), (5001, n)]:
            w.write(a, want[a:b])
        w.finish()
        assert np.array_equal(ds[()], want)
    for a, b in writes[:-1]:
        assert a % chunk == 0 and b % chunk == 0 and b > a
    assert writes[-1][1] == n
    assert [a for a, _ in writes] == sorted({a for a, _ in writes})  # each row once


def _write(path: Path, counts: np.ndarray, *, calibrate_at: tuple[int, ...] = ()) -> None:
    pipe = Pipeline()
    with SessionWriter(path, SessionHeader("raw", meta=SessionMeta(patient_id="M-1"))) as w:
        for a in range(0, len(counts), 1000):
            b = min(len(counts), a + 1000)
            for k, row in enumerate(calibrate_at, 1):
                if a <= row < b:
                    w.log_calibration(_calibration(k))
                    pipe.set_calibration(_calibration(k))
            blk = SampleBlock(FrameKind.RAW, np.arange(a, b, dtype=np.int64),
                              10.0 + np.arange(a, b) / FS, 1.7e9,
                              lost_before=np.zeros(b - a, np.int64), adc=counts[a:b])
            w.append(blk, pipe.process(counts[a:b]))
        close_recording(w)  # /smoothed and /strides stored, as the recorder closes


def test_a_closed_recording_stores_the_smoothed_angles_of_its_whole_raw_record(
    counts, small_blocks, tmp_path
):
    """The close smooths from the file a block at a time: the stored tilts are those of the
    whole record's smoothed_angles (same blocks), quantised, and the readers' joint angles
    equal the whole-array ones within the storage's 0.01 deg."""
    import gaitmon.finish.smoothed as sm

    path = tmp_path / "closed.h5"
    _write(path, counts, calibrate_at=(12_000,))
    with open_session(path) as s:
        assert s.smoothed_stored and s.n_samples == N
        want = sm.smoothed_angles(counts, s.header.table, s.calibration, s.calibration_changes,
                                  np.zeros(N, np.int64), FS)  # fmt: skip
        assert np.array_equal(s.h5["smoothed/tilt_deg"][()],
                              encode("smoothed/tilt_deg", want["smoothed/tilt_deg"]))
        joint = s.read("processed/joint_deg")
    assert np.abs(joint - want["smoothed/joint_deg"]).max() <= 0.011


def _strides(n_rows: int, rng: np.random.Generator) -> list[Stride]:
    out = []
    a = 3
    while True:
        length = int(rng.integers(80, 140))
        if a + length >= n_rows:
            break
        toe = a + int(0.6 * length)
        out.append(Stride(a, a + length, toe, length / FS, 0.6 * length / FS, 0.4 * length / FS,
                          60.0, 40.0))  # fmt: skip
        a += length
    # one ending on the last row (its ROM runs to the end of the data)
    out.append(Stride(a, n_rows - 1, a + 5, 0.1, 0.05, 0.05, 50.0, 50.0))
    return out


def test_cycles_and_stride_figures_from_float32_angles_in_blocks_equal_the_float64_ones(
    monkeypatch,
):
    """The analysis takes the joint angles as read (float32) instead of a float64 copy, and
    resamples the cycles a block of strides at a time: every figure is the same to the bit
    as the previous whole-array float64 computation."""
    import gaitmon.dsp.gait as gait
    from gaitmon.dsp.stride_extremes import stride_extremes

    rng = np.random.default_rng(3)
    n = 20_000
    joints32 = (rng.normal(0, 20, (n, 3))).astype(np.float32)
    strides = _strides(n, rng)
    a64 = joints32.astype(np.float64)

    # the previous code, whole arrays in float64
    start = np.array([s.start_idx for s in strides])
    end = np.array([s.end_idx for s in strides])
    toe = np.array([s.toe_off_idx for s in strides])
    frac = np.linspace(0.0, 1.0, 101)
    pos = start[:, None] + (end - start)[:, None] * frac[None, :]
    i0 = np.minimum(np.floor(pos).astype(np.int64), (end - 1)[:, None])
    w = (pos - i0)[..., None]
    want_cycles = a64[i0] * (1.0 - w) + a64[i0 + 1] * w
    padded = np.concatenate([a64, np.full((1, 3), np.nan)])
    idx = np.column_stack([start, end + 1]).ravel()
    want_rom = (np.maximum.reduceat(padded, idx, axis=0)[::2]
                - np.minimum.reduceat(padded, idx, axis=0)[::2])  # fmt: skip
    want_peak = np.maximum.reduceat(padded[:, 1], np.column_stack([toe, end + 1]).ravel())[::2]

    monkeypatch.setattr(gait, "NORMALISE_BLOCK_STRIDES", 37)  # ~5 blocks, the last one short
    got = gait.normalise_strides(joints32, strides)
    assert got.dtype == np.float64 and len(got) == len(strides) > 150
    assert np.array_equal(got, want_cycles)
    assert np.array_equal(gait.normalise_strides(a64, strides), want_cycles)
    peak, rom = stride_extremes(joints32, start, end, toe)
    assert np.array_equal(np.array(rom), want_rom)
    assert np.array_equal(np.array(peak), want_peak)
    assert np.isfinite(want_rom[-1]).all()  # (the stride on the last row has its figures)


@pytest.mark.parametrize("n_strides", [0, 1, 2, 157])
def test_cycle_statistics_a_block_of_strides_at_a_time_equal_those_of_every_cycle_at_once(
    monkeypatch, n_strides
):
    """The review keeps the mean, the SD and the few cycles it draws, not every cycle: the
    mean and SD are those of the whole (k, 101, 3) array to the bit (as the report's), the
    cycles kept those the window draws."""
    import gaitmon.analysis as analysis
    from gaitmon.analysis import StrideRow, cycle_stats, cycles, evenly_chosen
    from gaitmon.dsp.gait import cycle_mean_sd

    rng = np.random.default_rng(5)
    n = 20_000
    joints32 = rng.normal(10, 25, (n, 3)).astype(np.float32)
    strides = _strides(n, rng)[:n_strides]
    # every third stride excluded: only the included ones count
    rows = [StrideRow(s, "excluded range" if k % 3 == 1 else "", 0.0, (0.0, 0.0, 0.0))
            for k, s in enumerate(strides)]  # fmt: skip
    whole = cycles(joints32.astype(np.float64), rows)
    want_mean, want_sd = cycle_mean_sd(whole)
    monkeypatch.setattr(analysis, "CYCLE_BLOCK_STRIDES", 16)  # 7 blocks of the 105 included
    mean, sd, kept = cycle_stats(joints32, rows, keep=40)
    assert np.array_equal(mean, want_mean, equal_nan=True)
    assert np.array_equal(sd, want_sd, equal_nan=True)
    assert np.array_equal(kept, whole[evenly_chosen(len(whole), 40)])
    assert len(kept) == min(40, len(whole))


def test_a_journal_s_rows_are_read_from_its_map_when_sliced_and_its_pages_let_go(
    counts, tmp_path, monkeypatch
):
    """Recovery reads the journal's rows out of a memory map a chunk at a time, instead of
    copying all of them into memory beside the map (an 8-hour journal: 138 MB): the rows are
    the ones written, in any slicing; the map's pages before the rows replayed are let go
    (madvise), and rows read again after that are still right (read from the file again)."""
    import gaitmon.io.journal as journal
    from gaitmon.io.journal import JournalRows, journal_path, read_journal

    w = SessionWriter(tmp_path / "live.h5", SessionHeader("raw"))
    pipe = Pipeline()
    blocks = []
    for a in range(0, 9000, 500):
        blk = SampleBlock(FrameKind.RAW, np.arange(a, a + 500, dtype=np.int64),
                          np.arange(a, a + 500) / FS, 1.7e9,
                          lost_before=np.full(500, a % 3, np.int64), adc=counts[a : a + 500])
        blocks.append(blk)
        w.append(blk, pipe.process(counts[a : a + 500]))
    w.flush()
    jpath = tmp_path / "copy.journal"
    jpath.write_bytes(journal_path(tmp_path / "live.h5").read_bytes())
    close_recording(w)
    released: list[int] = []
    real = journal._release
    monkeypatch.setattr(journal, "_release", lambda mm, upto: (released.append(upto),
                                                                real(mm, upto)))
    c = read_journal(jpath)
    rows = c.rows
    assert isinstance(rows, JournalRows) and len(rows) == 9000
    assert released == [jpath.stat().st_size]  # the parse read every page: all let go
    released.clear()
    np.testing.assert_array_equal(rows["adc"][0:9000], counts[:9000])
    np.testing.assert_array_equal(rows["seq"][1234:5678], np.arange(1234, 5678))
    np.testing.assert_array_equal(rows[4990:5010]["lost_before"],
                                  np.r_[np.full(10, 4500 % 3), np.full(10, 5000 % 3)])
    for b in range(1000, 9001, 1000):  # as the replay goes
        rows.release_before(b)
    assert len(released) == 9 and released == sorted(released)
    assert released[-1] > 8999 * 48  # (the whole map, at the end)
    np.testing.assert_array_equal(np.asarray(rows["adc"]), counts[:9000])  # read again
    np.testing.assert_array_equal(np.asarray(rows)["host_time_s"],
                                  np.concatenate([b.host_time_s for b in blocks]))
