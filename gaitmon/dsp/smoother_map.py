"""The smoother's banded solve (:mod:`gaitmon.dsp.smoother`'s model, "the model" below): the
normal equations of the RTS smoother's mean, their banded Cholesky factor (one kept for the
constant variances of the gravity pass, every segment and window of a length sharing it) and
the two substitutions, run by :mod:`gaitmon.dsp.kernels`' loops.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from gaitmon.dsp import kernels

_PRIOR_THETA_VAR = 1.0
_PRIOR_BIAS_VAR = 0.1**2


def _normal_band(w_meas: np.ndarray, qa: np.ndarray, q_bias: float, dt_s: float) -> np.ndarray:
    """The normal matrix of the model (upper band form, ab[2 + i - j, j] = A[i, j], as LAPACK
    and :func:`gaitmon.dsp.loops.band_cholesky` take it), unknowns theta_k = 2k, b_k = 2k + 1.

    It depends on the variances only, not on the data: the gravity pass's constant variances
    give every segment and every window of a length the same matrix (``_constant_factor``).
    """
    n = len(w_meas)
    m = 2 * n
    ab = np.zeros((3, m))
    # (slices: the same additions as index arrays, several times faster)
    ab[2, 0] += 1.0 / _PRIOR_THETA_VAR  # prior on x_0
    ab[2, 1] += 1.0 / _PRIOR_BIAS_VAR
    ab[2, 0:m:2] += w_meas  # measurements
    if n > 1:
        # transitions k = 1..n-1: residual theta_k - theta_{k-1} + dt b_{k-1} - omega_k dt
        v = 1.0 / qa[1:]
        tk, tp, bp = slice(2, m, 2), slice(0, m - 2, 2), slice(1, m - 1, 2)
        ab[2, tp] += v
        ab[2, bp] += v * dt_s * dt_s
        ab[2, tk] += v
        ab[1, bp] += -v * dt_s  # A[tp, bp]
        ab[0, tk] += -v  # A[tp, tk]
        ab[1, tk] += v * dt_s  # A[bp, tk]
        # bias random walk: residual b_k - b_{k-1}
        u = 1.0 / q_bias
        bk = slice(3, m, 2)
        ab[2, bp] += u
        ab[2, bk] += u
        ab[0, bk] += -u  # A[bp, bk]
    return ab


def _normal_rhs(
    z: np.ndarray, gyro_rad_s: np.ndarray, w_meas: np.ndarray, qa: np.ndarray, dt_s: float,
    theta_prior: float | None,
) -> np.ndarray:  # fmt: skip
    """The right-hand side of the normal equations (the data's part)."""
    n = len(z)
    m = 2 * n
    g = np.zeros(m)
    g[0] += (z[0] if theta_prior is None else theta_prior) / _PRIOR_THETA_VAR
    g[0:m:2] += w_meas * z
    if n > 1:
        v = 1.0 / qa[1:]
        wdt = gyro_rad_s[1:] * dt_s
        g[0 : m - 2 : 2] += -v * wdt
        g[1 : m - 1 : 2] += v * dt_s * wdt
        g[2:m:2] += v * wdt
    return g


def _measurement_weights(r: np.ndarray) -> np.ndarray:
    return np.where(np.isfinite(r), 1.0 / np.where(np.isfinite(r), r, 1.0), 0.0)


def _constant_factor(
    n: int, r: float, qa: float, q_bias: float, dt_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """The banded Cholesky factor of the normal matrix for constant variances and the
    reciprocal of its diagonal (read-only)."""
    cb = _normal_band(_measurement_weights(np.full(n, r)), np.full(n, qa), q_bias, dt_s)
    kernels.band_cholesky(cb)
    inv_diag = 1.0 / cb[2]
    cb.flags.writeable = inv_diag.flags.writeable = False
    return cb, inv_diag


def _constant_rhs(
    z: np.ndarray, w: np.ndarray, w_meas: float, v: float, dt_s: float, prior: np.ndarray,
    rows: int | None = None,
) -> np.ndarray:  # fmt: skip
    """(2N, S) the right-hand side of the normal equations (:func:`_normal_rhs`) for constant
    weights, S segments side by side: the measurement ``w_meas`` z_k on theta_k, each
    transition's v (w_k dt) on theta_(k-1), b_(k-1) and theta_k (v = 1 / q_angle), and the
    prior ``prior`` (S,) on theta_0 (weight 1 / _PRIOR_THETA_VAR). In one compiled pass
    (:func:`gaitmon.dsp.loops.constant_rhs`) where the rule picks numba for ``rows`` (the
    solve's), else numpy; the same numbers."""
    n = len(z)
    g = np.empty((2 * n, z.shape[1]))
    module = None if rows is None else kernels.compiled_for(rows, count=False)
    if module is not None and w.dtype == np.float64 and z.dtype == np.float64:
        zt = np.ascontiguousarray(z.T)  # (the gravity pass's z~ is segment-major: no copy)
        wc = w if kernels.plain(w) else np.array(w, order="C")
        module.constant_rhs(zt, wc, float(w_meas), float(v), float(dt_s),
                            (1.0 / _PRIOR_THETA_VAR) * np.asarray(prior, dtype=np.float64), g)
        return g
    wdt = w * dt_s
    th = g[0::2]
    np.multiply(w_meas, z, out=th)
    th[0] += (1.0 / _PRIOR_THETA_VAR) * prior
    b = g[1::2]
    np.multiply(v * dt_s, wdt[1:], out=b[:-1])
    b[-1] = 0.0
    # v (w_k dt), in place (the same products as v * wdt: no second (N, S) temporary)
    vw = wdt[1:]
    vw *= v
    th[1:] += vw
    th[:-1] -= vw
    return g


class _Factors:
    """The factors kept (~7 MB per 100 k rows each): two, as a long record's smoother blocks
    have two lengths (the first and last block, the others: gaitmon.finish.smoothed; 102 k and
    114 k rows), so each is built once. The older is let go before a third is built: three
    are never held at once."""

    KEEP = 2

    def __init__(self) -> None:
        self._kept: dict[tuple[int, float, float, float, float], tuple[np.ndarray, ...]] = {}
        self.hits = self.misses = 0

    def get(self, *key: Any) -> tuple[np.ndarray, np.ndarray]:
        factor = self._kept.pop(key, None)  # (put back last: the most recently used)
        if factor is None:
            self.misses += 1
            while len(self._kept) >= self.KEEP:
                del self._kept[next(iter(self._kept))]
            factor = _constant_factor(*key)
        else:
            self.hits += 1
        self._kept[key] = factor
        return factor[0], factor[1]

    def __len__(self) -> int:
        return len(self._kept)

    def clear(self) -> None:
        self._kept.clear()
        self.hits = self.misses = 0


_factors = _Factors()


def _factor(
    n: int, r: float, qa: float, q_bias: float, dt_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """The constant-variance factor (``_constant_factor``) of these, kept (:class:`_Factors`)."""
    return _factors.get(n, r, qa, q_bias, dt_s)


def release_factors() -> None:
    """Drop the kept factors once a record is smoothed."""
    _factors.clear()


def smooth_map(
    z: np.ndarray, gyro_rad_s: np.ndarray, r: np.ndarray | float, qa: np.ndarray | float,
    q_bias: float, dt_s: float, theta_prior: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The RTS smoother's mean (theta, bias) of the model, shaped like ``z``, in one
    banded solve.

    With scalar (constant) ``r`` and ``qa`` the normal matrix does not depend on the data: its
    Cholesky factor is computed once per length and reused (the gravity pass: every segment
    and every window), and ``z``, ``gyro_rad_s`` may be (N, S), S segments solved side by side
    (:func:`gaitmon.dsp.loops.constant_map_solve`). Otherwise ``z`` is (N,) and the matrix is
    factored for the call (:func:`gaitmon.dsp.loops.band_cholesky`, ``band_solve``: LAPACK's
    ``solveh_banded``, to rounding).
    """
    n = len(z)
    if n == 0:
        return np.empty(np.shape(z)), np.empty(np.shape(z))
    if np.ndim(r) == 0 and np.ndim(qa) == 0:
        cb, inv_diag = _factor(n, float(r), float(qa), float(q_bias), float(dt_s))
        # (any layout: the gravity pass's z~ comes segment-major)
        z2 = np.asarray(z, dtype=np.float64).reshape(n, -1)
        w2 = np.asarray(gyro_rad_s, dtype=np.float64).reshape(z2.shape)
        prior = z2[0] if theta_prior is None else np.full(z2.shape[1], float(theta_prior))
        w_meas = 1.0 / float(r) if np.isfinite(r) else 0.0  # (no measurement: weight 0)
        x = _constant_rhs(z2, w2, w_meas, 1.0 / float(qa), float(dt_s), prior, n)
        kernels.constant_map_solve(cb, inv_diag, x)
        theta, bias = x[0::2], x[1::2]
        if np.ndim(z) == 1:
            return theta[:, 0], bias[:, 0]
        return theta, bias
    r_k, qa_k = np.asarray(r, dtype=np.float64), np.asarray(qa, dtype=np.float64)
    w_k = _measurement_weights(r_k)
    ab = _normal_band(w_k, qa_k, q_bias, dt_s)
    g = _normal_rhs(z, gyro_rad_s, w_k, qa_k, dt_s, theta_prior)
    kernels.band_cholesky(ab)
    kernels.band_solve(ab, g)
    return g[0::2], g[1::2]
