"""``gait-aware``: "gait-aware Kalman", the app's default tilt method, and its offline pass
"gait-aware Kalman + RTS smoother".

The causal filter (gaitmon.dsp.motion_kalman.GaitAwareKalman) trusts the accelerometer by how
much each segment moves, judged on the raw accelerometer (and, for the foot, follows it while
the board is turned out of the sagittal plane); the offline pass is the zero-lag RTS
smoother over the same model (gaitmon.dsp.smoother), whose first pass is this causal filter.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from gaitmon.dsp.methods.base import KalmanStage, TiltInput, TiltMethod, TiltSettings, TiltStage

if TYPE_CHECKING:  # imported where a record is filtered: listing the methods reads no filter
    from gaitmon.dsp.motion_kalman import GaitAwareKalman


class GaitAwareStage(KalmanStage):
    """GaitAwareKalman fed the raw accelerometer (it judges the motion on it)."""

    def __init__(self, kf: GaitAwareKalman) -> None:
        super().__init__(kf)
        self.kf: GaitAwareKalman = kf

    def process(self, block: TiltInput, /) -> np.ndarray:
        return self.kf.process(block.acc_x_ms2, block.acc_z_ms2, block.gyro_rad_s)


@dataclass(frozen=True)
class GaitAware(TiltMethod):
    name: ClassVar[str] = "gait-aware"
    label: ClassVar[str] = "gait-aware Kalman"
    offline_label: ClassVar[str | None] = "gait-aware Kalman + RTS smoother"
    live: ClassVar[bool] = True
    tip: ClassVar[str] = ("Trusts the accelerometer by how much each segment moves: 2-3.5x "
                          "closer to the simulator's truth than the paper's filter, and the "
                          "foot 3x closer on real walks (docs/filters.md)")  # fmt: skip

    def causal_stage(self, settings: TiltSettings) -> TiltStage:
        from gaitmon.dsp.motion_kalman import GaitAwareKalman

        return GaitAwareStage(GaitAwareKalman(settings.fs_hz))

    def estimate(
        self, acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray,
        fs_hz: float, segment: str,
    ) -> np.ndarray:  # fmt: skip
        from gaitmon.dsp.motion_kalman import GaitAwareKalman

        kf = GaitAwareKalman(fs_hz, segments=(segment,))
        return np.asarray(kf.process(acc_x_ms2, acc_z_ms2, gyro_rad_s))

    def offline(
        self, acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray,
        fs_hz: float, segment: str,
    ) -> np.ndarray:  # fmt: skip
        from gaitmon.dsp.smoother import smooth_tilt

        return smooth_tilt(acc_x_ms2, acc_z_ms2, gyro_rad_s, fs_hz, segment)

    def describe(self, settings: TiltSettings) -> str:
        return "(accelerometer weighted by the segment's motion; docs/filters.md)"
