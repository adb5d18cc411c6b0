"""Sagittal gait kinematics for the simulated unit: joint angles, segment tilts, sensor motion.

This module owns the *true* motion of one leg: the joint-angle curves over the gait cycle, the
stride-by-stride timing (cadence, variability, a standing period first), the segment tilts that
follow from the clinical convention of ``gaitmon.dsp.angles``, and the linear acceleration of the
four sensor points from a simple planar leg linkage. ``sensors.py`` turns this into ADC counts.

Normative curves
----------------
Hip, knee and ankle follow normal adults' sagittal curves over the gait cycle (Winter's
ensemble averages as Fourier series: ``gait_curves.py``). The pelvis (body board) gets a small
forward lean with a twice-per-stride oscillation of +-1.5 deg.

Timing
------
The continuous *normative* phase p(t) (integer part = stride count) is a monotone C1 interpolant
(scipy PCHIP) through knots at every heel strike (p = k) and toe off (p = k + 0.60). Putting the
toe-off knot at ``stance_fraction`` of each stride's duration stretches stance and squeezes swing
(the long-stance pattern) without touching the curves; stride durations are drawn per stride
with the configured CV. The subject stands still (p constant at mid-stance, all joint angles 0)
for ``standing_s``, then the angles ramp in over ``ramp_strides`` strides. Every quantity is carried
with its first and second time derivative (a small forward-mode "jet", ``jets.py``), so rates
and linear accelerations are analytic, not numerical.

Standing still on request (``GaitModel.stand`` / ``walk``, the simulator's stand-still command):
the subject slows over one stride (the angles ramp out as they ramped in) and stops at the next
mid-stance far enough ahead (p = k + START_PHASE, at least 1.5 strides after the last sample
produced, so no produced sample changes), in the standing pose: all angles 0, both FSRs loaded.
The phase stays there (two equal knots: PCHIP keeps it flat, C1) until ``walk``, then the knots
that follow are shifted by the time stood and the angles ramp in again. A request while the
first standing period lasts extends or ends it instead.

Geometry (world frame: F forward, U up; tilts counter-clockwise seen from the subject's right)
------------------------------------------------------------------------------------------------
A segment with tilt th has its board x axis (up along the segment) along (-sin th, cos th) and its
z axis (forward) along (cos th, sin th). Thigh and shank run from their proximal joint down along
(sin th, -cos th); the foot points forward along (cos th, sin th). Segment lengths are Winter's
anthropometric fractions of body height (thigh 0.245 H, shank 0.246 H).

Forward progression (``gaitmon.io.sim.contact``): the foot lies flat and still on the ground in
mid-stance (its tilt blended to 0 there), the hip stands on the linkage above it, and between
foot-flats the hip follows a C2 curve to the next one, which lies a stride length ahead
(``GaitConfig.stride_length_m``, default 0.8 H; speed = stride length x cadence / 120).
``GaitModel.strides`` gives the true stride lengths, times and foot clearances.

Realism (all off by default; ``realism="real"`` of ``gaitmon.io.sim.config`` turns them on with
the parameters measured on real feet, docs/simulator.md "Realism levels")
------------------------------------------------------------------------------------------------
* ``stride_length_cv``: stride k lands (1 + cv z_k) of its base length further (z_k standard
  normal, clipped at 2.5, drawn per stride in order from its own generator); the hip's curves
  join the foot-flats where they now lie, so the sensors see it.
* ``stance_micro_rad``: the stance foot rolls over: from foot-flat on it turns toe-down at a
  steady rate and gives the angle back by toe off (``_stance_micro``); it turns about
  ``stance_pivot_m`` from the sensor (the real level: the ball of the foot, measured on gdins;
  (0, 0): the sensor's own point), so the truth's foot tilt and ankle include it and the
  foot sensor's path moves by (R(micro) - I)(sensor - pivot) (``_points``); the rest of the
  linkage keeps the flat foot, and the footprints (each foot-flat's start) do not move.
* ``roll_sd_deg`` / ``swing_roll_deg`` / ``swing_yaw_deg``: each board leaves the sagittal
  plane: a slow random roll about the walking direction, a roll bump in every swing, and a yaw
  out and back in every swing, both about the board's own point.
* ``turn_every_strides`` ...: turns of ``turn_deg`` change the walking direction (``heading``;
  with ``turn_in_swing`` the foot board keeps its heading through stance and turns in swing):
  every sensor point's horizontal path is its forward travel laid along the heading, so a
  turning stride's length (the footprints' straight distance, ``StrideTruth.stride_length_m``)
  is shorter than its path (``path_length_m``), and the sensors feel the turn's centripetal
  acceleration.

KinematicsBlock carries the heading, roll and swing yaw with their rates; the sagittal truth
(tilts, joint angles) is the pitch about each board's rolled right axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.io.sim.contact import (
    FLAT_END,
    FLAT_START,
    FREE_SPAN,
    SWING_LIFT_H,
    FootGeometry,
    flat_window,
    hip_over_contact,
    quintic_hermite,
    swing_lift,
)
from gaitmon.io.sim.gait_config import (
    DEG,
    FOOT_FLAT_PHASE,
    HEEL_OFF_PHASE,
    START_PHASE,
    TOE_OFF_PHASE,
    GaitConfig,
    KinematicsBlock,
    StrideTruth,
)
from gaitmon.io.sim.gait_curves import ANKLE_COEFFS_DEG, HIP_COEFFS_DEG, KNEE_COEFFS_DEG
from gaitmon.io.sim.jets import (
    FourierCoeffs,
    Jet,
    _cos_jet,
    _ramp_integral,
    _smoothstep,
    _stop_bump,
    _swing_window,
    fourier_series,
)
from gaitmon.io.sim.kinematics_realism import ROLL_FREQS, SWING_FROM, RealismMotion

if TYPE_CHECKING:
    from scipy.interpolate import PchipInterpolator

__all__ = [
    "DEG",
    "FOOT_FLAT_PHASE",
    "HEEL_OFF_PHASE",
    "MIN_STAND_S",
    "OPEN_STAND_S",
    "ROLL_FREQS",
    "START_PHASE",
    "STOP_AHEAD_STRIDES",
    "SWING_FROM",
    "TOE_OFF_PHASE",
    "GaitConfig",
    "GaitModel",
    "KinematicsBlock",
    "StrideTruth",
]

OPEN_STAND_S = 1e7  # the length of a stand nobody has ended yet (about four months)
STOP_AHEAD_STRIDES = 0.1  # margin between the last sample produced and a stop's influence
MIN_STAND_S = 0.5  # a stop that has begun to take effect lasts at least this long


@dataclass
class GaitModel(RealismMotion):
    """Deterministic gait for a config: any sample range can be evaluated in any order.

    The stride schedule is drawn lazily from its own seeded generator, always in the same order,
    so the motion at a given sample never depends on which ranges were asked for before.
    """

    config: GaitConfig = field(default_factory=GaitConfig)

    def __post_init__(self) -> None:
        cfg = self.config
        self._rng = np.random.default_rng(np.random.SeedSequence(cfg.seed, spawn_key=(1,)))
        self._durations_s = np.empty(0)
        self._interp: PchipInterpolator | None = None  # built on first use
        self._t_walk_s = min(cfg.standing_s, OPEN_STAND_S)  # inf: stand until walk()
        self._hs_times = np.empty(0)
        self._to_times = np.empty(0)
        self._horizon_s = -np.inf
        # stops on request after the first walk: [phase, seconds stood], in phase order; the
        # device times each one starts and ends are in _stop_t_s (filled by _rebuild)
        self._stops: list[list[float]] = []
        self._stop_t_s: list[tuple[float, float]] = []
        self._stand_requested = False
        self.foot = FootGeometry.for_height(cfg.height_m)
        self._ends_cache: dict[float, np.ndarray] = {}  # _free_ends, per foot-flat
        # realism: per-stride draws (stride length factor, stance rocking amplitude) from their
        # own generator, in stride order (so the default's draws above never change), and the
        # roll's random phases
        self._stride_rng = np.random.default_rng(np.random.SeedSequence(cfg.seed, spawn_key=(6,)))
        self._stride_z = np.empty((0, 2))
        self._roll_phase = np.random.default_rng(
            np.random.SeedSequence(cfg.seed, spawn_key=(7,))
        ).uniform(0.0, 2.0 * np.pi, (4, len(ROLL_FREQS)))

    # ---- stride schedule -------------------------------------------------------------------
    def _ensure(self, t_max_s: float) -> None:
        """Make the phase interpolant valid (and final) up to t_max_s."""
        cfg = self.config
        # PCHIP slopes at a knot depend on its neighbours only: keep 3 spare strides beyond t_max.
        need = t_max_s + 3.0 * 1.5 * cfg.stride_s
        if self._horizon_s >= need:
            return
        while self._horizon_s < need:
            self._extend_schedule()
            self._rebuild()

    def _extend_schedule(self) -> None:
        """Draw the next 512 stride durations (a subclass may take them from elsewhere)."""
        cfg = self.config
        z = self._rng.standard_normal(512)
        d = cfg.stride_s * np.clip(1.0 + cfg.stride_cv * z, 0.5, 1.5)
        self._durations_s = np.concatenate([self._durations_s, d])

    def _schedule(self) -> tuple[float, np.ndarray, np.ndarray]:
        """(first toe off, heel strikes k = 1, 2, ..., toe offs of strides k = 1, 2, ...) in
        device seconds, before any stop on request: the knots of the phase.
        (``gaitmon.io.sim.bilateral`` takes them from the walk both legs share.)"""
        s = self.config.stance_frac
        d = self._durations_s
        # The first "stride" starts at mid-stance: it covers (1 - START_PHASE) of the cycle.
        first_to = self._t_walk_s + d[0] * s * (TOE_OFF_PHASE - START_PHASE) / TOE_OFF_PHASE
        first_hs = first_to + d[0] * (1.0 - s)
        hs = first_hs + np.concatenate([[0.0], np.cumsum(d[1:])])  # heel strike k = 1, 2, ...
        to = hs + s * np.concatenate([d[1:], [d[-1]]])  # toe off of stride k
        return float(first_to), hs, to

    def _rebuild(self) -> None:
        first_to, hs, to = self._schedule()
        self._hs_times = hs
        self._to_times = np.concatenate([[first_to], to])
        t_knots = [0.0, self._t_walk_s, first_to] if self._t_walk_s > 0 else [0.0, first_to]
        p_knots = [START_PHASE] * (len(t_knots) - 1) + [TOE_OFF_PHASE]
        k = np.arange(1, len(hs) + 1, dtype=np.float64)
        tk = np.empty(2 * len(hs))
        pk = np.empty(2 * len(hs))
        tk[0::2], tk[1::2] = hs, to
        pk[0::2], pk[1::2] = k, k + TOE_OFF_PHASE
        t_all = np.concatenate([t_knots, tk])
        p_all = np.concatenate([p_knots, pk])
        if self._t_walk_s > 0:
            # Before t=0 stand still too, so the interpolant is flat on [0, t_walk].
            t_all = np.concatenate([[-1.0], t_all])
            p_all = np.concatenate([[START_PHASE], p_all])
        self._stop_t_s = []
        self._ends_cache.clear()  # the stops may have changed: the hip's curves with them
        if self._stops:
            t_all, p_all = self._insert_stops(t_all, p_all)
            self._hs_times = np.interp(np.arange(1, len(hs) + 1), p_all, t_all)
            self._to_times = np.interp(np.arange(len(hs) + 1) + TOE_OFF_PHASE, p_all, t_all)
            hs = self._hs_times
        from scipy.interpolate import PchipInterpolator  # lazy: ~1 s to import

        self._interp = PchipInterpolator(t_all, p_all, extrapolate=True)
        self._horizon_s = hs[-4]

    def _insert_stops(self, t_all: np.ndarray, p_all: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Knots with each requested stop: the phase reaches it (on the time line without this
        stop), stays for its length, and every later knot moves later by that length."""
        t_out, p_out = t_all.copy(), p_all.copy()
        for p_stop, stood_s in self._stops:
            t_a = float(np.interp(p_stop, p_out, t_out))
            later = p_out > p_stop
            t_out = np.where(later, t_out + stood_s, t_out)
            k = int(np.searchsorted(p_out, p_stop))
            t_out = np.insert(t_out, k, [t_a, t_a + stood_s])
            p_out = np.insert(p_out, k, [p_stop, p_stop])
            self._stop_t_s.append((t_a, t_a + stood_s))
        return t_out, p_out

    # ---- standing still on request ----------------------------------------------------------
    def phase_at(self, t_s: float) -> float:
        return float(self.phase_jet(np.array([t_s])).v[0])

    @property
    def walk_start_s(self) -> float:
        """When the first standing period ends (OPEN_STAND_S or more: not before ``walk``)."""
        return self._t_walk_s

    def standing_at(self, t_s: float) -> bool:
        """Whether the subject stands (or is about to) at ``t_s``: in the first standing period,
        or told to stand and not told to walk since."""
        return t_s < self._t_walk_s or self._stand_requested

    def stand(self, after_t_s: float) -> float:
        """Stand still until ``walk``, changing nothing before ``after_t_s`` (the time of the
        next sample to produce). Returns when the subject will be standing."""
        self._ensure(after_t_s)
        self._stand_requested = True
        if after_t_s < self._t_walk_s:  # still in the first standing period: extend it
            self._t_walk_s = OPEN_STAND_S
            self._rebuild()
            return 0.0
        if self._stop_t_s and after_t_s < self._stop_t_s[-1][1]:  # stopping or standing
            self._stops[-1][1] = OPEN_STAND_S
            self._rebuild()
            return self._stop_t_s[-1][0]
        ramp = self.config.ramp_strides
        earliest = max(
            self.phase_at(after_t_s) + self._reach() + STOP_AHEAD_STRIDES,
            (self._stops[-1][0] if self._stops else START_PHASE) + 2.0 * ramp,
        )
        p_stop = math.ceil(earliest - START_PHASE) + START_PHASE
        self._stops.append([p_stop, OPEN_STAND_S])
        self._rebuild()
        return self._stop_t_s[-1][0]

    def _reach(self) -> float:
        """How far back in phase a stop changes the motion: its ramp-out, seen by the hip
        before it too (between foot-flats the hip joins the next foot-flat's pose and place,
        FREE_SPAN ahead), and the PCHIP slope at the heel strike before it (0.25 before; the
        interval from the toe off before that, 0.65 before)."""
        return max(self.config.ramp_strides + FREE_SPAN, START_PHASE + 1.0 - TOE_OFF_PHASE)

    def walk(self, after_t_s: float) -> None:
        """Walk again (no-op while walking), changing nothing before ``after_t_s``."""
        self._ensure(after_t_s)
        self._stand_requested = False
        if after_t_s < self._t_walk_s:
            self._t_walk_s = after_t_s + 0.01
        elif self._stop_t_s and after_t_s < self._stop_t_s[-1][1]:
            p_stop = self._stops[-1][0]
            t_a = self._stop_t_s[-1][0]
            if self.phase_at(after_t_s) <= p_stop - self._reach() - STOP_AHEAD_STRIDES:
                self._stops.pop()  # it has not begun to show: as if never asked
            else:
                self._stops[-1][1] = max(after_t_s + 0.01, t_a + MIN_STAND_S) - t_a
        else:
            return
        self._rebuild()

    def heel_strike_times_s(self, t_max_s: float) -> np.ndarray:
        """True heel-strike times up to t_max_s (the first is one partial stride after standing)."""
        self._ensure(t_max_s)
        return self._hs_times[self._hs_times <= t_max_s]

    def toe_off_times_s(self, t_max_s: float) -> np.ndarray:
        self._ensure(t_max_s)
        return self._to_times[self._to_times <= t_max_s]

    def events(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """(heel_strike_idx, toe_off_idx): first sample at or after each event in [start, stop)."""
        fs = self.config.fs_hz
        t_max = stop / fs
        self._ensure(t_max)

        def idx(times: np.ndarray) -> np.ndarray:
            i = np.ceil(times * fs - 1e-9).astype(np.int64)
            return i[(i >= start) & (i < stop)]

        return idx(self._hs_times), idx(self._to_times)

    # ---- motion ----------------------------------------------------------------------------
    def phase_jet(self, t_s: np.ndarray) -> Jet:
        self._ensure(float(np.max(t_s, initial=0.0)))
        assert self._interp is not None
        t = np.asarray(t_s, dtype=np.float64)
        return Jet(self._interp(t), self._interp(t, 1), self._interp(t, 2))

    def evaluate(self, start: int, stop: int) -> KinematicsBlock:
        """True motion for samples start .. stop-1 (sample n is at t = n / fs)."""
        if stop < start:
            raise ValueError(f"empty or reversed sample range [{start}, {stop})")
        # Cache-sized pieces: large temporaries cost more in page faults than in arithmetic.
        step = 16384
        if stop - start <= step:
            return self._evaluate(start, stop)
        parts = [self._evaluate(a, min(a + step, stop)) for a in range(start, stop, step)]
        return KinematicsBlock(
            **{
                name: np.concatenate([getattr(b, name) for b in parts])
                for name in KinematicsBlock.__dataclass_fields__
            }
        )

    def distance_m(self, phase: np.ndarray) -> np.ndarray:
        """The distance walked at each normative phase, m: one stride length per cycle once
        walking, less while the walk ramps in and out of each stop. Heel strike k lands at
        ``distance_m(k)`` (gaitmon.io.sim.contact)."""
        p = np.asarray(phase, dtype=np.float64)
        d = self._base_distance_m(p)
        if self.config.stride_length_cv and p.size:
            # stride k (heel strike k to k + 1) is (1 + cv z_k) times its base length: exact at
            # integer phases (where the foot lands), linear between (never used there)
            k_max = max(int(np.ceil(np.max(p))) + 1, 1)
            ks = np.arange(k_max + 1, dtype=np.float64)
            base = self._base_distance_m(ks)
            z = self._stride_draws(k_max)[:, 0]
            extra = np.concatenate([[0.0], np.cumsum(np.diff(base) * self.config.stride_length_cv
                                                     * z[:k_max])])  # fmt: skip
            d = d + np.interp(p, ks, extra)
        return np.asarray(d)

    def _base_distance_m(self, p: np.ndarray) -> np.ndarray:
        cfg = self.config
        d = _ramp_integral(p - START_PHASE, cfg.ramp_strides)[0] * cfg.stride_len_m
        for p_stop, _ in self._stops:
            d = d - _stop_bump(p - p_stop, cfg.ramp_strides)[1][0] * cfg.stride_len_m
        return np.asarray(d)

    def _angles(self, p: Jet) -> tuple[Jet, ...]:
        """(hip, knee, ankle, body, thigh, shank, foot, env) as jets of whatever ``p`` is a jet
        of: time (evaluate) or the phase itself (d = 1, dd = 0: derivatives w.r.t. phase)."""
        cfg = self.config
        q = np.mod(p.v, 1.0)
        env = p.compose(*_smoothstep(p.v - START_PHASE, cfg.ramp_strides))
        for p_stop, _ in self._stops:
            # ramp out into the stop and in again after it
            u = p.v - p_stop
            if np.any(u > -cfg.ramp_strides):
                env = env - p.compose(*_stop_bump(u, cfg.ramp_strides)[0])

        def curve(coeffs: FourierCoeffs) -> Jet:
            f, f1, f2 = fourier_series(coeffs, q)
            return p.compose(f * DEG, f1 * DEG, f2 * DEG)

        hip = curve(HIP_COEFFS_DEG) * env
        knee_n = curve(KNEE_COEFFS_DEG)
        if cfg.knee_scale != 1.0:
            win = p.compose(*_swing_window(q))
            # Scale only the flexion above the stance level (5 deg) so swing stays continuous.
            base = 5.0 * DEG
            knee_n = (knee_n - base) * (win * (cfg.knee_scale - 1.0) + 1.0) + base
        knee = knee_n * env
        body = (_cos_jet(p, q, 4.0 * np.pi, 0.1) * cfg.body_osc_rad + cfg.body_lean_rad) * env
        thigh = body + hip
        shank = thigh - knee
        # the foot lies flat on the ground in mid-stance (contact module); the ankle follows
        foot = (shank + curve(ANKLE_COEFFS_DEG) * env) * (p.compose(*flat_window(q)) * -1.0 + 1.0)
        ankle = foot - shank
        return hip, knee, ankle, body, thigh, shank, foot, env

    def _hip(self, p: Jet, thigh: Jet, shank: Jet, foot: Jet, env: Jet) -> tuple[Jet, Jet]:
        """The hip (forward, up): above the flat stance foot at its place while the foot lies
        flat, a C2 curve in phase from one foot-flat to the next (gaitmon.io.sim.contact)."""
        cfg, geo = self.config, self.foot
        s = p.v - FLAT_END
        kb = np.floor(s)  # the foot-flat the sample is after (or in, when pinned)
        u = (s - kb) / FREE_SPAN
        free = u < 1.0
        k = np.where(free, kb, kb + 1.0)  # the stride whose foot lies flat when pinned
        hip_f, hip_u = hip_over_contact(
            self.distance_m(k), thigh, shank, foot, cfg.thigh_m, cfg.shank_m, geo
        )
        if not free.any():
            return hip_f, hip_u
        ks, inv = np.unique(kb[free], return_inverse=True)
        ends = self._free_ends(ks)  # (K, 2 axes, 6)
        out = []
        pf = Jet(p.v[free], p.d[free], p.dd[free])
        sp = FREE_SPAN
        for axis, pinned in ((0, hip_f), (1, hip_u)):
            e = ends[:, axis, :]
            x, x1, x2 = quintic_hermite(u[free], e[inv])
            curve = pf.compose(x, x1 / sp, x2 / sp**2)
            if axis == 1:  # the other leg's mid-stance lifts the hip while this foot swings
                b0, b1, b2 = swing_lift(u[free])
                lift = pf.compose(b0, b1 / sp, b2 / sp**2) * Jet(*(j[free] for j in env))
                curve = curve + lift * (SWING_LIFT_H * cfg.height_m)
            full = Jet(pinned.v.copy(), pinned.d.copy(), pinned.dd.copy())
            for arr, part in zip(full, curve, strict=True):
                arr[free] = part
            out.append(full)
        return out[0], out[1]

    def _free_ends(self, ks: np.ndarray) -> np.ndarray:
        """(K, 2, 6): for the curve after foot-flat k, the hip (forward, up) at both ends and
        its first two derivatives w.r.t. the curve's own parameter (quintic_hermite's ends).
        Cached per k: it depends on the phase and the stops only (_rebuild clears it)."""
        missing = np.array([k for k in ks if k not in self._ends_cache])
        if len(missing):
            cfg, geo, sp = self.config, self.foot, FREE_SPAN
            ends = []
            for at, contact in ((missing + FLAT_END, missing),
                                (missing + 1.0 + FLAT_START, missing + 1.0)):  # fmt: skip
                pj = Jet(at, np.ones_like(at), np.zeros_like(at))
                _, _, _, _, th, sh, ft, _ = self._angles(pj)
                ends.append(hip_over_contact(self.distance_m(contact), th, sh, ft,
                                             cfg.thigh_m, cfg.shank_m, geo))  # fmt: skip
            per_axis = [
                np.stack([a.v, a.d * sp, a.dd * sp**2, b.v, b.d * sp, b.dd * sp**2], axis=1)
                for a, b in zip(ends[0], ends[1], strict=True)
            ]
            both = np.stack(per_axis, axis=1)
            for k, row in zip(missing, both, strict=True):
                self._ends_cache[float(k)] = row
        return np.stack([self._ends_cache[float(k)] for k in ks])

    def _evaluate(self, start: int, stop: int) -> KinematicsBlock:
        cfg = self.config
        idx = np.arange(start, stop, dtype=np.int64)
        t = idx / cfg.fs_hz
        p = self.phase_jet(t)
        hip, knee, ankle, body, thigh, shank, foot, env = self._angles(p)
        points = self._points(p, thigh, shank, foot, env)
        micro = self._stance_micro(p, env)
        if micro is not None:  # the flat foot rolls over (realism; its sensor: _points)
            foot, ankle = foot + micro, ankle + micro
        lin_acc = np.stack([np.stack([pf.dd, pu.dd], axis=-1) for pf, pu in points], axis=1)
        pos = np.stack([np.stack([pf.v, pu.v], axis=-1) for pf, pu in points], axis=1)
        vel = np.stack([np.stack([pf.d, pu.d], axis=-1) for pf, pu in points], axis=1)
        tilts = (body, thigh, shank, foot)
        head = self.heading(p)
        rolls = self.roll(p, env)
        yaws = self.board_yaw(p, env)
        if cfg.turn_in_swing and cfg.turn_every_strides:
            # the foot's heading is the walk's at its last foot-flat through stance, then turns
            # to the next foot-flat's in swing: its yaw from the walking direction
            yaws[3] = yaws[3] + self.heading(self._swing_warp(p)) - head
        return KinematicsBlock(
            sample_idx=idx,
            t_s=t,
            phase=p.v,
            phase_rate_hz=p.d,
            walking=env.v,
            joint_rad=np.stack([hip.v, knee.v, ankle.v], axis=-1),
            tilt_rad=np.stack([j.v for j in tilts], axis=-1),
            rate_rad_s=np.stack([j.d for j in tilts], axis=-1),
            lin_acc_ms2=lin_acc,
            position_m=pos,
            velocity_m_s=vel,
            heading_rad=head.v,
            yaw_rate_rad_s=head.d,
            roll_rad=np.stack([r.v for r in rolls], axis=-1),
            roll_rate_rad_s=np.stack([r.d for r in rolls], axis=-1),
            board_yaw_rad=np.stack([y.v for y in yaws], axis=-1),
            board_yaw_rate_rad_s=np.stack([y.d for y in yaws], axis=-1),
        )

    def _points(
        self, p: Jet, thigh: Jet, shank: Jet, foot: Jet, env: Jet
    ) -> tuple[tuple[Jet, Jet], ...]:
        """(forward, up) of the four sensor points: body at the hip, thigh and shank boards at
        mid-segment, the foot board on the dorsum."""
        cfg, geo = self.config, self.foot
        hip_f, hip_u = self._hip(p, thigh, shank, foot, env)
        st, ct = thigh.sin(), thigh.cos()
        ss, cs = shank.sin(), shank.cos()
        sf, cf = foot.sin(), foot.cos()
        knee_f, knee_u = hip_f + st * cfg.thigh_m, hip_u - ct * cfg.thigh_m
        ankle_f, ankle_u = knee_f + ss * cfg.shank_m, knee_u - cs * cfg.shank_m
        half_t, half_s = 0.5 * cfg.thigh_m, 0.5 * cfg.shank_m
        fwd, up = geo.sensor_fwd_m, geo.sensor_up_m
        foot_f, foot_u = ankle_f + cf * fwd - sf * up, ankle_u + sf * fwd + cf * up
        px, pz = cfg.stance_pivot_m
        micro = self._stance_micro(p, env) if px or pz else None
        if micro is not None:
            # the roll-over turns the foot by micro about the pivot (px, pz) from the sensor in
            # the foot's frame: the sensor moves by (R(micro) - I) (sensor - pivot) in the world
            df, du = (cf * px - sf * pz) * -1.0, (sf * px + cf * pz) * -1.0
            cm, sm = micro.cos() - 1.0, micro.sin()
            foot_f = foot_f + cm * df - sm * du
            foot_u = foot_u + sm * df + cm * du
        return (
            (hip_f, hip_u),
            (hip_f + st * half_t, hip_u - ct * half_t),
            (knee_f + ss * half_s, knee_u - cs * half_s),
            (foot_f, foot_u),
        )

    # ---- truth per stride ---------------------------------------------------------------------
    def strides(self, start: int, stop: int) -> StrideTruth:
        """The true strides that start (heel strike) in samples [start, stop): stride k runs
        from heel strike k to k + 1; its length is the foot sensor's forward displacement from
        one foot-flat to the next (= where heel strike k + 1 landed minus where k did), its
        clearance the sensor's highest point over that interval above its foot-flat height."""
        fs = self.config.fs_hz
        self._ensure(stop / fs + 3.0 * self.config.stride_s)
        i = np.ceil(self._hs_times * fs - 1e-9).astype(np.int64)
        keep = (i >= start) & (i < stop)
        k = np.flatnonzero(keep).astype(np.float64) + 1.0  # heel strike j is phase j + 1
        length = self.distance_m(k + 1.0) - self.distance_m(k)
        grid = np.linspace(FLAT_START, 1.0 + FLAT_START, 201)
        pv = (k[:, None] + grid[None, :]).ravel()
        pj = Jet(pv, np.ones_like(pv), np.zeros_like(pv))
        _, _, _, _, th, sh, ft, en = self._angles(pj)
        up = self._points(pj, th, sh, ft, en)[3][1].v.reshape(len(k), len(grid))
        clearance = up.max(axis=1, initial=-np.inf) - self.foot.flat_sensor_height_m
        t_next = np.interp(k + 1.0, np.arange(1, len(self._hs_times) + 1), self._hs_times)
        path, turn = None, None
        if self.config.turn_every_strides:
            path, turn = length, np.empty(len(k))
            length = np.empty(len(k))
            # the sensor's way between the two foot-flats in the world: forward travel dF along
            # the heading psi; Simpson's rule on 1601 phase points (error < 1e-6 m)
            g = np.linspace(FLAT_START, 1.0 + FLAT_START, 1601)
            for n, kk in enumerate(k):
                pv = kk + g
                pj = Jet(pv, np.ones_like(pv), np.zeros_like(pv))
                _, _, _, _, th, sh, ft, en = self._angles(pj)
                dfwd = self._points(pj, th, sh, ft, en)[3][0].d  # dF/dphase
                psi = self.heading(pj).v
                wts = np.ones(len(g))
                wts[1:-1:2], wts[2:-1:2] = 4.0, 2.0
                wts *= (g[1] - g[0]) / 3.0
                dx, dy = np.sum(wts * dfwd * np.cos(psi)), np.sum(wts * dfwd * np.sin(psi))
                length[n] = np.hypot(dx, dy)
                turn[n] = psi[-1] - psi[0]
        return StrideTruth(
            heel_strike_idx=i[keep],
            stride_length_m=length,
            stride_time_s=t_next - self._hs_times[keep],
            foot_clearance_m=clearance,
            path_length_m=path,
            turn_rad=turn,
        )
