"""One stride's planar strapdown integration between two foot-flats (module doc, steps 2-6).

Part of the stride-length method: the method is the module doc of
:mod:`gaitmon.dsp.stride_length` (its steps, which "module doc, step N" below refers to).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitmon.dsp.stride_anchors import _FootFlat
from gaitmon.dsp.stride_method import ANCHOR_LEVER_M as ANCHOR_LEVER_M
from gaitmon.dsp.stride_method import MOUNT_COS_MIN as MOUNT_COS_MIN
from gaitmon.dsp.stride_method import MOUNT_ITERATIONS as MOUNT_ITERATIONS
from gaitmon.dsp.stride_method import MOUNT_MIN_VEL_M_S as MOUNT_MIN_VEL_M_S
from gaitmon.dsp.stride_method import OUT_OF_PLANE_PITCH_RAD as OUT_OF_PLANE_PITCH_RAD
from gaitmon.dsp.stride_method import OUT_OF_PLANE_VEL_M_S as OUT_OF_PLANE_VEL_M_S


def _cumtrapz(y: np.ndarray, dt: float) -> np.ndarray:
    out = np.zeros_like(y)
    out[1:] = np.cumsum(0.5 * (y[1:] + y[:-1])) * dt
    return out


@dataclass(frozen=True)
class _Pass:
    forward_m: float
    clearance_m: float
    pitch_misfit_rad: float  # the gyro's pitch at the second foot-flat less the accelerometer's
    vel_misfit_m_s: tuple[float, float]  # (forward, up) velocity at the second foot-flat



def _integrate(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, fs_hz: float, f0: _FootFlat, f1: _FootFlat,
    mount_cos: float,
) -> _Pass:  # fmt: skip
    """Steps 2-4 of the module doc between two foot-flats, the board's forward axis and gyro
    taken as ``mount_cos`` of the foot's (step 5)."""
    a, b = f0.anchor, f1.anchor
    dt = 1.0 / fs_hz
    u = np.arange(b - a + 1) / (b - a)  # 0 at the first anchor, 1 at the second
    bias = 0.5 * (f0.gyro_bias_rad_s + f1.gyro_bias_rad_s)
    rate = (gy[a : b + 1] - bias) / mount_cos
    p0, p1 = f0.pitch_rad(mount_cos), f1.pitch_rad(mount_cos)
    pitch = p0 + _cumtrapz(rate, dt)
    # the gyro's own closure (its standing bias is removed by the calibration; the residual
    # estimated at a foot-flat is not used here: a rolling stance foot would fake one)
    pitch_misfit = float(pitch[-1] + bias / mount_cos * (b - a) * dt - p1)
    pitch -= (pitch[-1] - p1) * u
    s, c = np.sin(pitch), np.cos(pitch)
    x, z = ax[a : b + 1], az[a : b + 1] / mount_cos
    acc_f = z * c - x * s
    acc_u = x * c + z * s - 0.5 * (f0.g_ms2(mount_cos) + f1.g_ms2(mount_cos))
    # a stance foot that still rolls (step 1) moves the board forward by its height above the
    # ground pivot times the roll rate (toe-down, negative rate: forward)
    v_ends = ((-ANCHOR_LEVER_M * f0.roll_rad_s / mount_cos,
               -ANCHOR_LEVER_M * f1.roll_rad_s / mount_cos), (0.0, 0.0))  # fmt: skip
    out = []
    misfit = []
    for acc, (v0, v1) in zip((acc_f, acc_u), v_ends, strict=True):
        v = v0 + _cumtrapz(acc, dt)
        misfit.append(float(v[-1] - v1))
        v -= (v[-1] - v1) * u
        p = _cumtrapz(v, dt)
        out.append(p)
    fwd, up = out
    up -= up[-1] * u
    return _Pass(float(fwd[-1]), float(np.max(up)), pitch_misfit, (misfit[0], misfit[1]))


def _stride(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, fs_hz: float, f0: _FootFlat, f1: _FootFlat
) -> tuple[float, float, bool]:
    """(forward displacement, clearance, out of plane) between two foot-flats (module doc,
    steps 2-6)."""
    p = _integrate(ax, az, gy, fs_hz, f0, f1, 1.0)
    # a board yawed on the foot sees only cos(yaw) of the pitch rate and forward acceleration
    # (step 5): the cosine in [MOUNT_COS_MIN, 1] at which the foot ends the stride with no
    # vertical velocity, if it misses by more than MOUNT_MIN_VEL_M_S and changes sign there
    hi_sign = np.sign(p.vel_misfit_m_s[1])
    lo, hi = MOUNT_COS_MIN, 1.0
    if abs(p.vel_misfit_m_s[1]) > MOUNT_MIN_VEL_M_S and (
        np.sign(_integrate(ax, az, gy, fs_hz, f0, f1, lo).vel_misfit_m_s[1]) == -hi_sign
    ):
        for _ in range(MOUNT_ITERATIONS):
            mid = 0.5 * (lo + hi)
            if np.sign(_integrate(ax, az, gy, fs_hz, f0, f1, mid).vel_misfit_m_s[1]) == hi_sign:
                hi = mid
            else:
                lo = mid
        p = _integrate(ax, az, gy, fs_hz, f0, f1, 0.5 * (lo + hi))
    out_of_plane = (
        abs(p.pitch_misfit_rad) > OUT_OF_PLANE_PITCH_RAD
        or abs(p.vel_misfit_m_s[0]) > OUT_OF_PLANE_VEL_M_S
    )
    return p.forward_m, p.clearance_m, out_of_plane
