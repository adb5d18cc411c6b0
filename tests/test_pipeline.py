"""The whole PC pipeline against the simulator's ground truth, and its chunking contract."""

import dataclasses

import numpy as np
import pytest
from helpers import assert_blocks_equal

from gaitmon.dsp.angles import joint_angles, wrap_angle
from gaitmon.dsp.calibration import standing_calibration
from gaitmon.dsp.pipeline import Pipeline, PipelineBlock, PipelineConfig
from gaitmon.engine.live_gait import GaitEvents
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

FS = 100.0
N = 9000  # 5 s standing, then ~85 s of walking


@pytest.fixture(scope="module")
def sim():
    gait = GaitModel(GaitConfig(seed=11, cadence_steps_min=105.0))
    return gait, simulate(N, gait, SensorConfig(seed=11))


@pytest.fixture(scope="module")
def calibrated(sim):
    _, sb = sim
    first = Pipeline().process(sb.counts[:450])
    cal = standing_calibration(first.acc_ms2[100:450], first.gyro_rad_s[100:450])
    return cal, Pipeline(calibration=cal).process(sb.counts)


def rmse_deg(est, truth, skip=1000):
    e = np.degrees(wrap_angle(est - truth))[skip:]
    return np.sqrt(np.mean(e**2, axis=0))


def test_calibration_recovers_the_simulated_mounting_and_bias(sim, calibrated):
    _gait, sb = sim
    cal, block = calibrated
    truth_bias = sb.gyro_bias_rad_s[100:450].mean(axis=0)
    np.testing.assert_allclose(cal.gyro_bias_rad_s, truth_bias, atol=0.005)
    # standing: every joint angle ~0 after zeroing
    standing = np.degrees(block.joint_kalman_rad[200:450])
    assert np.max(np.abs(standing.mean(axis=0))) < 1.0


def test_kalman_joint_angles_follow_ground_truth(sim, calibrated):
    _, sb = sim
    _, b = calibrated
    truth = sb.kinematics
    kalman = rmse_deg(b.joint_kalman_rad, truth.joint_rad)
    accel = rmse_deg(b.joint_acc_rad, truth.joint_rad)
    print(f"\njoint RMSE deg (hip, knee, ankle): Kalman {kalman.round(2)}, accel {accel.round(2)}")
    assert np.all(kalman < 8.0)
    # the point of the fusion: impacts and swing fool the accelerometer
    assert np.all(kalman < accel)
    tilt_k = rmse_deg(b.tilt_kalman_rad, truth.tilt_rad)
    tilt_a = rmse_deg(b.tilt_acc_rad, truth.tilt_rad)
    print(f"tilt RMSE deg (body..foot): Kalman {tilt_k.round(2)}, accel {tilt_a.round(2)}")
    assert np.all(tilt_k[1:] < tilt_a[1:])


def test_clinical_signs_knee_flexes_positive_in_swing(sim, calibrated):
    _, sb = sim
    _, b = calibrated
    knee = np.degrees(b.joint_kalman_rad[1500:, 1])
    assert 45.0 < knee.max() < 80.0
    assert knee.min() > -15.0
    # hip flexes (+) before heel strike and extends (-) in late stance, as in the truth
    hip_true = np.degrees(sb.kinematics.joint_rad[1500:, 0])
    hip = np.degrees(b.joint_kalman_rad[1500:, 0])
    assert np.corrcoef(hip, hip_true)[0, 1] > 0.9


def test_joint_angles_are_the_documented_tilt_differences(calibrated):
    _, b = calibrated
    t = b.tilt_kalman_rad
    np.testing.assert_allclose(b.joint_kalman_rad[:, 0], wrap_angle(t[:, 1] - t[:, 0]))
    np.testing.assert_allclose(b.joint_kalman_rad[:, 1], wrap_angle(t[:, 1] - t[:, 2]))
    np.testing.assert_allclose(b.joint_kalman_rad[:, 2], wrap_angle(t[:, 3] - t[:, 2]))
    np.testing.assert_array_equal(joint_angles(b.tilt_acc_rad), b.joint_acc_rad)


def test_gait_events_and_strides_match_ground_truth(sim, calibrated):
    gait, _ = sim
    _, b = calibrated
    hs_true, to_true = gait.events(0, N)
    # every true heel strike found once, within 20 ms (2 samples)
    assert len(b.heel_strike_idx) == len(hs_true)
    assert np.max(np.abs(b.heel_strike_idx - hs_true)) <= 2
    assert len(b.toe_off_idx) == len(to_true)
    assert np.max(np.abs(b.toe_off_idx - to_true)) <= 2
    stride_true = np.diff(hs_true) / FS
    # the strides as the engine makes them from these events (GaitEvents, the file's function)
    strides = GaitEvents(FS).strides(b.heel_strike_idx, b.toe_off_idx)
    assert len(strides) >= len(hs_true) - 2
    got = np.array([s.stride_time_s for s in strides])
    assert np.median(np.abs(got - stride_true[-len(got) :])) <= 0.02
    stance = np.mean([s.stance_pct for s in strides])
    assert 55.0 < stance < 65.0
    cadence = np.mean([s.cadence_derived_steps_per_min for s in strides])
    assert cadence == pytest.approx(105.0, rel=0.05)


def test_event_delay_compensation_equals_the_filter_group_delay(sim):
    _, sb = sim
    on = Pipeline(PipelineConfig()).process(sb.counts[:3000])
    off = Pipeline(PipelineConfig(compensate_event_delay=False)).process(sb.counts[:3000])
    assert PipelineConfig().event_delay_samples == 6  # 2nd order, 4 Hz at 100 Hz: 5.7 samples
    np.testing.assert_array_equal(off.heel_strike_idx - 6, on.heel_strike_idx)


def test_arbitrary_chunking_gives_exactly_the_whole_record_output(sim, calibrated):
    _, sb = sim
    cal, whole = calibrated
    rng = np.random.default_rng(5)
    p = Pipeline(calibration=cal)
    parts: list[PipelineBlock] = []
    i = 0
    while i < N:
        c = int(rng.choice([0, 1, 3, 10, 57, 640, 2100]))
        parts.append(p.process(sb.counts[i : i + c]))
        i += c
    assert_blocks_equal(parts, whole)
    assert [b.start_idx for b in parts] == list(np.cumsum([0] + [b.n for b in parts[:-1]]))
    np.testing.assert_array_equal(parts[-1].kalman_bias_rad_s, whole.kalman_bias_rad_s)


def test_reset_reproduces_the_first_run(sim):
    _, sb = sim
    p = Pipeline()
    first = p.process(sb.counts[:2000])
    p.reset()
    again = p.process(sb.counts[:2000])
    np.testing.assert_array_equal(first.tilt_kalman_rad, again.tilt_kalman_rad)
    assert again.start_idx == 0


@pytest.mark.parametrize(
    "change, word",
    [
        ({"cutoff_hz": 80.0}, "Nyquist"),
        ({"r": 0.0}, "r must"),
        ({"fsr_hysteresis": -5.0}, "hysteresis"),
        ({"q_gyro": -1.0}, "q_gyro"),
    ],
)
def test_bad_settings_are_refused_with_the_name(change, word):
    with pytest.raises(ValueError, match=word):
        PipelineConfig(**change)


def test_wrong_block_shape_is_refused():
    with pytest.raises(ValueError, match="shape"):
        Pipeline().process(np.zeros((10, 13), dtype=np.uint16))


def test_zeroing_mid_stream_causes_no_kalman_transient(sim):
    """After 20 s the filter has learnt the gyro bias; installing the same bias as a
    calibration must not disturb it (the bias state moves with the subtracted offset)."""
    _, sb = sim
    p = Pipeline()
    before = p.process(sb.counts[:2000])
    cal = standing_calibration(before.acc_ms2[100:450], before.gyro_rad_s[100:450])
    p.set_calibration(dataclasses.replace(cal, tilt_offset_rad=np.zeros(4)))
    after = p.process(sb.counts[2000:2600])
    reference = Pipeline().process(sb.counts[:2600])  # never recalibrated
    # same tilts as the uncalibrated run to within the bias-estimate mismatch, from sample 1
    diff = np.degrees(np.abs(after.tilt_kalman_rad - reference.tilt_kalman_rad[2000:]))
    assert diff.max() < 0.5
    np.testing.assert_allclose(
        after.kalman_bias_rad_s + cal.gyro_bias_rad_s, reference.kalman_bias_rad_s, atol=1e-3
    )
