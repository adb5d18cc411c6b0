"""Compiled inner loops (numba): the recursions that no vectorised numpy form computes well.

Only loops that numpy cannot do in a few passes live here: the gait-aware filter's update is a
two-state recursion whose wrap rule depends on the state before each sample (and its per-sample
choice of measurement and gain, fused into the same loop); the smoother's banded substitutions
are recursions too. What vectorises (the accelerometer tilt, the gravity reference's trigonometry
and low-pass) stays in numpy. Each kernel is compiled on its first call and cached on disk in the
user's cache folder (:func:`numba_cache_dir`), so later runs start at once. Never beside this
module: files pip does not know of, left in an installed package's ``__pycache__``, outlive its
uninstall and hide a later editable install of gaitmon (``cannot import name '__version__'``).

numba is the dependency for this because the alternatives were measured and were slower: the same
recursion as one banded triangular system per block (BLAS ``dtbsv``) with the wrap rule applied
by predicted re-solves cost 0.09 s per recorded hour for 4 segments, and the motion windows and
gain choice another 0.05 s in numpy passes; this loop costs ~0.02 s for all of it.
"""

from __future__ import annotations

import math
import os

import numpy as np

from gaitmon import paths
from gaitmon.errors import UserError

NUMBA_MISSING = "gaitmon's filters need numba: pip install 'numba>=0.60'"


def numba_cache_dir() -> str:
    """Where numba caches the compiled loops: ``NUMBA_CACHE_DIR`` when the user set it, else
    ``numba`` in gaitmon's folder of the user's cache (platformdirs: ~/.cache/gaitmon/numba on
    Linux)."""
    explicit = os.environ.get("NUMBA_CACHE_DIR", "")
    if explicit:
        return explicit
    try:
        folder = str(paths.user_cache_dir())
    except ModuleNotFoundError:  # an environment installed before gaitmon required platformdirs
        from numba.misc import appdirs  # the same rules, vendored by numba

        folder = str(appdirs.user_cache_dir("gaitmon", False))  # type: ignore[no-untyped-call]
    return os.path.join(folder, "numba")


def _cache_in_user_folder() -> None:
    """Point numba's cache at :func:`numba_cache_dir` before the kernels below are decorated
    (numba picks a function's cache folder then). The environment variable is numba's own
    setting; child processes inherit it, so they share one cache."""
    try:
        os.environ["NUMBA_CACHE_DIR"] = numba_cache_dir()
        from numba.core.config import reload_config
    except ModuleNotFoundError as exc:
        if (exc.name or "").partition(".")[0] in ("numba", "llvmlite"):
            raise UserError(NUMBA_MISSING) from None
        raise
    # numba reads its settings at import, and it may have been imported before this module
    reload_config()  # type: ignore[no-untyped-call]


_cache_in_user_folder()

from numba import njit  # noqa: E402  (after the cache folder is set)

_TWO_PI = 2.0 * math.pi


@njit(cache=True, nogil=True)
def gait_aware_update(
    dev: np.ndarray, w: np.ndarray, z_acc: np.ndarray, z_grav: np.ndarray, tail: np.ndarray,
    n_win: np.ndarray, gravity: np.ndarray, gated: np.ndarray, static_acc: np.ndarray,
    static_rate: np.ndarray,
    k_static: np.ndarray, k_grav: np.ndarray, r_static: np.ndarray,
    r_moving: np.ndarray, acc_scale: np.ndarray, rate_scale: np.ndarray, log_r: np.ndarray,
    gains: np.ndarray, dt_s: float, start: bool, theta: np.ndarray, bias: np.ndarray,
    theta_out: np.ndarray, mag: np.ndarray, plane_thr: np.ndarray, plane_alpha: np.ndarray,
    k_plane: np.ndarray, plane_lp: np.ndarray, r_plane: np.ndarray,
    h_grav: np.ndarray, cov: np.ndarray, exact: np.ndarray,
    q: np.ndarray, r_grav: np.ndarray, p_end: np.ndarray, r_factor: np.ndarray, huber: float,
    start_static: np.ndarray, stride_foot: int, stride_r: np.ndarray,
    stride_int: np.ndarray, stride_state: np.ndarray, stride_limits: np.ndarray,
) -> None:  # fmt: skip
    """The gait-aware filter over one block (gaitmon.dsp.motion_kalman, module doc), per
    segment column in time order; writes ``theta_out`` (N, S) and carries the state.

    Inputs (N, S): ``dev`` = | |a| - g |, the gyro rate ``w``, the accelerometer tilt
    ``z_acc`` and the gravity tilt ``z_grav`` (read only for the ``gravity`` segments). Per
    segment (S,): whether it takes the gravity tilt while moving, or nothing (``gated``), or
    else the accelerometer tilt weighted by the motion; the motion window ``n_win`` and its
    thresholds, the static and gravity gains (S, 2), and the weighted
    segments' R = r_moving (1 + (dev/acc_scale)^2)
    (1 + (rate/rate_scale)^2 if rate_scale > 0) whose gain is read off the table ``gains``
    (M, S, 2) at ``log_r`` (M,), linearly between knots. State: ``tail`` (n_max - 1, 2, S), the
    last samples' (dev, |w|) (-inf before the first); ``start`` sets theta from the first
    sample's measurement; ``theta``, ``bias`` (S,).

    Out of plane: ``mag`` (N, S) = |a| of the two axes, low-passed by one pole
    (``plane_lp`` (S,) carried, lp += ``plane_alpha`` (|a| - lp)); while lp < ``plane_thr``
    (0 = never) the accelerometer tilt is the measurement with the angle gain ``k_plane`` (S,)
    and none on the bias, before any other rule (in the start-up, the angle-only gain of the
    propagated covariance for the variance ``r_plane`` (S,)).

    Start-up (gaitmon.dsp.motion_kalman, "Start-up"): the gravity tilt's bias gain ``h_grav``
    (N, S) is per sample; while ``exact[c]`` the segment's gain is the time-varying Kalman gain
    of its covariance ``cov[c]`` = (P00, P01, P11), propagated with Q = ``q[c]`` (q_angle,
    q_bias) and updated with the chosen measurement's R (``r_static``, ``r_grav``, the weighted
    R; none while gated); once P00 and P11 fall to ``p_end[c]`` (2,) the segment goes over to
    the scheduled gains above (``exact[c]`` cleared). While exact, a segment with
    ``start_static[c]`` False takes no quasi-static sample, and at each foot-flat onset of the
    column ``stride_foot`` (-1 = none) a segment with ``stride_r[c]`` > 0 takes the mean gyro
    rate of the stride that ended as a bias measurement (R = stride_r / T^2); carried:
    ``stride_int`` (S,) the gyro integrals since the last onset, ``stride_state`` (time since
    it, -1 = none; the foot flat at the last sample); ``stride_limits`` (shortest, longest).
    """
    n, s = dev.shape
    m = tail.shape[0]  # n_max - 1
    n_knots = len(log_r)
    # the motion windows: the maxima of the last n_win samples (the tail before row 0)
    win_d = np.empty((n, s))
    win_r = np.empty((n, s))
    ext_d = np.empty(m + n)  # (tail, this block) of one segment
    ext_r = np.empty(m + n)
    for c in range(s):
        for t in range(m):
            ext_d[t] = tail[t, 0, c]
            ext_r[t] = tail[t, 1, c]
        for k in range(n):
            ext_d[m + k] = dev[k, c]
            ext_r[m + k] = abs(w[k, c])
        nw = n_win[c]
        for k in range(n):
            md = ext_d[m + k]
            mr = ext_r[m + k]
            for j in range(m + k - nw + 1, m + k):
                md = max(md, ext_d[j])
                mr = max(mr, ext_r[j])
            win_d[k, c] = md
            win_r[k, c] = mr
        for t in range(m):  # the tail for the next block
            tail[t, 0, c] = ext_d[n + t]
            tail[t, 1, c] = ext_r[n + t]
    # the update, the segments side by side (their recursions overlap in the CPU)
    for k in range(n):
        # the stride-periodic bias (start-up): the foot's foot-flat onsets mark whole strides
        ready = False  # a stride ended at this sample: stride_int holds its mean rates
        span = 0.0
        if stride_foot >= 0:
            f = stride_foot
            flat = win_d[k, f] < static_acc[f] and win_r[k, f] < static_rate[f]
            if stride_state[0] >= 0.0:  # the time and gyro integrals since the last onset
                stride_state[0] += dt_s
                for c in range(s):
                    stride_int[c] += w[k, c] * dt_s
            # an onset; none within stride_limits[0] of the last (a foot-flat's toggling)
            if flat and stride_state[1] == 0.0 and not 0.0 <= stride_state[0] < stride_limits[0]:
                span = stride_state[0]
                ready = 0.0 < span <= stride_limits[1]
                stride_state[0] = 0.0
                for c in range(s):
                    stride_int[c] = stride_int[c] / span if ready else 0.0
            stride_state[1] = 1.0 if flat else 0.0
        for c in range(s):
            md = win_d[k, c]
            mr = win_r[k, c]
            static = md < static_acc[c] and mr < static_rate[c]
            if exact[c] and not start_static[c]:
                static = False
            z = z_acc[k, c]
            h = 0.0
            r_now = math.inf  # the measurement's R, for the exact start-up gain
            plane = False
            lp = plane_lp[c] + plane_alpha[c] * (mag[k, c] - plane_lp[c])
            plane_lp[c] = lp
            if lp < plane_thr[c]:
                k0 = k_plane[c]
                k1 = 0.0
                plane = True
            elif static:
                k0 = k_static[c, 0]
                k1 = k_static[c, 1]
                r_now = r_static[c]
            elif gravity[c]:
                z = z_grav[k, c]
                h = h_grav[k, c]
                k0 = k_grav[c, 0]
                k1 = k_grav[c, 1]
                r_now = r_grav[k, c]
            elif gated[c]:
                k0 = 0.0
                k1 = 0.0
            else:
                rr = r_moving[c] * (1.0 + (md / acc_scale[c]) ** 2)
                r_now = rr
                if rate_scale[c] > 0.0:
                    rr *= 1.0 + (mr / rate_scale[c]) ** 2
                if not math.isfinite(rr):
                    k0 = 0.0
                    k1 = 0.0
                else:
                    lr = math.log10(rr)
                    if lr <= log_r[0]:
                        k0 = gains[0, c, 0]
                        k1 = gains[0, c, 1]
                    elif lr >= log_r[n_knots - 1]:
                        k0 = gains[n_knots - 1, c, 0]
                        k1 = gains[n_knots - 1, c, 1]
                    else:
                        i = min(int((lr - log_r[0]) / (log_r[1] - log_r[0])), n_knots - 2)
                        while i > 0 and log_r[i] > lr:
                            i -= 1
                        while log_r[i + 1] < lr:
                            i += 1
                        f = (lr - log_r[i]) / (log_r[i + 1] - log_r[i])
                        k0 = gains[i, c, 0] + f * (gains[i + 1, c, 0] - gains[i, c, 0])
                        k1 = gains[i, c, 1] + f * (gains[i + 1, c, 1] - gains[i, c, 1])
            if start and k == 0:  # the angle starts at the first measurement (wrapped)
                theta[c] = z - _TWO_PI * math.floor(z / _TWO_PI + 0.5)
            b = bias[c]
            pred = theta[c] + (w[k, c] - b) * dt_s
            e = z - pred - h * b
            if abs(e) > math.pi:  # paper 000's wrap(z - theta-)
                e -= _TWO_PI * math.floor(e / _TWO_PI + 0.5)
            if exact[c]:  # the start-up: the exact gain of the propagated covariance
                p00 = cov[c, 0] - 2.0 * dt_s * cov[c, 1] + dt_s * dt_s * cov[c, 2] + q[c, 0]
                p01 = cov[c, 1] - dt_s * cov[c, 2]
                p11 = cov[c, 2] + q[c, 1]
                if plane:  # the angle alone (the bias is left alone out of plane)
                    k0 = p00 / (p00 + r_plane[c])
                    k1 = 0.0
                    p01 -= k0 * p01  # (Joseph form for the gain (k0, 0): P11 unchanged)
                    p00 -= k0 * p00
                elif math.isfinite(r_now):
                    ph0 = p00 + h * p01
                    ph1 = p01 + h * p11
                    sv = ph0 + h * ph1 + r_now * r_factor[c]
                    if e * e > huber * huber * sv:  # beyond huber sigmas: weighed as at huber
                        sv = e * e / (huber * huber)
                    k0 = ph0 / sv
                    k1 = ph1 / sv
                    p00 -= k0 * ph0
                    p01 -= k0 * ph1
                    p11 -= k1 * ph1
                else:
                    k0 = 0.0
                    k1 = 0.0
                cov[c, 0] = p00
                cov[c, 1] = p01
                cov[c, 2] = p11
                if p00 <= p_end[c, 0] and p11 <= p_end[c, 1]:
                    exact[c] = False
            theta[c] = pred + k0 * e
            bias[c] = b + k1 * e
            if ready:
                mean_w = stride_int[c]
                stride_int[c] = 0.0
                if exact[c] and stride_r[c] > 0.0:  # mean gyro over the stride = the bias
                    eb = mean_w - bias[c]
                    sv = cov[c, 2] + stride_r[c] / (span * span)
                    if eb * eb > huber * huber * sv:
                        sv = eb * eb / (huber * huber)
                    g0 = cov[c, 1] / sv
                    g1 = cov[c, 2] / sv
                    theta[c] += g0 * eb
                    bias[c] += g1 * eb
                    cov[c, 0] -= g0 * cov[c, 1]
                    cov[c, 1] -= g0 * cov[c, 2]
                    cov[c, 2] -= g1 * cov[c, 2]
            theta_out[k, c] = theta[c]


@njit(cache=True, nogil=True)
def constant_map_solve(
    cb: np.ndarray, inv_diag: np.ndarray, z: np.ndarray, w: np.ndarray, w_meas: float, v: float,
    dt_s: float, prior_z: np.ndarray, prior_w: float, x: np.ndarray,
) -> None:  # fmt: skip
    """The smoother's normal equations A x = g of S segments at once, for constant variances,
    given the banded Cholesky factor of A (``cb``: LAPACK's upper band form, cb[2 + i - j, j] =
    U[i, j], A = U^T U; ``inv_diag`` = 1 / cb[2]), with g built on the fly from the data
    (z, w: (N, S)); writes x (2N, S): theta_k = x[2k], b_k = x[2k + 1].

    g is :func:`gaitmon.dsp.smoother._normal_rhs` for constant weights: the measurement
    ``w_meas`` z_k on theta_k, each transition's v (w_k dt) on theta_(k-1), b_(k-1) and theta_k
    (v = 1 / q_angle), and the prior ``prior_w`` ``prior_z`` on theta_0. The two substitutions
    are LAPACK's ``dpbtrs`` (U^T y = g, then U x = y); the S segments share the factor and run
    side by side, so their dependency chains overlap.
    """
    n, s = z.shape
    m = 2 * n
    for j in range(m):  # forward: U^T y = g, y in x
        k = j // 2
        for c in range(s):
            if j % 2 == 0:  # theta_k
                g = w_meas * z[k, c]
                if k == 0:
                    g += prior_w * prior_z[c]
                else:
                    g += v * (w[k, c] * dt_s)
                if k + 1 < n:
                    g -= v * (w[k + 1, c] * dt_s)
            else:  # b_k
                g = v * dt_s * (w[k + 1, c] * dt_s) if k + 1 < n else 0.0
            if j >= 1:
                g -= cb[1, j] * x[j - 1, c]
            if j >= 2:
                g -= cb[0, j] * x[j - 2, c]
            x[j, c] = g * inv_diag[j]
    for j in range(m - 1, -1, -1):  # backward: U x = y
        for c in range(s):
            t = x[j, c]
            if j + 1 < m:
                t -= cb[1, j + 1] * x[j + 1, c]
            if j + 2 < m:
                t -= cb[0, j + 2] * x[j + 2, c]
            x[j, c] = t * inv_diag[j]
