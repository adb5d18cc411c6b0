"""Streaming linear filters of paper 000: the Butterworth low-pass and gyro integration.

Both are designed and run by :mod:`gaitmon.dsp.iir` (numpy alone: no scipy on the live or
``process`` path) and carry their state across blocks, so a record processed in any chunking
gives bit-for-bit the output of one call on the whole record.
"""

from __future__ import annotations

import numpy as np

from gaitmon.dsp.iir import LinearFilter, butter_lowpass, lfilter_zi, running_sum
from gaitmon.dsp.setting_checks import check_lowpass


def as_2d(x: np.ndarray) -> tuple[np.ndarray, bool]:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        return x[:, None], True
    if x.ndim != 2:
        raise ValueError(f"expected an array of shape (N,) or (N, channels), got {x.shape}")
    return x, False


def as_2d_pair(
    acc_tilt_rad: np.ndarray, gyro_rad_s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, bool]:
    """A tilt filter's two inputs as (N, segments) float arrays, and whether they were (N,)."""
    if np.shape(acc_tilt_rad) != np.shape(gyro_rad_s):
        raise ValueError(
            f"tilt {np.shape(acc_tilt_rad)} and gyro {np.shape(gyro_rad_s)} shapes differ"
        )
    z, was_1d = as_2d(acc_tilt_rad)
    w, _ = as_2d(gyro_rad_s)
    return z, w, was_1d


class ChannelFilter:
    """Block handling shared by the per-channel linear filters.

    ``process`` takes (N,) or (N, channels) and returns the same shape; the state is created from
    the first sample and must keep the same channel count afterwards. Subclasses provide
    ``_initial_state(first_row)``: the stages (:class:`gaitmon.dsp.iir.LinearFilter`, in
    cascade) started for that first sample.
    """

    _stages: list[LinearFilter] | None = None
    _channels = 0

    def reset(self) -> None:
        self._stages = None

    def _initial_state(self, first: np.ndarray) -> list[LinearFilter]:
        raise NotImplementedError

    def _filter(self, x2: np.ndarray) -> np.ndarray:
        assert self._stages is not None
        y = x2
        for stage in self._stages:
            y = stage.process(y)
        return y

    def process(self, x: np.ndarray) -> np.ndarray:
        """Filter (N,) or (N, channels) along time; returns the same shape."""
        x2, was_1d = as_2d(x)
        if x2.shape[0] == 0:
            y = np.empty_like(x2)
        else:
            if self._stages is None:
                self._stages = self._initial_state(x2[0])
                self._channels = x2.shape[1]
            elif self._channels != x2.shape[1]:
                raise ValueError(
                    f"this filter carries state for {self._channels} channels, got {x2.shape[1]}"
                )
            y = self._filter(x2)
        return y[:, 0] if was_1d else y


class Butterworth(ChannelFilter):
    """Order-n Butterworth low-pass designed from (cutoff_hz, fs_hz, order), over any channels.

    The paper's 4 Hz / 100 Hz / order-2 filter is y(k) = A x(k) + B x(k-1) + C x(k-2) + D y(k-1)
    + E y(k-2), i.e. b = [A, B, C], a = [1, -D, -E] (see ``paper_coefficients``).

    ``initial="first"`` (default) starts the filter in steady state at the first sample, so a
    record that starts at 1 g does not show a start-up ramp from zero; ``initial="zero"`` is the
    bare difference equation with zero history, as on the microcontroller.
    """

    def __init__(
        self,
        cutoff_hz: float = 4.0,
        fs_hz: float = 100.0,
        order: int = 2,
        initial: str = "first",
    ) -> None:
        self.check(cutoff_hz, fs_hz, order, initial)
        self.cutoff_hz = float(cutoff_hz)
        self.fs_hz = float(fs_hz)
        self.order = int(order)
        self.initial = initial
        b, a = butter_lowpass(self.order, self.cutoff_hz, self.fs_hz)
        self.b: np.ndarray = b
        self.a: np.ndarray = a
        self._zi_unit = lfilter_zi(b, a)

    @staticmethod
    def check(cutoff_hz: float, fs_hz: float, order: int, initial: str = "first") -> None:
        """Raise ValueError naming the first bad setting (no filter is designed)."""
        check_lowpass(cutoff_hz, fs_hz, order, initial)

    @property
    def coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """(b, a) with a[0] == 1."""
        return self.b.copy(), self.a.copy()

    @property
    def paper_coefficients(self) -> dict[str, float]:
        """A..E in the paper's difference-equation form (order 2 only)."""
        if self.order != 2:
            raise ValueError("the paper's A..E form exists for order 2 only")
        return {
            "A": float(self.b[0]),
            "B": float(self.b[1]),
            "C": float(self.b[2]),
            "D": float(-self.a[1]),
            "E": float(-self.a[2]),
        }

    def _initial_state(self, first: np.ndarray) -> list[LinearFilter]:
        start = first if self.initial == "first" else np.zeros_like(first)
        return [LinearFilter(self.b, self.a, first.size, self._zi_unit[:, None] * start[None, :])]


class GyroIntegrator:
    """Tilt by integrating the gyro rate: theta(k) = theta(k-1) + omega(k) * dt_s.

    theta(-1) is the initial tilt given with the first block (the accelerometer tilt in the
    pipeline, as the paper initialises from standing). It drifts with any uncorrected bias.
    """

    def __init__(self, dt_s: float = 0.01) -> None:
        if not dt_s > 0:
            raise ValueError(f"dt_s must be positive, got {dt_s}")
        self.dt_s = float(dt_s)
        self._zi: np.ndarray | None = None

    def reset(self) -> None:
        self._zi = None

    def process(self, rate_rad_s: np.ndarray, initial_rad: np.ndarray | float = 0.0) -> np.ndarray:
        """(N,) or (N, segments) rate -> integrated tilt (rad). ``initial_rad`` is used once."""
        x2, was_1d = as_2d(rate_rad_s)
        if x2.shape[0] == 0:
            out = np.empty_like(x2)
            return out[:, 0] if was_1d else out
        if self._zi is None:
            self._zi = np.broadcast_to(np.asarray(initial_rad, dtype=np.float64), (x2.shape[1],))
            self._zi = self._zi.reshape(1, -1).copy()
        # lfilter([dt], [1, -1]): theta_k = theta_k-1 + dt omega_k, summed in order
        y = running_sum(x2 * self.dt_s, self._zi[0])
        self._zi = y[-1:].copy()
        return y[:, 0] if was_1d else y
