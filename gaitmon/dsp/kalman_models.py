"""The Kalman models of the companion papers 001, 002 and 004, and the tools to analyse them.

Paper 000's own tilt filter is :class:`gaitmon.dsp.kalman.TiltKalman`; this module owns the others:

* :class:`LinearKalman` -- the textbook discrete filter every model here is an instance of:

      predict  x-_k = A x_{k-1} + B u_{k-lag}        P-_k = A P_{k-1} A^T + Q
      update   K_k = P-_k H^T (H P-_k H^T + R)^-1
               x_k = x-_k + K_k (z_k - H x-_k)       P_k = (I - K_k H) P-_k

  ``x0``/``P0`` are the estimate one sample *before* the first (every sample, including the
  first, is predicted and then updated). ``input_lag=0`` uses the input of the same sample (paper
  001, eq. 11), ``input_lag=1`` the previous one (papers 002/004: x_{k+1} = A x_k + B u_k); the
  input before the first sample is zero. P and K do not depend on the data, so their sequence is
  computed once (until it stops changing) and reused.
* Paper 004 (Wahyudi & Widada): :func:`angle_from_rate_kalman` (x_{k+1} = x_k + T u_k + w,
  y = x + v) and :func:`position_from_accel_kalman` (x = [s, v], A = [[1, T], [0, 1]],
  B = [T^2/2, T]^T, y = s + v). The paper's Q is "S_w = E(w w^T)" (Dan Simon's notation, its
  ref. 4): the noise enters through the input, so Q = sigma_u^2 B B^T, R = sigma_y^2.
* Paper 001 (Lasmadi et al.): :func:`constant_rate_kalman`, state [a_x, a'_x, a_y, a'_y, a_z,
  a'_z], per axis A_i = [[1, dt], [0, 0]] and B_i = [0, 1]^T (the gyro rate becomes the rate
  state), Q_i = q [[dt^3/3, dt^2/2], [dt^2/2, dt]], H picks the three angles, R = diag(variance
  of the gyro rate per axis) -- the paper's recipe, although R then has the units of a rate
  squared while it weighs an angle measurement. ``q`` is the process-noise spectral density
  (rad^2/s^3 for a white angular-acceleration model; the paper prints Q_i without a factor,
  i.e. q = 1). The paper never says what its measurement Z is; gaitmon feeds an absolute angle.
  Also the ENU -> NED axis mapping (:func:`enu_to_ned`) and the accuracy metric
  (:func:`galat_pct`, :func:`akurasi_pct`).
* Paper 002 (Fathoni & Prastiyanto): :func:`pva_kalman` with A = [[1, Ts, Ts^2/2], [0, 1, Ts],
  [0, 0, 1]], Ts = 1 ms, R = 0.00005. The paper does not print Q; gaitmon uses Q = diag(0, 0, q),
  the "da/dt = 0" equation of its model driven by white noise of variance q per step. The paper's
  eq. 9 measures the position (H = [1, 0, 0], the H its pole analysis uses); its text feeds the
  accelerometer in as the third state (H = [0, 0, 1]); both are offered. Also the gravity
  compensation from the 3-axis tilt (:func:`gravity_compensate`), the steady-state gain
  (:func:`steady_state_gain`, the DARE solved by :func:`gaitmon.dsp.iir.solve_discrete_are`,
  numpy alone) and observer poles (:func:`observer_poles`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike

from gaitmon.dsp.iir import solve_discrete_are

# the gain schedule is precomputed this far; a filter whose gain has not settled by then (e.g. an
# unobservable state whose variance keeps growing) carries on with the Riccati recursion live
_MAX_GAIN_STEPS = 20_000
STANDARD_GRAVITY_CM_S2 = 980.0  # paper 002 converts g to cm/s^2 with x 980


# --------------------------------------------------------------------------- the generic filter
@dataclass(frozen=True)
class _Schedule:
    k: np.ndarray  # (M, n, m) gains at steps 0..M-1
    p: np.ndarray  # (M, n, n) covariance after the update
    k_ss: np.ndarray
    p_ss: np.ndarray
    converged: bool


# a matrix as a hashable (shape, values) pair, so the gain schedule can be cached
_MatKey = tuple[tuple[int, ...], tuple[float, ...]]


def _key(a: np.ndarray) -> _MatKey:
    return (a.shape, tuple(np.asarray(a, dtype=np.float64).ravel().tolist()))


def _riccati_step(
    a: np.ndarray, h: np.ndarray, q: np.ndarray, r: np.ndarray, p: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """One predict/update of the covariance: P_{k-1} -> (K_k, P_k)."""
    pm = a @ p @ a.T + q
    s = h @ pm @ h.T + r
    k = np.linalg.solve(s.T, (pm @ h.T).T).T  # pm h^T s^-1
    p_new = (np.eye(a.shape[0]) - k @ h) @ pm
    return k, 0.5 * (p_new + p_new.T)  # kept symmetric against rounding drift


@lru_cache(maxsize=64)
def _schedule_cached(
    a_k: _MatKey, h_k: _MatKey, q_k: _MatKey, r_k: _MatKey, p0_k: _MatKey
) -> _Schedule:
    def arr(k: _MatKey) -> np.ndarray:
        return np.array(k[1], dtype=np.float64).reshape(k[0])

    a, h, q, r, p = arr(a_k), arr(h_k), arr(q_k), arr(r_k), arr(p0_k)
    ks: list[np.ndarray] = []
    ps: list[np.ndarray] = []
    converged = False
    for _ in range(_MAX_GAIN_STEPS):
        k, p_new = _riccati_step(a, h, q, r, p)
        if (
            ks
            and np.allclose(k, ks[-1], rtol=1e-13, atol=0.0)
            and np.allclose(p_new, ps[-1], rtol=1e-13, atol=1e-300)
        ):
            converged = True
            break
        ks.append(k)
        ps.append(p_new)
        p = p_new
    return _Schedule(np.array(ks), np.array(ps), ks[-1], ps[-1], converged)


class LinearKalman:
    """A discrete Kalman filter with constant matrices, streaming (see the module doc).

    ``process(z, u=None)``: z is (N,) for one measurement or (N, m); optionally (N, m, C) to run
    C independent data sets through the same filter at once. u is (N,), (N, p) or (N, p, C) like z.
    Returns the posterior states (N, n) (or (N, n, C)).
    """

    def __init__(
        self,
        A: ArrayLike,
        H: ArrayLike,
        Q: ArrayLike,
        R: ArrayLike,
        B: ArrayLike | None = None,
        x0: ArrayLike | None = None,
        P0: ArrayLike | None = None,
        input_lag: int = 0,
    ) -> None:
        self.A = np.atleast_2d(np.asarray(A, dtype=np.float64))
        n = self.A.shape[0]
        self.H = np.atleast_2d(np.asarray(H, dtype=np.float64))
        m = self.H.shape[0]
        self.Q = np.atleast_2d(np.asarray(Q, dtype=np.float64))
        self.R = np.atleast_2d(np.asarray(R, dtype=np.float64))
        self.B = None if B is None else np.asarray(B, dtype=np.float64).reshape(n, -1)
        checks = (
            (self.A.shape == (n, n), f"A must be square, got {self.A.shape}"),
            (self.H.shape[1] == n, f"H {self.H.shape} does not fit {n} states"),
            (self.Q.shape == (n, n), f"Q must be {n}x{n}, got {self.Q.shape}"),
            (self.R.shape == (m, m), f"R must be {m}x{m}, got {self.R.shape}"),
            (input_lag in (0, 1), f"input_lag must be 0 or 1, got {input_lag}"),
        )
        for ok, msg in checks:
            if not ok:
                raise ValueError(msg)
        for name, mat in (("Q", self.Q), ("R", self.R)):
            if not np.all(np.isfinite(mat)) or np.min(np.linalg.eigvalsh(0.5 * (mat + mat.T))) < (
                -1e-12 * max(1.0, float(np.abs(mat).max()))
            ):
                raise ValueError(f"{name} must be a finite positive semi-definite matrix")
        self.x0 = np.zeros(n) if x0 is None else np.asarray(x0, dtype=np.float64).reshape(n)
        self.P0 = np.zeros((n, n)) if P0 is None else np.asarray(P0, dtype=np.float64)
        self.input_lag = int(input_lag)
        self._sched = _schedule_cached(
            _key(self.A), _key(self.H), _key(self.Q), _key(self.R), _key(self.P0)
        )
        self.reset()

    @property
    def n_states(self) -> int:
        return self.A.shape[0]

    @property
    def n_measurements(self) -> int:
        return self.H.shape[0]

    @property
    def steady_state_gain(self) -> np.ndarray:
        """The gain the schedule converged to (n, m)."""
        return self._sched.k_ss.copy()

    def covariance_at(self, step: int) -> np.ndarray:
        """P after the update at step ``step``."""
        return (self._sched.p[step] if step < len(self._sched.p) else self._sched.p_ss).copy()

    def reset(self) -> None:
        self._x: np.ndarray | None = None  # (n, C)
        self._u_prev: np.ndarray | None = None  # (p, C)
        self._step = 0
        self._p_live: np.ndarray | None = None  # P past an unconverged schedule

    def process(self, z: np.ndarray, u: np.ndarray | None = None) -> np.ndarray:
        z3, shape_kind = self._as3(z, self.n_measurements, "z")
        n_samples, _, c = z3.shape
        u3 = None
        if self.B is not None:
            if u is None:
                raise ValueError("this model has an input: pass u")
            u3, _ = self._as3(u, self.B.shape[1], "u")
            if u3.shape[0] != n_samples or u3.shape[2] != c:
                raise ValueError(f"u {np.shape(u)} does not match z {np.shape(z)}")
        elif u is not None:
            raise ValueError("this model has no input, but u was given")
        if self._x is None:
            self._x = np.repeat(self.x0[:, None], c, axis=1)
            if self.B is not None:
                self._u_prev = np.zeros((self.B.shape[1], c))
        elif self._x.shape[1] != c:
            raise ValueError(f"this filter carries state for {self._x.shape[1]} data sets, got {c}")
        out = np.empty((n_samples, self.n_states, c))
        a, b, h = self.A, self.B, self.H
        ks, m_sched, k_ss = self._sched.k, len(self._sched.k), self._sched.k_ss
        x, step = self._x, self._step
        u_prev = self._u_prev
        for i in range(n_samples):
            xp = a @ x
            if b is not None:
                # both set with B: u3 from u above, u_prev when the state was first made
                assert u3 is not None and u_prev is not None
                ui = u3[i] if self.input_lag == 0 else u_prev
                xp = xp + b @ ui
                u_prev = u3[i]
            if step < m_sched:
                k = ks[step]
            elif self._sched.converged:
                k = k_ss
            else:
                k = self._live_gain()
            x = xp + k @ (z3[i] - h @ xp)
            out[i] = x
            step += 1
        self._x, self._step, self._u_prev = x, step, u_prev
        if shape_kind == 3:
            return out
        return out[:, :, 0]

    def _live_gain(self) -> np.ndarray:
        p = self._sched.p_ss if self._p_live is None else self._p_live
        k, self._p_live = _riccati_step(self.A, self.H, self.Q, self.R, p)
        return k

    @staticmethod
    def _as3(v: np.ndarray, width: int, name: str) -> tuple[np.ndarray, int]:
        a = np.asarray(v, dtype=np.float64)
        if a.ndim == 1 and width == 1:
            return a[:, None, None], 1
        if a.ndim == 2 and a.shape[1] == width:
            return a[:, :, None], 2
        if a.ndim == 3 and a.shape[1] == width:
            return a, 3
        raise ValueError(f"{name} must be (N, {width}) or (N, {width}, C), got {a.shape}")


# --------------------------------------------------------------------------- paper 004
def angle_from_rate_kalman(
    dt_s: float,
    rate_noise_sd: float,
    angle_noise_sd: float,
    x0: float = 0.0,
    p0: float = 0.0,
) -> LinearKalman:
    """Paper 004's gyro model: x_{k+1} = x_k + T u_k + w, y = x + v (eqs. 25-26).

    w = T n_u with n_u the rate noise, so Q = (T sigma_u)^2; R = sigma_y^2. ``process(y, u)``.
    """
    _check_positive(dt_s=dt_s)
    _check_nonneg(rate_noise_sd=rate_noise_sd, p0=p0)
    _check_positive(angle_noise_sd=angle_noise_sd)
    b = np.array([[dt_s]])
    return LinearKalman(
        A=[[1.0]],
        B=b,
        H=[[1.0]],
        Q=rate_noise_sd**2 * (b @ b.T),
        R=[[angle_noise_sd**2]],
        x0=[x0],
        P0=[[p0]],
        input_lag=1,
    )


def position_from_accel_kalman(
    dt_s: float,
    accel_noise_sd: float,
    position_noise_sd: float,
    x0: tuple[float, float] = (0.0, 0.0),
    P0: np.ndarray | None = None,
) -> LinearKalman:
    """Paper 004's accelerometer model, x = [s, v] (eqs. 33-34).

    Q = sigma_a^2 B B^T, R = sigma_s^2. ``process(y, u)`` -> [s, v] per sample.
    """
    _check_positive(dt_s=dt_s, position_noise_sd=position_noise_sd)
    _check_nonneg(accel_noise_sd=accel_noise_sd)
    t = dt_s
    b = np.array([[t * t / 2.0], [t]])
    return LinearKalman(
        A=[[1.0, t], [0.0, 1.0]],
        B=b,
        H=[[1.0, 0.0]],
        Q=accel_noise_sd**2 * (b @ b.T),
        R=[[position_noise_sd**2]],
        x0=np.asarray(x0, dtype=np.float64),
        P0=P0,
        input_lag=1,
    )


# --------------------------------------------------------------------------- paper 001
def constant_rate_q(dt_s: float) -> np.ndarray:
    """Paper 001 eq. 14 for one axis: [[dt^3/3, dt^2/2], [dt^2/2, dt]]."""
    return np.array([[dt_s**3 / 3.0, dt_s**2 / 2.0], [dt_s**2 / 2.0, dt_s]])


def constant_rate_kalman(
    dt_s: float,
    rate_var: np.ndarray | float,
    q: float = 1.0,
    n_axes: int = 3,
    x0: np.ndarray | None = None,
) -> LinearKalman:
    """Paper 001's constant-rate model over ``n_axes`` axes (6 states for 3 axes).

    ``rate_var`` is R's diagonal (the paper: the variance of each axis' gyro rate), ``q`` scales
    Q_i. ``process(angle_meas (N, n_axes), gyro_rate (N, n_axes))`` -> states (N, 2 n_axes) in
    the order [a_x, a'_x, a_y, a'_y, ...]; angles are ``[:, 0::2]``.
    """
    _check_positive(dt_s=dt_s)
    _check_nonneg(q=q)
    if int(n_axes) != n_axes or n_axes < 1:
        raise ValueError(f"n_axes must be a positive whole number, got {n_axes}")
    r = np.broadcast_to(np.asarray(rate_var, dtype=np.float64), (n_axes,))
    if np.any(~np.isfinite(r)) or np.any(r <= 0):
        raise ValueError(f"the rate variances must be positive, got {r}")
    a_i = np.array([[1.0, dt_s], [0.0, 0.0]])
    b_i = np.array([[0.0], [1.0]])
    eye = np.eye(n_axes)
    h = np.kron(eye, np.array([[1.0, 0.0]]))
    return LinearKalman(
        A=np.kron(eye, a_i),
        B=np.kron(eye, b_i),
        H=h,
        Q=q * np.kron(eye, constant_rate_q(dt_s)),
        R=np.diag(r),
        x0=x0,
        input_lag=0,
    )


def enu_to_ned(xyz: np.ndarray) -> np.ndarray:
    """Paper 001's axis mapping ENU -> NED over the last axis.

    x_ned = y_enu (roll), y_ned = x_enu (pitch), z_ned = -z_enu (yaw); its own inverse.
    """
    v = np.asarray(xyz, dtype=np.float64)
    if v.shape[-1] != 3:
        raise ValueError(f"expected 3 axes in the last dimension, got {v.shape}")
    return np.stack([v[..., 1], v[..., 0], -v[..., 2]], axis=-1)


def galat_pct(
    reference: np.ndarray | float, estimate: np.ndarray | float, min_abs_reference: float = 1e-9
) -> np.ndarray:
    """Paper 001 eq. 20: |(T - P) / T| x 100 %.

    The metric is relative, so it does not exist for a zero reference: where |T| <
    ``min_abs_reference`` the result is NaN (reported as "undefined"), never a division blow-up.
    """
    t = np.asarray(reference, dtype=np.float64)
    p = np.asarray(estimate, dtype=np.float64)
    ok = np.abs(t) >= min_abs_reference
    safe = np.where(ok, t, 1.0)
    return np.where(ok, np.abs((t - p) / safe) * 100.0, np.nan)


def akurasi_pct(
    reference: np.ndarray | float, estimate: np.ndarray | float, min_abs_reference: float = 1e-9
) -> np.ndarray:
    """Paper 001 eq. 21: |100 % - galat| (NaN where galat is undefined).

    Note the absolute value: an error of 150 % reads as 50 % "accuracy"; only galat <= 100 %
    makes the number mean what it says.
    """
    return np.abs(100.0 - galat_pct(reference, estimate, min_abs_reference))


# --------------------------------------------------------------------------- paper 002
def pva_matrices(
    ts_s: float = 1e-3, q: float = 1.0, measured: str = "position"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, H, Q) of paper 002's position/velocity/acceleration model (see the module doc)."""
    _check_positive(ts_s=ts_s)
    _check_nonneg(q=q)
    a = np.array([[1.0, ts_s, ts_s**2 / 2.0], [0.0, 1.0, ts_s], [0.0, 0.0, 1.0]])
    if measured == "position":
        h = np.array([[1.0, 0.0, 0.0]])
    elif measured == "acceleration":
        h = np.array([[0.0, 0.0, 1.0]])
    else:
        raise ValueError(f"measured must be 'position' or 'acceleration', got {measured!r}")
    return a, h, np.diag([0.0, 0.0, q])


def pva_kalman(
    ts_s: float = 1e-3,
    q: float = 1.0,
    r: float = 0.00005,
    measured: str = "position",
    x0: np.ndarray | None = None,
    P0: np.ndarray | None = None,
) -> LinearKalman:
    """Paper 002's 3-state filter; ``process(z)`` -> [s, v, a] per sample."""
    _check_positive(r=r)
    a, h, qm = pva_matrices(ts_s, q, measured)
    return LinearKalman(A=a, H=h, Q=qm, R=[[r]], x0=x0, P0=P0)


def steady_state_gain(A: np.ndarray, H: np.ndarray, Q: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The converged (filter-form) Kalman gain from the discrete algebraic Riccati equation.

    P- solves P = A P A^T - A P H^T (H P H^T + R)^-1 H P A^T + Q (the DARE of the dual system,
    as scipy.linalg.solve_discrete_are(A^T, H^T, Q, R)); K = P- H^T (H P- H^T + R)^-1, the gain
    of x = x- + K (z - H x-).
    """
    a = np.atleast_2d(np.asarray(A, dtype=np.float64))
    h = np.atleast_2d(np.asarray(H, dtype=np.float64))
    q = np.atleast_2d(np.asarray(Q, dtype=np.float64))
    r = np.atleast_2d(np.asarray(R, dtype=np.float64))
    try:
        p = solve_discrete_are(a.T, h.T, q, r)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise ValueError(
            "no steady-state gain: the Riccati equation has no stabilising solution "
            f"(is the model detectable from this H?): {exc}"
        ) from exc
    s = h @ p @ h.T + r
    return np.linalg.solve(s.T, (p @ h.T).T).T


def observer_poles(A: np.ndarray, K: np.ndarray, H: np.ndarray, form: str = "paper") -> np.ndarray:
    """Eigenvalues of the estimation-error dynamics.

    ``form="paper"``: eig(A - K H), paper 002's formula -- the poles of a *predictor-form*
    observer x-_{k+1} = A x-_k + K (z_k - H x-_k). ``form="filter"``: eig((I - K H) A), the error
    dynamics of the filter-form estimate x_k = x-_k + K (z_k - H x-_k) that a Kalman gain K_k from
    paper 002's eq. 12 actually drives (the same as eig(A - (A K) H)).
    """
    a = np.atleast_2d(np.asarray(A, dtype=np.float64))
    h = np.atleast_2d(np.asarray(H, dtype=np.float64))
    k = np.asarray(K, dtype=np.float64).reshape(a.shape[0], h.shape[0])
    if form == "paper":
        m = a - k @ h
    elif form == "filter":
        m = (np.eye(a.shape[0]) - k @ h) @ a
    else:
        raise ValueError(f"form must be 'paper' or 'filter', got {form!r}")
    return np.linalg.eigvals(m)


def stability_verdict(poles: np.ndarray, tol: float = 1e-9) -> str:
    """'stable' (all |z| < 1), 'marginal' (largest |z| = 1 within tol) or 'unstable'."""
    r = float(np.max(np.abs(np.asarray(poles))))
    if r < 1.0 - tol:
        return "stable"
    if r <= 1.0 + tol:
        return "marginal"
    return "unstable"


def accel_tilt_angles(acc_g: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Paper 002 eq. 13 for (..., 3) accelerations [Ax, Ay, Az] in g: (rho, phi, theta) in rad.

    rho = atan(Ax / sqrt(Ay^2 + Az^2)), phi = atan(Ay / sqrt(Ax^2 + Az^2)),
    theta = atan(sqrt(Ax^2 + Ay^2) / Az). arctan2 keeps theta right for Az <= 0 (past 90 deg).
    """
    a = np.asarray(acc_g, dtype=np.float64)
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    rho = np.arctan2(ax, np.hypot(ay, az))
    phi = np.arctan2(ay, np.hypot(ax, az))
    theta = np.arctan2(np.hypot(ax, ay), az)
    return rho, phi, theta


def gravity_compensate(acc_g: np.ndarray) -> np.ndarray:
    """Paper 002's gravity removal: (..., 3) g -> linear acceleration in cm/s^2 (x 980).

    Each axis loses the gravity component the tilt angles imply: sin(rho) on x, sin(phi) on y
    and cos(theta) on z (theta is measured from the z axis, so the paper's "sine of the angle"
    is the cosine there). With the angles taken from the same sample, sin(rho) = Ax/|A| etc.,
    so the result is A (1 - 1/|A|) x 980: exactly zero at rest at any tilt -- and, because tilt
    and linear acceleration cannot be told apart from one sample, a linear acceleration a along x
    with no tilt comes out as only about a^3/2 (in g): most of the motion is removed with gravity.
    """
    a = np.asarray(acc_g, dtype=np.float64)
    if a.shape[-1] != 3:
        raise ValueError(f"expected [Ax, Ay, Az] in the last dimension, got {a.shape}")
    rho, phi, theta = accel_tilt_angles(a)
    g_vec = np.stack([np.sin(rho), np.sin(phi), np.cos(theta)], axis=-1)
    return (a - g_vec) * STANDARD_GRAVITY_CM_S2


# --------------------------------------------------------------------------- helpers
def _check_positive(**values: float) -> None:
    for name, v in values.items():
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive number, got {v}")


def _check_nonneg(**values: float) -> None:
    for name, v in values.items():
        if not (np.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be zero or positive, got {v}")
