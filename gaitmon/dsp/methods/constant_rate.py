"""``constant-rate``: paper 001's per-axis [angle, rate] Kalman model used on the
accelerometer tilt as its angle measurement (q = 1, R = 0.3 rad^2, paper 000's R, because
paper 001's R recipe needs a whole record)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from gaitmon.dsp.filters import as_2d_pair
from gaitmon.dsp.methods.base import ParamSpec, TiltFilter, TiltMethod

if TYPE_CHECKING:  # the model itself is imported when a record is filtered, not to list the
    # methods (reading a file, ``gaitmon info``, ``process --help`` read only the registry)
    from gaitmon.dsp.kalman_models import LinearKalman


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
                from gaitmon.dsp.kalman_models import constant_rate_kalman

                x0 = np.zeros(2 * z.shape[1])
                x0[0::2] = z[0]  # start from the first accelerometer tilt, as paper 000 does
                self._kf = constant_rate_kalman(
                    self.dt_s, self.r_rad2, self.q, n_axes=z.shape[1], x0=x0
                )
            angles = self._kf.process(z, w)[:, 0::2]
        return angles[:, 0] if was_1d else angles

    def reset(self) -> None:
        self._kf = None


@dataclass(frozen=True)
class ConstantRate(TiltMethod):
    q: float = 1.0
    r_rad2: float = 0.3

    name: ClassVar[str] = "constant-rate"
    label: ClassVar[str] = "Kalman, constant-rate model (paper 001)"
    lab_name: ClassVar[str | None] = "kalman constant-rate (paper 001)"
    param_specs: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("q", "q (spectral density)", 1.0, 1e-6, 1e6, 4),
        ParamSpec("r_rad2", "R (rad²)", 0.3, 1e-6, 100.0, 4),
    )

    def lab_filter(self, dt_s: float) -> TiltFilter:
        return ConstantRateTilt(dt_s, self.q, self.r_rad2)
