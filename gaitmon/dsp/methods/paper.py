"""``paper``: "Kalman (paper, seed 000)", paper 000's tilt Kalman filter exactly as published.

Fed the accelerometer tilt of the 4 Hz 2nd-order Butterworth-filtered accelerometer, with the
paper's Q_angle, Q_gyro and R (gaitmon.dsp.kalman.TiltKalman). In the pipeline it reads those
from the pipeline's settings; in the lab ("kalman (paper 000)") from its own parameters.
It has no offline variant.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from gaitmon.dsp.kalman import TiltKalman
from gaitmon.dsp.methods.base import (
    KalmanStage,
    ParamSpec,
    TiltFilter,
    TiltInput,
    TiltMethod,
    TiltSettings,
    TiltStage,
)


class PaperStage(KalmanStage):
    """TiltKalman on the low-passed accelerometer tilt, as paper 000 runs it."""

    def __init__(self, kf: TiltKalman) -> None:
        super().__init__(kf)
        self.kf: TiltKalman = kf

    def process(self, block: TiltInput, /) -> np.ndarray:
        return self.kf.process(block.acc_tilt_rad, block.gyro_rad_s)


@dataclass(frozen=True)
class PaperKalman(TiltMethod):
    q_angle: float = 0.001
    q_gyro: float = 0.003
    r: float = 0.3

    name: ClassVar[str] = "paper"
    label: ClassVar[str] = "Kalman (paper, seed 000)"
    live: ClassVar[bool] = True
    lab_name: ClassVar[str | None] = "kalman (paper 000)"
    tip: ClassVar[str] = ("The source paper's Kalman filter exactly as published "
                          "(Q_angle, Q_gyro and R in Settings)")  # fmt: skip
    noun: ClassVar[str] = "the paper's Kalman filter"
    reads_settings: ClassVar[tuple[str, ...]] = ("q_angle", "q_gyro", "r")
    param_specs: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("q_angle", "Q angle", 0.001, 1e-7, 10.0, 6),
        ParamSpec("q_gyro", "Q gyro", 0.003, 0.0, 10.0, 6),
        ParamSpec("r", "R (rad²)", 0.3, 1e-6, 100.0, 4),
    )

    def causal_stage(self, settings: TiltSettings) -> TiltStage:
        s = settings
        return PaperStage(TiltKalman(1.0 / s.fs_hz, s.q_angle, s.q_gyro, s.r, s.kalman_form))

    def estimate(
        self, acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray,
        fs_hz: float, segment: str,
    ) -> np.ndarray:  # fmt: skip
        from gaitmon.dsp.filters import Butterworth

        acc = Butterworth(4.0, fs_hz, 2).process(np.stack([acc_x_ms2, acc_z_ms2], axis=1))
        z = np.arctan2(acc[:, 1], acc[:, 0])
        kf = TiltKalman(1.0 / fs_hz, self.q_angle, self.q_gyro, self.r)
        return np.asarray(kf.process(z, gyro_rad_s))

    def lab_filter(self, dt_s: float) -> TiltFilter:
        return TiltKalman(dt_s, self.q_angle, self.q_gyro, self.r)

    def describe(self, settings: TiltSettings) -> str:
        s = settings
        return f"({s.kalman_form} form) Q_angle {s.q_angle:g}, Q_gyro {s.q_gyro:g}, R {s.r:g}"
