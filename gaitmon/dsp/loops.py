"""The inner loops of the gait-aware filter and the smoother, as plain Python: the one source.

The recursions numpy cannot do in a few passes live here: the gait-aware filter's update is a
two-state recursion whose wrap rule depends on the state before each sample (and its per-sample
choice of measurement and gain, fused into the same loop); the smoother's banded factorisation
and substitutions are recursions too. So do, since issue 28, the per-block passes long batch
work runs compiled in one sweep instead of numpy's several (each with its temporaries): counts
to physical units (:func:`physical`), the gravity reference's gyro angle and its low-passed
world-frame force (:func:`gyro_angle`, :func:`gravity_average`), the filter's motion inputs
(:func:`gait_aware_inputs`), the zeroed tilts and joints (:func:`zeroed_tilts`), the
smoother's turn and right-hand side (:func:`reduced`, :func:`turned`, :func:`constant_rhs`),
and the stride measures' strapdown pass (:func:`stride_pass`, in :mod:`gaitmon.dsp.loops_stride`
for this file's size, re-exported here).
Each does numpy's operations in numpy's order, so it gives the numpy path's numbers (bit for
bit on the bench's hour against the code before); numpy keeps the live blocks, short records
and processes without numba (:mod:`gaitmon.dsp.kernels`), and what numpy does best stays
there (the arctangents and the single-precision sines and cosines: SIMD, and the loops would
not round the single-precision turn as numpy does).

Each function here runs two ways from this one source (:mod:`gaitmon.dsp.kernels` chooses):
compiled by numba (``gaitmon.dsp.kernels_numba``: ``njit`` applied to these very functions,
cached in the user's cache folder), or as it stands in the interpreter, given
``memoryview`` s of the arrays (``mv[k, c]`` reads a Python float, several times faster than
indexing a numpy array). So the code here uses only what both understand: indexing, ``len``,
``.shape``, ``math`` and the builtins ``abs``, ``min``, ``max``, ``int``, ``float``, ``round``
(half to even, as ``np.rint``) and ``range``; a loop calls no other (numba would not compile
the call). This module imports neither numba nor numpy.
"""

from __future__ import annotations

import math
from typing import Any

from gaitmon.dsp.loops_stride import stride_pass as stride_pass

Array = Any  # a float64 numpy array (compiled) or a memoryview of one (interpreted)

_TWO_PI = 2.0 * math.pi


def gait_aware_update(
    win_d: Array, win_r: Array, w: Array, z_acc: Array, z_grav: Array, gravity: Array,
    gated: Array, static_acc: Array, static_rate: Array,
    k_static: Array, k_grav: Array, r_static: Array,
    r_moving: Array, acc_scale: Array, rate_scale: Array, log_r: Array,
    gains: Array, dt_s: float, start: bool, theta: Array, bias: Array,
    theta_out: Array, mag: Array, plane_thr: Array, plane_alpha: Array,
    k_plane: Array, plane_lp: Array, r_plane: Array,
    h_grav: Array, cov: Array, exact: Array,
    q: Array, r_grav: Array, p_end: Array, r_factor: Array, huber: float,
    start_static: Array, stride_foot: int, stride_r: Array,
    stride_int: Array, stride_state: Array, stride_limits: Array,
) -> None:  # fmt: skip
    """The gait-aware filter over one block (gaitmon.dsp.motion_kalman, module doc), per
    segment column in time order; writes ``theta_out`` (N, S) and carries the state.

    Inputs (N, S): the motion windows ``win_d`` = max | |a| - g | and ``win_r`` = max |w|
    over each segment's last n_win samples (:func:`gaitmon.dsp.kernels.motion_windows`), the
    gyro rate ``w``, the accelerometer tilt ``z_acc`` and the gravity tilt ``z_grav`` (read
    only for the ``gravity`` segments). Per segment (S,): whether it takes the gravity tilt
    while moving, or nothing (``gated``), or else the accelerometer tilt weighted by the
    motion; the windows' thresholds, the static and gravity gains (S, 2), and the weighted
    segments' R = r_moving (1 + (dev/acc_scale)^2)
    (1 + (rate/rate_scale)^2 if rate_scale > 0) whose gain is read off the table ``gains``
    (M, S, 2) at ``log_r`` (M,), linearly between knots. State: ``start`` sets theta from the
    first sample's measurement; ``theta``, ``bias`` (S,).

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
    n, s = win_d.shape
    n_knots = len(log_r)
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
            lp = plane_lp[c]
            lp = lp + plane_alpha[c] * (mag[k, c] - lp)
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
            th = pred + k0 * e
            theta[c] = th
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
                    th += g0 * eb
                    theta[c] = th
                    bias[c] += g1 * eb
                    cov[c, 0] -= g0 * cov[c, 1]
                    cov[c, 1] -= g0 * cov[c, 2]
                    cov[c, 2] -= g1 * cov[c, 2]
            theta_out[k, c] = th


def constant_map_solve(cb: Array, inv_diag: Array, x: Array) -> None:
    """The smoother's normal equations A x = g of S segments at once, in place (x (2N, S): g on
    entry, the solution on return), given the banded Cholesky factor of A (``cb``: LAPACK's
    upper band form, cb[2 + i - j, j] = U[i, j], A = U^T U; ``inv_diag`` = 1 / cb[2]).

    The two substitutions are LAPACK's ``dpbtrs`` (U^T y = g, then U x = y); the S segments
    share the factor and run side by side, so their dependency chains overlap.
    """
    m, s = x.shape
    for j in range(min(m, 2)):  # forward: U^T y = g, y in x
        d = inv_diag[j]
        for c in range(s):
            t = x[j, c]
            if j == 1:
                t -= cb[1, 1] * x[0, c]
            x[j, c] = t * d
    for j in range(2, m):
        c1 = cb[1, j]
        c0 = cb[0, j]
        d = inv_diag[j]
        for c in range(s):
            x[j, c] = (x[j, c] - c1 * x[j - 1, c] - c0 * x[j - 2, c]) * d
    if m >= 2:  # backward: U x = y
        d = inv_diag[m - 1]
        for c in range(s):
            x[m - 1, c] = x[m - 1, c] * d
        c1 = cb[1, m - 1]
        d = inv_diag[m - 2]
        for c in range(s):
            x[m - 2, c] = (x[m - 2, c] - c1 * x[m - 1, c]) * d
    elif m == 1:
        for c in range(s):
            x[0, c] = x[0, c] * inv_diag[0]
    for j in range(m - 3, -1, -1):
        c1 = cb[1, j + 1]
        c0 = cb[0, j + 2]
        d = inv_diag[j]
        for c in range(s):
            x[j, c] = (x[j, c] - c1 * x[j + 1, c] - c0 * x[j + 2, c]) * d


def band_cholesky(ab: Array) -> None:
    """The Cholesky factor U (A = U^T U) of a symmetric positive definite matrix with two
    off-diagonals, in place, in LAPACK's upper band form (ab (3, M): ab[2 + i - j, j] = A[i, j];
    ``dpbtrf``'s numbers, to rounding). Raises ValueError where A is not positive definite."""
    m = ab.shape[1]
    for j in range(m):
        # U[j-2, j], U[j-1, j], then U[j, j]
        u0 = 0.0
        if j >= 2:
            u0 = ab[0, j] / ab[2, j - 2]
            ab[0, j] = u0
        u1 = 0.0
        if j >= 1:
            u1 = ab[1, j]
            if j >= 2:
                u1 -= ab[1, j - 1] * u0
            u1 /= ab[2, j - 1]
            ab[1, j] = u1
        d = ab[2, j] - u0 * u0 - u1 * u1
        if not d > 0.0:
            raise ValueError("the smoother's normal matrix is not positive definite")
        ab[2, j] = math.sqrt(d)


def band_solve(cb: Array, g: Array) -> None:
    """Solve U^T U x = g in place (g (M,)) given :func:`band_cholesky`'s factor ``cb``."""
    m = len(g)
    for j in range(m):  # U^T y = g
        t = g[j]
        if j >= 1:
            t -= cb[1, j] * g[j - 1]
        if j >= 2:
            t -= cb[0, j] * g[j - 2]
        g[j] = t / cb[2, j]
    for j in range(m - 1, -1, -1):  # U x = y
        t = g[j]
        if j + 1 < m:
            t -= cb[1, j + 1] * g[j + 1]
        if j + 2 < m:
            t -= cb[0, j + 2] * g[j + 2]
        g[j] = t / cb[2, j]


def running_mean(x: Array, size: int, cval: float, out: Array) -> None:
    """The mean over a window of ``size`` samples centred on each sample (samples
    i - size // 2 .. i - size // 2 + size - 1, ``cval`` outside), along each row of x (R, N),
    into out: scipy.ndimage's ``uniform_filter1d(mode="constant")``, as a running sum (the first
    window summed in order, then each step adding (entering - leaving) / size)."""
    rows, n = x.shape
    left = size // 2
    for r in range(rows):
        tmp = 0.0
        for i in range(-left, size - left):
            tmp += x[r, i] if 0 <= i < n else cval
        tmp /= size
        out[r, 0] = tmp
        for i in range(1, n):
            j = i + size - 1 - left  # entering
            k = i - 1 - left  # leaving
            enter = x[r, j] if j < n else cval
            leave = x[r, k] if k >= 0 else cval
            tmp += (enter - leave) / size
            out[r, i] = tmp


def lfilter(b: Array, a: Array, x: Array, z: Array, y: Array) -> None:
    """scipy.signal.lfilter's direct form II transposed along axis 0 of x (N, C) into y (N, C),
    the C channels side by side, from the state z (p, C) (scipy's ``zi``), left in z (its
    ``zf``). b, a (p + 1,) with a[0] = 1 (normalised, padded to one length, p >= 1). scipy's
    operations in its order: y = z_0 + b_0 x, z_i = (z_i+1 + b_i+1 x) - a_i+1 y (z_p = 0), so
    the numbers are scipy's and any cut of the record into calls gives the same ones.

    Compiled only (gaitmon.dsp.iir's numpy block form serves where numba does not): the
    interpreted form is the reference the tests read."""
    n, c = x.shape
    p = len(b) - 1
    if p == 2:  # the pipeline's low-passes: a pair of channels at a time, their states in
        # registers (the two recursions overlap in the CPU), the same operations
        b0, b1, b2 = b[0], b[1], b[2]
        a1, a2 = a[1], a[2]
        for j in range(0, c, 2):
            v = min(j + 1, c - 1)  # (an odd last channel runs twice: the same numbers)
            u0, u1 = z[0, j], z[1, j]
            v0, v1 = z[0, v], z[1, v]
            for k in range(n):
                xu = x[k, j]
                xv = x[k, v]
                yu = u0 + b0 * xu
                yv = v0 + b0 * xv
                u0 = u1 + b1 * xu - a1 * yu
                v0 = v1 + b1 * xv - a1 * yv
                u1 = b2 * xu - a2 * yu
                v1 = b2 * xv - a2 * yv
                y[k, j] = yu
                y[k, v] = yv
            z[0, j], z[1, j] = u0, u1
            z[0, v], z[1, v] = v0, v1
        return
    b0 = b[0]
    bp = b[p]
    ap = a[p]
    for k in range(n):
        for j in range(c):
            xk = x[k, j]
            yk = z[0, j] + b0 * xk
            for i in range(p - 1):
                z[i, j] = z[i + 1, j] + b[i + 1] * xk - a[i + 1] * yk
            z[p - 1, j] = bp * xk - ap * yk
            y[k, j] = yk


def physical(counts: Array, cols: Array, zero: Array, scale: Array, out: Array) -> None:
    """Raw counts (N, C) to physical units: out[k, i] = (counts[k, cols[i]] - zero[i]) *
    scale[i] (:meth:`gaitmon.dsp.channels.ChannelTable.to_physical`'s operations, in its
    order: the same numbers)."""
    n = counts.shape[0]
    m = len(cols)
    for k in range(n):
        for i in range(m):
            out[k, i] = (float(counts[k, cols[i]]) - zero[i]) * scale[i]


def constant_rhs(
    zt: Array, w: Array, w_meas: float, v: float, dt_s: float, prior: Array, g: Array
) -> None:  # fmt: skip
    """The smoother's right-hand side for constant weights into g (2N, S), S segments side by
    side, from z~ laid out segment-major (``zt`` (S, N)) and the gyro w (N, S)
    (:func:`gaitmon.dsp.smoother_map._constant_rhs`'s operations in its order): on theta_k
    ((w_meas z_k [+ prior (S,), weighted, on k = 0]) + (w_k dt) v) - (w_k+1 dt) v, on b_k
    (v dt) (w_k+1 dt), 0 on the last bias."""
    n, s = w.shape
    vdt = v * dt_s
    for k in range(n):
        for c in range(s):
            t = w_meas * zt[c, k]
            if k == 0:
                t += prior[c]
            else:
                t += (w[k, c] * dt_s) * v
            if k + 1 < n:
                wn = w[k + 1, c] * dt_s
                t -= wn * v
                g[2 * k + 1, c] = vdt * wn
            else:
                g[2 * k + 1, c] = 0.0
            g[2 * k, c] = t


def zeroed_tilts(
    tilt: Array, offset: Array, plus: Array, minus: Array, out_tilt: Array, out_joint: Array
) -> None:  # fmt: skip
    """Zeroed tilts out_tilt (N, S) = wrap(tilt - offset) (out_tilt may be tilt) and joint
    angles out_joint (N, J) = wrap(zeroed[plus] - zeroed[minus]), wrap to (-pi, pi] as
    :func:`gaitmon.dsp.angles.wrap_angle` does it (x - 2 pi rint(x / 2 pi), + 2 pi at -pi;
    an x in (-pi, pi] is itself; NaN where x is not finite):
    :meth:`gaitmon.dsp.calibration.Calibration.apply_tilt` and
    :func:`gaitmon.dsp.angles.joint_angles`, the same operations."""
    n, s = tilt.shape
    m = len(plus)
    for k in range(n):
        # a row's s tilts, then its m joints of those tilts: one wrap for both (a shared
        # helper would have to be compiled on its own for numba and for the built module)
        for q in range(s + m):
            if q < s:
                x = tilt[k, q] - offset[q]
            else:
                x = out_tilt[k, plus[q - s]] - out_tilt[k, minus[q - s]]
            if not -math.pi < x <= math.pi:
                if math.isfinite(x):
                    x = x - float(round(x * (1.0 / _TWO_PI))) * _TWO_PI
                    if x <= -math.pi:
                        x += _TWO_PI
                else:
                    x = math.nan
            if q < s:
                out_tilt[k, q] = x
            else:
                out_joint[k, q - s] = x


def gravity_average(
    ax: Array, az: Array, c: Array, sn: Array, b: Array, a: Array, z: Array, step: Array,
    count: int, h_table: Array, r0: Array, start_c: Array, dt_s: float, cols: Array,
    avg: Array, h_out: Array, r_out: Array,
) -> None:  # fmt: skip
    """The gravity reference's low-passed world-frame specific force (gaitmon.dsp.
    gravity_reference.GravityReference.process, one pass for what it did in several): per
    sample and segment j of the group (N, G inputs), up = ax c + az sn and fwd = az c - ax sn
    (c, sn the turn's cosine and sine), each low-passed by scipy's second-order recursion
    (:func:`lfilter`'s operations: b, a (3,), the state z (2, 2G): the up channels, then the
    fwd), divided by the step response ``step`` at the sample's count since the reset
    (``count`` at the first; not past the table's end, where it is 1), into avg (2, N, G).
    With it, the filter's inputs for the group's columns ``cols`` of h_out, r_out (N, S): the
    bias gain h_k (``h_table`` at the count, its last entry beyond) and the gravity tilt's R,
    r0 + (start_c / t)^2 at t = (count + k + 1) dt_s (gaitmon.dsp.motion_kalman,
    "Start-up"). A segment's two channels run side by side, their states in registers."""
    n, g = ax.shape
    b0, b1, b2 = b[0], b[1], b[2]
    a1, a2 = a[1], a[2]
    n_step = len(step)
    n_h = len(h_table)
    for j in range(g):
        col = cols[j]
        u0, u1 = z[0, j], z[1, j]  # the up channel's state
        f0, f1 = z[0, g + j], z[1, g + j]  # the fwd channel's
        for k in range(n):
            at = count + k
            h_out[k, col] = h_table[min(at, n_h - 1)]
            t = start_c[col] / (float(at + 1) * dt_s)
            r_out[k, col] = r0[col] + t * t
            x_up = ax[k, j] * c[k, j] + az[k, j] * sn[k, j]
            x_fwd = az[k, j] * c[k, j] - ax[k, j] * sn[k, j]
            y_up = u0 + b0 * x_up
            u0 = u1 + b1 * x_up - a1 * y_up
            u1 = b2 * x_up - a2 * y_up
            y_fwd = f0 + b0 * x_fwd
            f0 = f1 + b1 * x_fwd - a1 * y_fwd
            f1 = b2 * x_fwd - a2 * y_fwd
            if at < n_step - 1:
                s_k = step[at]
                y_up = y_up / s_k
                y_fwd = y_fwd / s_k
            avg[0, k, j] = y_up
            avg[1, k, j] = y_fwd
        z[0, j], z[1, j] = u0, u1
        z[0, g + j], z[1, g + j] = f0, f1


def gait_aware_inputs(
    ax: Array, az: Array, w: Array, n_win: Array, g: float, tail: Array,
    mag: Array, win_d: Array, win_r: Array,
) -> None:  # fmt: skip
    """The gait-aware filter's motion inputs (N, S) of one block (gaitmon.dsp.motion_kalman,
    what numpy did in several passes): mag = |a| of the two axes (sqrt(ax^2 + az^2)), and the
    maxima of dev = | mag - g | and of |w| over each segment's last ``n_win`` samples, the
    samples before the block read from ``tail`` ((M, 2, S), M = max n_win - 1: dev and |w| of
    the last M samples, -inf before the first), which becomes this block's last M. A window's
    maximum is NaN where its own sample is (an earlier NaN is passed over):
    :func:`gaitmon.dsp.kernels.motion_windows`' numbers. (dev and |w| first, then each
    window's maximum from the last sample back, in place.)"""
    n, s = ax.shape
    m = tail.shape[0]
    for k in range(n):
        for c in range(s):
            mg = math.sqrt(ax[k, c] * ax[k, c] + az[k, c] * az[k, c])
            mag[k, c] = mg
            win_d[k, c] = abs(mg - g)
            win_r[k, c] = abs(w[k, c])
    for k in range(n - 1, -1, -1):  # (the samples before k still hold dev and |w|)
        for c in range(s):
            vd = win_d[k, c]
            vr = win_r[k, c]
            for j in range(1, n_win[c]):
                i = k - j
                if i >= 0:
                    ud = win_d[i, c]
                    ur = win_r[i, c]
                else:
                    ud = tail[m + i, 0, c]
                    ur = tail[m + i, 1, c]
                if ud > vd:  # (False for NaN: passed over; a NaN sample keeps its NaN)
                    vd = ud
                if ur > vr:
                    vr = ur
            win_d[k, c] = vd
            win_r[k, c] = vr
    # the tail: dev and |w| of the last m samples (of the tail before, then of the block)
    for i in range(m):
        src = n - m + i
        if src >= 0:
            for c in range(s):
                tail[i, 0, c] = abs(mag[src, c] - g)
                tail[i, 1, c] = abs(w[src, c])
        else:
            for c in range(s):
                tail[i, 0, c] = tail[i + n, 0, c]
                tail[i, 1, c] = tail[i + n, 1, c]


def turned(ax: Array, az: Array, col: int, c: Array, sn: Array, re: Array, im: Array) -> None:
    """Column ``col`` of the specific force (ax, az (N, S)) turned into the world frame by the
    turn's cosine and sine (N,): re = ax c + az sn, im = az c - ax sn (N,)
    (:func:`gaitmon.dsp.smoother.gravity_tilt`'s numpy operations, in their order)."""
    for k in range(len(c)):
        x = ax[k, col]
        z = az[k, col]
        re[k] = x * c[k] + z * sn[k]
        im[k] = z * c[k] - x * sn[k]


def gyro_angle(w: Array, offset: Array, dt_s: float, start: Array, theta: Array,
               turn: Array) -> None:  # fmt: skip
    """The gravity reference's gyro angle theta (N, S), summed in order from ``start`` (S,)
    (the angle before the block): theta_k = theta_k-1 + (w_k + offset) dt_s, and its turn
    reduced to about (-pi, pi]: theta - 2 pi rint(theta / 2 pi) (gaitmon.dsp.gravity_reference
    .GravityReference, numpy's operations in their order: the cumulative sum's additions)."""
    n, s = w.shape
    for c in range(s):
        t = start[c]
        for k in range(n):
            t = t + (w[k, c] + offset[c]) * dt_s
            theta[k, c] = t
            turn[k, c] = t - float(round(t * (1.0 / _TWO_PI))) * _TWO_PI


def reduced(theta: Array, col: int, turn: Array) -> None:
    """Column ``col`` of theta (N, S) reduced to about (-pi, pi] into turn (N,):
    theta - 2 pi rint(theta / 2 pi) (:func:`gaitmon.dsp.smoother.gravity_tilt`'s numpy
    operations)."""
    for k in range(len(turn)):
        t = theta[k, col]
        turn[k] = t - float(round(t * (1.0 / _TWO_PI))) * _TWO_PI
