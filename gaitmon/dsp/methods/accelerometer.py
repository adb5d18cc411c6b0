"""``accelerometer``: the accelerometer tilt itself, unfiltered (paper 000's red curve; the
"no filter" reference of the lab)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from gaitmon.dsp.filters import as_2d_pair
from gaitmon.dsp.methods.base import TiltFilter, TiltMethod


class AccelerometerTilt:
    """The accelerometer tilt passed through unchanged (the 'no filter' reference)."""

    def process(self, acc_tilt_rad: np.ndarray, gyro_rad_s: np.ndarray) -> np.ndarray:
        z, _, was_1d = as_2d_pair(acc_tilt_rad, gyro_rad_s)
        return z[:, 0].copy() if was_1d else z.copy()

    def reset(self) -> None:
        pass


@dataclass(frozen=True)
class Accelerometer(TiltMethod):
    name: ClassVar[str] = "accelerometer"
    label: ClassVar[str] = "accelerometer tilt"
    lab_name: ClassVar[str | None] = "accelerometer"

    def lab_filter(self, dt_s: float) -> TiltFilter:
        return AccelerometerTilt()
