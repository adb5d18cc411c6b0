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
off-diagonals with the unknowns ordered theta_0, b_0, theta_1, ...). It is solved that way, by
a banded Cholesky factorisation (LAPACK's ``dpbtrf``/``dpbtrs`` as loops,
:mod:`gaitmon.dsp.loops`; ``scipy.linalg.solveh_banded`` agrees to rounding): the same numbers
as a forward Kalman pass followed by the RTS backward pass (tests/test_accuracy_filters.py
checks it against a hand-written RTS loop), in O(N).

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
filter's: an RTS first pass gave the same figures within 0.1 deg at 1.5x the cost, and a second
gravity pass (``gravity_passes``) changed them by < 0.05 deg; plain gyro integration, which
would cost nothing, did not do (the foot's tilt drifted away in turns, the ankle's RMSE grew to
15 deg). This needs no segment lengths and no sensor placement, only the gyro's relative
rotation over a few seconds.

Out of plane (segments whose tuning has ``plane_fraction``: the foot). Where the board is turned
out of the sagittal plane (:func:`out_of_plane`: the planar |a| averaged over 1 s below
``plane_fraction`` g), the one gyro axis does not turn the specific force into a fixed frame, so
z~ is wrong there; the last gravity pass of such a segment is solved once more with the
accelerometer tilt in those samples (variance ``r_out_of_plane``), z~ elsewhere. Walking never
trips the test (a walking foot's mean |a| is above 1 g): then nothing changes. On BROAD, 3-D
motion that is not gait, the foot's offline tilt went from 11.0 / 6.9 / 8.4 / 21.7 deg to
4.9 / 9.7 / 8.3 / 12.2 (trials 02 / 07 / 16 / 24; docs/filters.md).

The first pass over a recording (:class:`CausalFirstPass`) is the causal filter run over the
whole record in row order exactly as the live pipeline runs it (restarted after long gaps, its
bias moved by new calibrations): where a pipeline has just run over the record with that filter
(``gaitmon process``), its angles are this first pass, bit for bit, and are used as such
instead of running the filter twice.

With constant variances the gravity pass's normal matrix does not depend on the data: every
segment and every window of one length share it, so its banded Cholesky factor is computed once
and each solve is two banded substitutions (``smooth_map``), run by one loop for all the
segments side by side (:func:`gaitmon.dsp.loops.constant_map_solve`, compiled by numba for long
records, :mod:`gaitmon.dsp.kernels`; the same numbers as LAPACK's solve, to rounding). The
windowed means and maxima are numpy's (:mod:`gaitmon.dsp.windows`: scipy.ndimage's filters,
to rounding), or a compiled loop where numba runs.

Long records are solved in windows of ``window`` samples that overlap by ``overlap`` on each
side; only each window's centre is kept (with 2 minutes of overlap the result differs from one
solve by < 0.01 deg on the simulator, checked in the tests).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np

from gaitmon.dsp import kernels
from gaitmon.dsp.angles import TWO_PI, wrap_angle
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
from gaitmon.dsp.smoother_map import release_factors as release_factors
from gaitmon.dsp.smoother_map import smooth_map as smooth_map
from gaitmon.dsp.windows import sliding_max, sliding_mean

WINDOW = 1 << 18  # 44 min at 100 Hz
OVERLAP = 1 << 15  # 5.5 min either side (the bias links minutes of data)
_CAUSAL_BLOCK = 1 << 14  # rows per call of the causal first pass


def centred_max(x: np.ndarray, n: int) -> np.ndarray:
    """Maximum over a window of n samples centred on each sample (shorter at the ends)."""
    return sliding_max(x, n, mode="nearest")


def gravity_tilt(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, theta_rad: np.ndarray, n: int
) -> np.ndarray:
    """z~ (rad, shaped like the inputs: (N,) or (N, S), along axis 0): the tilt at which the
    windowed world-frame specific force is vertical.

    ``theta_rad`` is the previous pass's tilt; the window is a boxcar of n samples applied three
    times (zero outside the record: the angle of the sum does not depend on its scale). The
    turn e^(-i theta) is taken in single precision, of the angle reduced first (as the live
    gravity reference does: 12x faster, and within 1e-7 rad).
    """
    theta = np.asarray(theta_rad, dtype=np.float64)
    # laid out along the last axis for the filters, one buffer per quantity (a 15-min block of
    # 4 segments with its context: 3.6 MB per float64 array), computed a row (a segment) at a
    # time: elementwise, the same numbers as whole arrays, without their temporaries
    th_t = theta.T
    ax, az = np.asarray(acc_x_ms2).T, np.asarray(acc_z_ms2).T
    re, im = np.empty(th_t.shape), np.empty(th_t.shape)
    spare = np.empty(th_t.shape[-1])
    # (x + i z) e^(-i theta) in one compiled pass per segment where numba serves
    module = kernels.compiled_for(th_t.shape[-1], count=False)
    whole = [np.asarray(acc_x_ms2), np.asarray(acc_z_ms2), theta]
    if module is None or theta.ndim != 2 or not all(kernels.plain(a) for a in whole):
        module = None
    for col, (r, i, th, x, z) in enumerate(zip(*map(np.atleast_2d, (re, im, th_t, ax, az)),
                                               strict=True)):  # fmt: skip
        if module is not None:
            turn = r
            module.reduced(theta, col, turn)
        else:
            turn = np.multiply(th, 1.0 / TWO_PI, out=r)
            np.rint(turn, out=turn)
            turn *= -TWO_PI
            turn += th
        turn32 = turn.astype(np.float32)
        c, s = np.cos(turn32), np.sin(turn32)
        del turn32, turn
        if module is not None:
            module.turned(whole[0], whole[1], col, c, s, r, i)
            continue
        np.multiply(x, c, out=r)
        r += np.multiply(z, s, out=spare)
        np.multiply(z, c, out=i)
        i -= np.multiply(x, s, out=spare)
    del spare
    # (compiled: from buffer to buffer, one spare passed on from the real part to the
    # imaginary: three arrays at most, as in numpy)
    re, buffer = kernels.running_means(re, n, 3)
    im, buffer = kernels.running_means(im, n, 3, buffer)
    del buffer
    np.arctan2(im, re, out=re)
    del im
    re += th_t
    return np.asarray(re.T)


def smoother_inputs(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray,
    fs_hz: float, tuning: SegmentTuning,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """(z unwrapped, R_k, Qa_k) for one segment's whole record."""
    first = _causal_tilt(acc_x_ms2[:, None], acc_z_ms2[:, None], gyro_rad_s[:, None], fs_hz,
                         ("segment",), [tuning])[:, 0]  # fmt: skip
    z = _unwrapped_tilt(acc_x_ms2, acc_z_ms2, first)
    n_win = tuning.window_samples(fs_hz)
    dev = centred_max(np.abs(np.hypot(acc_x_ms2, acc_z_ms2) - STANDARD_GRAVITY_MS2), n_win)
    rate = centred_max(np.abs(gyro_rad_s), n_win)
    r = measurement_variance(dev, rate, tuning)
    qa = tuning.q_angle * (1.0 + (np.abs(gyro_rad_s) / tuning.rate_scale_rad_s) ** 2)
    return z, r, qa


def _causal_tilt(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray,
    fs_hz: float, segments: tuple[str, ...], tunings: list[SegmentTuning],
) -> np.ndarray:  # fmt: skip
    """The causal gait-aware filter's tilts of segments ((N, S) inputs; continuous, rad)."""
    from gaitmon.dsp.motion_kalman import GaitAwareKalman

    kf = GaitAwareKalman(fs_hz, segments=segments, tuning=dict(zip(segments, tunings,
                                                                   strict=True)))  # fmt: skip
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


def smooth_tilt(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray, fs_hz: float,
    segment: str = "foot", *, tuning: SegmentTuning | None = None,
    window: int = WINDOW, overlap: int = OVERLAP,
) -> np.ndarray:  # fmt: skip
    """Offline (zero-lag) tilt of one segment's whole record, rad, (N,). See the module doc."""
    ax, az, w = (np.asarray(a, dtype=np.float64) for a in (acc_x_ms2, acc_z_ms2, gyro_rad_s))
    if not (ax.shape == az.shape == w.shape and ax.ndim == 1):
        raise ValueError("acc_x, acc_z and gyro must be 1-D arrays of the same length")
    tun = tuning or tuning_for(segment)
    return smooth_tilts(ax[:, None], az[:, None], w[:, None], fs_hz, (segment,),
                        tunings={segment: tun}, window=window, overlap=overlap)[:, 0]  # fmt: skip


def smooth_tilts(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray, fs_hz: float,
    segments: tuple[str, ...] = SEGMENTS, *, tunings: dict[str, SegmentTuning] | None = None,
    window: int = WINDOW, overlap: int = OVERLAP, first_pass: np.ndarray | None = None,
) -> np.ndarray:  # fmt: skip
    """Offline (zero-lag) tilts of several segments' whole records, rad, (N, S), one column
    per entry of ``segments`` (each with its own tuning). See the module doc.

    The segments run side by side: one causal first pass for all, and one gravity pass (one
    factor, one solve) for the segments whose gravity tunings agree. ``first_pass`` (N, S):
    the causal filter's tilts when they are known already (:class:`CausalFirstPass`).
    """
    ax, az, w = (np.asarray(a, dtype=np.float64) for a in (acc_x_ms2, acc_z_ms2, gyro_rad_s))
    s = len(segments)
    if not (ax.shape == az.shape == w.shape and ax.ndim == 2 and ax.shape[1] == s):
        raise ValueError(f"acc_x, acc_z and gyro must be (N, {s}) arrays")
    table = tunings or {}
    tuns = [table[seg] if seg in table else tuning_for(seg) for seg in segments]
    return _smooth_tilts([ax, az, w, first_pass], fs_hz, segments, tuns, window, overlap)


def _smooth_tilts(
    held: list[np.ndarray | None], fs_hz: float, segments: tuple[str, ...],
    tuns: list[SegmentTuning], window: int, overlap: int,
) -> np.ndarray:  # fmt: skip
    """:func:`smooth_tilts` of ``held`` = [acc_x, acc_z, gyro (N, S) float64, first pass or
    None], which it empties: where the caller keeps no other reference, the accelerometer
    and the first pass are let go before the last solve (an 8-hour record's smoother block:
    ~10 MB of its peak)."""
    if not (np.isfinite(fs_hz) and fs_hz > 0):
        raise ValueError(f"fs_hz must be a positive number, got {fs_hz}")
    ax, az, w, first_pass = held
    held.clear()
    assert ax is not None and az is not None and w is not None
    s = len(segments)
    dt = 1.0 / fs_hz
    shape = ax.shape
    if len(ax) == 0:
        return np.empty(shape)
    out: np.ndarray | None = None  # made once a column is solved (not held through solves)
    plain = [j for j, t in enumerate(tuns) if t.gravity_window_s is None]
    for j in plain:  # no gravity pass: the smoother on the accelerometer tilt
        z, r, qa = smoother_inputs(ax[:, j], az[:, j], w[:, j], fs_hz, tuns[j])
        out = np.empty(shape) if out is None else out
        out[:, j] = _solve_windows(z, w[:, j], r, qa, tuns[j].q_bias, dt, window, overlap)
    grav = [j for j in range(s) if j not in plain]
    if not grav:
        assert out is not None
        return out

    def cols(a: np.ndarray, idx: list[int]) -> np.ndarray:  # a view where that is all of a
        return a if idx == list(range(a.shape[1])) else a[:, idx]

    if first_pass is not None:
        theta = cols(np.asarray(first_pass, dtype=np.float64), grav)
        del first_pass
    else:
        theta = _causal_tilt(cols(ax, grav), cols(az, grav), cols(w, grav), fs_hz,
                             tuple(segments[j] for j in grav), [tuns[j] for j in grav])  # fmt: skip
    groups: dict[tuple[float, float, float, float, int], list[int]] = {}
    for i, j in enumerate(grav):
        t = tuns[j]
        assert t.gravity_window_s is not None
        key = (t.gravity_window_s, t.r_gravity, t.q_angle, t.q_bias, t.gravity_passes)
        groups.setdefault(key, []).append(i)
    for k, ((window_s, r_grav, q_angle, q_bias, passes), members) in enumerate(groups.items()):
        cg = [grav[i] for i in members]
        th = cols(theta, members)
        n_grav = max(1, round(window_s * fs_hz))
        masks = {i: out_of_plane(ax[:, j], az[:, j], fs_hz, tuns[j]) for i, j in enumerate(cg)}
        planes = {i: m for i, m in masks.items() if m is not None}
        for p in range(passes):  # constant variances: one factor for every window
            z_grav = gravity_tilt(cols(ax, cg), cols(az, cg), th, n_grav)
            prev = th if p == passes - 1 and planes else None
            del th
            if k == len(groups) - 1 and p == passes - 1 and not planes:
                del ax, az, theta  # (used no more: not held through the last solve)
            th = _solve_windows(z_grav, cols(w, cg), r_grav, q_angle, q_bias, dt, window,
                                overlap)  # fmt: skip
            if prev is not None:  # out of plane: the accelerometer tilt there, one more solve
                for i, mask in planes.items():
                    j = cg[i]
                    z = np.where(mask, _unwrapped_tilt(ax[:, j], az[:, j], prev[:, i]),
                                 z_grav[:, i])  # fmt: skip
                    r = np.where(mask, tuns[j].r_out_of_plane, r_grav)
                    th[:, i] = _solve_windows(z, w[:, j], r, np.full(len(z), q_angle), q_bias,
                                              dt, window, overlap)  # fmt: skip
            del z_grav, prev
        out = np.empty(shape) if out is None else out
        out[:, cg] = th
    assert out is not None
    return out


def out_of_plane(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, fs_hz: float, tuning: SegmentTuning
) -> np.ndarray | None:
    """Where one segment's board is out of the sagittal plane, offline (the causal filter's
    test, gaitmon.dsp.motion_kalman, "Out of plane", with the planar |a| averaged over a centred
    boxcar of 1 / (2 ``plane_cutoff_hz``) s, 1 s at 0.5 Hz); None where the tuning has no such
    test or no sample is out of plane."""
    if tuning.plane_fraction is None:
        return None
    n = max(1, round(fs_hz / (2.0 * tuning.plane_cutoff_hz)))
    mag = np.multiply(acc_x_ms2, acc_x_ms2)  # |a| = sqrt(ax^2 + az^2), as the causal filter's
    mag += np.multiply(acc_z_ms2, acc_z_ms2)
    mean = sliding_mean(np.sqrt(mag, out=mag), n, mode="nearest")
    mask = mean < tuning.plane_fraction * STANDARD_GRAVITY_MS2
    return mask if mask.any() else None


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
    out = np.empty(z.shape)
    for start in range(0, n, window):
        a, b = max(0, start - overlap), min(n, start + window + overlap)
        theta, _ = smooth_map(z[a:b], w[a:b], part(r, a, b), part(qa, a, b), q_bias, dt)
        keep = slice(start, min(n, start + window))
        out[keep] = theta[keep.start - a : keep.stop - a]
    return out


def smooth_record_tilts(
    adc_counts: np.ndarray, table: ChannelTable, calibrations: list[tuple[int, Calibration]],
    fs_hz: float, first_pass: np.ndarray | None = None,
) -> np.ndarray:  # fmt: skip
    """(N, 4) zeroed tilts (rad) of a whole raw recording by the RTS smoother, per segment.

    ``calibrations`` are (first row, Calibration) in row order, the first at row 0: each row's
    gyro bias is removed before smoothing and its tilt offsets after, as the pipeline does.
    ``first_pass``: the causal filter's (N, 4) tilts of these rows (:class:`CausalFirstPass`);
    None runs the filter from the first row.
    """
    counts = np.asarray(adc_counts)
    n = len(counts)
    starts = [max(0, int(r)) for r, _ in calibrations] + [n]

    ranges = list(zip(calibrations, starts[:-1], starts[1:], strict=True))
    gyro = kernels.to_physical(table, counts, GYRO_IDX)
    for (_, cal), a, b in ranges:
        gyro[a:b] -= cal.gyro_bias_rad_s
    held = [kernels.to_physical(table, counts, ACC_X_IDX),
            kernels.to_physical(table, counts, ACC_Z_IDX), gyro,
            None if first_pass is None else np.asarray(first_pass, dtype=np.float64)]  # fmt: skip
    # the smoother lets go of what it no longer needs: this frame keeps no reference
    del gyro, first_pass, counts, adc_counts
    out = _smooth_tilts(held, fs_hz, SEGMENTS, [tuning_for(seg) for seg in SEGMENTS], WINDOW,
                        OVERLAP)  # fmt: skip
    if kernels.compiled_for(n, count=False) is not None and kernels.plain(out):
        for (_, cal), a, b in ranges:  # (in place, one compiled pass: the same numbers)
            kernels.zeroed_tilts(out[a:b], cal.tilt_offset_rad, out[a:b])
        return out
    for (_, cal), a, b in ranges:
        out[a:b] -= cal.tilt_offset_rad
    return np.asarray(wrap_angle(out))


class CausalFirstPass:
    """The smoother's first pass over a whole raw record: the causal gait-aware filter run over
    the rows in order exactly as the live pipeline runs it (``Pipeline`` with its default
    ``tilt_method``): on the raw accelerometer and the gyro less the calibration in force,
    restarted after each long gap (``restarts``; the learnt bias is kept), fed the frames lost
    in each bridged gap filled in (``filled``, gaitmon.dsp.lost_frames.bridged_losses), and with
    its bias state moved by each new calibration's gyro bias (``Pipeline.set_calibration``).
    So where a pipeline ran over the record with that filter and no change of settings, its
    ``PipelineBlock.tilt_kalman_continuous_rad`` is this, bit for bit (tests), and
    ``gaitmon process`` takes it from there instead of running the filter again.

    ``rows(a, b, counts)`` gives the (b - a, 4) tilts (rad, continuous) of rows a:b, whose raw
    counts are ``counts``; ranges are asked in row order and may overlap the previous one
    (a >= the previous a): the filter runs on from the last row it reached.
    """

    def __init__(
        self, table: ChannelTable, calibration: Calibration,
        changes: list[tuple[int, Calibration]], restarts: np.ndarray, fs_hz: float,
        filled: Mapping[int, int] | None = None,
    ) -> None:  # fmt: skip
        from gaitmon.dsp.motion_kalman import GaitAwareKalman

        # {row: lost frames filled in before it} (gaitmon.dsp.lost_frames.bridged_losses): the
        # filter runs over them as the pipeline does, on the unit's uniform time base
        fills = sorted((filled or {}).items())
        self._fill_rows = np.array([r for r, _ in fills], dtype=np.int64)
        self._fill_n = np.array([k for _, k in fills], dtype=np.int64)
        self._last_phys: np.ndarray | None = None  # the row before the next one run

        self._kf = GaitAwareKalman(fs_hz)
        self._table = table
        self._in_force = calibration
        # (row, calibration) in row order; at one row, in the order given (as the replay)
        self._changes = sorted(((max(0, int(r)), c) for r, c in changes), key=lambda x: x[0])
        self._restarts = {int(r) for r in restarts if int(r) > 0}
        self._events = sorted({*self._restarts, *(r for r, _ in self._changes)})
        self._done = 0  # rows the filter has run over
        self._kept = np.empty((0, len(SEGMENTS)))  # the tilts of rows _kept_from:_done
        self._kept_from = 0

    def rows(self, a: int, b: int, counts: np.ndarray) -> np.ndarray:
        if not self._kept_from <= a <= self._done:
            raise ValueError(f"rows {a}:{b} asked out of order (the filter is at {self._done})")
        if b > self._done:
            new = self._run(np.asarray(counts)[self._done - a : b - a], self._done)
            self._kept = np.concatenate([self._kept[a - self._kept_from :], new])
            self._kept_from, self._done = a, b
        return self._kept[a - self._kept_from : b - self._kept_from]

    def _run(self, counts: np.ndarray, first: int) -> np.ndarray:
        """Run the filter over ``counts``, the rows from ``first``."""
        from gaitmon.dsp.lost_frames import fill_lost

        n = len(counts)
        cuts = sorted({0, n, *range(0, n, _CAUSAL_BLOCK),  # blocks that stay in the cache
                       *(e - first for e in self._events if first <= e < first + n)})  # fmt: skip
        parts = []
        for a, b in itertools.pairwise(cuts):
            row = first + a
            while self._changes and self._changes[0][0] <= row:
                _, cal = self._changes.pop(0)
                self._kf.shift_bias(-(cal.gyro_bias_rad_s - self._in_force.gyro_bias_rad_s))
                self._in_force = cal
            if row in self._restarts:
                self._kf.restart()
            phys = kernels.to_physical(self._table, counts[a:b])
            fill = np.zeros(b - a, dtype=np.int64)
            lo, hi = np.searchsorted(self._fill_rows, [row, first + b])
            fill[self._fill_rows[lo:hi] - row] = self._fill_n[lo:hi]
            ext, pos = fill_lost(phys, fill, self._last_phys)
            if len(phys):
                self._last_phys = phys[-1].copy()
            gyro = self._in_force.apply_gyro(ext[:, GYRO_IDX])
            tilt = self._kf.process(ext[:, ACC_X_IDX], ext[:, ACC_Z_IDX], gyro)
            parts.append(tilt if pos is None else tilt[pos])
        return np.concatenate(parts) if parts else np.empty((0, len(SEGMENTS)))
