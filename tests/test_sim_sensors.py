"""The simulated sensors: sign conventions, gyro truth, FSR sub-phases, quantisation."""

import numpy as np
import pytest

from gaitmon.dsp.channels import (
    ACC_X_IDX,
    ACC_Z_IDX,
    DEFAULT_TABLE,
    FSR_IDX,
    GYRO_IDX,
    STANDARD_GRAVITY_MS2,
)
from gaitmon.io.sim.kinematics import HEEL_OFF_PHASE, TOE_OFF_PHASE, GaitConfig, GaitModel
from gaitmon.io.sim.sensors import FSR_THRESHOLD_COUNTS, SensorConfig, SensorModel

FS = 100.0
NOISE_FREE = {"acc_noise_ms2": 0.0, "gyro_noise_rad_s": 0.0, "fsr_noise_counts": 0.0}
ACC_LSB_MS2 = DEFAULT_TABLE.channels[0].units_per_count
GYRO_LSB_RAD_S = DEFAULT_TABLE.channels[2].units_per_count


def _model(gait: GaitConfig | None = None, **sensor) -> SensorModel:
    return SensorModel(GaitModel(gait or GaitConfig(seed=7)), SensorConfig(seed=7, **sensor))


def test_static_accel_tilt_is_true_tilt_plus_mount_offset():
    # Large, mixed-sign offsets exercise every quadrant sign of the convention, not just ~0.
    offsets = (0.5, -0.3, 1.2, -0.9)
    model = _model(mount_offset_rad=offsets, **NOISE_FREE)
    block = model.next_block(int(4 * FS))  # the subject is standing still
    phys = DEFAULT_TABLE.to_physical(block.counts)
    tilt = np.arctan2(phys[:, ACC_Z_IDX], phys[:, ACC_X_IDX])
    # half an LSB on each axis, seen at 1 g: the quantisation bound on the angle
    bound = np.hypot(0.5, 0.5) * ACC_LSB_MS2 / STANDARD_GRAVITY_MS2
    assert np.max(np.abs(tilt - (block.kinematics.tilt_rad + offsets))) <= bound
    # and the magnitude is 1 g: nothing but gravity while still
    g = np.hypot(phys[:, ACC_Z_IDX], phys[:, ACC_X_IDX])
    assert np.max(np.abs(g - STANDARD_GRAVITY_MS2)) < 2 * ACC_LSB_MS2


def test_mount_offsets_are_a_few_degrees_and_reproducible():
    a = _model().mount_offset_rad
    b = _model().mount_offset_rad
    np.testing.assert_array_equal(a, b)
    assert np.all(np.abs(np.rad2deg(a)) < 10.0)
    assert np.max(np.abs(np.rad2deg(a))) > 0.5  # zeroing matters
    assert len(set(np.round(a, 6))) == 4  # per board


def test_gyro_integrates_to_the_true_tilt_change_minus_bias():
    model = _model(**NOISE_FREE)
    block = model.next_block(int(40 * FS))  # standing 5 s, then walking
    phys = DEFAULT_TABLE.to_physical(block.counts)
    true_tilt = block.kinematics.tilt_rad
    # Standing: the gyro reads its bias, to within half an LSB.
    still = slice(0, int(4 * FS))
    assert np.max(np.abs(phys[still][:, GYRO_IDX] - block.gyro_bias_rad_s[still])) <= (
        0.5 * GYRO_LSB_RAD_S + 1e-12
    )
    # Walking: the bias-free rate integrates to the tilt change. Rounding errors of a varying
    # signal add up like a random walk (0.002 rad/s RMS each, ~0.1 deg over 30 s); the
    # trapezoid rule on the fast foot adds less than that.
    walk = slice(int(10 * FS), None)
    rate = (phys[:, GYRO_IDX] - block.gyro_bias_rad_s)[walk]
    integ = np.concatenate([np.zeros((1, 4)), np.cumsum(0.5 * (rate[1:] + rate[:-1]) / FS, axis=0)])
    err = integ - (true_tilt[walk] - true_tilt[walk][0])
    assert np.max(np.abs(err)) < np.deg2rad(0.5)
    # Without subtracting the bias the integral drifts by the bias times the time (trapezoid
    # rule: a plain sum is off by half the last sample's rate, up to ~1 deg on the foot).
    r = phys[walk][:, GYRO_IDX]
    raw = 0.5 * (r[1:] + r[:-1]).sum(axis=0) / FS
    b = block.gyro_bias_rad_s[walk]
    expected_drift = 0.5 * (b[1:] + b[:-1]).sum(axis=0) / FS
    assert np.all(np.abs(expected_drift) > np.deg2rad(5.0))  # biases are big enough to matter
    np.testing.assert_allclose(
        raw - (true_tilt[-1] - true_tilt[walk][0]), expected_drift, atol=np.deg2rad(1.0)
    )


def test_gyro_sign_matches_accel_tilt_rate_while_walking():
    model = _model(**NOISE_FREE)
    block = model.next_block(int(30 * FS))
    walking = slice(int(10 * FS), None)
    d_tilt = np.gradient(block.kinematics.tilt_rad[walking], 1 / FS, axis=0)
    gyro = DEFAULT_TABLE.to_physical(block.counts)[walking][:, GYRO_IDX]
    for seg in range(1, 4):  # body barely moves
        assert np.corrcoef(d_tilt[:, seg], gyro[:, seg])[0, 1] > 0.99


def _boundaries(mask: np.ndarray) -> np.ndarray:
    return np.flatnonzero(np.diff(mask.astype(np.int8)) != 0) + 1


@pytest.mark.parametrize("pattern", ["normal", "long-stance"])
def test_fsr_is_loaded_exactly_in_its_sub_phases(pattern):
    model = _model(GaitConfig(seed=7, pattern=pattern), **NOISE_FREE)
    block = model.next_block(int(60 * FS))
    q = np.mod(block.kinematics.phase, 1.0)
    expected = {
        "heel": q < HEEL_OFF_PHASE,  # heel strike .. heel off
        "toe": (q >= 0.10) & (q < TOE_OFF_PHASE),  # foot flat .. toe off
    }
    edge = int(np.ceil(model.config.fsr_edge_s * FS))
    for j, name in enumerate(("heel", "toe")):
        loaded = block.counts[:, FSR_IDX[j]] > FSR_THRESHOLD_COUNTS
        exp = expected[name]
        wrong = np.flatnonzero(loaded != exp)
        near = _boundaries(exp)
        assert len(near) > 80  # many strides checked
        # every disagreement sits in the ramp at a boundary, never mid-phase or mid-swing
        dist = np.min(np.abs(wrong[:, None] - near[None, :]), axis=1) if len(wrong) else []
        assert np.all(np.asarray(dist) <= edge), name
        peaks = block.counts[exp, FSR_IDX[j]]
        assert np.percentile(peaks, 50) > 1.5 * FSR_THRESHOLD_COUNTS  # well above threshold
        assert peaks.max() > 2.5 * FSR_THRESHOLD_COUNTS
        assert block.counts[~exp, FSR_IDX[j]].max() < FSR_THRESHOLD_COUNTS
    swing = q >= TOE_OFF_PHASE + 0.02
    assert block.counts[swing][:, FSR_IDX].max() < 100  # zero-ish in swing


def test_counts_saturate_at_the_adc_range():
    # Impacts far beyond the +-5.5 g span drive the x axes into both rails.
    model = _model(impact_peak_ms2=(1000.0, 1000.0, 1000.0, 1000.0))
    block = model.next_block(int(20 * FS))
    x = block.counts[:, ACC_X_IDX]
    phys = block.physical[:, ACC_X_IDX]
    assert block.counts.dtype == np.uint16
    assert x.max() == 4095 and x.min() == 0
    expected = DEFAULT_TABLE.to_physical(np.full((1, 14), 4095))[0, ACC_X_IDX]
    assert np.all(x[phys > expected + ACC_LSB_MS2] == 4095)
    low = DEFAULT_TABLE.to_physical(np.zeros((1, 14)))[0, ACC_X_IDX]
    assert np.all(x[phys < low - ACC_LSB_MS2] == 0)
    inside = (phys > low + ACC_LSB_MS2) & (phys < expected - ACC_LSB_MS2)
    assert np.all((x[inside] > 0) & (x[inside] < 4095))  # no wrap-around, no early clipping


def test_heel_strikes_make_impact_transients():
    model = _model()
    block = model.next_block(int(40 * FS))
    hs, _ = model.gait.events(0, len(block.counts))
    foot_x = block.physical[:, ACC_X_IDX[3]]
    quiet = foot_x - np.convolve(foot_x, np.ones(15) / 15, mode="same")
    at_hs = np.concatenate([np.abs(quiet[h : h + 3]) for h in hs[1:-1]])
    assert np.median(at_hs) > 3 * np.median(np.abs(quiet[int(6 * FS) :]))


def test_any_chunking_gives_the_same_samples():
    whole = _model().next_block(5000)
    model = _model()
    parts = [model.next_block(n) for n in (1, 499, 1000, 3, 2497, 1000)]
    np.testing.assert_array_equal(np.concatenate([p.counts for p in parts]), whole.counts)
    model.reset()
    np.testing.assert_array_equal(model.next_block(100).counts, whole.counts[:100])


def test_realism_options_are_off_by_default_and_change_only_what_they_model():
    from gaitmon.io.sim.sensors import realistic_sensors, simulate

    gait = GaitModel(GaitConfig(seed=5))
    plain = simulate(3000, gait, SensorConfig(seed=5))
    real = simulate(3000, GaitModel(GaitConfig(seed=5)), realistic_sensors(5, turns=True))
    # the truth is the bone's: the same motion under both sensor models
    np.testing.assert_array_equal(plain.kinematics.tilt_rad, real.kinematics.tilt_rad)
    standing = slice(0, 400)  # no heel strike, no turn yet: the same accelerometer samples
    acc = np.concatenate([ACC_X_IDX, ACC_Z_IDX])
    np.testing.assert_array_equal(plain.counts[standing][:, acc], real.counts[standing][:, acc])
    walking = slice(1500, 3000)
    assert np.any(plain.counts[walking] != real.counts[walking])
    # in chunks: the same samples (wobble and turns are functions of time)
    model = SensorModel(GaitModel(GaitConfig(seed=5)), realistic_sensors(5, turns=True))
    parts = np.concatenate([model.next_block(c).counts for c in (1, 999, 2000)])
    np.testing.assert_array_equal(parts, real.counts)
