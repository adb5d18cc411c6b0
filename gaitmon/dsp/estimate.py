"""The public evaluation entry point: one segment's tilt by a named method.

``estimate_tilt(acc_x_ms2, acc_z_ms2, gyro_y_rad_s, fs_hz, *, segment="foot", method=...,
offline=False)`` takes 1-D arrays of one segment (accelerometer x and z in m/s^2, gyro about y in
rad/s, bias already removed if known) and returns the tilt in rad (continuous, not wrapped), by
any method of the registry (gaitmon.dsp.methods):

* ``"paper"`` -- "Kalman (paper, seed 000)": paper 000's pipeline exactly, i.e. the 4 Hz
  2nd-order Butterworth on the accelerometer, atan2, then gaitmon.dsp.kalman.TiltKalman with the
  paper's Q_angle, Q_gyro, R. It has no offline variant (``offline=True`` is refused).
* ``"gait-aware"`` -- gaitmon.dsp.motion_kalman.GaitAwareKalman (causal), or with
  ``offline=True`` the RTS smoother of gaitmon.dsp.smoother (zero lag, whole record).
* the lab's methods (``"accelerometer"``, ``"complementary"``, ...): their filter on the
  accelerometer tilt of the raw axes.
"""

from __future__ import annotations

import numpy as np

from gaitmon.dsp.methods import DEFAULT_METHOD, get_method, method_label

__all__ = ["DEFAULT_METHOD", "check_method", "estimate_tilt", "method_label"]


def check_method(method: str, offline: bool = False) -> None:
    """ValueError unless the app offers ``method`` (and, with ``offline``, its offline pass)."""
    get_method(method, offline, live=True)


def estimate_tilt(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_y_rad_s: np.ndarray, fs_hz: float,
    *, segment: str = "foot", method: str = DEFAULT_METHOD, offline: bool = False,
) -> np.ndarray:  # fmt: skip
    """One segment's tilt (rad, (N,)) by ``method`` (see the module doc)."""
    m = get_method(method, offline)
    ax, az, w = (np.asarray(a, dtype=np.float64) for a in (acc_x_ms2, acc_z_ms2, gyro_y_rad_s))
    if not (ax.ndim == 1 and ax.shape == az.shape == w.shape):
        raise ValueError(
            f"acc_x, acc_z and gyro must be 1-D arrays of one length, got "
            f"{ax.shape}, {az.shape}, {w.shape}"
        )
    if offline:
        return m.offline(ax, az, w, fs_hz, segment)
    return m.estimate(ax, az, w, fs_hz, segment)
