"""Issue 13 in the engine: the snapshot says which tilt filter made the angles, which force
sensors the pipeline found faulty (and when), and where the gait events come from. Driven by the
simulated unit over the in-process transport; the references are the simulator's own: the
sample the sensor was broken at, its true heel strikes and its frame log."""

import functools

import numpy as np
import pytest
from helpers import make_engine as _make_engine
from helpers import wait_for

from gaitmon.dsp.channels import FSR_IDX
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.io.sim import GaitConfig, SimulatedUnit
from gaitmon.io.sim.kinematics import GaitModel
from gaitmon.io.sim.sensors import SensorConfig, SensorModel

make_engine = functools.partial(_make_engine, standing_s=2.0, seed=5)


def test_a_dead_heel_sensor_only_changes_the_counts_never_the_truth():
    cfg = GaitConfig(seed=2, standing_s=1.0)
    healthy = SensorModel(GaitModel(cfg), SensorConfig(seed=2))
    broken = SensorModel(GaitModel(cfg), SensorConfig(seed=2))
    a = healthy.next_block(3000)
    b0 = broken.next_block(1234)
    broken.set_fsr_fault(1234, heel_dead=True, toe_stuck=False)
    b1 = broken.next_block(1766)
    counts = np.concatenate([b0.counts, b1.counts])
    heel = FSR_IDX[0]
    # before the fault and on every other channel: the same samples
    np.testing.assert_array_equal(counts[:1234], a.counts[:1234])
    others = [c for c in range(counts.shape[1]) if c != heel]
    np.testing.assert_array_equal(counts[:, others], a.counts[:, others])
    assert a.counts[1234:, heel].max() > 2000  # the healthy heel loads in every stance
    assert counts[1234:, heel].max() < 60  # the dead one reads its noise around 0
    # the unit's truth is the subject's gait, whatever the sensor does
    unit = SimulatedUnit(cfg, SensorConfig(seed=2), speed=float("inf"))
    ref = SimulatedUnit(cfg, SensorConfig(seed=2), speed=float("inf"))
    unit.set_foot_sensor_fault(heel_dead=True, toe_stuck=True)
    assert unit.foot_sensor_fault == (True, True)
    unit.sensors.next_block(3000)
    ref.sensors.next_block(3000)
    np.testing.assert_array_equal(unit.truth().heel_strike_idx, ref.truth().heel_strike_idx)
    unit.set_foot_sensor_fault(False, False)
    assert unit.foot_sensor_fault == (False, False)


def test_the_snapshot_names_the_tilt_filter_and_follows_a_change():
    _, eng = make_engine()
    with eng:
        wait_for(lambda: eng.samples_total >= 300, what="data")
        snap = eng.snapshot(1.0)
        assert snap.angle_method == "gait-aware Kalman"
        assert snap.event_source == "fsr" and snap.fsr_faults == ()
        eng.apply_config(PipelineConfig(tilt_method="paper"))
        wait_for(lambda: eng.snapshot(0.1).angle_method == "Kalman (paper, seed 000)",
                 what="the paper's filter named")  # fmt: skip
        assert eng.config.tilt_method == "paper"


@pytest.mark.parametrize(("mode", "source"), [("tilt", ""), ("joint", "unit")])
def test_in_the_units_modes_the_angles_are_the_units_own(mode, source):
    _, eng = make_engine(mode)
    with eng:
        wait_for(lambda: eng.samples_total >= 200, what="data")
        eng.apply_config(PipelineConfig(tilt_method="paper"))  # saved, not in force
        n = eng.samples_total
        wait_for(lambda: eng.samples_total >= n + 100, what="data after the change")
        snap = eng.snapshot(1.0)
    assert snap.angle_method == "the unit's own Kalman"
    assert snap.event_source == source
    assert snap.fsr_faults == ()


def true_strides_between(unit, a, b):
    """True heel strikes (one per stride) at sample indices in (a, b]."""
    hs = unit.truth(0, b + 1).heel_strike_idx
    return int(np.sum((hs > a) & (hs <= b)))


@pytest.mark.parametrize(
    ("fault", "sensor", "reason"),
    [((True, False), "heel", "never loads"), ((False, True), "toe", "never unloads")],
)
def test_a_foot_sensor_failing_while_walking_is_flagged_within_5_strides_and_strides_go_on(
    fault, sensor, reason
):
    unit, eng = make_engine()
    with eng:
        wait_for(lambda: eng.samples_total >= 1200, what="10 s of walking")
        assert eng.snapshot(1.0).fsr_faults == ()
        broken_at = unit.set_foot_sensor_fault(*fault)
        wait_for(lambda: eng.snapshot(0.1).fsr_faults, what="the fault")
        snap = eng.snapshot(1.0)
        (notice,) = snap.fsr_faults
        assert (notice.sensor, notice.reason) == (sensor, reason)
        assert notice.message == f"{sensor} force sensor {reason}: gait events from the foot gyro"
        assert snap.event_source == "foot gyro"
        # the notice's time, on the unit's sample clock (no frame is lost in process)
        first_sample = int(unit.frame_log()[1][0])
        decided = first_sample + round(notice.t_s * eng.fs_hz)
        assert decided > broken_at
        assert 1 <= true_strides_between(unit, broken_at, decided) <= 5
        # the gait panel goes on counting strides, from the foot gyro, at the true stride time
        n0, at0 = snap.gait.n_strides, unit.samples_produced
        wait_for(lambda: true_strides_between(unit, at0, unit.samples_produced) >= 6,
                 what="6 more strides")  # fmt: skip
        wait_for(lambda: eng.snapshot(0.1).gait.n_strides >= n0 + 5, what="strides counted")
        snap = eng.snapshot(5.0)
        true_hs = unit.truth(0, unit.samples_produced).heel_strike_idx
        assert snap.gait.last_stride_time_s == pytest.approx(
            np.median(np.diff(true_hs[-6:])) / eng.fs_hz, rel=0.1
        )
        # another tilt filter reads the FSRs the same way: the sensor stays flagged and the
        # strides go on from the gyro without a break (they came from the broken sensor for
        # ~4 strides when a new pipeline checked afresh)
        n1 = eng.snapshot(0.1).gait.n_strides
        eng.apply_config(PipelineConfig(tilt_method="paper"))
        wait_for(lambda: eng.snapshot(0.1).angle_method == "Kalman (paper, seed 000)",
                 what="the new filter")  # fmt: skip
        at1 = unit.samples_produced
        wait_for(lambda: true_strides_between(unit, at1, unit.samples_produced) >= 5,
                 what="5 more strides")  # fmt: skip
        snap = eng.snapshot(0.1)
        assert snap.event_source == "foot gyro" and snap.fsr_faults == (notice,)
        # (a dead heel gives none: the new pipeline's first gyro stride needs two heel
        # strikes after its start and the detector's latency)
        assert snap.gait.n_strides >= n1 + 3
        # a new FSR threshold may be what mends a sensor: that one is checked afresh
        eng.apply_config(PipelineConfig(tilt_method="paper", fsr_threshold=900.0))
        wait_for(lambda: eng.snapshot(0.1).event_source == "fsr", what="a fresh check")
        wait_for(lambda: eng.snapshot(0.1).event_source == "foot gyro", what="found again")
        assert eng.snapshot(0.1).fsr_faults == (notice,)


def test_the_simulator_options_schedule_a_foot_sensor_fault(capsys):
    import argparse

    from gaitmon.commands.simulate import add_simulator_options, sim_config_from_args
    from gaitmon.io.sim.config import build_unit

    parser = argparse.ArgumentParser(prog="gaitmon simulate")
    add_simulator_options(parser)
    cfg = sim_config_from_args(parser.parse_args(["--heel-dead-at", "12.5"]))
    assert cfg.heel_dead_at_s == 12.5 and cfg.toe_stuck_at_s == float("inf")
    unit = build_unit(cfg)
    heel, toe = unit.sensors.fsr_fault_at(np.array([0, 1249, 1250, 9000]))
    assert heel.tolist() == [False, False, True, True] and not toe.any()
    with pytest.raises(SystemExit):
        parser.parse_args(["--toe-stuck-at", "-1"])
    assert "--toe-stuck-at: must be >= 0 s" in capsys.readouterr().err
