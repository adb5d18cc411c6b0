"""A force sensor the foot-gyro cross-check flags is in the file (``/events/fsr_faults``), the
same whether written live, recovered from the journal or reprocessed, and ``info`` says that
the events then come from the foot gyro."""

import shutil

import h5py
import numpy as np
import pytest

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import FSR_IDX
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.finish import close_recording, open_session
from gaitmon.finish.reprocess import rewrite_processed
from gaitmon.io.device import SampleBlock
from gaitmon.io.journal import journal_path
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session import SessionHeader, SessionWriter
from gaitmon.io.sim import GaitConfig, GaitModel
from gaitmon.io.sim.sensors import realistic_sensors, simulate

FS = 100.0
N = 6000  # 60 s
DEAD_FROM = 3000  # the heel sensor reads ~0 counts (a broken wire) from 30 s on


@pytest.fixture(scope="module")
def counts():
    gait = GaitModel(GaitConfig(seed=11))
    c = simulate(N, gait, realistic_sensors(11)).counts.copy()
    c[DEAD_FROM:, FSR_IDX[0]] = 15
    return c


def record(path, counts, crash_copy=None):
    header = SessionHeader("raw", FS, config=PipelineConfig(), calibration=Calibration.identity())
    w = SessionWriter(path, header)
    pipe = Pipeline(PipelineConfig())
    rng = np.random.default_rng(3)
    i = 0
    while i < N:
        b = min(N, i + int(rng.integers(1, 40)))
        adc = counts[i:b]
        seq = np.arange(i, b, dtype=np.int64)
        blk = SampleBlock(FrameKind.RAW, seq, 10.0 + seq / FS, 1.7e9,
                          lost_before=np.zeros(b - i, np.int64), adc=adc)  # fmt: skip
        w.append(blk, pipe.process(adc))
        i = b
    if crash_copy is not None:  # file + journal as a kill -9 leaves them
        w.flush()
        for src, dst in ((path, crash_copy), (journal_path(path), journal_path(crash_copy))):
            shutil.copyfile(src, dst)
    close_recording(w)


def test_the_flagged_sensor_is_in_the_file_live_recovered_and_reprocessed(counts, tmp_path):
    # the reference: the pipeline over the whole record in one call (it is chunk-invariant)
    ref = Pipeline(PipelineConfig()).process(counts).fsr_faults
    assert [(f.sensor, f.reason) for f in ref] == [("heel", "never loads")]
    decided = ref[0].decided_idx
    assert DEAD_FROM < decided < DEAD_FROM + 5 * 130  # within 5 strides (~1.2 s each)
    live, crashed = tmp_path / "live.h5", tmp_path / "crashed.h5"
    record(live, counts, crash_copy=crashed)
    with h5py.File(live, "r") as f:  # plain h5py: the documented table
        t = f["events/fsr_faults"][()]
    assert t["sample_idx"].tolist() == [decided]
    assert t["stride_start_idx"].tolist() == [ref[0].stride_start_idx]
    assert [x.decode() for x in t["sensor"]] == ["heel"]
    reprocessed = rewrite_processed(live, tmp_path / "again.h5", PipelineConfig()).path
    for path in (live, crashed, reprocessed):
        with open_session(path) as s:
            assert [(f.sensor, f.reason, f.decided_idx) for f in s.fsr_faults] == [
                ("heel", "never loads", decided)
            ], path.name
            assert s.event_source == (
                f"the force sensors, then the foot gyro from {decided / FS:.1f} s "
                "(heel force sensor never loads)"
            )
            # the events go on after the sensor died: from the foot gyro
            assert np.sum(s.heel_strike_idx > decided) >= 20


def test_info_says_where_the_events_come_from(counts, tmp_path, capsys):
    from gaitmon.cli import main

    path = tmp_path / "dead.h5"
    record(path, counts)
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "events       from the force sensors, then the foot gyro from" in out
    assert "(heel force sensor never loads)" in out
    assert "angles       gait-aware Kalman + RTS smoother (zero-lag, analysed here)" in out
    good = tmp_path / "good.h5"
    record(good, simulate(N, GaitModel(GaitConfig(seed=11)), realistic_sensors(11)).counts)
    assert main(["info", str(good)]) == 0
    assert "events       from the force sensors (cross-checked with the foot gyro: no fault)" in (
        capsys.readouterr().out
    )
