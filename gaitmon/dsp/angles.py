"""Angle helpers and the clinical joint-angle convention.

Segment tilts are sagittal-plane rotations, positive counter-clockwise as seen from the subject's
right side (see ``gaitmon.dsp.channels`` for the mounting that makes atan2(a_z, a_x) follow this):
thigh and shank tilt is positive when the distal end swings forward, foot tilt is positive toe-up,
body tilt is positive leaning back. After the standing calibration every tilt is 0 upright and:

* hip flexion +       = thigh - body
* knee flexion +      = thigh - shank
* ankle dorsiflexion + = foot - shank

Every difference is wrapped to (-pi, pi].
"""

from __future__ import annotations

import numpy as np

from gaitmon.dsp.channel_table import JOINT_PAIRS as JOINT_PAIRS  # re-exported

TWO_PI = 2.0 * np.pi

# JOINT_PAIRS: (plus, minus) index into SEGMENTS per joint, from the channel table's joints
_PLUS = np.array([p for p, _ in JOINT_PAIRS], dtype=np.intp)
_MINUS = np.array([m for _, m in JOINT_PAIRS], dtype=np.intp)
JOINT_PLUS, JOINT_MINUS = _PLUS, _MINUS  # (the compiled loops take them: gaitmon.dsp.kernels)


def wrap_angle(x: np.ndarray | float) -> np.ndarray:
    """Wrap radians to (-pi, pi]."""
    x = np.asarray(x, dtype=np.float64)
    # rint is several times faster than np.mod on long arrays; fix the one boundary it gets wrong
    if x.ndim == 0:
        y0 = x - TWO_PI * np.rint(x * (1.0 / TWO_PI))
        return np.where(y0 <= -np.pi, y0 + TWO_PI, y0)
    # (in one buffer: the same operations, without four temporaries: ~10x faster)
    y = x * (1.0 / TWO_PI)
    np.rint(y, out=y)
    y *= TWO_PI
    np.subtract(x, y, out=y)
    low = y <= -np.pi
    if low.any():
        y[low] += TWO_PI
    return y


def accel_tilt(ax: np.ndarray, az: np.ndarray) -> np.ndarray:
    """Tilt (rad) from the accelerometer's x and z axes: atan2(a_z, a_x), in (-pi, pi]."""
    return np.arctan2(az, ax)


def joint_angles(tilt_rad: np.ndarray) -> np.ndarray:
    """(N, 4) segment tilts (body, thigh, shank, foot) -> (N, 3) hip, knee, ankle in rad.

    Clinical signs: hip flexion +, knee flexion +, ankle dorsiflexion +; wrapped to (-pi, pi].
    """
    t = np.asarray(tilt_rad, dtype=np.float64)
    return wrap_angle(t[..., _PLUS] - t[..., _MINUS])
