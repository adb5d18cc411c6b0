"""The simulated foot on the ground: foot-flat, and the hip that carries the leg between.

``kinematics.py`` gives the joint angles; this module places the leg in the world so that the
stance foot lies still on the ground while it is flat (the foot sensor's acceleration is then
that of a walking body moving forward, with a stance phase at zero velocity, as a
zero-velocity-update stride estimator assumes):

* **Foot-flat.** The foot's tilt from the normative curves (shank + ankle) is blended to 0 over
  the middle of stance (``flat_window``: 0 at heel strike, 1 from 14 % to 36 %, 0 again from 42 % of
  the cycle, C2 ramps), so the foot lies flat on level ground there, as a real foot does from
  loading response to heel rise. The ankle angle of the truth follows (ankle = foot - shank):
  the ankle rocker of mid-stance.
* **The hip while the foot is flat** is where the leg linkage (thigh, shank, flat foot) puts it
  above the foot's place on the ground, so the foot and its sensor are exactly still.
* **Between foot-flats** (heel rise, push-off, swing, heel strike, loading response: the other
  leg, not simulated, carries the body through most of it) the hip follows a quintic Hermite
  curve in the gait phase that joins the hip at the end of one foot-flat to the hip at the start
  of the next, matching position, velocity and acceleration at both ends (C2 in phase), lifted
  by a bump (``swing_lift``, 0.04 H at its peak, C2 at both ends) while the other leg passes
  its mid-stance, so the swinging foot mostly clears the ground (the ball dips ~1 cm below it
  in mid-swing, ~3 cm in stiff-knee gait: a toe drag); the foot follows from the linkage. The
  heel and forefoot rockers are not modelled: heel and ball are near the ground at heel strike
  and toe off, not pinned to it.
* **Where the foot lands.** The heel of foot-flat k lies at the distance walked D(k) of the gait
  model (a stride length per cycle once walking, shorter while the walk ramps in or out), so the
  true length of stride k (heel strike k to k + 1) is D(k + 1) - D(k): the sensor's displacement
  from one foot-flat to the next.

Foot geometry (fractions of body height, after Winter's anthropometry: foot length 0.152 H,
ankle height 0.039 H): the heel 0.03 H behind the ankle, the ball of the foot 0.08 H ahead of
it, both 0.039 H below it on the sole; the sensor on the dorsum 6 cm ahead of and 3 cm above the
ankle.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from gaitmon.io.sim.jets import Jet

FLAT_RAMP_IN = (0.0, 0.14)  # foot-flat ramps in over this part of the cycle ...
FLAT_RAMP_OUT = (0.36, 0.42)  # ... and out over this one (heel rise)
FLAT_START, FLAT_END = FLAT_RAMP_IN[1], FLAT_RAMP_OUT[0]  # the foot lies exactly flat between
FREE_SPAN = 1.0 - (FLAT_END - FLAT_START)  # phase from one foot-flat to the next
SWING_LIFT_H = 0.04  # hip lift at mid-swing (the other leg's mid-stance), fraction of height

Triple = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class FootGeometry:
    """Points of the foot relative to the ankle, in the foot's frame (forward along the sole,
    up normal to it), metres."""

    heel_back_m: float
    ball_fwd_m: float
    sole_down_m: float
    sensor_fwd_m: float = 0.06
    sensor_up_m: float = 0.03

    @classmethod
    def for_height(cls, height_m: float) -> FootGeometry:
        return cls(heel_back_m=0.03 * height_m, ball_fwd_m=0.08 * height_m,
                   sole_down_m=0.039 * height_m)  # fmt: skip

    @property
    def heel_to_ball_m(self) -> float:
        return self.heel_back_m + self.ball_fwd_m

    @property
    def flat_sensor_height_m(self) -> float:
        """Height of the sensor point above the ground while the foot lies flat."""
        return self.sole_down_m + self.sensor_up_m


def _quintic_step(x: np.ndarray) -> Triple:
    """C2 step 0 -> 1 on x in [0, 1] (6x^5 - 15x^4 + 10x^3) and its two derivatives."""
    inside = (x > 0) & (x < 1)
    x = np.clip(x, 0.0, 1.0)
    f = x**3 * (10.0 + x * (-15.0 + 6.0 * x))
    f1 = np.where(inside, 30.0 * x**2 * (1.0 - x) ** 2, 0.0)
    f2 = np.where(inside, 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x), 0.0)
    return f, f1, f2


def flat_window(q: np.ndarray) -> Triple:
    """(value, d/dq, d2/dq2) of the foot-flat weight over the cycle phase q in [0, 1)."""
    (a0, a1), (b0, b1) = FLAT_RAMP_IN, FLAT_RAMP_OUT
    up, up1, up2 = _quintic_step((q - a0) / (a1 - a0))
    dn, dn1, dn2 = _quintic_step((q - b0) / (b1 - b0))
    wa, wb = 1.0 / (a1 - a0), 1.0 / (b1 - b0)
    return up - dn, up1 * wa - dn1 * wb, up2 * wa**2 - dn2 * wb**2


def swing_lift(u: np.ndarray) -> Triple:
    """64 u^3 (1 - u)^3 on u in [0, 1] (peak 1 at 0.5; value, slope and curvature 0 at both
    ends) and its two derivatives w.r.t. u."""
    v = u * (1.0 - u)
    f = 64.0 * v**3
    f1 = 192.0 * v**2 * (1.0 - 2.0 * u)
    f2 = 384.0 * v * (1.0 - 2.0 * u) ** 2 - 384.0 * v**2
    return f, f1, f2


_H = np.array([  # quintic Hermite basis on [0, 1], polynomial coefficients of u^0 .. u^5
    [1, 0, 0, -10, 15, -6],  # value at 0
    [0, 1, 0, -6, 8, -3],  # slope at 0
    [0, 0, 0.5, -1.5, 1.5, -0.5],  # curvature at 0
    [0, 0, 0, 10, -15, 6],  # value at 1
    [0, 0, 0, -4, 7, -3],  # slope at 1
    [0, 0, 0, 0.5, -1, 0.5],  # curvature at 1
], dtype=np.float64)  # fmt: skip


def quintic_hermite(u: np.ndarray, ends: np.ndarray) -> Triple:
    """(N,) u in [0, 1], (N, 6) [x0, x0', x0'', x1, x1', x1''] (derivatives w.r.t. u) ->
    the interpolant's value and first two derivatives w.r.t. u."""
    c = ends @ _H  # (N, 6) coefficients of u^0 .. u^5
    powers = u[:, None] ** np.arange(6)
    k = np.arange(6)
    val = np.sum(c * powers, axis=1)
    d1 = np.sum(c[:, 1:] * k[1:] * powers[:, :5], axis=1)
    d2 = np.sum(c[:, 2:] * (k[2:] * (k[2:] - 1)) * powers[:, :4], axis=1)
    return val, d1, d2


def hip_over_contact(
    heel_f_m: np.ndarray,
    thigh: Jet,
    shank: Jet,
    foot: Jet,
    thigh_m: float,
    shank_m: float,
    geo: FootGeometry,
) -> tuple[Jet, Jet]:
    """Hip (forward, up) for a foot whose heel lies on the ground at forward position
    ``heel_f_m`` (the foot is flat there; its tilt is 0 with no rate when it is used)."""
    x, z = -geo.heel_back_m, -geo.sole_down_m
    sf, cf = foot.sin(), foot.cos()
    hip_f = (thigh.sin() * thigh_m + shank.sin() * shank_m + (cf * x - sf * z)) * -1.0 + heel_f_m
    hip_u = thigh.cos() * thigh_m + shank.cos() * shank_m - (sf * x + cf * z)
    return hip_f, hip_u
