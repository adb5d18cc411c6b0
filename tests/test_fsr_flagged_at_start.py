"""A force sensor flagged before the recording started: the file says so from row 0, and a
recovery (or reprocessing) replays with it flagged from row 0, as the live recorder ran.

Before, the journal held no force-sensor faults, so recovery replayed from row 0 with the dead
sensor trusted: its first strides' gait events came from the dead sensor (none) and the fault was
found again a few strides in, at another row, so the recovered file disagreed with the live one.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import FSR_IDX
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.finish import flagged_at_start, open_session, replay_pipeline
from gaitmon.io.device import SampleBlock
from gaitmon.io.journal import journal_path
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session import SessionHeader, SessionWriter
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

N_BEFORE = 2000  # samples the live pipeline saw before the recording (it flags the heel)
N_REC = 3000  # recorded rows
HEEL_DEAD = ("heel", "never loads")


def _dead_heel_counts() -> np.ndarray:
    counts = simulate(N_BEFORE + N_REC, GaitModel(GaitConfig(seed=4)), SensorConfig(seed=4)).counts
    counts = counts.copy()
    counts[:, FSR_IDX[0]] = counts[:, FSR_IDX[0]].min()  # the heel sensor never loads
    return counts


def _live_recording(path, counts: np.ndarray):
    """What the engine does: a pipeline that flagged the heel before the recording hands every
    fault it knows to the first recorded block; the recorder is then killed (``abort`` keeps
    the journal, as kill -9 does)."""
    before = Pipeline()
    before.process(counts[:N_BEFORE])
    assert [(f.sensor, f.reason) for f in before.fsr_faults] == [HEEL_DEAD]
    # the recorded rows are processed by a pipeline that starts at row 0 with the heel flagged
    # (the live one was warm; starting it here makes the live file exactly reproducible)
    live = Pipeline()
    live.flag_fsr_faults([HEEL_DEAD])
    rec = counts[N_BEFORE:]
    w = SessionWriter(path, SessionHeader("raw", config=PipelineConfig()))
    wall = time.time() - time.monotonic()
    events: list[np.ndarray] = []
    for a in range(0, N_REC, 100):
        blk = live.process(rec[a : a + 100])
        if a == 0:  # sensors flagged before the recording started are faulty in it from row 0
            # (the engine's one pipeline counts from before the recording: its faults' indices
            # lie before the first recorded block's)
            known = tuple(dataclasses.replace(f, stride_start_idx=f.stride_start_idx - N_BEFORE,
                                              decided_idx=f.decided_idx - N_BEFORE)
                          for f in before.fsr_faults)  # fmt: skip
            blk = dataclasses.replace(blk, fsr_faults=known)
        events.append(blk.heel_strike_idx)
        seq = np.arange(a, a + len(blk.settling), dtype=np.int64)
        host = np.full(len(seq), 1.0)
        w.append(SampleBlock(FrameKind.RAW, seq, host, wall, adc=rec[a : a + 100]), blk)
    w.flush()
    w.abort(RuntimeError("killed"))
    return np.concatenate(events)


def test_recovery_replays_with_the_sensor_flagged_from_row_0(tmp_path) -> None:
    path = tmp_path / "flagged.h5"
    live_hs = _live_recording(path, _dead_heel_counts())
    assert journal_path(path).exists()
    assert len(live_hs) >= 20  # the foot gyro's heel strikes from the first stride on
    with open_session(path) as s:
        assert s.recovered and s.reprocessed
        assert [(f.sensor, f.reason, f.decided_idx) for f in s.fsr_faults] == [(*HEEL_DEAD, 0)]
        np.testing.assert_array_equal(s.heel_strike_idx, live_hs)


def test_replay_without_the_flag_disagrees_in_the_first_strides() -> None:
    """The old replay (nothing flagged at row 0): the dead heel gives no heel strikes until the
    check flags it again, strides later, so the seeding above is what makes them agree."""
    rec = _dead_heel_counts()[N_BEFORE:]
    cal = Calibration.identity()

    def heel_strikes(flagged):
        chunks = list(replay_pipeline(rec, PipelineConfig(), cal, flagged_at_start=flagged))
        faults = [f for c in chunks for f in c[4]]
        return np.concatenate([c[2] for c in chunks]), faults

    seeded, seeded_faults = heel_strikes([HEEL_DEAD])
    fresh, fresh_faults = heel_strikes(())
    assert seeded_faults == [(0, 0, *HEEL_DEAD)]
    assert [f[2:] for f in fresh_faults] == [HEEL_DEAD] and fresh_faults[0][0] > 300
    assert seeded[0] < 150 and fresh[0] > 300  # strides lost before the flag, without it
    np.testing.assert_array_equal(seeded[seeded >= fresh[0] + 200],
                                  fresh[fresh >= fresh[0] + 200])  # fmt: skip


def test_flagged_at_start_takes_the_faults_known_at_row_0_once() -> None:
    rows = [(0, "heel", "never loads"), (0, "heel", "never loads"), (412, "toe", "never unloads")]
    assert flagged_at_start(rows) == (HEEL_DEAD,)
    assert flagged_at_start([]) == ()


def test_process_keeps_the_flag_with_the_same_force_sensor_settings_only(tmp_path) -> None:
    from gaitmon.finish import rewrite_processed

    path = tmp_path / "flagged.h5"
    live_hs = _live_recording(path, _dead_heel_counts())
    with open_session(path) as s:  # recovered
        assert s.recovered
    same = rewrite_processed(path, tmp_path / "same.h5", PipelineConfig(cutoff_hz=4.0)).path
    with open_session(same) as s:
        assert [(f.sensor, f.reason, f.decided_idx) for f in s.fsr_faults] == [(*HEEL_DEAD, 0)]
        np.testing.assert_array_equal(s.heel_strike_idx, live_hs)
    # another threshold may be what made the sensor look dead: it is checked from scratch
    other = rewrite_processed(path, tmp_path / "other.h5", PipelineConfig(fsr_threshold=900.0)).path
    with open_session(other) as s:
        assert [(f.sensor, f.reason) for f in s.fsr_faults] == [HEEL_DEAD]
        assert s.fsr_faults[0].decided_idx > 300
