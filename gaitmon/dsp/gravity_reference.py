"""The gait-aware Kalman filter's gravity measurement (:class:`GravityReference`): the
gyro-turned specific force, low-passed. :mod:`gaitmon.dsp.motion_kalman`'s module doc
describes the filter ("the module doc" below).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from gaitmon.dsp.angles import TWO_PI
from gaitmon.dsp.iir import LinearFilter, butter_lowpass, lfilter


@lru_cache(maxsize=16)
def _tables(
    cutoff_hz: float, fs_hz: float
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]:
    """(b, a, lag_s, the step response s_k, h_k) of the low-pass (the class doc); kept, as
    the filter's gain table is: a reference of these settings made again (the next record or
    connect) does not filter its tables again. Callers copy the arrays they keep.

    Filtered by the interpreted loops (as live work is), whatever loops the process has
    loaded: the compiled recursion rounds differently and cut the step response at another
    length (1,220 samples against numpy's, for 0.5 Hz), so a recording made live and the
    same recording processed differed by ~1e-12 rad in the filter's tilts."""
    from gaitmon.dsp import kernels

    with kernels.live():
        return _filtered_tables(cutoff_hz, fs_hz)


def _filtered_tables(
    cutoff_hz: float, fs_hz: float
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]:
    dt_s = 1.0 / fs_hz
    b, a = butter_lowpass(2, cutoff_hz, fs_hz)
    k = np.arange(len(b))
    # the low-pass's delay at DC: a gyro bias b turns the gyro angle at b, so z~ leads the
    # tilt by lag_s * b (the filter's measurement model, z~ = theta + lag_s b)
    lag_s = float((k @ b / b.sum() - k @ a / a.sum()) * dt_s)
    # the step response from rest, s_k, and h_k, until s_k is within 1e-12 of 1
    n_h = round(60.0 / cutoff_hz * fs_hz)
    step = lfilter(b, a, np.ones(n_h))
    n_h = int(np.flatnonzero(np.abs(step - 1.0) > 1e-12)[-1]) + 2
    t = np.arange(n_h) * dt_s
    step = step[:n_h]
    step[-1] = 1.0
    h = t - lfilter(b, a, t) / step
    h[-1] = lag_s
    return b, a, lag_s, step, h


class GravityReference:
    """Causal gravity-referenced tilt of S segments (module doc, "Gravity measurement").

    ``process(ax, az, w)`` with (N, S) inputs returns z~ (rad, (N, S), continuous up to the
    wrap of its arg), minus ``h * offset_rad_s``. Stateful; any chunking gives bit-for-bit
    the same output.

    Start-up. The low-pass starts from rest (zero state) and its output is divided by its own
    step response s_k (the same low-pass fed ones from rest): a weighted mean of the samples
    seen so far, with the low-pass's weights, that becomes the plain low-pass as s_k -> 1
    (within 1e-12 after ~30 s at 0.25 Hz). Started from a single sample instead (its steady
    state for it), the low-pass would carry that sample's own acceleration (a swinging
    thigh's, several m/s^2) for its ~3 s memory; started from the mean of a first window, it
    rings when the stride's oscillation comes in. A gyro bias b turns the gyro angle by b t,
    which the mean sees late by the mean age of what it holds: z~ = theta + h_k b with
    h_k = t_k - avg(t)_k, which tends to ``lag_s``; :meth:`bias_gain` gives h_k for the sample
    count since the reset, computed once by passing the ramp t through the same mean.
    """

    def __init__(self, cutoff_hz: float, fs_hz: float, n_segments: int) -> None:
        self.dt_s = 1.0 / fs_hz
        b, a, self.lag_s, step, h = _tables(float(cutoff_hz), float(fs_hz))
        self._ba = (b.copy(), a.copy())
        self._step, self._h = step.copy(), h.copy()
        # added to the gyro before it is integrated: undoes shift_bias, so a new calibration
        # does not turn the gyro angle differently from before
        self.offset_rad_s = np.zeros(n_segments)
        self.reset()

    def reset(self) -> None:
        self._theta: np.ndarray | None = None  # the gyro angle at the last sample
        self._lp: LinearFilter | None = None
        self._count = 0  # samples since the reset

    @property
    def count(self) -> int:
        """Samples since the reset."""
        return self._count

    def _at(self, table: np.ndarray, count: int, n: int) -> np.ndarray:
        return np.asarray(table[np.minimum(np.arange(count, count + n), len(table) - 1)])

    def bias_gain(self, count: int, n: int) -> np.ndarray:
        """h_k (s) of the ``n`` samples from ``count`` samples after the reset on."""
        return self._at(self._h, count, n)

    def _turn(self, ax: np.ndarray, az: np.ndarray, w: np.ndarray,
              module: Any = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
        """(the gyro angle, the cosine and sine of its turn) of the block's samples; summed
        and reduced by numba's compiled loop where ``module`` is given (the same numbers)."""
        if self._theta is None:  # the gyro angle starts at the first accelerometer tilt
            self._theta = np.arctan2(az[0], ax[0]) - (w[0] + self.offset_rad_s) * self.dt_s
        if module is not None:
            theta, turn = np.empty(w.shape), np.empty(w.shape)
            module.gyro_angle(w, self.offset_rad_s, self.dt_s, self._theta, theta, turn)
            turn32 = turn.astype(np.float32)
            return theta, np.cos(turn32), np.sin(turn32)
        # one cumulative sum from the carried angle: the same additions in any chunking
        rate = np.empty((len(w) + 1, w.shape[1]))
        rate[0] = self._theta
        np.add(w, self.offset_rad_s, out=rate[1:])
        rate[1:] *= self.dt_s
        theta = np.cumsum(rate, axis=0)[1:]
        # the turn in single precision (20x faster; 1e-7 rad), of the angle reduced first
        turn = np.multiply(theta, 1.0 / TWO_PI, out=rate[1:])
        np.rint(turn, out=turn)
        turn *= -TWO_PI
        turn += theta
        turn32 = turn.astype(np.float32)
        return theta, np.cos(turn32), np.sin(turn32)

    def process_compiled(
        self, module: Any, ax: np.ndarray, az: np.ndarray, w: np.ndarray, cols: np.ndarray,
        h_out: np.ndarray, r_out: np.ndarray, r0: np.ndarray, start_c: np.ndarray,
    ) -> np.ndarray:  # fmt: skip
        """:meth:`process` by numba's compiled loop (``module``: gaitmon.dsp.kernels_numba;
        :func:`gaitmon.dsp.loops.gravity_average`), which also writes the filter's bias gain
        and gravity R into the columns ``cols`` of h_out, r_out (N, S) (r0, start_c (S,):
        gaitmon.dsp.motion_kalman, "Start-up"). The same numbers as :meth:`process`, to
        rounding (its low-pass in the compiled form: scipy's recursion)."""
        n, s = ax.shape
        theta, c, sn = self._turn(ax, az, w, module)
        if self._lp is None:  # the low-pass starts from rest
            self._lp = LinearFilter(*self._ba, 2 * s)
        avg = np.empty((2, n, s))
        assert self._lp.order == 2  # (the loop is scipy's second-order recursion)
        module.gravity_average(ax, az, c, sn, self._lp.b, self._lp.a, self._lp.direct_state(),
                               self._step, self._count, self._h, r0, start_c, self.dt_s, cols,
                               avg, h_out, r_out)  # fmt: skip
        self._count += n
        self._theta = theta[-1].copy()
        tilt = np.arctan2(avg[1], avg[0], out=avg[1])
        tilt += theta
        if self.offset_rad_s.any():  # (- h x 0 changes no number)
            tilt -= h_out[:, cols] * self.offset_rad_s
        return tilt

    def process(self, ax: np.ndarray, az: np.ndarray, w: np.ndarray) -> np.ndarray:
        n, s = ax.shape
        theta, c, sn = self._turn(ax, az, w)
        world = np.empty((len(theta), 2 * s))  # (up, fwd) x S
        np.add(ax * c, az * sn, out=world[:, :s])
        np.subtract(az * c, ax * sn, out=world[:, s:])
        if self._lp is None:  # the low-pass starts from rest
            self._lp = LinearFilter(*self._ba, 2 * s)
        avg = self._lp.process(world)
        if self._count < len(self._step) - 1:  # the start-up's mean (the class doc)
            avg = avg / self._at(self._step, self._count, n)[:, None]
        h = self.bias_gain(self._count, n)[:, None]
        self._count += n
        self._theta = theta[-1].copy()
        tilt = theta + np.arctan2(avg[:, s:], avg[:, :s])
        return np.asarray(tilt - h * self.offset_rad_s)
