"""Every sagittal tilt filter gaitmon knows, behind one interface, for the lab and for a UI to list.

A tilt filter is a streaming stage with

    process(acc_tilt_rad, gyro_rad_s) -> tilt_rad      # (N,) or (N, segments), same shape out
    reset()

Inputs: the accelerometer tilt atan2(a_z, a_x) and the (bias-corrected) gyro rate about the
hinge axis, whose sign makes d(tilt)/dt = +gyro (see gaitmon.dsp.channels). Outputs are
continuous angles (not wrapped); wrap them with gaitmon.dsp.angles.wrap_angle for display.
Any chunking of the input gives the same output as one call on the whole record.

``TILT_FILTERS`` maps a display name to a factory ``(dt_s) -> filter`` with the defaults below:

* "accelerometer"             -- the accelerometer tilt itself (paper 000's red curve);
* "gyro"                      -- integration of the rate from the first accelerometer tilt
                                 (paper 000's blue curve, without its display low-pass);
* "complementary"             -- paper 003 at its 3 Hz cut-off;
* "complementary (adaptive)"  -- paper 003 with the FFT-chosen cut-off (gaitmon.dsp.complementary);
* "kalman (paper 000)"        -- gaitmon.dsp.kalman.TiltKalman with the paper's parameters;
* "kalman constant-rate (paper 001)" -- paper 001's per-axis [angle, rate] model used on the
                                 accelerometer tilt as its angle measurement (q = 1, R = 0.3 rad^2,
                                 paper 000's R, because paper 001's R recipe needs a whole record).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol, runtime_checkable

import numpy as np

from gaitmon.dsp.complementary import AdaptiveCutoff, ComplementaryFilter
from gaitmon.dsp.filters import GyroIntegrator, as_2d_pair
from gaitmon.dsp.kalman import TiltKalman
from gaitmon.dsp.kalman_models import LinearKalman, constant_rate_kalman


@runtime_checkable
class TiltFilter(Protocol):
    def process(self, acc_tilt_rad: np.ndarray, gyro_rad_s: np.ndarray) -> np.ndarray: ...

    def reset(self) -> None: ...


class AccelerometerTilt:
    """The accelerometer tilt passed through unchanged (the 'no filter' reference)."""

    def process(self, acc_tilt_rad: np.ndarray, gyro_rad_s: np.ndarray) -> np.ndarray:
        z, _, was_1d = as_2d_pair(acc_tilt_rad, gyro_rad_s)
        return z[:, 0].copy() if was_1d else z.copy()

    def reset(self) -> None:
        pass


class GyroTilt:
    """theta(k) = theta(k-1) + omega(k) dt, theta(-1) = the first accelerometer tilt."""

    def __init__(self, dt_s: float = 0.01) -> None:
        self._integrator = GyroIntegrator(dt_s)
        self._started = False

    def process(self, acc_tilt_rad: np.ndarray, gyro_rad_s: np.ndarray) -> np.ndarray:
        z, w, was_1d = as_2d_pair(acc_tilt_rad, gyro_rad_s)
        if not self._started and z.shape[0]:
            self._started = True
            tilt = self._integrator.process(w, initial_rad=z[0])
        else:
            tilt = self._integrator.process(w)
        return tilt[:, 0] if was_1d else tilt

    def reset(self) -> None:
        self._integrator.reset()
        self._started = False


class ConstantRateTilt:
    """Paper 001's constant-rate Kalman model as a tilt filter, one axis per segment."""

    def __init__(self, dt_s: float = 0.01, q: float = 1.0, r_rad2: float = 0.3) -> None:
        self.dt_s, self.q, self.r_rad2 = float(dt_s), float(q), float(r_rad2)
        self._kf: LinearKalman | None = None

    def process(self, acc_tilt_rad: np.ndarray, gyro_rad_s: np.ndarray) -> np.ndarray:
        z, w, was_1d = as_2d_pair(acc_tilt_rad, gyro_rad_s)
        if z.shape[0] == 0:
            angles = z.copy()
        else:
            if self._kf is None:
                x0 = np.zeros(2 * z.shape[1])
                x0[0::2] = z[0]  # start from the first accelerometer tilt, as paper 000 does
                self._kf = constant_rate_kalman(
                    self.dt_s, self.r_rad2, self.q, n_axes=z.shape[1], x0=x0
                )
            angles = self._kf.process(z, w)[:, 0::2]
        return angles[:, 0] if was_1d else angles

    def reset(self) -> None:
        self._kf = None


TILT_FILTERS: dict[str, Callable[[float], TiltFilter]] = {
    "accelerometer": lambda dt_s: AccelerometerTilt(),
    "gyro": lambda dt_s: GyroTilt(dt_s),
    "complementary": lambda dt_s: ComplementaryFilter(dt_s, cutoff_hz=3.0),
    "complementary (adaptive)": lambda dt_s: ComplementaryFilter(
        dt_s, cutoff_hz=3.0, adaptive=AdaptiveCutoff()
    ),
    "kalman (paper 000)": lambda dt_s: TiltKalman(dt_s),
    "kalman constant-rate (paper 001)": lambda dt_s: ConstantRateTilt(dt_s),
}


def make_tilt_filter(name: str, dt_s: float = 0.01) -> TiltFilter:
    """A fresh filter by its registry name (clear error for an unknown one)."""
    try:
        factory = TILT_FILTERS[name]
    except KeyError:
        known = ", ".join(TILT_FILTERS)
        raise ValueError(f"unknown tilt filter {name!r}; known: {known}") from None
    return factory(dt_s)
