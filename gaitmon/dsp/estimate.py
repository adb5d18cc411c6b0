"""The public evaluation entry point: one segment's tilt by a named method.

``estimate_tilt(acc_x_ms2, acc_z_ms2, gyro_y_rad_s, fs_hz, *, segment="foot", method=...,
offline=False)`` takes 1-D arrays of one segment (accelerometer x and z in m/s^2, gyro about y in
rad/s, bias already removed if known) and returns the tilt in rad (continuous, not wrapped):

* ``"paper"`` -- "Kalman (paper, seed 000)": paper 000's pipeline exactly, i.e. the 4 Hz
  2nd-order Butterworth on the accelerometer, atan2, then gaitmon.dsp.kalman.TiltKalman with the
  paper's Q_angle, Q_gyro, R. It has no offline variant (``offline=True`` is refused).
* ``"gait-aware"`` -- gaitmon.dsp.motion_kalman.GaitAwareKalman (causal), or with
  ``offline=True`` the RTS smoother of gaitmon.dsp.smoother (zero lag, whole record).
"""

from __future__ import annotations

import numpy as np

METHODS: dict[str, str] = {
    "paper": "Kalman (paper, seed 000)",
    "gait-aware": "gait-aware Kalman",
}
OFFLINE_NAMES: dict[str, str] = {"gait-aware": "gait-aware Kalman + RTS smoother"}
DEFAULT_METHOD = "gait-aware"


def method_label(method: str, offline: bool = False) -> str:
    """The name shown to users and stored in files for a method (live or offline)."""
    check_method(method, offline)
    return OFFLINE_NAMES[method] if offline else METHODS[method]


def check_method(method: str, offline: bool = False) -> None:
    if method not in METHODS:
        raise ValueError(f"unknown tilt method {method!r}; use one of {sorted(METHODS)}")
    if offline and method not in OFFLINE_NAMES:
        raise ValueError(f"tilt method {method!r} has no offline smoother")


def estimate_tilt(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_y_rad_s: np.ndarray, fs_hz: float,
    *, segment: str = "foot", method: str = DEFAULT_METHOD, offline: bool = False,
) -> np.ndarray:  # fmt: skip
    """One segment's tilt (rad, (N,)) by ``method`` (see the module doc)."""
    check_method(method, offline)
    ax, az, w = (np.asarray(a, dtype=np.float64) for a in (acc_x_ms2, acc_z_ms2, gyro_y_rad_s))
    if not (ax.ndim == 1 and ax.shape == az.shape == w.shape):
        raise ValueError(
            f"acc_x, acc_z and gyro must be 1-D arrays of one length, got "
            f"{ax.shape}, {az.shape}, {w.shape}"
        )
    if method == "paper":
        from gaitmon.dsp.filters import Butterworth
        from gaitmon.dsp.kalman import TiltKalman

        acc = Butterworth(4.0, fs_hz, 2).process(np.stack([ax, az], axis=1))
        z = np.arctan2(acc[:, 1], acc[:, 0])
        return np.asarray(TiltKalman(dt_s=1.0 / fs_hz).process(z, w))
    if offline:
        from gaitmon.dsp.smoother import smooth_tilt

        return smooth_tilt(ax, az, w, fs_hz, segment)
    from gaitmon.dsp.motion_kalman import GaitAwareKalman

    return np.asarray(GaitAwareKalman(fs_hz, segments=(segment,)).process(ax, az, w))
