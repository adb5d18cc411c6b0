"""Paper 004's exponential filters (order 1, 2, M) and the trapezoid integrator they feed.

Paper 004 (Wahyudi & Widada, "Perbandingan antara tapis Kalman dan tapis eksponensial ...") eq. 17:

    y(n) = (1 - alpha) x(n) + alpha y(n-1),        alpha = 1 / (1 + 2 pi fc / fs)   (eq. 20)

Higher orders repeat the same stage ("jika dilakukan berulang-ulang"): order M is M identical
first-order stages in cascade, transfer function ((1 - alpha) / (1 - alpha z^-1))^M, DC gain 1.
Note: the paper's printed eqs. 18-19 are not that cascade. Eq. 19 is a single first-order stage
unrolled over M steps, y(n) = (1-alpha) sum_{k=1..M} alpha^(k-1) x(n-k+1) + alpha^M y(n-M), but
printed with alpha where alpha^M belongs, which as printed has DC gain (1 - alpha^M)/(1 - alpha)
instead of 1. gaitmon implements the cascade the text describes.

In the paper the exponential path only filters; the angle (gyro) or position (accelerometer) is
then obtained by integrating with the trapezoid rule, :class:`TrapezoidIntegrator`.

Both classes are streaming stages: (N,) or (N, channels) in, same shape out, state carried across
blocks (:mod:`gaitmon.dsp.iir`, numpy alone), ``reset()``; any chunking gives the same output.
"""

from __future__ import annotations

import numpy as np

from gaitmon.dsp.filters import ChannelFilter, as_2d
from gaitmon.dsp.iir import LinearFilter, running_sum


def exponential_alpha(cutoff_hz: float, fs_hz: float) -> float:
    """Paper 004 eq. 20: alpha = 1 / (1 + 2 pi fc / fs) (the RC low-pass analogy)."""
    if not (np.isfinite(fs_hz) and fs_hz > 0):
        raise ValueError(f"sample rate must be positive, got {fs_hz} Hz")
    if not (np.isfinite(cutoff_hz) and cutoff_hz > 0):
        raise ValueError(f"cut-off must be positive, got {cutoff_hz} Hz")
    return 1.0 / (1.0 + 2.0 * np.pi * cutoff_hz / fs_hz)


class ExponentialFilter(ChannelFilter):
    """Order-M exponential low-pass (M cascaded paper-004 stages) over any number of channels.

    Give either ``alpha`` (0 <= alpha < 1) or ``cutoff_hz`` and ``fs_hz``.
    ``initial="zero"`` is the bare difference equation with y(-1) = 0 (a step input then gives
    1 - alpha^(n+1) at order 1); ``initial="first"`` starts every stage in steady state at the
    first sample, so a signal that starts away from zero has no start-up ramp.
    """

    def __init__(
        self,
        alpha: float | None = None,
        *,
        cutoff_hz: float | None = None,
        fs_hz: float | None = None,
        order: int = 1,
        initial: str = "zero",
    ) -> None:
        if alpha is None:
            if cutoff_hz is None or fs_hz is None:
                raise ValueError("give either alpha or both cutoff_hz and fs_hz")
            alpha = exponential_alpha(cutoff_hz, fs_hz)
        elif cutoff_hz is not None or fs_hz is not None:
            raise ValueError("give either alpha or cutoff_hz/fs_hz, not both")
        if not (np.isfinite(alpha) and 0.0 <= alpha < 1.0):
            raise ValueError(f"alpha must be in [0, 1), got {alpha}")
        if int(order) != order or not 1 <= order <= 32:
            raise ValueError(f"order must be a whole number from 1 to 32, got {order}")
        if initial not in ("zero", "first"):
            raise ValueError(f"initial must be 'zero' or 'first', got {initial!r}")
        self.alpha = float(alpha)
        self.order = int(order)
        self.initial = initial
        self._b = np.array([1.0 - self.alpha])
        self._a = np.array([1.0, -self.alpha])

    def _initial_state(self, first: np.ndarray) -> list[LinearFilter]:
        # lfilter's state for y(-1) = v is alpha * v (y(n) = b x(n) + zi, zi = alpha y(n-1))
        start = first if self.initial == "first" else np.zeros_like(first)
        return [
            LinearFilter(self._b, self._a, first.size, self.alpha * start[None, :])
            for _ in range(self.order)
        ]


class TrapezoidIntegrator:
    """Integral by the trapezoid rule: y(k) = y(k-1) + dt/2 (x(k) + x(k-1)).

    The first output is y(0) = ``initial`` (given with the first block): the integral's value at
    the first sample's time. Integration runs from there.
    """

    def __init__(self, dt_s: float) -> None:
        if not (np.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s must be positive, got {dt_s}")
        self.dt_s = float(dt_s)
        self._y: np.ndarray | None = None  # (channels,) output at the last sample
        self._x: np.ndarray | None = None  # (channels,) last input

    def reset(self) -> None:
        self._y = self._x = None

    def process(self, x: np.ndarray, initial: np.ndarray | float = 0.0) -> np.ndarray:
        """Integrate (N,) or (N, channels). ``initial`` is the output at the very first sample."""
        x2, was_1d = as_2d(x)
        n, c = x2.shape
        if n == 0:
            out = np.empty_like(x2)
            return out[:, 0] if was_1d else out
        incr = np.empty_like(x2)
        incr[1:] = 0.5 * self.dt_s * (x2[1:] + x2[:-1])
        if self._y is None:
            prev_y = np.broadcast_to(np.asarray(initial, dtype=np.float64), (c,)).copy()
            incr[0] = 0.0  # y(0) = initial
        else:
            assert self._x is not None
            prev_y = self._y
            incr[0] = 0.5 * self.dt_s * (x2[0] + self._x)
        # one running sum from the carried output: the same additions in any chunking
        y = running_sum(incr, prev_y)
        self._y = y[-1].copy()
        self._x = x2[-1].copy()
        return y[:, 0] if was_1d else y
