"""The strides' planar strapdown integration between two foot-flats (module doc, steps 2-6), a
batch of strides at once: each stride's samples one row of a padded 2-D array, every step
taken along the rows with the numbers it gives on the stride's own 1-D slice.

Cost (issue 28): where the compiled loops serve (a batch job that loaded them: ``process``, a
close, recovery; :mod:`gaitmon.dsp.kernels`' rule), each pass over a batch is one sweep per
stride (:func:`gaitmon.dsp.loops.stride_pass`: ~3x less CPU than numpy's ~40 passes); else
numpy does it, one pass per operation into a batch's own buffers, reused from step to step.
Either computes only what is read: the first pass of every stride (the board along the foot;
numpy divides by no cosine of 1, which would change no bit) everything, a step of the yaw
bisection (step 5) only the vertical velocity at the second anchor, whose sign is all it
needs. The strides that take the bisection are gathered from every batch of a call and
bisected together, its ten passes once a call, not once a batch. Every number is the one the
per-stride form's operations give, in their order, in each form (tests/test_stride_batched.py
and tests/test_stride_pass_forms.py compare them to the bit).

Part of the stride-length method: the method is the module doc of
:mod:`gaitmon.dsp.stride_length` (its steps, which "module doc, step N" below refers to).
"""

from __future__ import annotations

import sys
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
    a numpy pass works in; ``loops``: the compiled loops to run the passes in
    (:func:`gaitmon.dsp.loops.stride_pass`), None: numpy."""

    def __init__(
        self, x: np.ndarray, z: np.ndarray, w_less_bias: np.ndarray, d: np.ndarray,
        f0: _FootFlats, f1: _FootFlats, bias: np.ndarray, u: np.ndarray, dt: float,
        loops: Any = None,
    ) -> None:  # fmt: skip
        self.x, self.z, self.w, self.d, self.f0, self.f1 = x, z, w_less_bias, d, f0, f1
        self.bias, self.u, self.dt, self.loops = bias, u, dt, loops
        self.rows = np.arange(len(d))
        self._buffers: tuple[list[np.ndarray], np.ndarray, np.ndarray] | None = None

    @property
    def buf(self) -> list[np.ndarray]:
        return self._scratch()[0]

    @property
    def tmp(self) -> np.ndarray:
        return self._scratch()[1]

    @property
    def past(self) -> np.ndarray:
        return self._scratch()[2]

    def _scratch(self) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
        """(five (S, W) buffers, an (S, W - 1) one, the samples past each second anchor): a
        numpy pass's, made at its first."""
        if self._buffers is None:
            n, width = self.x.shape
            self._buffers = ([np.empty_like(self.x) for _ in range(5)],
                             np.empty((n, width - 1)), np.arange(width) > self.d[:, None])
        return self._buffers

    @classmethod
    def gather(
        cls, ax: np.ndarray, az: np.ndarray, gy: np.ndarray, f0: _FootFlats, f1: _FootFlats,
        fs_hz: float, loops: Any = None,
    ) -> _Batch:  # fmt: skip
        d = f1.anchor - f0.anchor
        idx = f0.anchor[:, None] + np.minimum(np.arange(int(d.max()) + 1), d[:, None])
        bias = 0.5 * (f0.gyro_bias_rad_s + f1.gyro_bias_rad_s)
        w = np.take(gy, idx)  # (np.take: the values of gy[idx], in less time)
        w -= bias[:, None]
        u = np.arange(idx.shape[1]) / d[:, None]  # 0 at the first anchor, 1 at the second
        return cls(np.take(ax, idx), np.take(az, idx), w, d, f0, f1, bias, u,
                   float(1.0 / fs_hz), loops)  # fmt: skip

    def take(self, i: np.ndarray) -> _Batch:
        return _Batch(self.x[i], self.z[i], self.w[i], self.d[i], self.f0.take(i),
                      self.f1.take(i), self.bias[i], self.u[i], self.dt, self.loops)  # fmt: skip

    def _looped(self, mount_cos: np.ndarray | None, full: bool) -> np.ndarray:
        """(S, 5) what :meth:`full` gives (``full`` False: only its last column), by the
        compiled loop, from the per-stride values the numpy pass computes (dividing by a
        cosine of 1 changes no bit)."""
        n = len(self.d)
        c = np.ones(n) if mount_cos is None else np.ascontiguousarray(mount_cos, np.float64)
        f0, f1 = self.f0, self.f1
        out = np.empty((n, 5))
        self.loops.stride_pass(
            self.x, self.z, self.w, np.ascontiguousarray(self.d, np.int64), c,
            f0.pitch_rad(c), f1.pitch_rad(c), self.bias / c,
            0.5 * (f0.g_ms2(c) + f1.g_ms2(c)), -ANCHOR_LEVER_M * f0.roll_rad_s / c,
            -ANCHOR_LEVER_M * f1.roll_rad_s / c, self.dt, full, out,
            np.empty((4, self.x.shape[1])))  # fmt: skip
        return out

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
        if self.loops is not None:
            return self._looped(mount_cos, False)[:, 4]
        _, z = self._pitch(mount_cos)
        run = _running_trapz(self._up(z, mount_cos), self.tmp)
        zero = np.zeros(len(self.d))
        return (zero + run[self.rows, self.d - 1] * self.dt) - zero

    def full(self, mount_cos: np.ndarray | None) -> tuple[np.ndarray, ...]:
        """Steps 2-4: (forward displacement, clearance, pitch misfit, forward velocity misfit,
        upward velocity misfit) of each stride."""
        if self.loops is not None:
            return tuple(np.ascontiguousarray(col) for col in self._looped(mount_cos, True).T)
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
    and f1[k] (found, f0's anchor before f1's; module doc, steps 2-6), a batch at a time."""
    d = f1.anchor - f0.anchor
    n = len(d)
    loops = _compiled_loops(len(gy)) if n else None
    length, clearance = np.full(n, np.nan), np.full(n, np.nan)
    pitch_misfit, vel_f, vel_u = np.empty(n), np.empty(n), np.empty(n)
    for k in _batches(d + 1):  # steps 2-4, the board along the foot
        b = _Batch.gather(ax, az, gy, f0.take(k), f1.take(k), fs_hz, loops)
        length[k], clearance[k], pitch_misfit[k], vel_f[k], vel_u[k] = b.full(None)
    # a board yawed on the foot sees only cos(yaw) of the pitch rate and forward acceleration
    # (step 5): the cosine in [MOUNT_COS_MIN, 1] at which the foot ends the stride with no
    # vertical velocity, if it misses by more than MOUNT_MIN_VEL_M_S and changes sign there
    # (bisection, each stride its own bounds)
    hi_sign = np.sign(vel_u)
    sub = np.flatnonzero(np.abs(vel_u) > MOUNT_MIN_VEL_M_S)
    for k in _batches(d[sub] + 1) if len(sub) else []:
        j = sub[k]
        b = _Batch.gather(ax, az, gy, f0.take(j), f1.take(j), fs_hz, loops)
        flips = np.sign(b.vertical_misfit(np.full(len(j), MOUNT_COS_MIN))) == -hi_sign[j]
        if not flips.any():
            continue
        j, b = j[flips], b.take(flips)
        lo, hi = np.full(len(j), MOUNT_COS_MIN), np.ones(len(j))
        for _ in range(MOUNT_ITERATIONS):
            mid = 0.5 * (lo + hi)
            high = np.sign(b.vertical_misfit(mid)) == hi_sign[j]
            hi, lo = np.where(high, mid, hi), np.where(high, lo, mid)
        length[j], clearance[j], pitch_misfit[j], vel_f[j], _ = b.full(0.5 * (lo + hi))
    out_of_plane = (np.abs(pitch_misfit) > OUT_OF_PLANE_PITCH_RAD) | (
        np.abs(vel_f) > OUT_OF_PLANE_VEL_M_S)  # fmt: skip
    return length, clearance, out_of_plane
