"""The checks of the filters' settings, apart from the filters: the low-pass's
(:meth:`gaitmon.dsp.filters.Butterworth.check`) and the tilt Kalman filter's
(:meth:`gaitmon.dsp.kalman.TiltKalman.check`) call these, and so does
:class:`gaitmon.dsp.pipeline_config.PipelineConfig`, which checks a file's recorded settings
without loading the filters (``gaitmon info``: ~1.5 ms of imports, issue 28)."""

from __future__ import annotations

import numpy as np


def check_lowpass(cutoff_hz: float, fs_hz: float, order: int, initial: str = "first") -> None:
    """Raise ValueError naming the first bad setting of the Butterworth low-pass."""
    if not fs_hz > 0:
        raise ValueError(f"sample rate must be positive, got {fs_hz} Hz")
    if not 0 < cutoff_hz < fs_hz / 2:
        raise ValueError(
            f"cut-off {cutoff_hz} Hz must be above 0 and below the Nyquist frequency {fs_hz / 2} Hz"
        )
    if int(order) != order or order < 1 or order > 8:
        raise ValueError(f"filter order must be a whole number from 1 to 8, got {order}")
    if initial not in ("first", "zero"):
        raise ValueError(f"initial must be 'first' or 'zero', got {initial!r}")


def check_tilt_kalman(dt_s: float, q_angle: float, q_gyro: float, r: float, form: str) -> None:
    """Raise ValueError naming the first bad setting of the tilt Kalman filter."""
    for name, value in (("dt_s", dt_s), ("r", r)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value}")
    for name, value in (("q_angle", q_angle), ("q_gyro", q_gyro)):
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be zero or positive, got {value}")
    if form not in ("paper", "discrete"):
        raise ValueError(f"form must be 'paper' or 'discrete', got {form!r}")
