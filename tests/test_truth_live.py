"""Issue 11, headless half: gaps, the one stride rule, event time base and gyro zeroing.

The engine is driven by the simulated unit over the in-process transport (the real decoder and
Device); references are the simulator's ledger and ground truth, and the recorded file read
back through ``analysis.analyse_session`` (what ``info``, review and the report show).
"""

import itertools
import time

import numpy as np
import pytest
from helpers import HeldClock, wait_for
from helpers import make_engine as _make_engine

from gaitmon.analysis import FIRST, GAP, SETTLING, analyse_session, stride_exclusion
from gaitmon.dsp.gait import Phase
from gaitmon.dsp.pipeline import SETTLE_S, Pipeline, PipelineConfig, settling_ranges
from gaitmon.engine.buffers import with_gap_rows
from gaitmon.engine.live_gait import GaitEvents
from gaitmon.finish import open_session, rewrite_processed
from gaitmon.io.sim import FaultConfig, GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

FS = 100.0


def seeded_engine(faults=None, standing_s=2.0, speed=10.0, clock=None):
    return _make_engine(faults=faults, standing_s=standing_s, speed=speed, seed=5,
                        stride_cv=0.005, clock=clock)  # fmt: skip


@pytest.fixture(scope="module")
def walk():
    gait = GaitModel(GaitConfig(seed=11, cadence_steps_min=110.0, standing_s=3.0))
    return simulate(6000, gait, SensorConfig(seed=11))


def _cut(counts, at, n_lost):
    keep = np.r_[0:at, at + n_lost : len(counts)]
    lost = np.zeros(len(keep), np.int64)
    lost[at] = n_lost
    return counts[keep], lost


# -- the pipeline's gap policy ------------------------------------------------------------------


def test_a_long_gap_restarts_the_pipeline_chunk_invariantly_and_flags_the_settling(walk):
    counts, lost = _cut(walk.counts, 3000, 300)
    whole = Pipeline().process(counts, lost)
    # any chunking gives the same output, also when a chunk starts at the gap
    p = Pipeline()
    cuts = ((0, 1234), (1234, 3000), (3000, 3001), (3001, 4999), (4999, len(counts)))
    parts = [p.process(counts[a:b], lost[a:b]) for a, b in cuts]
    np.testing.assert_array_equal(
        np.concatenate([b.joint_kalman_rad for b in parts]), whole.joint_kalman_rad
    )
    np.testing.assert_array_equal(np.concatenate([b.settling for b in parts]), whole.settling)
    np.testing.assert_array_equal(
        np.concatenate([b.heel_strike_idx for b in parts]), whole.heel_strike_idx
    )
    assert [int(r) for b in parts for r in b.restart_idx] == [3000]
    # the settling flag covers SETTLE_S from the first row after the gap, and nothing else
    settle = np.flatnonzero(whole.settling)
    assert settle[0] == 3000 and len(settle) == round(SETTLE_S * FS)
    assert settling_ranges([3000], FS) == [(3000, 3000 + round(SETTLE_S * FS))]
    # a stride the engine makes of the events across the gap is excluded by the one stride
    # rule (the file's and the panel's), and none after it is counted before it settled
    strides = GaitEvents(FS).strides(whole.heel_strike_idx, whole.toe_off_idx)
    gaps = np.array([3000])
    reasons = [stride_exclusion(s, i, None, gaps, settling_ranges(gaps, FS))
               for i, s in enumerate(strides)]  # fmt: skip
    spans = [s.start_idx < 3000 <= s.end_idx for s in strides]
    assert any(spans) and all(r == GAP for r, sp in zip(reasons, spans, strict=True) if sp)
    assert all(r != "" for r, s in zip(reasons, strides, strict=True)
               if 3000 <= s.start_idx < 3000 + round(SETTLE_S * FS))  # fmt: skip
    # the gyro integration starts again at the accelerometer's tilt after the gap (one step of
    # integration on)
    step = np.abs(whole.gyro_rad_s[3000]) / FS
    assert np.all(np.abs(whole.tilt_gyro_rad[3000] - whole.tilt_acc_rad[3000]) <= step + 1e-9)


def test_any_chunking_with_many_gaps_gives_the_output_of_one_call(walk):
    rng = np.random.default_rng(3)
    counts = walk.counts
    lost = np.zeros(len(counts), np.int64)
    at = rng.choice(np.arange(100, len(counts)), 40, replace=False)
    lost[at] = rng.choice([1, 2, 5, 6, 40, 300], len(at))  # bridged and restarting losses
    whole = Pipeline().process(counts, lost)
    assert len(whole.restart_idx) == int(np.sum(lost > 5))
    p = Pipeline()
    edges = np.unique(np.r_[0, np.sort(rng.integers(1, len(counts), 60)), len(counts)])
    parts = [p.process(counts[a:b], lost[a:b]) for a, b in itertools.pairwise(edges)]
    for name in ("joint_kalman_rad", "tilt_gyro_rad", "fsr_counts", "phase", "settling"):
        np.testing.assert_array_equal(np.concatenate([getattr(b, name) for b in parts]),
                                      getattr(whole, name), err_msg=name)  # fmt: skip
    for name in ("heel_strike_idx", "toe_off_idx", "restart_idx"):
        np.testing.assert_array_equal(np.concatenate([getattr(b, name) for b in parts]),
                                      getattr(whole, name), err_msg=name)  # fmt: skip
    # the strides the engine makes of the events (GaitEvents), fed block by block
    live = GaitEvents(FS)
    got = [s for b in parts for s in live.strides(b.heel_strike_idx, b.toe_off_idx)]
    assert got == GaitEvents(FS).strides(whole.heel_strike_idx, whole.toe_off_idx)


def test_a_restarted_kalman_keeps_its_bias_and_takes_the_next_angle():
    from gaitmon.dsp.kalman import TiltKalman

    kf = TiltKalman()
    n = 3000
    kf.process(np.full(n, 0.2), np.full(n, 0.05))  # a 0.05 rad/s gyro bias is learnt
    bias = kf.bias_rad_s
    assert bias is not None and abs(bias[0] - 0.05) < 0.01
    kf.restart()
    out = kf.process(np.full(10, -0.4), np.full(10, 0.05))
    assert abs(out[0] - (-0.4)) < 0.01  # the new angle comes from the measurement
    np.testing.assert_allclose(kf.bias_rad_s, bias, atol=1e-3)  # the bias is kept


def test_a_restarted_detector_reports_no_event_for_the_state_it_finds():
    from gaitmon.dsp.gait import GaitEventDetector

    det = GaitEventDetector()
    loaded, free = np.full((50, 2), 3000.0), np.full((50, 2), 0.0)
    det.process(free)
    det.restart()
    b = det.process(loaded)  # loaded after an outage: not a heel strike
    assert len(b.heel_strike_idx) == 0 and det.samples_seen == 100
    b = det.process(free)
    b = det.process(loaded)
    assert b.heel_strike_idx.tolist() == [150]  # a real one, on the continuing index


def test_a_short_loss_is_bridged(walk):
    # bridged as time: the filters are fed the 3 lost frames filled in (no restart, nothing
    # settling), so they follow the loss-free run, where rows taken as frames fall behind
    counts, lost = _cut(walk.counts, 3000, 3)
    told = Pipeline().process(counts, lost)
    untold = Pipeline().process(counts)
    whole = Pipeline().process(walk.counts)
    assert not told.settling.any() and len(told.restart_idx) == 0
    np.testing.assert_array_equal(told.joint_kalman_rad[:3000], whole.joint_kalman_rad[:3000])
    after = slice(3000, 3300)
    ref = whole.joint_kalman_rad[3003:3303]
    err_told = np.abs(told.joint_kalman_rad[after] - ref).max()
    err_untold = np.abs(untold.joint_kalman_rad[after] - ref).max()
    assert err_told < 0.5 * err_untold, (err_told, err_untold)


def test_zeroing_restarts_the_gyro_integration_from_the_zeroed_pose():
    # the unit's time is held inside its 6 s of standing (3 s, then 4 s after the zero): the
    # zero and the readings after it are of standing however late a loaded machine gets there
    clock = HeldClock(hold_s=0.0)
    _unit, eng = seeded_engine(standing_s=6.0, speed=5.0, clock=clock)
    with eng:
        clock.hold(3.0 / 5.0)
        wait_for(lambda: eng.samples_total >= 290, what="standing data")
        before = eng.snapshot(0.5).series["joint_gyro_deg"][-1]
        cal = eng.zero()
        clock.hold(4.0 / 5.0)
        # it takes effect ZERO_MARGIN_S after its window, at a sample the data decide
        wait_for(lambda: eng.calibration is cal, what="the zero in force")
        at_zero = eng.samples_total
        wait_for(lambda: eng.samples_total >= at_zero + 50, what="data after zeroing")
        after = eng.snapshot(0.3).series["joint_gyro_deg"]
    # the uncorrected bias made it drift before; right after Zero it reads the standing pose
    assert np.max(np.abs(before)) > 3.0
    assert np.max(np.abs(after)) < 2.0, after[-1]


# -- lost frames on screen ----------------------------------------------------------------------


def test_lost_frames_are_nan_rows_at_their_true_times():
    cols = {"t_s": np.array([0.0, 0.01, 0.05]), "joint_kalman_deg": np.ones((3, 3))}
    out = with_gap_rows(cols, np.array([0, 0, 3]), FS, 100)
    np.testing.assert_allclose(out["t_s"], [0.0, 0.01, 0.02, 0.03, 0.04, 0.05])
    np.testing.assert_array_equal(out["lost"], [0, 0, 1, 1, 1, 0])
    joint = out["joint_kalman_deg"]
    assert np.isnan(joint[2:5]).all() and not np.isnan(joint[5]).any()


def test_random_loss_keeps_display_time_true_and_breaks_the_traces():
    faults = FaultConfig(seed=6, loss_pct=2.0)
    _unit, eng = seeded_engine(faults)
    with eng:
        wait_for(lambda: eng.samples_total >= 1500, what="1500 samples")
        snap = eng.snapshot(10.0)
    s = snap.series
    # one row per unit sample period: lost frames are rows, not skipped time
    np.testing.assert_allclose(np.diff(s["t_s"]), 1 / FS, atol=1e-9)
    lost_rows = s["lost"] > 0
    assert lost_rows.sum() > 5
    assert np.isnan(s["joint_kalman_deg"][lost_rows]).all()
    assert np.isnan(s["fsr_counts"][lost_rows]).all() and np.isnan(s["phase"][lost_rows]).all()
    assert not np.isnan(s["joint_kalman_deg"][~lost_rows]).any()


# -- events and phases on one time base ---------------------------------------------------------


def test_phase_changes_at_the_event_instants_live():
    _unit, eng = seeded_engine(standing_s=1.0)
    with eng:
        wait_for(lambda: eng.samples_total >= 1500, what="walking")
        snap = eng.snapshot(8.0)
    t, phase = snap.series["t_s"], snap.series["phase"]
    # (events at the window's first sample have no sample before them to compare with)
    hs = snap.heel_strike_t_s[(snap.heel_strike_t_s < t[-1] - 0.2)
                              & (snap.heel_strike_t_s > t[0] + 0.1)]  # fmt: skip
    to = snap.toe_off_t_s[(snap.toe_off_t_s < t[-1] - 0.2) & (snap.toe_off_t_s > t[0] + 0.1)]
    assert len(hs) >= 4 and len(to) >= 4
    for e in hs:
        i = int(np.argmin(np.abs(t - e)))
        assert phase[i] == Phase.LOADING and phase[i - 1] == Phase.SWING, (e, phase[i - 3 : i + 10])
    for e in to:
        i = int(np.argmin(np.abs(t - e)))
        near = phase[i - 3 : i + 10]
        assert phase[i] == Phase.SWING and phase[i - 1] == Phase.PUSH_OFF, (e, near)
    # the newest rows have no phase yet (the detector has not decided them)
    lag = PipelineConfig().phase_lag_samples
    assert lag == 8 and np.isnan(phase[-lag:]).all()


# -- one stride rule, live and recorded ---------------------------------------------------------


@pytest.mark.parametrize(
    ("loss_pct", "cut_s"), [(2.0, 0.0), (0.0, 3.0), (2.0, 3.0)], ids=["loss", "cut", "loss+cut"]
)
def test_live_cadence_matches_the_recording_with_loss_and_a_cut(tmp_path, loss_pct, cut_s):
    faults = FaultConfig(seed=5, loss_pct=loss_pct, link_drops=((20.0, cut_s),) if cut_s else ())
    _unit, eng = seeded_engine(faults)
    path = tmp_path / "walk.h5"
    live = []
    with eng:
        eng.start_recording(path)
        while eng.samples_total < 4500:
            time.sleep(0.02)
            g = eng.snapshot(1.0).gait
            # from 3 strides in the mean on (one stride is quantised to 10 ms: +-1 step/min)
            if len(g.cycles_deg) >= 3:
                live.append(g.cadence_derived_steps_per_min)
        eng.stop_recording()
    with open_session(path) as s:
        a = analyse_session(s)
        report = a.summary().cadence_derived_steps_per_min
        reasons = [r.excluded for r in a.rows]
        gaps = [g for g in s.gaps if g.n_lost > 5]
    assert report == pytest.approx(110.0, abs=1.0)  # the simulator's cadence
    assert len(live) > 20
    assert max(abs(np.array(live) - report)) <= 1.0, (min(live), max(live), report)
    assert reasons[0] == FIRST
    if cut_s:
        assert len(gaps) == 1
        # the stride around the outage and those while the filter settles do not count
        assert SETTLING in reasons and reasons.count(GAP) <= 1


def test_process_restarts_where_the_live_pipeline_did(tmp_path):
    faults = FaultConfig(seed=7, link_drops=((15.0, 3.0),))
    _unit, eng = seeded_engine(faults)
    path = tmp_path / "walk.h5"
    with eng:
        eng.start_recording(path)
        wait_for(lambda: eng.samples_total >= 3000, what="3000 samples")
        eng.stop_recording()
    with open_session(path) as s:
        gap = next(g.sample_idx for g in s.gaps if g.n_lost > 5)
        live_fsr = s.read("processed/fsr_counts")
        live_hs = s.heel_strike_idx
    out = rewrite_processed(path, tmp_path / "again.h5", PipelineConfig())
    with open_session(out.path) as s:
        fsr = s.read("processed/fsr_counts")
        hs = s.heel_strike_idx
    # both restarted at the gap: from there on the contacts and events are the same
    np.testing.assert_array_equal(fsr[gap:], live_fsr[gap:])
    np.testing.assert_array_equal(hs[hs >= gap], live_hs[live_hs >= gap])


def test_review_phase_and_readout_use_the_event_time_base(tmp_path, record_simulated):
    from gaitmon.review.model import open_document
    from gaitmon.review.view import phase_on_event_time, readout_html

    path = record_simulated(tmp_path / "walk.h5", duration_s=12)
    doc = open_document(path)
    try:
        src = doc.current
        hs = src.heel_strike_idx[2:-2]
        to = src.toe_off_idx[2:-2]
        assert len(hs) >= 4
        phase = phase_on_event_time(doc, src, 0, doc.n_rows)
        np.testing.assert_array_equal(phase[hs], Phase.LOADING)
        np.testing.assert_array_equal(phase[hs - 1], Phase.SWING)
        np.testing.assert_array_equal(phase[to], Phase.SWING)
        # the cursor on a heel-strike line reads the loading phase, not "swing"
        for i in hs[:3]:
            assert "loading" in readout_html(doc, float(doc.t_s[i]), 0)
    finally:
        doc.close()
