"""The smoother's first pass is the live pipeline's gait-aware filter, bit for bit.

``gaitmon process`` takes the first pass from the pipeline's replay instead of running the
filter again; that is only right if the two are the same numbers. Checked on a walk with a
long gap (a restart, the bias kept) and two new calibrations (one at the gap's row), with the
first pass asked in overlapping blocks as the smoother asks for it, and through the file
path: a reprocessed file's ``/smoothed`` equals the one computed from the raw counts alone.
"""

from __future__ import annotations

import numpy as np
import pytest

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import DEFAULT_TABLE
from gaitmon.dsp.lost_frames import bridged_losses, restart_rows
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.dsp.smoother import CausalFirstPass
from gaitmon.finish import close_recording
from gaitmon.finish.replay import replay_pipeline
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

N = 9000


@pytest.fixture(scope="module")
def record():
    counts = simulate(N, GaitModel(GaitConfig(seed=3)), SensorConfig(seed=3)).counts
    lost = np.zeros(N, dtype=np.int64)
    lost[4000] = 300  # a 3-s gap before row 4000: the pipeline restarts there
    lost[6500] = 2  # a short one: bridged, no restart
    cal0 = Calibration(np.array([0.1, -0.05, 0.2, 0.3]), np.array([0.01, -0.02, 0.0, 0.015]))
    cal1 = Calibration(np.array([0.12, -0.04, 0.18, 0.31]), np.array([0.02, -0.01, 0.005, 0.0]))
    cal2 = Calibration(np.array([0.0, 0.0, 0.1, 0.2]), np.array([-0.01, 0.0, 0.01, 0.02]))
    changes = [(2500, cal1), (4000, cal2)]
    return counts, lost, cal0, changes


def test_the_first_pass_is_the_replayed_pipelines_filter(record) -> None:
    counts, lost, cal0, changes = record
    assert restart_rows(lost, 100.0).tolist() == [4000]
    replay = list(replay_pipeline(counts, PipelineConfig(), cal0, changes, chunk_rows=1234,
                                  lost_before=lost))  # fmt: skip
    assert all(ch.first_pass_rad is not None for ch in replay)
    live = np.concatenate([ch.first_pass_rad for ch in replay])
    assert bridged_losses(lost, 100.0) == {6500: 2}
    fp = CausalFirstPass(DEFAULT_TABLE, cal0, changes, restart_rows(lost, 100.0), 100.0,
                         bridged_losses(lost, 100.0))  # fmt: skip
    # overlapping blocks in row order, as smoothed_blocks asks (context before each block)
    got = np.empty((N, 4))
    for a, b in [(0, 3000), (2000, 5200), (5000, 5001), (4500, 6500), (6000, 9000)]:
        got[a:b] = fp.rows(a, b, counts[a:b])
    np.testing.assert_array_equal(got, live)
    # and it is the filter the pipeline shows, once offset and wrapped
    blk = Pipeline(PipelineConfig(), cal0).process(counts[:2500])
    np.testing.assert_array_equal(blk.tilt_kalman_rad, cal0.apply_tilt(live[:2500]))


def test_rows_asked_out_of_order_are_refused(record) -> None:
    counts, lost, cal0, changes = record
    fp = CausalFirstPass(DEFAULT_TABLE, cal0, changes, restart_rows(lost, 100.0), 100.0)
    fp.rows(0, 3000, counts[:3000])
    fp.rows(2000, 4000, counts[2000:4000])
    with pytest.raises(ValueError, match="out of order"):
        fp.rows(1000, 2000, counts[1000:2000])  # before the rows still kept


def test_a_replay_with_another_filter_or_after_new_settings_offers_no_first_pass(record):
    counts, _, cal0, _ = record
    paper = list(replay_pipeline(counts[:3000], PipelineConfig(tilt_method="paper"), cal0))
    assert all(ch.first_pass_rad is None for ch in paper)
    new = PipelineConfig(fsr_threshold=PipelineConfig().fsr_threshold + 50)
    mixed = list(replay_pipeline(counts[:3000], PipelineConfig(), cal0, [(1500, new)],
                                 chunk_rows=1000))  # fmt: skip
    assert [ch.first_pass_rad is not None for ch in mixed] == [True, True, False, False]


def _recorded(path, counts, lost):
    """A raw session written as the recorder writes it (a gap, no new settings)."""
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionWriter

    pipe = Pipeline()
    with SessionWriter(path, SessionHeader("raw")) as w:
        for a in range(0, len(counts), 500):
            b = min(len(counts), a + 500)
            blk = SampleBlock(FrameKind.RAW, np.arange(a, b, dtype=np.int64),
                              np.arange(a, b) / 100.0, 1.7e9, lost_before=lost[a:b],
                              adc=counts[a:b])  # fmt: skip
            w.append(blk, pipe.process(counts[a:b], lost[a:b]))
        close_recording(w)  # /smoothed and /strides stored, as the recorder closes


def test_process_without_a_temporary_file_computes_the_first_pass_to_the_same_numbers(
    record, tmp_path, monkeypatch
) -> None:
    """`process` keeps the pipeline's filter for the smoother in a temporary file; where none
    can be made, or writing it fails half-way (a full disk), the smoother runs the filter
    itself: the same /smoothed, and no error."""
    import tempfile

    from gaitmon.finish import open_session
    from gaitmon.finish.reprocess import rewrite_processed

    counts, lost, _, _ = record
    src = tmp_path / "rec.h5"
    _recorded(src, counts, lost)

    def smoothed(path):
        with open_session(path) as s:
            s.use_angles("smoothed")
            return s.read("processed/tilt_deg")

    import gaitmon.dsp.smoother as smoother

    ran: list[int] = []
    real_rows = smoother.CausalFirstPass.rows
    with monkeypatch.context() as mp:
        mp.setattr(smoother.CausalFirstPass, "rows",
                   lambda self, a, b, c: (ran.append(a), real_rows(self, a, b, c))[1])
        rewrite_processed(src, tmp_path / "kept.h5", PipelineConfig())
        assert ran == []  # kept from the replay
        rewrite_processed(src, tmp_path / "paper.h5", PipelineConfig(tilt_method="paper"))
        assert ran  # the replay's filter is another: the smoother runs its own
    want = smoothed(tmp_path / "kept.h5")
    np.testing.assert_array_equal(smoothed(tmp_path / "paper.h5"), want)  # not a setting of it

    def no_temp(*a, **k):
        raise OSError(28, "No space left on device")

    import gaitmon.finish.smoothed as smoothed_module

    # (a record this short is kept in memory: the file is made at once when none is allowed)
    monkeypatch.setattr(smoothed_module, "KEPT_IN_MEMORY_MAX_BYTES", 0)
    with monkeypatch.context() as mp:
        mp.setattr(tempfile, "TemporaryFile", no_temp)
        rewrite_processed(src, tmp_path / "none.h5", PipelineConfig())
    np.testing.assert_array_equal(smoothed(tmp_path / "none.h5"), want)

    real = tempfile.TemporaryFile

    class FillsUp:
        def __init__(self, f):
            self._f, self._written = f, 0

        def write(self, data):
            self._written += len(data)
            if self._written > 100_000:
                raise OSError(28, "No space left on device")
            return self._f.write(data)

        def __getattr__(self, name):
            return getattr(self._f, name)

    with monkeypatch.context() as mp:
        mp.setattr(tempfile, "TemporaryFile", lambda *a, **k: FillsUp(real(*a, **k)))
        rewrite_processed(src, tmp_path / "full.h5", PipelineConfig())
    np.testing.assert_array_equal(smoothed(tmp_path / "full.h5"), want)


@pytest.mark.parametrize("memory_max_bytes", [1 << 30, 40_000, 0])
def test_kept_rows_read_back_from_memory_from_the_file_and_after_the_move(memory_max_bytes):
    """Rows held in memory, moved to the file part-way (40 kB: after the 2nd chunk), or in the
    file from the first: any window of them reads back as added, into a new writeable array."""
    from gaitmon.finish.smoothed import KeptFirstPass

    rng = np.random.default_rng(1)
    chunks = [rng.standard_normal((n, 4)) for n in (700, 1234, 1, 3000, 66)]
    whole = np.concatenate(chunks)
    with KeptFirstPass(memory_max_bytes=memory_max_bytes) as kept:
        at = 0
        for c in chunks:
            kept.add(at, c)
            at += len(c)
        assert (kept._file is not None) == (memory_max_bytes < whole.nbytes)
        rows = kept.first_pass
        assert rows is not None
        for a, b in [(0, len(whole)), (650, 2000), (1934, 1935), (1935, 1935), (4000, 5001)]:
            got = rows(a, b)
            np.testing.assert_array_equal(got, whole[a:b])
            assert got.flags.c_contiguous and got.flags.writeable and got.base is None
        with pytest.raises(ValueError, match="asked of 5001 kept"):
            rows(0, 5002)
    assert kept.first_pass is None  # closed: nothing kept
