"""The simulated leg's motion out of the sagittal plane and its variability (the "Realism"
section of :mod:`gaitmon.io.sim.kinematics`'s module doc, which describes them): turns
(heading), each board's roll and swing yaw, the stance foot's roll-over, and the per-stride
draws. :class:`RealismMotion` is a part of :class:`gaitmon.io.sim.kinematics.GaitModel`.
"""

from __future__ import annotations

import functools

import numpy as np

from gaitmon.io.sim.contact import FLAT_END, FLAT_START
from gaitmon.io.sim.gait_config import START_PHASE, TOE_OFF_PHASE, GaitConfig
from gaitmon.io.sim.jets import Jet

ROLL_FREQS = (0.137, 0.419, 0.853)  # the roll's sines, cycles per stride (realism)
SWING_FROM = TOE_OFF_PHASE  # the swing bumps of roll and yaw (realism) span toe off .. heel strike
_ODD_PEAK = 0.6495190528383291  # max of sin^2(pi u) sin(2 pi u) on [0, 1] (at u = 1/3)


def _swing_bump(q: np.ndarray, odd: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Over the swing (q from SWING_FROM to 1), peak 1: sin^2(pi u) (``odd`` False: out and
    back once) or sin^2(pi u) sin(2 pi u) / its peak (``odd``: out one way, then the other, no
    net turn), u the swing's fraction; 0 elsewhere. Value and derivatives w.r.t. q."""
    span = 1.0 - SWING_FROM
    u = (np.asarray(q, dtype=np.float64) - SWING_FROM) / span
    inside = (u > 0.0) & (u < 1.0)
    s2, ds2, dds2 = (np.sin(np.pi * u) ** 2, np.pi * np.sin(2.0 * np.pi * u),
                     2.0 * np.pi**2 * np.cos(2.0 * np.pi * u))  # fmt: skip
    if odd:
        w = 2.0 * np.pi
        sn, cs = np.sin(w * u), np.cos(w * u)
        f = s2 * sn / _ODD_PEAK
        f1 = (ds2 * sn + s2 * w * cs) / _ODD_PEAK
        f2 = (dds2 * sn + 2.0 * ds2 * w * cs - s2 * w * w * sn) / _ODD_PEAK
    else:
        f, f1, f2 = s2, ds2, dds2
    return (np.where(inside, f, 0.0), np.where(inside, f1 / span, 0.0),
            np.where(inside, f2 / span**2, 0.0))  # fmt: skip


@functools.lru_cache(maxsize=1)
def _rollover() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stance roll-over's shape on u in [0, 1] (foot-flat start .. toe off), 20001 points:
    (angle, its slope, the slope's slope). The slope rises smoothly to 1 by u = 0.15, stays 1
    to the end of foot-flat, then fades while a sin^2 bump gives the angle back: the angle is 0
    at both ends with slope 0 (C1), and 1 x (foot-flat's share) by the end of foot-flat."""
    u = np.linspace(0.0, 1.0, 20001)
    u1 = (FLAT_END - FLAT_START) / (TOE_OFF_PHASE - FLAT_START)

    def step(x: np.ndarray) -> np.ndarray:
        x = np.clip(x, 0.0, 1.0)
        return x * x * (3.0 - 2.0 * x)

    s = (u - u1) / (1.0 - u1)
    base = step(u / 0.15) * (1.0 - step(s))
    bump = np.where((s > 0) & (s < 1), np.sin(np.pi * s) ** 2, 0.0)
    du = u[1] - u[0]

    def integral(r: np.ndarray) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * du)])

    k = integral(base)[-1] / integral(bump)[-1]
    r = base - k * bump
    g = integral(r)
    g[-1] = 0.0
    return g, r, np.gradient(r, du)



class RealismMotion:
    """GaitModel's realism (kinematics module doc, "Realism"): all off by default."""

    # set by GaitModel.__post_init__
    config: GaitConfig
    _stride_rng: np.random.Generator
    _stride_z: np.ndarray
    _roll_phase: np.ndarray

    def _stride_draws(self, k_max: int) -> np.ndarray:
        """(>= k_max + 1, 2) standard normal draws per stride, clipped to +-2.5: the stride
        length factor's and the stance rocking's log amplitude's."""
        while len(self._stride_z) <= k_max:
            z = np.clip(self._stride_rng.standard_normal((512, 2)), -2.5, 2.5)
            self._stride_z = np.concatenate([self._stride_z, z])
        return self._stride_z

    # ---- out of the sagittal plane (realism) --------------------------------------------------
    def heading(self, p: Jet) -> Jet:
        """Walking direction (rad, > 0 to the left) as a jet of what ``p`` is a jet of: turns of
        ``turn_deg`` over ``turn_strides`` every ``turn_every_strides`` strides, from
        ``first_turn_strides`` after the ramp-in; the rate is 2 sin^2 shaped (no jerk at the
        ends)."""
        cfg = self.config
        zero = np.zeros_like(p.v)
        if not cfg.turn_every_strides:
            return Jet(zero, zero.copy(), zero.copy())
        a = np.radians(cfg.turn_deg)
        ts, every = cfg.turn_strides, cfg.turn_every_strides
        s = p.v - (START_PHASE + cfg.ramp_strides + cfg.first_turn_strides)
        j = np.floor(s / every)
        u = np.clip((s - j * every) / ts, 0.0, 1.0)
        inside = (u > 0.0) & (u < 1.0)
        h = u - np.sin(2.0 * np.pi * u) / (2.0 * np.pi)
        f = np.where(s < 0.0, 0.0, a * (j + h))
        f1 = np.where(inside & (s >= 0.0), a / ts * (1.0 - np.cos(2.0 * np.pi * u)), 0.0)
        f2 = np.where(inside & (s >= 0.0), a / ts**2 * 2.0 * np.pi * np.sin(2.0 * np.pi * u), 0.0)
        return p.compose(f, f1, f2)

    def _swing_warp(self, p: Jet) -> Jet:
        """The phase the foot's heading follows (``turn_in_swing``): held at each foot-flat's
        start (k + FLAT_START) until toe off, then a quintic step to the next foot-flat's."""
        q = p.v - FLAT_START
        k = np.floor(q)
        span = 1.0 - (TOE_OFF_PHASE - FLAT_START)
        x = np.clip((q - k - (TOE_OFF_PHASE - FLAT_START)) / span, 0.0, 1.0)
        h = x**3 * (10.0 - 15.0 * x + 6.0 * x * x)
        h1 = 30.0 * x * x * (1.0 - x) ** 2 / span
        h2 = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / span**2
        return p.compose(k + FLAT_START + h, h1, h2)

    def roll(self, p: Jet, env: Jet) -> list[Jet]:
        """Each board's roll about the walking direction (rad): ``roll_sd_deg`` RMS, a sum of
        three sines of the phase at incommensurate frequencies (ROLL_FREQS per stride) with
        seeded phases, faded in and out with the walk (0 standing)."""
        cfg = self.config
        out = []
        for j, (sd, peak) in enumerate(zip(cfg.roll_sd_deg, cfg.swing_roll_deg, strict=True)):
            f, f1, f2 = np.zeros_like(p.v), np.zeros_like(p.v), np.zeros_like(p.v)
            if sd:
                c = np.radians(sd) * np.sqrt(2.0 / len(ROLL_FREQS))
                for fr, ph in zip(ROLL_FREQS, self._roll_phase[j], strict=True):
                    w = 2.0 * np.pi * fr
                    sn, cs = np.sin(w * p.v + ph), np.cos(w * p.v + ph)
                    f, f1, f2 = f + c * sn, f1 + c * w * cs, f2 - c * w * w * sn
            if peak:
                b, b1, b2 = _swing_bump(np.mod(p.v, 1.0), odd=False)
                a = np.radians(peak)
                f, f1, f2 = f + a * b, f1 + a * b1, f2 + a * b2
            out.append(p.compose(f, f1, f2) * env)
        return out

    def board_yaw(self, p: Jet, env: Jet) -> list[Jet]:
        """Each board's yaw from the walking direction (rad, > 0 to the left): out by
        ``swing_yaw_deg`` and back in every swing (the foot's toe-in / toe-out swing), the
        board turning about its own point (its path is the walk's)."""
        out = []
        for peak in self.config.swing_yaw_deg:
            b, b1, b2 = _swing_bump(np.mod(p.v, 1.0), odd=True)
            a = np.radians(peak)
            out.append(p.compose(a * b, a * b1, a * b2) * env)
        return out

    def _stance_micro(self, p: Jet, env: Jet) -> Jet | None:
        """The stance foot's roll-over (rad, added to its tilt and the ankle's, not to the
        linkage: the foot turns about ``stance_pivot_m`` from its sensor, which moves the foot
        sensor's point only (``_points``)): from foot-flat on the foot turns
        toe-down at a steady rate (the heel starts to rise early, as real feet do: the pitch
        gyro reads about -0.2 rad/s through the whole still phase, docs/simulator.md), and
        gives the angle back by toe off (``_ROLLOVER``). Stride k's amplitude is
        stance_micro_rad exp(spread z_k); None when off."""
        cfg = self.config
        if not cfg.stance_micro_rad:
            return None
        k = np.floor(p.v)
        u = (p.v - k - FLAT_START) / (TOE_OFF_PHASE - FLAT_START)
        inside = (u > 0.0) & (u < 1.0)
        k_max = max(int(np.max(k, initial=0.0)), 0)
        z = self._stride_draws(k_max + 1)
        ki = np.clip(k.astype(np.int64), 0, None)
        amp = -cfg.stance_micro_rad * np.exp(cfg.stance_micro_spread * z[ki, 1])
        g, r, dr = _rollover()
        span = TOE_OFF_PHASE - FLAT_START
        grid = np.linspace(0.0, 1.0, len(g))
        uc = np.clip(u, 0.0, 1.0)
        f = np.where(inside, amp * np.interp(uc, grid, g), 0.0)
        f1 = np.where(inside, amp * np.interp(uc, grid, r) / span, 0.0)
        f2 = np.where(inside, amp * np.interp(uc, grid, dr) / span**2, 0.0)
        return p.compose(f, f1, f2) * env
