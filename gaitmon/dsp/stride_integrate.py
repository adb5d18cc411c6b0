"""The strides' planar strapdown integration between two foot-flats (module doc, steps 2-6), a
batch of strides at once: each stride's samples one row of a padded 2-D array, every step
taken along the rows with the numbers it gives on the stride's own 1-D slice.

Cost (issue 28): where the compiled loops serve (a batch job that loaded them: ``process``, a
close, recovery; :mod:`gaitmon.dsp.kernels`' rule), each pass is one sweep per stride over its
samples where they lie (:func:`gaitmon.dsp.loops.stride_pass`: no padded batch, ~3x less CPU
than numpy's ~40 passes); else numpy does it a batch at a time, one pass per operation into
the batch's own buffers, reused from step to step. Either computes only what is read: the
first pass of every stride (the board along the foot; numpy divides by no cosine of 1, which
would change no bit) everything, a step of the yaw bisection (step 5) only the vertical
velocity at the second anchor, whose sign is all it needs, for the strides of all batches
together (its ten passes once a call, not once a batch). Every number is the one the
per-stride form's operations give, in their order, in each form (tests/test_stride_batched.py
and tests/test_stride_pass_forms.py compare them to the bit).

Part of the stride-length method: the method is the module doc of
:mod:`gaitmon.dsp.stride_length` (its steps, which "module doc, step N" below refers to).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from gaitmon.dsp.stride_anchors import _batches, _FootFlats
from gaitmon.dsp.stride_method import ANCHOR_LEVER_M as ANCHOR_LEVER_M
from gaitmon.dsp.stride_method import MOUNT_COS_MIN as MOUNT_COS_MIN
from gaitmon.dsp.stride_method import MOUNT_ITERATIONS as MOUNT_ITERATIONS
from gaitmon.dsp.stride_method import MOUNT_MIN_VEL_M_S as MOUNT_MIN_VEL_M_S
from gaitmon.dsp.stride_method import OUT_OF_PLANE_PITCH_RAD as OUT_OF_PLANE_PITCH_RAD
from gaitmon.dsp.stride_method import OUT_OF_PLANE_VEL_M_S as OUT_OF_PLANE_VEL_M_S


def _running_trapz(y: np.ndarray, tmp: np.ndarray) -> np.ndarray:
    """``tmp`` (S, W - 1) = the running sums of each row's trapezoids (np.cumsum adds along a
    row in order, as on the row alone); the integral at column k > 0 is ``tmp[:, k - 1] * dt``."""
    np.add(y[:, 1:], y[:, :-1], out=tmp)
    np.multiply(tmp, 0.5, out=tmp)
    return np.cumsum(tmp, axis=1, out=tmp)


def _cumtrapz(y: np.ndarray, dt: float, out: np.ndarray, tmp: np.ndarray) -> np.ndarray:
    """``out`` (S, W) = the trapezoidal integral of each row of ``y`` from 0; ``out`` may be
    ``y``."""
    _running_trapz(y, tmp)
    out[:, 0] = 0.0
    np.multiply(tmp, dt, out=out[:, 1:])
    return out


class _Batch:
    """Strides' samples from the first anchor to the second, one row each (past its last
    sample a row repeats it: never read), what every pass over them shares, and the buffers
    a pass works in."""

    def __init__(
        self, x: np.ndarray, z: np.ndarray, w_less_bias: np.ndarray, d: np.ndarray,
        f0: _FootFlats, f1: _FootFlats, bias: np.ndarray, u: np.ndarray, dt: float,
    ) -> None:  # fmt: skip
        self.x, self.z, self.w, self.d, self.f0, self.f1 = x, z, w_less_bias, d, f0, f1
        self.bias, self.u, self.dt = bias, u, dt
        self.rows = np.arange(len(d))
        self.past = np.arange(x.shape[1]) > d[:, None]
        self.buf = [np.empty_like(x) for _ in range(5)]
        self.tmp = np.empty((x.shape[0], x.shape[1] - 1))

    @classmethod
    def gather(
        cls, ax: np.ndarray, az: np.ndarray, gy: np.ndarray, f0: _FootFlats, f1: _FootFlats,
        fs_hz: float,
    ) -> _Batch:  # fmt: skip
        d = f1.anchor - f0.anchor
        idx = f0.anchor[:, None] + np.minimum(np.arange(int(d.max()) + 1), d[:, None])
        bias = 0.5 * (f0.gyro_bias_rad_s + f1.gyro_bias_rad_s)
        w = np.take(gy, idx)  # (np.take: the values of gy[idx], in less time)
        w -= bias[:, None]
        u = np.arange(idx.shape[1]) / d[:, None]  # 0 at the first anchor, 1 at the second
        return cls(np.take(ax, idx), np.take(az, idx), w, d, f0, f1, bias, u, 1.0 / fs_hz)

    def take(self, i: np.ndarray) -> _Batch:
        return _Batch(self.x[i], self.z[i], self.w[i], self.d[i], self.f0.take(i),
                      self.f1.take(i), self.bias[i], self.u[i], self.dt)  # fmt: skip

    def _pitch(self, mount_cos: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Step 2 with the board's forward axis and gyro read as ``mount_cos`` ((S,); None:
        1) of the foot's (step 5): the pitch's sine and cosine (buffers 1 and 2) and its
        misfit at the second anchor; a_z as read (buffer 0 if divided)."""
        f0, f1, d, dt = self.f0, self.f1, self.d, self.dt
        pitch, sin, cos = self.buf[:3]
        if mount_cos is None:
            _cumtrapz(self.w, dt, pitch, self.tmp)  # the rate: the gyro less its bias
            p0 = np.arctan2(f0.acc_z_ms2, f0.acc_x_ms2)
            p1 = np.arctan2(f1.acc_z_ms2, f1.acc_x_ms2)
            bias = self.bias
        else:
            np.divide(self.w, mount_cos[:, None], out=pitch)
            _cumtrapz(pitch, dt, pitch, self.tmp)
            p0, p1 = f0.pitch_rad(mount_cos), f1.pitch_rad(mount_cos)
            bias = self.bias / mount_cos
        pitch += p0[:, None]
        end = pitch[self.rows, d]
        # the gyro's own closure (its standing bias is removed by the calibration; the residual
        # estimated at a foot-flat is not used here: a rolling stance foot would fake one)
        pitch_misfit = end + bias * d * dt - p1
        pitch -= np.multiply((end - p1)[:, None], self.u, out=sin)
        np.sin(pitch, out=sin)
        np.cos(pitch, out=cos)
        z = self.z if mount_cos is None else np.divide(self.z, mount_cos[:, None], out=pitch)
        return pitch_misfit, z

    def _g(self, mount_cos: np.ndarray | None) -> np.ndarray:
        f0, f1 = self.f0, self.f1
        if mount_cos is None:
            return 0.5 * (np.hypot(f0.acc_x_ms2, f0.acc_z_ms2) + np.hypot(f1.acc_x_ms2,
                                                                          f1.acc_z_ms2))
        return 0.5 * (f0.g_ms2(mount_cos) + f1.g_ms2(mount_cos))

    def _up(self, z: np.ndarray, mount_cos: np.ndarray | None) -> np.ndarray:
        """Step 3's upward acceleration (buffer 4; buffers 1 and 2 spent)."""
        _, sin, cos, _, up = self.buf
        np.multiply(self.x, cos, out=up)
        up += np.multiply(z, sin, out=sin)
        up -= self._g(mount_cos)[:, None]
        return up

    def vertical_misfit(self, mount_cos: np.ndarray) -> np.ndarray:
        """(S,) the upward velocity at the second anchor, integrated from 0 at the first (what
        the yaw bisection reads of a pass)."""
        _, z = self._pitch(mount_cos)
        run = _running_trapz(self._up(z, mount_cos), self.tmp)
        zero = np.zeros(len(self.d))
        return (zero + run[self.rows, self.d - 1] * self.dt) - zero

    def full(self, mount_cos: np.ndarray | None) -> tuple[np.ndarray, ...]:
        """Steps 2-4: (forward displacement, clearance, pitch misfit, forward velocity misfit,
        upward velocity misfit) of each stride."""
        pitch_misfit, z = self._pitch(mount_cos)
        _, sin, cos, fwd, _ = self.buf
        rows, d, u, dt, tmp = self.rows, self.d, self.u, self.dt, self.tmp
        np.multiply(z, cos, out=fwd)
        fwd -= np.multiply(self.x, sin, out=self.buf[4])
        up = self._up(z, mount_cos)
        # a stance foot that still rolls (step 1) moves the board forward by its height above
        # the ground pivot times the roll rate (toe-down, negative rate: forward)
        v0, v1 = -ANCHOR_LEVER_M * self.f0.roll_rad_s, -ANCHOR_LEVER_M * self.f1.roll_rad_s
        if mount_cos is not None:
            v0, v1 = v0 / mount_cos, v1 / mount_cos
        scratch = self.buf[1]
        # step 4, forward: the velocity from v0, its misfit at the second anchor removed
        # linearly, and the displacement there
        v = _cumtrapz(fwd, dt, fwd, tmp)
        v += v0[:, None]
        misfit_f = v[rows, d] - v1
        v -= np.multiply(misfit_f[:, None], u, out=scratch)
        forward = _running_trapz(v, tmp)[rows, d - 1] * dt
        # upward: from 0 to 0, the height at the second anchor removed linearly too
        zero = np.zeros(len(d))
        v = _cumtrapz(up, dt, up, tmp)
        v += 0.0  # (zero + v: a -0.0 is 0.0 as the per-stride form has it)
        misfit_u = v[rows, d] - zero
        v -= np.multiply(misfit_u[:, None], u, out=scratch)
        height = _cumtrapz(v, dt, v, tmp)
        height -= np.multiply(height[rows, d][:, None], u, out=scratch)
        height[self.past] = -np.inf
        return forward, np.max(height, axis=1), pitch_misfit, misfit_f, misfit_u


def _compiled_loops(rows: int) -> Any:
    """The compiled loops where :mod:`gaitmon.dsp.kernels`' rule picks them for work on a
    record of ``rows`` samples (its rows counted already, by the replay that found the heel
    strikes), else None: numpy (live work, short records, no numba). A process that has not
    loaded the rule (a reader computing the measures of a file: ``gaitmon info``, a report)
    runs numpy, and imports none of it."""
    kernels = sys.modules.get("gaitmon.dsp.kernels")
    return None if kernels is None else kernels.compiled_for(rows, count=False)


def _strides(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, fs_hz: float, f0: _FootFlats,
    f1: _FootFlats,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """(forward displacement, clearance, out of plane) of each stride between foot-flats f0[k]
    and f1[k] (found, f0's anchor before f1's; module doc, steps 2-6): by the compiled loop
    where it serves, else with numpy a batch at a time."""
    loops = _compiled_loops(len(gy)) if len(f0.anchor) else None
    if loops is not None:
        return _looped(loops, ax, az, gy, fs_hz, f0, f1)
    d = f1.anchor - f0.anchor
    n = len(d)
    length, clearance = np.full(n, np.nan), np.full(n, np.nan)
    pitch_misfit, vel_f, vel_u = np.empty(n), np.empty(n), np.empty(n)
    for k in _batches(d + 1):  # steps 2-4, the board along the foot
        b = _Batch.gather(ax, az, gy, f0.take(k), f1.take(k), fs_hz)
        length[k], clearance[k], pitch_misfit[k], vel_f[k], vel_u[k] = b.full(None)
    # a board yawed on the foot sees only cos(yaw) of the pitch rate and forward acceleration
    # (step 5): the cosine in [MOUNT_COS_MIN, 1] at which the foot ends the stride with no
    # vertical velocity, if it misses by more than MOUNT_MIN_VEL_M_S and changes sign there
    # (bisection, each stride its own bounds)
    hi_sign = np.sign(vel_u)
    sub = np.flatnonzero(np.abs(vel_u) > MOUNT_MIN_VEL_M_S)
    for k in _batches(d[sub] + 1) if len(sub) else []:
        j = sub[k]
        b = _Batch.gather(ax, az, gy, f0.take(j), f1.take(j), fs_hz)
        flips = np.sign(b.vertical_misfit(np.full(len(j), MOUNT_COS_MIN))) == -hi_sign[j]
        if not flips.any():
            continue
        j, b = j[flips], b.take(flips)
        cos = _mount_cos(b.vertical_misfit, hi_sign[j])
        length[j], clearance[j], pitch_misfit[j], vel_f[j], _ = b.full(cos)
    return length, clearance, _out_of_plane(pitch_misfit, vel_f)


def _mount_cos(
    vertical_misfit: Callable[[np.ndarray], np.ndarray], hi_sign: np.ndarray
) -> np.ndarray:  # fmt: skip
    """Step 5's bisection: the mounting cosine in [MOUNT_COS_MIN, 1] of each stride at which
    its upward velocity misfit (``vertical_misfit(cos)``) changes sign, from ``hi_sign`` (the
    misfit's sign at a cosine of 1; -hi_sign at MOUNT_COS_MIN), each stride its own bounds."""
    lo, hi = np.full(len(hi_sign), MOUNT_COS_MIN), np.ones(len(hi_sign))
    for _ in range(MOUNT_ITERATIONS):
        mid = 0.5 * (lo + hi)
        high = np.sign(vertical_misfit(mid)) == hi_sign
        hi, lo = np.where(high, mid, hi), np.where(high, lo, mid)
    return 0.5 * (lo + hi)


def _out_of_plane(pitch_misfit: np.ndarray, vel_f: np.ndarray) -> np.ndarray:
    return (np.abs(pitch_misfit) > OUT_OF_PLANE_PITCH_RAD) | (
        np.abs(vel_f) > OUT_OF_PLANE_VEL_M_S)  # fmt: skip


def _plain(a: np.ndarray, dtype: type) -> np.ndarray:
    """``a`` as the compiled loop is built for (C-contiguous, writeable, of ``dtype``: a call
    of other types would compile another form, or be refused by the module built ahead of
    time), copied only if it is not."""
    a = np.asarray(a)
    ok = a.dtype == dtype and a.flags.c_contiguous and a.flags.writeable
    return a if ok else np.array(a, dtype=dtype)


def _looped(
    loops: Any, ax: np.ndarray, az: np.ndarray, gy: np.ndarray, fs_hz: float, f0: _FootFlats,
    f1: _FootFlats,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """:func:`_strides` by the compiled loop (:func:`gaitmon.dsp.loops.stride_pass`), which
    reads each stride's samples where they lie: no padded batch, no gathered copy. The same
    steps, each stride's per-stride values computed as the numpy pass computes them (dividing
    by a cosine of 1 changes no bit), the same bisection."""
    ax, az, gy = (_plain(a, np.float64) for a in (ax, az, gy))
    start = _plain(f0.anchor, np.int64)
    d = _plain(f1.anchor - f0.anchor, np.int64)
    bias = 0.5 * (f0.gyro_bias_rad_s + f1.gyro_bias_rad_s)
    dt = float(1.0 / fs_hz)
    buf = np.empty((4, int(d.max()) + 1))

    def run(j: np.ndarray | None, c: np.ndarray, full: bool) -> np.ndarray:
        """(len(c), 5) the pass of strides ``j`` (None: all) at cosines ``c``."""
        g0, g1 = (f0, f1) if j is None else (f0.take(j), f1.take(j))
        b = bias if j is None else bias[j]
        out = np.empty((len(c), 5))
        loops.stride_pass(
            ax, az, gy, start if j is None else start[j], d if j is None else d[j], c,
            g0.pitch_rad(c), g1.pitch_rad(c), b, b / c, 0.5 * (g0.g_ms2(c) + g1.g_ms2(c)),
            -ANCHOR_LEVER_M * g0.roll_rad_s / c, -ANCHOR_LEVER_M * g1.roll_rad_s / c, dt,
            full, out, buf)  # fmt: skip
        return out

    first = run(None, np.ones(len(d)), True)
    length, clearance = first[:, 0].copy(), first[:, 1].copy()
    pitch_misfit, vel_f, vel_u = first[:, 2].copy(), first[:, 3].copy(), first[:, 4]
    # step 5, as _strides
    hi_sign = np.sign(vel_u)
    j = np.flatnonzero(np.abs(vel_u) > MOUNT_MIN_VEL_M_S)
    if len(j):
        j = j[np.sign(run(j, np.full(len(j), MOUNT_COS_MIN), False)[:, 4]) == -hi_sign[j]]
    if len(j):
        q = run(j, _mount_cos(lambda c: run(j, c, False)[:, 4], hi_sign[j]), True)
        length[j], clearance[j], pitch_misfit[j], vel_f[j] = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return length, clearance, _out_of_plane(pitch_misfit, vel_f)
