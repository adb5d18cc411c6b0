"""The pipeline's tilt method choice, the FSR check against the foot gyro and the fallback to the
gyro's events, and what a stored configuration without a method means."""

import numpy as np
import pytest

from gaitmon.dsp.channels import FSR_IDX
from gaitmon.dsp.gait import strides_from_events
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.engine.live_gait import GaitEvents
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

N = 6000
ONSET = 3000  # the heel sensor dies 30 s in


@pytest.fixture(scope="module")
def sim():
    gait = GaitModel(GaitConfig(seed=41))
    sb = simulate(N, gait, SensorConfig(seed=41))
    return gait, sb


def dead(counts, col, value):
    c = counts.copy()
    c[ONSET:, FSR_IDX[col]] = value
    return c


def test_default_method_is_gait_aware_and_the_paper_stays_selectable(sim):
    _, sb = sim
    assert PipelineConfig().tilt_method == "gait-aware"
    assert PipelineConfig(tilt_method="paper").tilt_method_label == "Kalman (paper, seed 000)"
    with pytest.raises(ValueError, match="unknown tilt method"):
        PipelineConfig(tilt_method="best")
    gait_aware = Pipeline().process(sb.counts[:2000]).tilt_kalman_rad
    paper = Pipeline(PipelineConfig(tilt_method="paper")).process(sb.counts[:2000])
    assert not np.allclose(gait_aware, paper.tilt_kalman_rad)


def test_a_stored_configuration_without_a_method_was_the_papers():
    old = {k: v for k, v in PipelineConfig().as_dict().items()
           if k not in ("tilt_method", "fsr_check")}  # fmt: skip
    cfg = PipelineConfig.from_stored({**old, "a_future_key": 1})
    assert cfg.tilt_method == "paper" and cfg.fsr_check is False
    assert PipelineConfig.from_stored(PipelineConfig().as_dict()) == PipelineConfig()


def test_healthy_sensors_raise_no_fault_and_gyro_events_agree(sim):
    gait, sb = sim
    b = Pipeline().process(sb.counts)
    assert b.fsr_faults == () and b.event_source == "fsr"
    true_hs, _ = gait.events(0, N)
    gyro_hs = np.asarray(b.gyro_heel_strike_idx)
    near = np.abs(gyro_hs[:, None] - true_hs[None, :]).min(axis=1)
    assert len(gyro_hs) >= len(true_hs) - 2 and np.all(near <= 4)


@pytest.mark.parametrize(
    ("col", "value", "sensor", "reason"),
    [(0, 15, "heel", "never loads"), (1, 4095, "toe", "never unloads")],
)
def test_a_dead_sensor_is_flagged_within_5_strides_and_events_come_from_the_gyro(
    sim, col, value, sensor, reason
):
    gait, sb = sim
    counts = dead(sb.counts, col, value)
    p = Pipeline()
    b = p.process(counts)
    assert [(f.sensor, f.reason) for f in b.fsr_faults] == [(sensor, reason)]
    fault = b.fsr_faults[0]
    true_hs, _ = gait.events(0, N)
    strides_until_known = np.sum((true_hs > ONSET) & (true_hs <= fault.decided_idx))
    assert strides_until_known <= 5
    assert b.event_source == "foot gyro" and p.event_source == "foot gyro"
    assert "foot gyro" in fault.message()
    # strides go on after the fault, at the true stride times
    strides = GaitEvents(100.0).strides(b.heel_strike_idx, b.toe_off_idx)  # the engine's
    late = [s for s in strides if s.start_idx > fault.decided_idx]
    assert len(late) >= 10
    truth = strides_from_events(true_hs, gait.events(0, N)[1], 100.0)
    true_starts = np.array([s.start_idx for s in truth])
    assert all(np.min(np.abs(true_starts - s.start_idx)) <= 4 for s in late)
    # the same in chunks
    p2 = Pipeline()
    parts = [p2.process(counts[i : i + 377]) for i in range(0, N, 377)]
    assert [f for q in parts for f in q.fsr_faults] == list(b.fsr_faults)
    np.testing.assert_array_equal(np.concatenate([q.heel_strike_idx for q in parts]),
                                  b.heel_strike_idx)  # fmt: skip
    live = GaitEvents(100.0)
    assert [s for q in parts for s in live.strides(q.heel_strike_idx, q.toe_off_idx)] == strides


def test_fsr_check_can_be_turned_off(sim):
    _, sb = sim
    b = Pipeline(PipelineConfig(fsr_check=False)).process(dead(sb.counts, 0, 15))
    assert b.fsr_faults == () and b.gyro_heel_strike_idx == () and b.event_source == "fsr"
