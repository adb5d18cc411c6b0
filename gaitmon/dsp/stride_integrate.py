"""The strides' planar strapdown integration between two foot-flats (module doc, steps 2-6), a
batch of strides at once: each stride's samples one row of a padded 2-D array, every step
taken along the rows with the numbers it gives on the stride's own 1-D slice.

Part of the stride-length method: the method is the module doc of
:mod:`gaitmon.dsp.stride_length` (its steps, which "module doc, step N" below refers to).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitmon.dsp.stride_anchors import _batches, _FootFlats
from gaitmon.dsp.stride_method import ANCHOR_LEVER_M as ANCHOR_LEVER_M
from gaitmon.dsp.stride_method import MOUNT_COS_MIN as MOUNT_COS_MIN
from gaitmon.dsp.stride_method import MOUNT_ITERATIONS as MOUNT_ITERATIONS
from gaitmon.dsp.stride_method import MOUNT_MIN_VEL_M_S as MOUNT_MIN_VEL_M_S
from gaitmon.dsp.stride_method import OUT_OF_PLANE_PITCH_RAD as OUT_OF_PLANE_PITCH_RAD
from gaitmon.dsp.stride_method import OUT_OF_PLANE_VEL_M_S as OUT_OF_PLANE_VEL_M_S


def _cumtrapz(y: np.ndarray, dt: float) -> np.ndarray:
    """The trapezoidal integral of each row from 0 (np.cumsum adds along a row in order, as
    on the row alone)."""
    out = np.zeros_like(y)
    out[:, 1:] = np.cumsum(0.5 * (y[:, 1:] + y[:, :-1]), axis=1) * dt
    return out


@dataclass(frozen=True)
class _Spans:
    """Strides' samples from the first anchor to the second, one row each (past its last
    sample a row repeats it: never read)."""

    x: np.ndarray  # (S, W) acc x
    z: np.ndarray  # (S, W) acc z
    w: np.ndarray  # (S, W) gyro
    d: np.ndarray  # (S,) the second anchor less the first (samples)
    f0: _FootFlats
    f1: _FootFlats

    def take(self, i: np.ndarray) -> _Spans:
        return _Spans(self.x[i], self.z[i], self.w[i], self.d[i], self.f0.take(i),
                      self.f1.take(i))  # fmt: skip


@dataclass(frozen=True)
class _Pass:
    forward_m: np.ndarray  # (S,)
    clearance_m: np.ndarray
    # the gyro's pitch at the second foot-flat less the accelerometer's; (forward, up)
    # velocity there
    pitch_misfit_rad: np.ndarray
    vel_misfit_m_s: tuple[np.ndarray, np.ndarray]


def _integrate(s: _Spans, fs_hz: float, mount_cos: np.ndarray) -> _Pass:
    """Steps 2-4 of the module doc between two foot-flats, the board's forward axis and gyro
    taken as ``mount_cos`` ((S,)) of the foot's (step 5)."""
    f0, f1, d = s.f0, s.f1, s.d
    c = mount_cos[:, None]
    rows = np.arange(len(d))
    dt = 1.0 / fs_hz
    u = np.arange(s.x.shape[1]) / d[:, None]  # 0 at the first anchor, 1 at the second
    bias = 0.5 * (f0.gyro_bias_rad_s + f1.gyro_bias_rad_s)
    rate = (s.w - bias[:, None]) / c
    p0, p1 = f0.pitch_rad(mount_cos), f1.pitch_rad(mount_cos)
    pitch = p0[:, None] + _cumtrapz(rate, dt)
    end = pitch[rows, d]
    # the gyro's own closure (its standing bias is removed by the calibration; the residual
    # estimated at a foot-flat is not used here: a rolling stance foot would fake one)
    pitch_misfit = end + bias / mount_cos * d * dt - p1
    pitch -= (end - p1)[:, None] * u
    sin, cos = np.sin(pitch), np.cos(pitch)
    x, z = s.x, s.z / c
    acc_f = z * cos - x * sin
    acc_u = x * cos + z * sin - (0.5 * (f0.g_ms2(mount_cos) + f1.g_ms2(mount_cos)))[:, None]
    # a stance foot that still rolls (step 1) moves the board forward by its height above the
    # ground pivot times the roll rate (toe-down, negative rate: forward)
    zero = np.zeros(len(d))
    v_ends = ((-ANCHOR_LEVER_M * f0.roll_rad_s / mount_cos,
               -ANCHOR_LEVER_M * f1.roll_rad_s / mount_cos), (zero, zero))  # fmt: skip
    out = []
    misfit = []
    for acc, (v0, v1) in zip((acc_f, acc_u), v_ends, strict=True):
        v = v0[:, None] + _cumtrapz(acc, dt)
        misfit.append(v[rows, d] - v1)
        v -= misfit[-1][:, None] * u
        out.append(_cumtrapz(v, dt))
    fwd, up = out
    up -= up[rows, d][:, None] * u
    past = np.arange(up.shape[1]) > d[:, None]
    return _Pass(fwd[rows, d], np.max(np.where(past, -np.inf, up), axis=1), pitch_misfit,
                 (misfit[0], misfit[1]))  # fmt: skip


def _mounted(s: _Spans, fs_hz: float) -> _Pass:
    """Steps 2-5 of a batch: integrated as they are, then where the vertical velocity misses
    zero, again at the board's mounting cosine (bisection, each stride its own bounds)."""
    p = _integrate(s, fs_hz, np.ones(len(s.d)))
    # a board yawed on the foot sees only cos(yaw) of the pitch rate and forward acceleration
    # (step 5): the cosine in [MOUNT_COS_MIN, 1] at which the foot ends the stride with no
    # vertical velocity, if it misses by more than MOUNT_MIN_VEL_M_S and changes sign there
    hi_sign = np.sign(p.vel_misfit_m_s[1])
    sub = np.flatnonzero(np.abs(p.vel_misfit_m_s[1]) > MOUNT_MIN_VEL_M_S)
    if len(sub):
        lo_pass = _integrate(s.take(sub), fs_hz, np.full(len(sub), MOUNT_COS_MIN))
        sub = sub[np.sign(lo_pass.vel_misfit_m_s[1]) == -hi_sign[sub]]
    if len(sub) == 0:
        return p
    t = s.take(sub)
    lo, hi = np.full(len(sub), MOUNT_COS_MIN), np.ones(len(sub))
    for _ in range(MOUNT_ITERATIONS):
        mid = 0.5 * (lo + hi)
        high = np.sign(_integrate(t, fs_hz, mid).vel_misfit_m_s[1]) == hi_sign[sub]
        hi, lo = np.where(high, mid, hi), np.where(high, lo, mid)
    q = _integrate(t, fs_hz, 0.5 * (lo + hi))
    for mine, theirs in ((p.forward_m, q.forward_m), (p.clearance_m, q.clearance_m),
                         (p.pitch_misfit_rad, q.pitch_misfit_rad),
                         (p.vel_misfit_m_s[0], q.vel_misfit_m_s[0])):  # fmt: skip
        mine[sub] = theirs
    return p


def _strides(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, fs_hz: float, f0: _FootFlats,
    f1: _FootFlats,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """(forward displacement, clearance, out of plane) of each stride between foot-flats f0[k]
    and f1[k] (found, f0's anchor before f1's; module doc, steps 2-6), a batch at a time."""
    d = f1.anchor - f0.anchor
    length, clearance = np.full(len(d), np.nan), np.full(len(d), np.nan)
    out_of_plane = np.zeros(len(d), bool)
    for k in _batches(d + 1):
        dk = d[k]
        idx = f0.anchor[k, None] + np.minimum(np.arange(int(dk.max()) + 1), dk[:, None])
        p = _mounted(_Spans(ax[idx], az[idx], gy[idx], dk, f0.take(k), f1.take(k)), fs_hz)
        length[k], clearance[k] = p.forward_m, p.clearance_m
        out_of_plane[k] = (np.abs(p.pitch_misfit_rad) > OUT_OF_PLANE_PITCH_RAD) | (
            np.abs(p.vel_misfit_m_s[0]) > OUT_OF_PLANE_VEL_M_S)  # fmt: skip
    return length, clearance, out_of_plane
