"""Standing calibration: known tilts and biases are recovered; movement is refused with a reason."""

from __future__ import annotations

import re

import numpy as np
import pytest

from gaitmon.dsp.calibration import (
    Calibration,
    CalibrationError,
    check_stillness,
    standing_calibration,
)
from gaitmon.dsp.channels import STANDARD_GRAVITY_MS2 as G

FS_HZ = 100.0
TILTS_RAD = np.array([0.05, -0.12, 0.3, -2.9])  # the foot near the atan2 jump on purpose
BIAS_RAD_S = np.array([0.02, -0.03, 0.15, -0.2])  # biases larger than the stillness limit


def _still(n: int = 200, tilts: np.ndarray = TILTS_RAD) -> tuple[np.ndarray, np.ndarray]:
    """Standing data with exactly-known means: gravity at ``tilts`` plus zero-mean ripple.

    The ripple is a whole number of sine periods, so its mean over the window is 0 (to rounding)
    and the true tilt is exactly ``tilts``; its size is well inside the stillness limits.
    """
    t = np.arange(n) / FS_HZ
    ripple = np.sin(2 * np.pi * 5.0 * t)  # 5 Hz: 10 whole periods in 2 s
    acc = np.empty((n, 4, 2))
    acc[:, :, 0] = G * np.cos(tilts) + 0.05 * ripple[:, None]
    acc[:, :, 1] = G * np.sin(tilts) - 0.05 * ripple[:, None]
    gyro = BIAS_RAD_S + 0.01 * ripple[:, None]
    return acc, gyro


def test_still_data_gives_the_known_tilts_and_biases():
    acc, gyro = _still()
    cal = standing_calibration(acc, gyro)
    np.testing.assert_allclose(cal.tilt_offset_rad, TILTS_RAD, rtol=0, atol=1e-9)
    np.testing.assert_allclose(cal.gyro_bias_rad_s, BIAS_RAD_S, rtol=0, atol=1e-9)


def test_applying_the_calibration_makes_standing_zero():
    acc, gyro = _still()
    cal = standing_calibration(acc, gyro)
    tilt = np.arctan2(acc[:, :, 1], acc[:, :, 0])
    # the ripple adds a little per-sample tilt; its mean is ~0 and nothing sits near +-pi
    calibrated = cal.apply_tilt(tilt)
    assert np.abs(calibrated).max() < 0.01
    np.testing.assert_allclose(cal.apply_gyro(gyro).mean(axis=0), 0.0, atol=1e-12)


def test_moving_segment_is_refused_with_a_reason_naming_it():
    acc, gyro = _still()
    t = np.arange(acc.shape[0]) / FS_HZ
    gyro = gyro.copy()
    gyro[:, 1] += 0.5 * np.sin(2 * np.pi * 1.0 * t)  # thigh swinging, RMS 0.35 rad/s
    # the message says what to do; the figures are the error's detail (a tooltip)
    with pytest.raises(CalibrationError) as err:
        standing_calibration(acc, gyro)
    assert str(err.value) == "Ask the patient to stand still: the thigh is moving"
    assert re.search(r"thigh gyro 0\.35\d* rad/s RMS exceeds 0\.05", err.value.detail)
    res = check_stillness(acc, gyro)
    assert not res.still
    assert "thigh" in res.reason and "shank" not in res.reason
    # orthogonal sines over whole periods: RMS = sqrt(0.5^2 / 2 + 0.01^2 / 2)
    assert res.gyro_rms_rad_s[1] == pytest.approx(np.sqrt((0.5**2 + 0.01**2) / 2), rel=1e-9)
    assert res.gyro_rms_rad_s[0] == pytest.approx(0.01 / np.sqrt(2), rel=1e-9)


def test_refusal_names_the_segments_that_move_most_in_plain_words():
    """The case seen in the live window: body 0.21 and thigh 1.61 rad/s RMS (limit 0.05); the
    old text was a list of figures, cut off in the status bar."""
    acc, gyro = _still()
    t = np.arange(acc.shape[0]) / FS_HZ
    swing = np.sqrt(2) * np.sin(2 * np.pi * 1.0 * t)  # unit RMS over whole periods
    gyro = gyro.copy()
    gyro[:, 0] += 0.21 * swing
    gyro[:, 1] += 1.61 * swing
    res = check_stillness(acc, gyro)
    assert res.message == "Ask the patient to stand still: the thigh is moving"
    assert "body gyro" in res.reason and "thigh gyro 1.61" in res.reason
    gyro[:, 2] += 1.4 * swing  # the shank swings about as much as the thigh
    res = check_stillness(acc, gyro)
    assert res.message == "Ask the patient to stand still: the thigh and shank are moving"
    still = check_stillness(*_still())
    assert still.still and still.message == "" and still.reason == ""


def test_accelerating_segment_is_refused():
    acc, gyro = _still()
    acc = acc.copy()
    acc[::2, 2, 0] += 1.0  # shank jolts: +-0.5 m/s^2 about the mean on x
    res = check_stillness(acc, gyro)
    assert not res.still
    assert "shank acceleration" in res.reason
    with pytest.raises(CalibrationError, match="shank"):
        standing_calibration(acc, gyro)


def test_a_bias_alone_is_not_movement():
    acc, gyro = _still()
    res = check_stillness(acc, gyro + 0.3)  # a large constant offset is bias, not motion
    assert res.still, res.reason


def test_window_too_short_is_refused():
    acc, gyro = _still(n=50)
    with pytest.raises(CalibrationError, match="too short"):
        standing_calibration(acc, gyro)
    # the minimum is configurable
    cal = standing_calibration(acc, gyro, min_duration_s=0.5)
    assert cal.tilt_offset_rad.shape == (4,)


def test_disconnected_accelerometer_is_refused():
    acc, gyro = _still()
    acc = acc.copy()
    acc[:, 3, :] = 0.01  # foot accelerometer reads nothing
    with pytest.raises(CalibrationError, match="foot reads"):
        standing_calibration(acc, gyro)


def test_nan_data_is_refused():
    acc, gyro = _still()
    gyro = gyro.copy()
    gyro[5, 0] = np.nan
    with pytest.raises(CalibrationError, match="body"):
        standing_calibration(acc, gyro)


def test_identity_and_round_trip():
    ident = Calibration.identity()
    assert np.array_equal(ident.tilt_offset_rad, np.zeros(4))
    assert np.array_equal(ident.gyro_bias_rad_s, np.zeros(4))
    cal = Calibration(TILTS_RAD, BIAS_RAD_S)
    back = Calibration.from_dict(cal.as_dict())
    assert np.array_equal(back.tilt_offset_rad, TILTS_RAD)
    assert np.array_equal(back.gyro_bias_rad_s, BIAS_RAD_S)
    with pytest.raises(ValueError):
        cal.tilt_offset_rad[0] = 1.0  # read-only, so a shared calibration cannot be mutated
    with pytest.raises(ValueError, match="shape"):
        Calibration(np.zeros(3), np.zeros(4))


def test_wrong_shapes_raise():
    acc, gyro = _still()
    with pytest.raises(ValueError, match="acc_ms2"):
        check_stillness(acc[:, :3], gyro)
    with pytest.raises(ValueError, match="gyro_rad_s"):
        check_stillness(acc, gyro[:-1])
