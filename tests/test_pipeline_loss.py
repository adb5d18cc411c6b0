"""Lost frames are time: the pipeline fills bridged losses in (linear between the rows around
them), so its filters and events see a uniform time base, and reports only rows."""


import numpy as np
import pytest
from helpers import assert_blocks_equal

from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.calibration import standing_calibration
from gaitmon.dsp.channels import FSR_IDX, GYRO_IDX, N_CHANNELS
from gaitmon.dsp.lost_frames import bridge_max_samples
from gaitmon.dsp.pipeline import Pipeline, PipelineBlock
from gaitmon.engine.live_gait import GaitEvents
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

FS = 100.0
N = 6000
ONSET = 3000  # the heel sensor dies here in the fault case


@pytest.fixture(scope="module")
def sim():
    gait = GaitModel(GaitConfig(seed=23, cadence_steps_min=108.0))
    sb = simulate(N, gait, SensorConfig(seed=23))
    first = Pipeline().process(sb.counts[:450])
    cal = standing_calibration(first.acc_ms2[100:450], first.gyro_rad_s[100:450])
    return gait, sb, cal


def lose(n, rng, frac=0.02, bursts=(1, 1), long_gaps=()):
    """Rows kept and lost_before for them: single or burst losses, plus long gaps (start, len)."""
    lost = np.zeros(n, bool)
    while lost.sum() < frac * n:
        k = int(rng.integers(bursts[0], bursts[1] + 1))
        a = int(rng.integers(600, n - k - 1))
        if not lost[a - 1 : a + k + 1].any():
            lost[a : a + k] = True
    for a, k in long_gaps:
        lost[a : a + k] = True
    keep = np.flatnonzero(~lost)
    return keep, np.diff(np.r_[-1, keep]) - 1


def test_a_linear_signal_is_read_the_same_with_frames_lost():
    # every channel a ramp in whole counts per frame: linear interpolation gives back exactly
    # the lost frames, so every stage sees the loss-free samples (to float rounding)
    n = 800
    k = np.arange(n)[:, None]
    slope = np.array([1, -1, 2, 3, -2, 1, 4, -3, 2, 1, -1, 3, 2, 4])[:N_CHANNELS]
    counts = (1800 + slope * k).astype(np.uint16)  # 200..4000 counts
    counts[:, GYRO_IDX] = 2000 + k  # the gyro channels: one count a frame
    lost = np.zeros(n, bool)
    lost[[50, 51, 52, 300, 301, 302, 303, 304, 500, 700]] = True
    keep = np.flatnonzero(~lost)
    whole = Pipeline().process(counts)
    part = Pipeline().process(counts[keep], np.diff(np.r_[-1, keep]) - 1)
    for name in ("acc_ms2", "gyro_rad_s", "fsr_counts", "tilt_gyro_rad", "tilt_kalman_rad"):
        np.testing.assert_allclose(getattr(part, name), getattr(whole, name)[keep], atol=1e-9,
                                   err_msg=name)  # fmt: skip
    # without filling in (each row taken as the next frame) the gyro integration falls behind
    naive = Pipeline().process(counts[keep])
    assert np.abs(naive.tilt_gyro_rad - whole.tilt_gyro_rad[keep]).max() > 1e-4


def test_two_percent_loss_keeps_the_live_joints_within_a_fifth_of_loss_free(sim):
    _, sb, cal = sim
    keep, lost_before = lose(N, np.random.default_rng(3))
    clean = Pipeline(calibration=cal).process(sb.counts)
    lossy = Pipeline(calibration=cal).process(sb.counts[keep], lost_before)
    naive = Pipeline(calibration=cal).process(sb.counts[keep])  # rows taken as frames
    truth = sb.kinematics.joint_rad

    def rmse(joint, rows):
        w = rows >= 1000
        return np.sqrt(np.mean(np.degrees(wrap_angle(joint[w] - truth[rows][w])) ** 2, axis=0))

    base = rmse(clean.joint_kalman_rad, np.arange(N))
    got = rmse(lossy.joint_kalman_rad, keep)
    assert np.all(got <= 1.2 * base), (got, base)
    assert rmse(naive.joint_kalman_rad, keep)[1] > 2 * base[1]  # what filling in fixes


def test_events_and_strides_are_rows_and_true_times(sim):
    _, sb, cal = sim
    keep, lost_before = lose(N, np.random.default_rng(4), frac=0.04, bursts=(1, 4))
    lossy = Pipeline(calibration=cal).process(sb.counts[keep], lost_before)
    clean = Pipeline(calibration=cal).process(sb.counts)
    # each heel strike on the row of the loss-free one, or on the next row that arrived
    assert len(lossy.heel_strike_idx) == len(clean.heel_strike_idx)
    want = np.searchsorted(keep, clean.heel_strike_idx)
    assert np.abs(lossy.heel_strike_idx - want).max() <= 1
    want_to = np.searchsorted(keep, clean.toe_off_idx)
    assert np.abs(lossy.toe_off_idx - want_to).max() <= 1
    gyro = np.searchsorted(keep, np.asarray(clean.gyro_heel_strike_idx))
    assert np.abs(np.asarray(lossy.gyro_heel_strike_idx) - gyro).max() <= 1
    # the engine's strides of these events (GaitEvents), timed as the engine and a file time
    # them, on the rows' true times t_s (StreamPosition.true_times: lost frames count)
    strides = GaitEvents(FS).strides(lossy.heel_strike_idx, lossy.toe_off_idx)
    clean_strides = GaitEvents(FS).strides(clean.heel_strike_idx, clean.toe_off_idx)
    assert len(strides) == len(clean_strides)
    t_s = keep / FS
    start = np.array([s.start_idx for s in strides])
    end = np.array([s.end_idx for s in strides])
    t_lossy = t_s[end] - t_s[start]
    t_clean = np.array([s.stride_time_s for s in clean_strides])
    # true times, not row counts: the loss-free stride's time, but for the frames lost just
    # before a heel strike's row (a heel strike on a lost frame is on the row after it)
    err = np.abs(t_lossy - t_clean)
    assert np.all(err <= (lost_before[start] + lost_before[end] + 1) / FS + 1e-9), err
    assert np.median(err) < 1e-9
    t_rows = np.array([s.stride_time_s for s in strides])  # taken as row counts: short
    assert np.abs(t_rows - t_clean).max() >= 0.1
    lost_in_strides = [lost_before[s.start_idx + 1 : s.end_idx + 1].sum() for s in strides]
    assert max(lost_in_strides) >= 3  # (strides did lose frames)
    for s in strides:
        assert 0 <= s.start_idx < s.toe_off_idx < s.end_idx < len(keep)


@pytest.mark.parametrize("heel_dead", [False, True])
def test_any_chunking_with_losses_gives_the_whole_record_output(sim, heel_dead):
    _, sb, cal = sim
    counts = sb.counts.copy()
    if heel_dead:  # a sensor flagged mid-record: the fault and the switch to the gyro's events
        counts[ONSET:, FSR_IDX[0]] = 0
    bridge = bridge_max_samples(FS)
    keep, lost_before = lose(N, np.random.default_rng(6), frac=0.03, bursts=(1, bridge),
                             long_gaps=((2000, 150), (4500, bridge + 1)))  # fmt: skip
    rows = counts[keep]
    whole = Pipeline(calibration=cal).process(rows, lost_before)
    assert len(whole.restart_idx) == 2
    if heel_dead:
        assert whole.fsr_faults and whole.event_source == "foot gyro"
    rng = np.random.default_rng(7)
    p = Pipeline(calibration=cal)
    parts: list[PipelineBlock] = []
    i = 0
    while i < len(rows):
        c = int(rng.choice([0, 1, 2, 3, 10, 57, 640]))
        parts.append(p.process(rows[i : i + c], lost_before[i : i + c]))
        i += c
    assert_blocks_equal(parts, whole)
    assert p.fsr_faults == whole.fsr_faults


def test_the_offline_replay_fills_in_the_same_frames_as_live(sim):
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.finish.replay import replay_pipeline
    from gaitmon.io.session.rows import rows_from_pipeline

    _, sb, cal = sim
    keep, lost_before = lose(N, np.random.default_rng(8), frac=0.03, bursts=(1, 4),
                             long_gaps=((3000, 40),))  # fmt: skip
    rows = sb.counts[keep]
    p = Pipeline(calibration=cal)
    live = [p.process(rows[a : a + 10], lost_before[a : a + 10]) for a in range(0, len(rows), 10)]
    chunks = list(replay_pipeline(rows, PipelineConfig(), cal, chunk_rows=777,
                                  lost_before=lost_before))  # fmt: skip
    for name in rows_from_pipeline(live[0]):
        got = np.concatenate([c.rows[name] for c in chunks])
        want = np.concatenate([rows_from_pipeline(b)[name] for b in live])
        np.testing.assert_array_equal(got, want, err_msg=name)
    np.testing.assert_array_equal(np.concatenate([c.heel_strike for c in chunks]),
                                  np.concatenate([b.heel_strike_idx for b in live]))  # fmt: skip


def test_the_offline_smoother_steps_over_the_filled_frames_too(sim):
    from gaitmon.dsp.channels import DEFAULT_TABLE
    from gaitmon.finish.smoothed import smoothed_angles

    _, sb, cal = sim
    keep, lost_before = lose(N, np.random.default_rng(9))
    truth = np.degrees(sb.kinematics.joint_rad)

    def rmse(rows, lost):
        got = smoothed_angles(sb.counts[rows], DEFAULT_TABLE, cal, [], lost, FS)
        e = (got["smoothed/joint_deg"].astype(np.float64) - truth[rows] + 180) % 360 - 180
        return np.sqrt(np.mean(e[rows >= 1000] ** 2, axis=0))

    base = rmse(np.arange(N), np.zeros(N, np.int64))
    filled = rmse(keep, lost_before)
    assert np.all(filled <= 1.1 * base), (filled, base)
    # rows taken as frames (told nothing was lost): the smoother reads them much worse
    assert rmse(keep, np.zeros(len(keep), np.int64))[1] > 1.3 * base[1]
