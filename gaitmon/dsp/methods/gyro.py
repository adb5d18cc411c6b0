"""``gyro``: integration of the gyro rate from the first accelerometer tilt (paper 000's blue
curve, without its display low-pass)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from gaitmon.dsp.filters import GyroIntegrator, as_2d_pair
from gaitmon.dsp.methods.base import TiltFilter, TiltMethod


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


@dataclass(frozen=True)
class Gyro(TiltMethod):
    name: ClassVar[str] = "gyro"
    label: ClassVar[str] = "gyro integration"
    lab_name: ClassVar[str | None] = "gyro"

    def lab_filter(self, dt_s: float) -> TiltFilter:
        return GyroTilt(dt_s)
