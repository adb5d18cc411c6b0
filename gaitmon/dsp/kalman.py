"""The two-state (angle, gyro bias) tilt Kalman filter of paper 000, exactly as published.

State x = [theta, b]; input u = omega (gyro rate); measurement z = accelerometer tilt.
Predict (the paper's hand-expanded form, ``form="paper"``; P = [[P1, P2], [P3, P4]]):

    theta- = theta + (omega - b) dt ;  b- = b
    P1- = P1 + (Q_angle - P3 - P2) dt ; P2- = P2 - P4 dt ; P3- = P3 - P4 dt ; P4- = P4 + Q_gyro dt

``form="discrete"`` adds the dt^2 P4 term of the exact discretisation to P1-. Update:

    E = P1- + R ; K0 = P1-/E ; K1 = P3-/E ; err = wrap(z - theta-)
    theta = theta- + K0 err ; b = b- + K1 err
    P1 = P1- - K0 P1- ; P2 = P2- - K0 P2- ; P3 = P3- - K1 P1- ; P4 = P4- - K1 P2-

Initial state: theta = the first measurement, b = ``initial_bias_rad_s`` (0), P = 0.
The state theta is continuous (it is not wrapped, so it crosses +-pi without a jump); only the
innovation is wrapped to (-pi, pi].

Speed. P and K do not depend on the data: they follow a fixed sequence that reaches a fixed point
after a few thousand steps. Up to that point the filter runs step by step with the exact gain
sequence. From there on it is a linear time-invariant system, run as two second-order transfer
functions (omega -> theta, z -> theta) with :class:`gaitmon.dsp.iir.LinearFilter` (numpy
alone): mathematically the same filter; it agrees with the step-by-step reference to ~1e-12. The
innovation's wrap is honoured by unwrapping z so that every innovation lies within (-pi, pi);
where that cannot be guaranteed (the accelerometer tilt more than pi away from the prediction),
the filter falls back to exact steps for a while.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from gaitmon.dsp.angles import TWO_PI, wrap_angle
from gaitmon.dsp.filters import as_2d_pair
from gaitmon.dsp.iir import LinearFilter, ss2tf
from gaitmon.dsp.setting_checks import check_tilt_kalman

_MAX_GAIN_STEPS = 50_000
_RECOVERY_STEPS = 64
# the LTI path works through long records in sub-blocks that stay in cache (about 2x faster)
_LTI_BLOCK = 16384
# innovations this close to +-pi are handled by exact steps, not the unwrapped linear path
_WRAP_MARGIN_RAD = 1e-6


@dataclass(frozen=True)
class _GainSchedule:
    k0: np.ndarray  # (M,) gain for theta at step k (0-based since reset)
    k1: np.ndarray  # (M,) gain for the bias
    p: np.ndarray  # (M, 4) P after the update at step k
    k0_ss: float
    k1_ss: float
    p_ss: np.ndarray  # (4,)
    converged: bool


@lru_cache(maxsize=32)
def _gain_schedule(
    dt_s: float, q_angle: float, q_gyro: float, r: float, form: str
) -> _GainSchedule:
    p1 = p2 = p3 = p4 = 0.0
    k0s: list[float] = []
    k1s: list[float] = []
    ps: list[tuple[float, float, float, float]] = []
    converged = False
    for _ in range(_MAX_GAIN_STEPS):
        if form == "discrete":
            p1 = p1 + dt_s * (dt_s * p4 - p2 - p3 + q_angle)
        else:
            p1 = p1 + (q_angle - p3 - p2) * dt_s
        p2 = p2 - p4 * dt_s
        p3 = p3 - p4 * dt_s
        p4 = p4 + q_gyro * dt_s
        e = p1 + r
        k0 = p1 / e
        k1 = p3 / e
        n1 = p1 - k0 * p1
        n2 = p2 - k0 * p2
        n3 = p3 - k1 * p1
        n4 = p4 - k1 * p2
        p1, p2, p3, p4 = n1, n2, n3, n4
        if k0s and k0 == k0s[-1] and k1 == k1s[-1] and (p1, p2, p3, p4) == tuple(ps[-1]):
            converged = True
            break
        k0s.append(k0)
        k1s.append(k1)
        ps.append((p1, p2, p3, p4))
    return _GainSchedule(
        k0=np.array(k0s),
        k1=np.array(k1s),
        p=np.array(ps),
        k0_ss=k0s[-1],
        k1_ss=k1s[-1],
        p_ss=np.array(ps[-1]),
        converged=converged,
    )


class TiltKalman:
    """Paper 000's tilt Kalman filter for one or several segments at once (see module doc)."""

    def __init__(
        self,
        dt_s: float = 0.01,
        q_angle: float = 0.001,
        q_gyro: float = 0.003,
        r: float = 0.3,
        form: str = "paper",
        initial_bias_rad_s: float = 0.0,
        fast_path: bool = True,
    ) -> None:
        """``fast_path=False`` runs every sample step by step (the reference; ~70x slower)."""
        self.check(dt_s, q_angle, q_gyro, r, form)
        self.dt_s = float(dt_s)
        self.q_angle = float(q_angle)
        self.q_gyro = float(q_gyro)
        self.r = float(r)
        self.form = form
        self.initial_bias_rad_s = float(initial_bias_rad_s)
        self._fast_path = bool(fast_path)
        self._sched = _gain_schedule(self.dt_s, self.q_angle, self.q_gyro, self.r, form)
        self._setup_lti()
        self.reset()

    @staticmethod
    def check(dt_s: float, q_angle: float, q_gyro: float, r: float, form: str) -> None:
        """Raise ValueError naming the first bad setting (nothing is computed)."""
        check_tilt_kalman(dt_s, q_angle, q_gyro, r, form)

    # ------------------------------------------------------------------ set-up
    def _setup_lti(self) -> None:
        """Transfer functions of the steady-state filter: (omega, z) -> (theta, bias).

        x_k = F x_{k-1} + G u_k with x = [theta, b], u = [omega, z]; as a standard state-space
        model with s_k = x_{k-1}: s_{k+1} = F s_k + G u_k, y_k = F s_k + G u_k.
        """
        k0, k1, dt = self._sched.k0_ss, self._sched.k1_ss, self.dt_s
        f = np.array([[1 - k0, -(1 - k0) * dt], [-k1, 1 + k1 * dt]])
        g = np.array([[(1 - k0) * dt, k0], [-k1 * dt, k1]])
        self._f = f
        nums = []
        den = None
        for inp in range(2):  # omega, z -> theta
            num, den = ss2tf(f, g, f[:1], g[:1], inp)
            nums.append(num[0])
        assert den is not None
        self._den = den
        self._nums = nums  # theta<-omega, theta<-z
        poles = np.roots(den)
        self._lti_ok = bool(
            self._fast_path and self._sched.converged and np.all(np.abs(poles) < 1)
        )

    def reset(self) -> None:
        self._theta: np.ndarray | None = None
        self._bias: np.ndarray | None = None
        self._step = 0
        self._recovery_left = 0
        # the LTI path's two filters (omega -> theta, z -> theta), running on across calls
        self._lti: tuple[LinearFilter, LinearFilter] | None = None
        self._last_z: np.ndarray | None = None  # (S,) last wrapped measurement (for unwrapping)
        self._turns: np.ndarray | None = None  # (S,) int64 2*pi turns added to the last z

    # ------------------------------------------------------------ inspection
    @property
    def steps(self) -> int:
        return self._step

    @property
    def bias_rad_s(self) -> np.ndarray | None:
        return None if self._bias is None else self._bias.copy()

    @property
    def angle_rad(self) -> np.ndarray | None:
        return None if self._theta is None else self._theta.copy()

    @property
    def P(self) -> np.ndarray:
        """Covariance after the last update (2x2); zeros before the first step."""
        if self._step == 0:
            return np.zeros((2, 2))
        i = min(self._step, len(self._sched.k0)) - 1
        return self._sched.p[i].reshape(2, 2).copy()

    @property
    def K(self) -> np.ndarray:
        """Gain [K0, K1] used at the last step."""
        if self._step == 0:
            return np.zeros(2)
        i = min(self._step, len(self._sched.k0)) - 1
        return np.array([self._sched.k0[i], self._sched.k1[i]])

    @property
    def steady_state_gain(self) -> np.ndarray:
        return np.array([self._sched.k0_ss, self._sched.k1_ss])

    def shift_bias(self, delta_rad_s: np.ndarray | float) -> None:
        """Add ``delta`` to the bias state (when the gyro input gets a new fixed offset).

        The next samples then run step by step until the linear path can take over again.
        """
        if self._bias is None:
            return
        self._bias = self._bias + np.asarray(delta_rad_s, dtype=np.float64)
        if self._lti is not None:
            self._lti = None
            self._last_z = self._turns = None
            self._recovery_left = max(self._recovery_left, 1)

    def restart(self) -> None:
        """Start the angle again from the next measurement, keeping the learnt gyro bias and
        the gains (after a link outage the old angle is stale, but the bias and the noise
        levels are not: the filter settles with its steady-state gain, not from P = 0)."""
        self._theta = None
        self._lti = None
        self._last_z = self._turns = None
        if self._bias is not None:
            self._recovery_left = max(self._recovery_left, 1)

    # ------------------------------------------------------------ processing
    def process(self, acc_tilt_rad: np.ndarray, gyro_rad_s: np.ndarray) -> np.ndarray:
        """Filter (N,) or (N, segments) measurements; returns the tilt (rad), same shape."""
        z, w, was_1d = as_2d_pair(acc_tilt_rad, gyro_rad_s)
        n, s = z.shape
        out = np.empty((n, s))
        if n == 0:
            return out[:, 0] if was_1d else out
        if self._theta is None:
            self._theta = z[0].copy()
        if self._bias is None:
            self._bias = np.full(s, self.initial_bias_rad_s)
        i = 0
        while i < n:
            if self._lti is not None:
                i = self._run_lti(z, w, out, i)
            else:
                i = self._run_exact(z, w, out, i)
        return out[:, 0] if was_1d else out

    def _exact_limit(self) -> int:
        """How many more samples must run step by step before the LTI path may take over."""
        if not self._lti_ok:
            return -1  # always exact
        return max(len(self._sched.k0) - self._step, self._recovery_left, 0)

    def _run_exact(self, z: np.ndarray, w: np.ndarray, out: np.ndarray, i: int) -> int:
        n = z.shape[0]
        limit = self._exact_limit()
        stop = n if limit < 0 else min(n, i + limit)
        theta, bias = self._theta, self._bias
        assert theta is not None and bias is not None
        k0s, k1s = self._sched.k0, self._sched.k1
        m = len(k0s)
        dt = self.dt_s
        for j in range(i, stop):
            step = self._step
            k0 = k0s[step] if step < m else self._sched.k0_ss
            k1 = k1s[step] if step < m else self._sched.k1_ss
            theta = theta + (w[j] - bias) * dt
            err = wrap_angle(z[j] - theta)
            theta = theta + k0 * err
            bias = bias + k1 * err
            out[j] = theta
            self._step = step + 1
        self._recovery_left = max(0, self._recovery_left - (stop - i))
        self._theta, self._bias = theta, bias
        if self._lti_ok and self._exact_limit() == 0:
            self._enter_lti()
        return stop

    def _enter_lti(self) -> None:
        """Start the LTI filters so that their zero-input response continues the current state."""
        assert self._theta is not None and self._bias is not None
        x = np.vstack([self._theta, self._bias])  # (2, S)
        fx = self._f @ x
        ffx = self._f @ fx
        # theta's free response (F x)_0, (F^2 x)_0 goes into the state of the z-path filter
        s = x.shape[1]
        zi = np.zeros((2, s))
        zi[0] = fx[0]
        zi[1] = ffx[0] + self._den[1] * fx[0]
        self._lti = (
            LinearFilter(self._nums[0], self._den, s),
            LinearFilter(self._nums[1], self._den, s, zi),
        )
        self._last_z = None  # re-anchored on the next sample from the prediction
        self._turns = None

    def _state_at(
        self, theta_prev: np.ndarray, theta: np.ndarray, z_unw: np.ndarray, w: np.ndarray
    ) -> np.ndarray:
        """Bias after a step, recovered from theta before and after it (steady-state gains)."""
        k0, k1, dt = self._sched.k0_ss, self._sched.k1_ss, self.dt_s
        pred = (theta - k0 * z_unw) / (1 - k0)  # theta = (1 - K0) pred + K0 z
        bias_prev = w - (pred - theta_prev) / dt  # pred = theta_prev + (w - b_prev) dt
        return bias_prev + k1 * (z_unw - pred)

    def _run_lti(self, z: np.ndarray, w: np.ndarray, out: np.ndarray, i: int) -> int:
        assert self._lti is not None and self._theta is not None and self._bias is not None
        zc, wc = z[i : i + _LTI_BLOCK], w[i : i + _LTI_BLOCK]
        n = zc.shape[0]
        dt = self.dt_s
        theta_prev = self._theta
        # unwrap z so that consecutive samples differ by at most pi, anchored on the prediction
        steps = np.empty(zc.shape, dtype=np.int64)
        if self._last_z is None:
            pred0 = theta_prev + (wc[0] - self._bias) * dt
            steps[0] = np.rint((pred0 - zc[0]) / TWO_PI)
        else:
            assert self._turns is not None
            steps[0] = self._turns - np.rint((zc[0] - self._last_z) / TWO_PI)
        if n > 1:
            steps[1:] = -np.rint(np.diff(zc, axis=0) / TWO_PI)
        turns = np.cumsum(steps, axis=0)
        z_unw = zc + TWO_PI * turns
        z_t = np.ascontiguousarray(z_unw.T)
        theta_t = (self._lti[0].process(wc) + self._lti[1].process(z_unw)).T  # (S, n)
        # innovation e = z - pred = (z - theta) / (1 - K0); the linear path is exact only while
        # every innovation is inside (-pi, pi), where wrap() does nothing
        innov = (z_t - theta_t) / (1 - self._sched.k0_ss)
        bad_cols = np.flatnonzero((np.abs(innov) >= np.pi - _WRAP_MARGIN_RAD).any(axis=0))
        good = n if bad_cols.size == 0 else int(bad_cols[0])
        theta = theta_t.T
        out[i : i + good] = theta[:good]
        self._step += good
        if good > 0:
            before = theta[good - 2] if good > 1 else theta_prev
            self._bias = self._state_at(before, theta[good - 1], z_unw[good - 1], wc[good - 1])
            self._theta = theta[good - 1].copy()
        if good == n:
            self._last_z = zc[-1].copy()
            self._turns = turns[-1].copy()
            return i + n
        # the sample at `good` needs a real wrap: take exact steps from the state before it
        self._lti = None
        self._last_z = self._turns = None
        self._recovery_left = _RECOVERY_STEPS
        return i + good
