"""The zero-lag offline tilt smoother: Rauch-Tung-Striebel over the gait-aware Kalman model.

With the default tuning (``gravity_window_s`` set, every segment) it runs in two steps: the
causal gait-aware filter gives a first tilt, and the RTS smoother below is solved on the gravity
tilt z~ made from it ("Gravity pass"). With ``gravity_window_s=None`` the smoother is solved on
the accelerometer tilt with the measurement variances described next.

Model (one segment; x_k = [theta_k, b_k], paper 000's state, exact discretisation):

    theta_k = theta_{k-1} + (omega_k - b_{k-1}) dt + v_k,   v_k ~ N(0, Qa_k)
    b_k     = b_{k-1} + u_k,                                 u_k ~ N(0, q_bias)
    z_k     = theta_k + e_k,                                 e_k ~ N(0, R_k)   (if R_k finite)
    prior   theta_0 ~ N(z_0, 1 rad^2),  b_0 ~ N(0, (0.1 rad/s)^2)

R_k is the causal filter's measurement variance (gaitmon.dsp.motion_kalman), but with the 50 ms
motion window *centred* on the sample (offline, the future is known). The angle's process noise
grows with the rate, Qa_k = q_angle (1 + (|omega_k| / rate_scale)^2): a fast-swinging segment's
gyro carries scale and axis errors the stationary model does not.

The RTS smoother's mean is the maximiser of the joint Gaussian density of all states given all
data, i.e. the solution of a linear least-squares problem whose normal matrix is banded (two
off-diagonals with the unknowns ordered theta_0, b_0, theta_1, ...). It is solved that way, with
LAPACK's banded Cholesky (``scipy.linalg.solveh_banded``): the same numbers as a forward Kalman
pass followed by the RTS backward pass (tests/test_accuracy_filters.py checks it against a
hand-written RTS loop), in O(N) with no Python loop over samples.

Gravity pass. The accelerometer tilt atan2(a_z, a_x) of a walking thigh or shank carries the
segment's own acceleration, and its weighted mean over a stride is not zero (the weights follow
the motion): that left a walking-mean tilt bias of 2-9 deg in the thigh and shank, i.e. in the
peak swing knee flexion, that the RMSE with its offset removed does not show. What does average
out is the acceleration itself: a sensor point's velocity is periodic (or steady), so over a few
strides the mean of its acceleration in the *world* frame is zero and the mean specific force is
gravity. With the tilt theta_j of the pass before, the board's specific force turned into the
world frame is (a_x + i a_z) e^(-i theta_j) = (f_up + i f_fwd) e^(i (phi_j - theta_j)); its mean
over a window centred on sample k (a boxcar of ``gravity_window_s`` applied three times, so a
stride's periodic acceleration leaks in only weakly) points at mean(phi - theta) from vertical.
So

    z~_k = theta_k + arg( sum_j w_(j-k) (a_x + i a_z)_j e^(-i theta_j) )

measures the tilt with the previous pass's errors replaced by their local deviation from their
window mean: a slow error (bias drift, the accelerometer's walking bias) is gone (a linear drift
cancels exactly in the centred window), and the gyro keeps the shape within the stride. The RTS
smoother is then solved on z~ with a constant variance ``r_gravity`` and a constant angle noise
``q_angle`` (the raw accelerometer tilt is not used again). The first tilt is the causal
filter's (it is needed anyway to unwrap the accelerometer tilt); an RTS first pass gave the
same figures within 0.1 deg at 1.5x the cost, and a second gravity pass (``gravity_passes``)
changed them by < 0.05 deg. This needs no segment lengths and no sensor placement, only the
gyro's relative rotation over a few seconds.

With constant variances the gravity pass's normal matrix does not depend on the data: every
segment and every window of one length share it, so its banded Cholesky factor is computed once
and each solve is two banded substitutions (``smooth_map``; the same numbers as a fresh solve).

Long records are solved in windows of ``window`` samples that overlap by ``overlap`` on each
side; only each window's centre is kept (with 2 minutes of overlap the result differs from one
solve by < 0.01 deg on the simulator, checked in the tests).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import (
    ACC_X_IDX,
    ACC_Z_IDX,
    GYRO_IDX,
    SEGMENTS,
    STANDARD_GRAVITY_MS2,
    ChannelTable,
)
from gaitmon.dsp.motion_kalman import SegmentTuning, measurement_variance, tuning_for

_PRIOR_THETA_VAR = 1.0
_PRIOR_BIAS_VAR = 0.1**2
WINDOW = 1 << 18  # 44 min at 100 Hz
OVERLAP = 1 << 15  # 5.5 min either side (the bias links minutes of data)
_CAUSAL_BLOCK = 1 << 14  # rows per call of the causal first pass


def centred_max(x: np.ndarray, n: int) -> np.ndarray:
    """Maximum over a window of n samples centred on each sample (shorter at the ends)."""
    from scipy.ndimage import maximum_filter1d  # lazy: scipy only where a filter is run

    return np.asarray(maximum_filter1d(x, size=n, mode="nearest"))


def gravity_tilt(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, theta_rad: np.ndarray, n: int
) -> np.ndarray:
    """z~ (rad, (N,)): the tilt at which the windowed world-frame specific force is vertical.

    ``theta_rad`` is the previous pass's tilt; the window is a boxcar of n samples applied three
    times (zero outside the record: the angle of the sum does not depend on its scale).
    """
    from scipy.ndimage import uniform_filter1d  # lazy

    world = (acc_x_ms2 + 1j * acc_z_ms2) * np.exp(-1j * theta_rad)
    re, im = world.real, world.imag
    for _ in range(3):
        re = uniform_filter1d(re, n, mode="constant")
        im = uniform_filter1d(im, n, mode="constant")
    return np.asarray(theta_rad + np.arctan2(im, re))


def smoother_inputs(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray,
    fs_hz: float, tuning: SegmentTuning,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """(z unwrapped, R_k, Qa_k) for one segment's whole record."""
    z = _unwrapped_tilt(acc_x_ms2, acc_z_ms2, _causal_tilt(acc_x_ms2, acc_z_ms2, gyro_rad_s,
                                                            fs_hz, tuning))  # fmt: skip
    n_win = tuning.window_samples(fs_hz)
    dev = centred_max(np.abs(np.hypot(acc_x_ms2, acc_z_ms2) - STANDARD_GRAVITY_MS2), n_win)
    rate = centred_max(np.abs(gyro_rad_s), n_win)
    r = measurement_variance(dev, rate, tuning)
    qa = tuning.q_angle * (1.0 + (np.abs(gyro_rad_s) / tuning.rate_scale_rad_s) ** 2)
    return z, r, qa


def _causal_tilt(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray,
    fs_hz: float, tuning: SegmentTuning,
) -> np.ndarray:  # fmt: skip
    """The causal gait-aware filter's tilt of one segment (continuous, rad)."""
    from gaitmon.dsp.motion_kalman import GaitAwareKalman

    kf = GaitAwareKalman(fs_hz, segments=("foot",), tuning={"foot": tuning})
    n = len(acc_x_ms2)
    if n <= _CAUSAL_BLOCK:
        return kf.process(acc_x_ms2, acc_z_ms2, gyro_rad_s)
    # in blocks that stay in the CPU's cache (the filter gives the same bits in any chunking)
    return np.concatenate([
        kf.process(acc_x_ms2[a : a + _CAUSAL_BLOCK], acc_z_ms2[a : a + _CAUSAL_BLOCK],
                   gyro_rad_s[a : a + _CAUSAL_BLOCK])
        for a in range(0, n, _CAUSAL_BLOCK)
    ])  # fmt: skip


def _unwrapped_tilt(acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """The accelerometer tilt unwrapped against the causal filter's (paper 000's wrapped
    innovation), not by continuity: it jumps across +-pi whenever the board's y axis nears the
    vertical."""
    return np.asarray(ref + wrap_angle(np.arctan2(acc_z_ms2, acc_x_ms2) - ref))


def _normal_band(w_meas: np.ndarray, qa: np.ndarray, q_bias: float, dt_s: float) -> np.ndarray:
    """The normal matrix of the model (upper band form, ab[2 + i - j, j] = A[i, j]; Fortran
    order, as LAPACK takes it without a copy), unknowns theta_k = 2k, b_k = 2k + 1.

    It depends on the variances only, not on the data: the gravity pass's constant variances
    give every segment and every window of a length the same matrix (``_constant_factor``).
    """
    n = len(w_meas)
    m = 2 * n
    ab = np.zeros((3, m), order="F")
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


@lru_cache(maxsize=2)  # a long record's windows have one or two lengths: ~10 MB per 100 k rows
def _constant_factor(n: int, r: float, qa: float, q_bias: float, dt_s: float) -> np.ndarray:
    """The banded Cholesky factor of the normal matrix for constant variances (read-only)."""
    from scipy.linalg import cholesky_banded  # lazy

    ab = _normal_band(_measurement_weights(np.full(n, r)), np.full(n, qa), q_bias, dt_s)
    cb = np.asfortranarray(cholesky_banded(ab, overwrite_ab=True, check_finite=False))
    cb.flags.writeable = False
    return cb


def release_factors() -> None:
    """Drop the cached factors (``_constant_factor``) once a record is smoothed."""
    _constant_factor.cache_clear()


def smooth_map(
    z: np.ndarray, gyro_rad_s: np.ndarray, r: np.ndarray | float, qa: np.ndarray | float,
    q_bias: float, dt_s: float, theta_prior: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The RTS smoother's mean (theta, bias) of the model above, (N,) each, in one banded solve.

    With scalar (constant) ``r`` and ``qa`` the normal matrix does not depend on the data, and
    its Cholesky factor is computed once per length and reused (the gravity pass: every segment
    and every window): the same LAPACK factorisation and substitution ``solveh_banded`` runs,
    so the same numbers, at a fifth of the cost.
    """
    from scipy.linalg import cho_solve_banded, solveh_banded  # lazy

    n = len(z)
    if n == 0:
        return np.empty(0), np.empty(0)
    if np.ndim(r) == 0 and np.ndim(qa) == 0:
        cb = _constant_factor(n, float(r), float(qa), float(q_bias), float(dt_s))
        r, qa = np.full(n, float(r)), np.full(n, float(qa))
        g = _normal_rhs(z, gyro_rad_s, _measurement_weights(r), qa, dt_s, theta_prior)
        x = cho_solve_banded((cb, False), g, overwrite_b=True, check_finite=False)
    else:
        r, qa = np.asarray(r, dtype=np.float64), np.asarray(qa, dtype=np.float64)
        w_meas = _measurement_weights(r)
        ab = _normal_band(w_meas, qa, q_bias, dt_s)
        g = _normal_rhs(z, gyro_rad_s, w_meas, qa, dt_s, theta_prior)
        x = solveh_banded(ab, g, overwrite_ab=True, overwrite_b=True, check_finite=False)
    return x[0::2], x[1::2]


def smooth_tilt(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray, fs_hz: float,
    segment: str = "foot", *, tuning: SegmentTuning | None = None,
    window: int = WINDOW, overlap: int = OVERLAP,
) -> np.ndarray:  # fmt: skip
    """Offline (zero-lag) tilt of one segment's whole record, rad, (N,). See the module doc."""
    if not (np.isfinite(fs_hz) and fs_hz > 0):
        raise ValueError(f"fs_hz must be a positive number, got {fs_hz}")
    tun = tuning or tuning_for(segment)
    ax, az, w = (np.asarray(a, dtype=np.float64) for a in (acc_x_ms2, acc_z_ms2, gyro_rad_s))
    if not (ax.shape == az.shape == w.shape and ax.ndim == 1):
        raise ValueError("acc_x, acc_z and gyro must be 1-D arrays of the same length")
    dt = 1.0 / fs_hz
    if tun.gravity_window_s is None:
        z, r, qa = smoother_inputs(ax, az, w, fs_hz, tun)
        return _solve_windows(z, w, r, qa, tun.q_bias, dt, window, overlap)
    theta = _causal_tilt(ax, az, w, fs_hz, tun)  # the first pass
    n = len(theta)
    if n == 0:
        return theta
    n_grav = max(1, round(tun.gravity_window_s * fs_hz))
    for _ in range(tun.gravity_passes):  # constant variances: one factor for every window
        z_grav = gravity_tilt(ax, az, theta, n_grav)
        theta = _solve_windows(z_grav, w, tun.r_gravity, tun.q_angle, tun.q_bias, dt, window,
                               overlap)  # fmt: skip
    return theta


def _solve_windows(
    z: np.ndarray, w: np.ndarray, r: np.ndarray | float, qa: np.ndarray | float, q_bias: float,
    dt: float, window: int, overlap: int,
) -> np.ndarray:  # fmt: skip
    """smooth_map's theta, in overlapping windows for long records (see the module doc);
    ``r`` and ``qa`` per sample, or constants."""

    def part(x: np.ndarray | float, a: int, b: int) -> np.ndarray | float:
        return x[a:b] if isinstance(x, np.ndarray) else x

    n = len(z)
    if n <= window + 2 * overlap:
        return smooth_map(z, w, r, qa, q_bias, dt)[0]
    out = np.empty(n)
    for start in range(0, n, window):
        a, b = max(0, start - overlap), min(n, start + window + overlap)
        theta, _ = smooth_map(z[a:b], w[a:b], part(r, a, b), part(qa, a, b), q_bias, dt)
        keep = slice(start, min(n, start + window))
        out[keep] = theta[keep.start - a : keep.stop - a]
    return out


def smooth_record_tilts(
    adc_counts: np.ndarray, table: ChannelTable, calibrations: list[tuple[int, Calibration]],
    fs_hz: float,
) -> np.ndarray:  # fmt: skip
    """(N, 4) zeroed tilts (rad) of a whole raw recording by the RTS smoother, per segment.

    ``calibrations`` are (first row, Calibration) in row order, the first at row 0: each row's
    gyro bias is removed before smoothing and its tilt offsets after, as the pipeline does.
    """
    counts = np.asarray(adc_counts)
    n = len(counts)
    starts = [max(0, int(r)) for r, _ in calibrations] + [n]

    def physical(ch: int) -> np.ndarray:  # one channel at a time: a long record stays small
        return (counts[:, ch].astype(np.float64) - table.zero_counts[ch]) * table.units_per_count[
            ch
        ]

    out = np.empty((n, len(SEGMENTS)))
    for j, seg in enumerate(SEGMENTS):
        bias = np.zeros(n)
        offset = np.zeros(n)
        for (_, cal), a, b in zip(calibrations, starts[:-1], starts[1:], strict=True):
            bias[a:b] = cal.gyro_bias_rad_s[j]
            offset[a:b] = cal.tilt_offset_rad[j]
        gyro = physical(GYRO_IDX[j]) - bias
        theta = smooth_tilt(physical(ACC_X_IDX[j]), physical(ACC_Z_IDX[j]), gyro, fs_hz, seg)
        out[:, j] = theta - offset
    return np.asarray(wrap_angle(out))
