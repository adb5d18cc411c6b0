"""Tilt against optical ground truth on real IMU recordings (BROAD, CC BY 4.0, Laidig et al. 2021).

Skips on a fresh clone where ../shared/data is absent. The reference planar tilt is
atan2(u_z, u_x) with u = R^T e_z (earth-up in sensor coordinates), valid while |u_y| < 0.5.
"""

import numpy as np
import pytest
from scipy import signal

from gaitmon.dsp.angles import accel_tilt, wrap_angle
from gaitmon.dsp.filters import Butterworth
from gaitmon.dsp.kalman import TiltKalman

h5py = pytest.importorskip("h5py")


def load_trial(root, name):
    with h5py.File(root / "broad" / f"{name}.hdf5", "r") as f:
        assert f.attrs["sampling_rate"] == pytest.approx(2000 / 7)
        acc, gyr, q = f["imu_acc"][:], f["imu_gyr"][:], f["opt_quat"][:]
    w, x, y, z = q.T
    up = np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1)
    lost = np.isnan(up).any(axis=1)

    def to_100hz(a):  # 2000/7 Hz -> 100 Hz
        return signal.resample_poly(np.nan_to_num(a), 7, 20, axis=0)

    lost100 = signal.resample_poly(lost.astype(float), 7, 20) > 0.01
    up100 = to_100hz(up)
    ref = np.arctan2(up100[:, 2], up100[:, 0])
    valid = ~lost100 & (np.abs(up100[:, 1]) < 0.5)
    valid[:200] = False  # resampling edge and filter start
    return to_100hz(acc), to_100hz(gyr), ref, valid


def tilt_errors_deg(root, name):
    acc, gyr, ref, valid = load_trial(root, name)
    acc_f = Butterworth().process(acc)
    t_acc = accel_tilt(acc_f[:, 0], acc_f[:, 2])
    t_kal = TiltKalman().process(t_acc, gyr[:, 1])

    def rms(est):
        return float(np.degrees(np.sqrt(np.mean(wrap_angle(est - ref)[valid] ** 2))))

    return rms(t_acc), rms(t_kal), int(valid.sum())


def test_gyro_y_is_the_rate_of_the_planar_tilt(shared_data):
    _acc, gyr, ref, valid = load_trial(shared_data, "16_undisturbed_fast_translation_B")
    rate = np.gradient(np.unwrap(ref)) * 100.0
    r = np.corrcoef(rate[valid], gyr[valid, 1])[0, 1]
    assert r > 0.95  # the sign convention gaitmon relies on: d(atan2(a_z, a_x))/dt = +gyr_y


def test_fast_translation_accelerometer_is_not_trusted_blindly(shared_data):
    acc_deg, kal_deg, n = tilt_errors_deg(shared_data, "16_undisturbed_fast_translation_B")
    print(
        f"\nBROAD 16 fast translation, {n} samples at 100 Hz: tilt RMS error vs optical "
        f"reference: accelerometer only {acc_deg:.1f} deg, paper's Kalman {kal_deg:.1f} deg"
    )
    # linear acceleration corrupts atan2(a_z, a_x); the gyro-fused estimate must stray less
    assert kal_deg < 0.85 * acc_deg
    assert acc_deg > 20.0  # this trial really does disturb the accelerometer


def test_slow_rotation_accelerometer_tilt_matches_optical_geometry(shared_data):
    acc_deg, kal_deg, _n = tilt_errors_deg(shared_data, "02_undisturbed_slow_rotation_B")
    print(f"\nBROAD 02 slow rotation: accelerometer {acc_deg:.1f} deg, Kalman {kal_deg:.1f} deg")
    # with little linear acceleration the accelerometer tilt is the optical tilt: this checks
    # the axis convention and the reference computation, not the filter
    assert acc_deg < 5.0


BROAD_TRIALS = (
    "02_undisturbed_slow_rotation_B",
    "07_undisturbed_fast_rotation_B",
    "16_undisturbed_fast_translation_B",
    "24_disturbed_tapping_A",
)


@pytest.mark.parametrize("trial", BROAD_TRIALS)
def test_live_foot_filter_is_never_worse_than_the_papers(shared_data, trial):
    """Issue 24: where the gait model fails (3-D rotation, translation, impacts; no foot-flat),
    the live gait-aware filter (foot tuning) still does at least as well as the paper's (+1 deg).
    Before the out-of-plane rule and the foot's gravity measurement: 42 / 42 / 77 / 46 deg
    against the paper's 21 / 12 / 43 / 34."""
    from gaitmon.dsp.estimate import estimate_tilt

    acc, gyr, ref, valid = load_trial(shared_data, trial)
    gy = gyr[:, 1] - gyr[20:100, 1].mean()  # at rest in its first second (as the lab)

    def rms(method):
        est = estimate_tilt(acc[:, 0], acc[:, 2], gy, 100.0, segment="foot", method=method)
        return float(np.degrees(np.sqrt(np.mean(wrap_angle(est - ref)[valid] ** 2))))

    paper, live = rms("paper"), rms("gait-aware")
    print(f"\nBROAD {trial[:2]}: foot tilt RMS paper {paper:.1f} deg, live {live:.1f} deg")
    assert live <= paper + 1.0
