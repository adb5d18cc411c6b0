"""Lost frames are time for the stride lengths too: the foot IMU's strapdown fills the losses the
pipeline bridges in as the pipeline does (gaitmon.dsp.lost_frames.bridged_fill / fill_lost), with
every index a row, in the offline function, the file's block-wise computation and the live
tracker alike; against the simulator's truth of each stride."""

import numpy as np
import pytest
from helpers import wait_for

from gaitmon.dsp.calibration import standing_calibration
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, SEGMENTS
from gaitmon.dsp.pipeline import Pipeline
from gaitmon.dsp.stride_length import (
    StrideLengthTracker,
    record_stride_measures,
    stride_measures,
)
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

FS = 100.0
N = 6000
FOOT = SEGMENTS.index("foot")


@pytest.fixture(scope="module")
def lossy():
    """A seeded walk with 2 % random single-frame loss: the rows that arrived (frame index of
    each), lost_before, the foot board's acc x / z and bias-corrected gyro per row, the
    pipeline's heel strikes (rows) and the true strides."""
    gait = GaitModel(GaitConfig(seed=31, cadence_steps_min=110.0))
    sb = simulate(N, gait, SensorConfig(seed=31))
    first = Pipeline().process(sb.counts[:450])
    cal = standing_calibration(first.acc_ms2[100:450], first.gyro_rad_s[100:450])
    rng = np.random.default_rng(7)
    lost = np.zeros(N, bool)
    while lost.sum() < 0.02 * N:
        a = int(rng.integers(600, N - 2))
        if not lost[a - 1 : a + 2].any():
            lost[a] = True
    keep = np.flatnonzero(~lost)
    lost_before = np.diff(np.r_[-1, keep]) - 1
    p = Pipeline(calibration=cal).process(sb.counts[keep], lost_before)
    phys = DEFAULT_TABLE.to_physical(sb.counts[keep])
    foot = (phys[:, ACC_X_IDX[FOOT]], phys[:, ACC_Z_IDX[FOOT]], p.gyro_rad_s[:, FOOT])
    return keep, lost_before, foot, p.heel_strike_idx, gait.strides(0, N)


def _signed_errors(keep, m, truth):
    """Signed length error (fraction) of each stride matched to a true one (frames)."""
    hs = keep[m.heel_strike_idx]
    j = np.clip(np.searchsorted(truth.heel_strike_idx, hs - 3), 0, len(truth.heel_strike_idx) - 1)
    ok = (np.abs(truth.heel_strike_idx[j] - hs) <= 3) & (hs > 1000)
    ok &= np.isfinite(m.stride_length_m)
    return m.stride_length_m[ok] / truth.stride_length_m[j[ok]] - 1.0


def test_two_percent_loss_leaves_the_stride_lengths_unbiased(lossy):
    keep, lost_before, foot, hs, truth = lossy
    filled = stride_measures(*foot, FS, hs, lost_before=lost_before)
    e = _signed_errors(keep, filled, truth)
    assert len(e) >= 30
    assert abs(np.median(e)) <= 0.005 and np.median(np.abs(e)) <= 0.01
    # the rows taken as consecutive frames (as before): ~2 % of each stride's time is missing
    naive = _signed_errors(keep, stride_measures(*foot, FS, hs), truth)
    assert np.median(naive) < -0.015


def test_indices_are_rows_and_stride_times_true_times(lossy):
    keep, lost_before, foot, hs, _ = lossy
    m = stride_measures(*foot, FS, hs, lost_before=lost_before)
    np.testing.assert_array_equal(m.heel_strike_idx, hs[:-1])
    true_time = np.diff(keep[hs]) / FS  # frames between the heel-strike rows
    np.testing.assert_allclose(m.stride_time_s, true_time, atol=1e-12)
    ff = m.foot_flat_idx[m.foot_flat_idx >= 0]
    assert len(ff) and ff.max() < len(keep)
    # each foot-flat anchor is a row inside its stride's span
    ok = (m.foot_flat_idx >= 0).all(axis=1)
    assert (m.foot_flat_idx[ok, 0] >= hs[:-1][ok]).all()
    assert (m.foot_flat_idx[ok, 1] >= hs[1:][ok]).all()


def test_a_record_read_in_blocks_and_the_live_tracker_give_the_same_numbers(lossy):
    keep, lost_before, foot, hs, _ = lossy
    whole = stride_measures(*foot, FS, hs, lost_before=lost_before)
    blocks = record_stride_measures(lambda a, b: tuple(x[a:b] for x in foot), len(keep), FS, hs,
                                    strides_per_block=3, lost_before=lost_before)  # fmt: skip
    for name in ("heel_strike_idx", "stride_length_m", "foot_clearance_m", "stride_time_s",
                 "foot_flat_idx", "flags"):  # fmt: skip
        np.testing.assert_array_equal(getattr(blocks, name), getattr(whole, name), err_msg=name)
    tr = StrideLengthTracker(FS)
    rng = np.random.default_rng(3)
    got, a = [], 0
    while a < len(keep):
        b = min(len(keep), a + int(rng.integers(1, 40)))
        got.append(tr.push(*(x[a:b] for x in foot), hs[hs < b], lost_before[a:b]))
        a = b
    got.append(tr.finish())
    for name in ("heel_strike_idx", "stride_length_m", "stride_time_s", "foot_flat_idx", "flags"):
        np.testing.assert_array_equal(np.concatenate([getattr(m, name) for m in got]),
                                      getattr(whole, name), err_msg=name)  # fmt: skip


def test_without_loss_lost_before_changes_nothing(lossy):
    _, _, foot, hs, _ = lossy
    zeros = np.zeros(len(foot[0]), np.int64)
    a = stride_measures(*foot, FS, hs, lost_before=zeros)
    b = stride_measures(*foot, FS, hs)
    np.testing.assert_array_equal(a.stride_length_m, b.stride_length_m)
    np.testing.assert_array_equal(a.foot_flat_idx, b.foot_flat_idx)


def test_the_live_panel_reads_the_true_stride_length_with_frame_loss():
    """Through the engine, the simulated link losing 2 % of the frames at random."""
    from gaitmon.engine import Engine
    from gaitmon.io.device import Device
    from gaitmon.io.sim import SimulatedUnit
    from gaitmon.io.sim.faults import FaultConfig
    from gaitmon.io.transport import InProcessTransport

    faults = FaultConfig(seed=9, loss_pct=2.0)
    # (5x: at 20x, on a loaded CI machine, the panel read 1.40 m against the true 1.36 m)
    unit = SimulatedUnit(GaitConfig(seed=5, standing_s=1.0), faults=faults, speed=5.0)
    eng = Engine(Device(InProcessTransport(unit)), "raw", transport_label="simulated")
    with eng:
        wait_for(lambda: eng.snapshot(0.1).gait.n_strides >= 14, what="14 strides")
        g = eng.snapshot(0.1).gait
        truth = unit.truth(0, unit.samples_produced)
    assert len(unit.ledger.dropped) > 20  # frames were lost
    # The panel shows the mean of its last 10 strides, and which frames the link loses depends
    # on its timing (36 or 37 of them here, run to run). One stride whose lost frame falls where
    # the foot is integrated is off by up to 8 %: in 60-s recordings with 2 % lost, the mean of
    # 10 consecutive strides was up to 1.2 % off, and CI's loaded run read 1.382 m against the
    # true 1.36 m (1.6 %). The per-stride median is held to 1 % in the file test below.
    assert g.stride_length_mean_m == pytest.approx(np.median(truth.stride_length_m[2:]), rel=0.02)
    assert g.speed_mean_m_s == pytest.approx(
        np.median(truth.stride_length_m[2:] / truth.stride_time_s[2:]), rel=0.025)


def test_a_recorded_file_reads_the_true_stride_lengths_with_frame_loss(tmp_path,
                                                                        record_simulated):
    """What info, review, the report and the exports read (gaitmon.analysis through
    ``/strides``): the true lengths and speeds, with 2 % of the frames lost."""
    import h5py

    from gaitmon.analysis import analyse_session
    from gaitmon.finish import open_session

    path = record_simulated(tmp_path / "lossy.h5", "--loss-pct", "2", duration_s=40,
                            standing_s=3)  # fmt: skip
    with h5py.File(path, "r") as f:
        t_hs, t_len, t_time = (f["truth"][k][()] for k in ("heel_strike", "stride_length_m",
                                                          "stride_time_s"))  # fmt: skip
        assert "strides" in f
    with open_session(path) as s:
        assert sum(g.n_lost for g in s.gaps) > 20
        rows = [r for r in analyse_session(s).rows if r.included]
    assert len(rows) >= 15
    e_len, e_speed = [], []
    for r in rows:
        k = int(np.argmin(np.abs(t_hs - r.stride.start_idx)))
        e_len.append(r.stride_length_m / t_len[k] - 1)
        e_speed.append(r.speed_m_s / (t_len[k] / t_time[k]) - 1)
    assert abs(np.median(e_len)) <= 0.01 and abs(np.median(e_speed)) <= 0.01
