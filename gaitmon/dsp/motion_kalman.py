"""The gait-aware causal tilt filter: paper 000's state, the measurement trusted by the motion.

State x = [theta, b] (tilt, gyro bias) and the prediction are paper 000's (SPEC section 4):

    theta- = theta + (omega - b) dt ;  b- = b

What changes is *when* the accelerometer tilt z = atan2(a_z, a_x) is believed. It measures the
tilt only while the segment's own acceleration is small, i.e. while | |a| - g | is small. Per
sample and segment the filter looks at the last ``window_s`` (50 ms) of raw (not low-passed)
samples:

    dev = max | |a| - g |  over the window,    rate = max |omega| over the window

and gives the measurement a variance R (rad^2) from them (:class:`SegmentTuning`):

* quasi-static (dev < ``static_acc_ms2`` and rate < ``static_rate_rad_s``): R = ``r_static``.
  For the foot this is foot-flat in every stance: the accelerometer is then as good as it gets.
* otherwise R = ``r_moving`` (1 + (dev / ``acc_scale_ms2``)^2), or infinity (no update at all)
  where ``r_moving`` is None. Thigh and body are never still while walking; a foot-style gate
  would leave them on the gyro alone for minutes, so they need a measurement while moving: with
  ``live_gravity_hz`` set (their default) it is the gravity measurement below; without it, this
  weak one, whose weight falls with the acceleration magnitude's deviation from 1 g (the
  smoother's first pass still uses it).

Gravity measurement (``live_gravity_hz``; every segment). Body, thigh and shank are never
still while walking, and the accelerometer tilt of a swinging thigh or shank carries its own
acceleration with a mean over the stride that is not zero in the board's frame: a walking bias
of 2-9 deg (the peak swing knee error). In a fixed frame, though, a sensor point's acceleration
averages to zero over whole strides (its velocity is periodic). So the filter turns the specific
force by the gyro angle Theta_k = Theta_(k-1) + omega_k dt (started at the first accelerometer
tilt) into that fixed frame, low-passes it (2nd-order Butterworth at ``live_gravity_hz``,
causal), and measures

    z~_k = Theta_k + arg( LP[ (a_x + i a_z) e^(-i Theta) ]_k )

the tilt at which the averaged specific force points up. A gyro bias b turns Theta away at b
rad/s and the low-pass sees that drift late by its DC delay ``lag`` (0.90 s at 0.25 Hz), so
z~ = theta + lag b: the measurement row is H = [1, lag], with its own steady-state gain
(``gravity_gain``), and the bias state absorbs it. ``shift_bias`` (a new calibration) is undone
in the gyro angle, so zeroing mid-stream does not disturb it. Quasi-static samples use the
accelerometer tilt with ``r_static`` as before. The foot keeps its foot-flat gate and, since
issue 24, takes the gravity measurement while moving too (with ``r_live_gravity`` 3e-3): on
real walks without a foot-flat in every stride (fast walking, speed changes) the gate alone left
it on the gyro for tens of seconds (gdins exp44: 27 deg against the paper's 12).

Out of plane (``plane_fraction``; the foot). The two accelerometer axes see gravity's whole
magnitude only while the board's y axis is level; turned out of the sagittal plane, the planar
|a| = g cos(beta) < g, the accelerometer tilt atan2(a_z, a_x) is still the planar tilt (of
gravity's projection), but gyro_y is no longer its rate and | |a| - g | no longer measures the
board's own acceleration. So the planar |a| is low-passed (one pole, ``plane_cutoff_hz``) and
while it is below ``plane_fraction`` g (0.95: beta > 18 deg; a walking foot's mean |a| is above
1 g, so walking never trips it) the accelerometer tilt is the measurement with the steady-state
angle gain of ``r_out_of_plane`` and no bias update (the mismatch is not a gyro bias). This is
what made the live filter better than the paper's on BROAD's 3-D trials (docs/filters.md).

Gain. The gain at each sample is the *steady-state* Kalman gain [K0, K1] of the paper's model
(exact discretisation, Q = diag(q_angle, q_bias)) for that sample's R, looked up in a table
over log10(R) (linear interpolation between 0.05-decade knots; R = infinity gives K = 0). It is a
gain-scheduled Kalman filter: with the large static gains the first foot-flat samples after a
swing correct the angle within a few samples, which is what the exact time-varying filter does
too (on the simulator the scheduled gains were as accurate as the exact time-varying
covariance; see docs/filters.md). The update is paper 000's, with K from the schedule:

    theta = theta- + K0 e ; b = b- + K1 e ;  e = z - theta- - h b-   (h = lag for z~, else 0)

Start-up (``start_prior``, default :data:`START_PRIOR`). A recording that starts without a
Zero, while the subject walks or sits, has an unknown gyro bias (up to a few deg/s) and an
unknown angle: the steady-state gains above learn a bias over ~10 s (the first strides read up
to 15 deg off on the simulator). So from the start, and again after a restart, each segment's
gain is the exact time-varying Kalman gain of the same model, K = P H^T / (H P H^T + R), with
the covariance P propagated from a wide prior (angle 0.5 rad, bias 0.05 rad/s: the simulator's
bias spread; real foot IMUs in ../shared/data read <= 0.012 rad/s before walking):

* R is the chosen measurement's (static, gravity, weighted; none while gated) times
  ``start_r_factor`` (10 for the foot: its quasi-static samples at the first push-offs carry
  the rotating foot's acceleration, and the exact gain would otherwise take that as bias);
* the gravity tilt's R grows by (``start_gravity_rad_s`` / t)^2, t the time since the gravity
  reference (re)started: its mean holds less than a stride at first (the shank's, ~25 deg off
  half a stride in; c = 0.3 rad s for the shank, 0.1 for body and thigh);
* the gravity tilt's bias gain h is the start-up's own h_k (:class:`GravityReference`), not the
  settled lag;
* an innovation beyond ``START_HUBER`` (2) standard deviations is weighed as if it were at 2
  (Huber): one bad sample cannot throw the still wide bias;
* a segment with ``start_static`` False (the body) takes no quasi-static sample: the pelvis
  accelerating forward at the walk's start keeps |a| near g, so its "static" accelerometer tilt
  is off and ramps (the gravity measurement takes those samples);
* stride-periodic bias (``stride_sigma_rad`` > 0: body, thigh, shank): a segment's tilt returns
  to the same value a stride later, so its mean gyro rate over a whole stride is its bias. The
  strides are the foot's foot-flat onsets (its quasi-static test; the foot counts as flat
  before the first sample; an onset within ``STRIDE_LIMITS[0]`` s of the last is not one, a
  stride longer than ``STRIDE_LIMITS[1]`` s is not taken); at each onset the stride's mean rate
  is a measurement of the bias, H = [0, 1], R = (``stride_sigma_rad`` / T)^2, T its duration
  (Huber as above). No accelerometer is in it, so the walk's acceleration does not tilt it;
* once the angle variance is below (``END_ANGLE_RAD``)^2 and the bias variance below
  ``END_FACTOR`` x its steady state, the segment goes over to the scheduled gains (the state is
  kept). A restart (a long gap) puts the angle variance back to the prior's and keeps the bias
  variance (at least its steady level): the bias learnt before the gap is still right.

Measured by ``python benchmarks/first_strides.py`` and ``python benchmarks/gap_settling.py
--gap-s 5`` (docs/filters.md). ``start_prior=None`` gives the scheduled gains from the first
sample (the tests of the steady-state form use it).

Speed and chunking. The accelerometer tilt, | |a| - g | and the gravity reference are computed
for a whole block at once (numpy). The motion windows, the choice of measurement and gain and
the update itself run in time order: the windows' maxima in numpy
(:func:`gaitmon.dsp.kernels.motion_windows`), the rest in one loop
(:func:`gaitmon.dsp.loops.gait_aware_update`: compiled by numba for long records, interpreted
for live blocks and short records, :mod:`gaitmon.dsp.kernels`); the state carried from the
previous block (the windows' last samples, the angle and the bias) is its start, so any
chunking performs the same floating-point operations in the same order and gives bit-for-bit
the same output (and either form of the loop the same, to rounding).

Wrap. The state stays continuous through +-pi; an innovation beyond +-pi (the accelerometer tilt
jumps by a turn when the board's y axis nears the vertical, and the foot's at impacts) is taken
modulo 2 pi, which is paper 000's wrap(z - theta-).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from gaitmon.dsp import kernels
from gaitmon.dsp.angles import TWO_PI
from gaitmon.dsp.channel_table import SEGMENTS, STANDARD_GRAVITY_MS2
from gaitmon.dsp.gravity_reference import GravityReference
from gaitmon.dsp.segment_tuning import (
    SEGMENT_TUNING,
    SegmentTuning,
    measurement_variance,
    tuning_for,
)

# the tuning and the gravity measurement live beside this module, which describes them
__all__ = [
    "END_ANGLE_RAD",
    "END_FACTOR",
    "SEGMENT_TUNING",
    "START_HUBER",
    "START_PRIOR",
    "STRIDE_LIMITS",
    "GaitAwareKalman",
    "GravityReference",
    "SegmentTuning",
    "gravity_gain",
    "measurement_variance",
    "prior_covariance",
    "steady_state_gain",
    "tuning_for",
]

_LOG_R_MIN, _LOG_R_MAX, _LOG_R_STEP = -9.0, 6.0, 0.05
# The start-up's prior standard deviations: the angle (rad; the first measurement sets it) and
# the gyro bias (rad/s; MEMS gyros are off by up to a few deg/s before a Zero), and the factor
# over the steady-state bias variance at which the scheduled gains take over (module doc).
START_PRIOR = (0.5, 0.05)
END_FACTOR = 2.0
END_ANGLE_RAD = float(np.radians(1.0))
START_HUBER = 2.0
# the stride-periodic bias (module doc): the shortest and longest stride (s) between foot-flat
# onsets taken
STRIDE_LIMITS = np.array([0.6, 2.5])


def prior_covariance(
    dt_s: float, q_angle: float, q_bias: float, r: np.ndarray, h_bias: float = 0.0
) -> np.ndarray:
    """(M, 2, 2) steady prior covariances of the paper's model for measurement variances r (M,).

    The measurement is z = theta + h_bias b (H = [1, h_bias]; the paper's h_bias = 0).
    The discrete Riccati equation P = F P (I + G P)^-1 F^T + Q, G = H^T H / r, solved for all r
    at once by the structured doubling algorithm (Chu, Fan, Lin 2005; quadratic convergence),
    which scipy's one-at-a-time ``solve_discrete_are`` agrees with (tests).
    """
    r = np.asarray(r, dtype=np.float64)
    m = len(r)
    eye = np.broadcast_to(np.eye(2), (m, 2, 2))
    a = np.broadcast_to(np.array([[1.0, 0.0], [-dt_s, 1.0]]), (m, 2, 2)).copy()  # F^T
    g = np.zeros((m, 2, 2))
    g[:, 0, 0] = 1.0 / r
    g[:, 0, 1] = g[:, 1, 0] = h_bias / r
    g[:, 1, 1] = h_bias * h_bias / r
    h = np.broadcast_to(np.diag([q_angle, q_bias]), (m, 2, 2)).copy()
    for _ in range(200):
        w_inv = np.linalg.inv(eye + g @ h)
        at = np.swapaxes(a, 1, 2)
        h_new = h + at @ h @ w_inv @ a
        g = g + a @ w_inv @ g @ at
        a = a @ w_inv @ a
        done = np.allclose(h_new, h, rtol=1e-15, atol=0.0)
        h = h_new
        if done:
            break
    return 0.5 * (h + np.swapaxes(h, 1, 2))


@lru_cache(maxsize=64)
def _gain_table(dt_s: float, q_angle: float, q_bias: float) -> tuple[np.ndarray, np.ndarray]:
    """(log10 R knots, (M, 2) steady-state gains [K0, K1]) of the paper's model."""
    log_r = np.arange(_LOG_R_MIN, _LOG_R_MAX + _LOG_R_STEP / 2, _LOG_R_STEP)
    r = 10.0**log_r
    p = prior_covariance(dt_s, q_angle, q_bias, r)
    gains = p[:, :, 0] / (p[:, 0, 0] + r)[:, None]
    return log_r, gains


def steady_state_gain(
    r: np.ndarray | float, dt_s: float, q_angle: float, q_bias: float
) -> np.ndarray:
    """(..., 2) scheduled gains [K0, K1] for measurement variances r (inf -> [0, 0])."""
    log_r, gains = _gain_table(float(dt_s), float(q_angle), float(q_bias))
    r = np.asarray(r, dtype=np.float64)
    finite = np.isfinite(r)
    lr = np.log10(np.where(finite, r, 1.0))
    out = np.empty((*r.shape, 2))
    for j in range(2):
        out[..., j] = np.where(finite, np.interp(lr, log_r, gains[:, j]), 0.0)
    return out


def gravity_gain(
    r: float, dt_s: float, q_angle: float, q_bias: float, h_bias: float
) -> np.ndarray:
    """[K0, K1], the steady-state gain for a measurement z = theta + h_bias b of variance r."""
    return np.array(_gravity_gain(float(r), float(dt_s), float(q_angle), float(q_bias),
                                  float(h_bias)))  # fmt: skip


@lru_cache(maxsize=64)
def _gravity_gain(
    r: float, dt_s: float, q_angle: float, q_bias: float, h_bias: float
) -> tuple[float, float]:
    # (kept, as the gain table: a filter of the same tuning made again, the next record or
    # the next connect, does not solve its Riccati equations again)
    p = prior_covariance(dt_s, q_angle, q_bias, np.array([r]), h_bias)[0]
    ph = p @ np.array([1.0, h_bias])
    k = ph / (ph[0] + h_bias * ph[1] + r)
    return float(k[0]), float(k[1])


@lru_cache(maxsize=64)
def _steady_bias_var(dt_s: float, q_angle: float, q_bias: float, r: float, h_bias: float) -> float:
    """The steady prior's bias variance for a measurement of variance r (kept, as above)."""
    return float(prior_covariance(dt_s, q_angle, q_bias, np.array([r]), h_bias)[0, 1, 1])



class GaitAwareKalman:
    """The gait-aware causal tilt filter for several segments at once (see the module doc).

    ``process(acc_x_ms2, acc_z_ms2, gyro_rad_s)`` takes (N,) or (N, S) raw accelerometer axes
    and the bias-corrected gyro rate, one column per entry of ``segments``, and returns the tilt
    (rad, continuous: not wrapped). Stateful; any chunking gives bit-for-bit the same output.
    """

    def __init__(
        self,
        fs_hz: float = 100.0,
        segments: tuple[str, ...] = SEGMENTS,
        tuning: dict[str, SegmentTuning] | None = None,
        start_prior: tuple[float, float] | None = START_PRIOR,
    ) -> None:
        if not (np.isfinite(fs_hz) and fs_hz > 0):
            raise ValueError(f"fs_hz must be a positive number, got {fs_hz}")
        self.fs_hz = float(fs_hz)
        self.dt_s = 1.0 / self.fs_hz
        self.segments = tuple(segments)
        table = tuning or SEGMENT_TUNING
        self.tunings = tuple(table[s] if s in table else tuning_for(s) for s in self.segments)
        tuns = self.tunings
        dt = self.dt_s
        # segments whose gravity low-pass has one cut-off share one gravity reference (one
        # call for them all: its columns do not depend on each other, bit for bit)
        groups: dict[float, list[int]] = {}
        for j, t in enumerate(tuns):
            if t.live_gravity_hz is not None:
                groups.setdefault(t.live_gravity_hz, []).append(j)
        self._gravity = [
            (GravityReference(hz, self.fs_hz, len(cols)), np.array(cols, dtype=np.intp))
            for hz, cols in groups.items()
        ]
        lag = np.zeros(len(tuns))
        for grav, cols in self._gravity:
            lag[cols] = grav.lag_s
        # per segment, what the update reads (gaitmon.dsp.loops.gait_aware_update)
        # while moving: the gravity tilt, or nothing (the foot's gate), or else the
        # accelerometer tilt weighted by the motion
        self._gravity_on = np.array([t.live_gravity_hz is not None for t in tuns], dtype=bool)
        self._gated = np.array([t.live_gravity_hz is None and t.r_moving is None for t in tuns],
                               dtype=bool)  # fmt: skip
        self._n_win = np.array([t.window_samples(self.fs_hz) for t in tuns], dtype=np.int64)
        self._win_groups = kernels.window_groups(self._n_win)
        self._lag = lag
        self._per_segment = {
            name: np.array([float(getattr(t, name) or 0.0) for t in tuns])
            for name in ("static_acc_ms2", "static_rate_rad_s", "r_static", "r_moving",
                         "acc_scale_ms2", "moving_rate_scale_rad_s")
        }  # fmt: skip
        self._k_static = np.array([steady_state_gain(t.r_static, dt, t.q_angle, t.q_bias)
                                   for t in tuns]).reshape(len(tuns), 2)  # fmt: skip
        self._k_grav = np.array([
            gravity_gain(t.r_live_gravity, dt, t.q_angle, t.q_bias, lag[j])
            if t.live_gravity_hz is not None else np.zeros(2)
            for j, t in enumerate(tuns)
        ]).reshape(len(tuns), 2)  # fmt: skip
        # the out-of-plane test (0 = none): its threshold on the low-passed |a|, the low-pass's
        # coefficient and the angle gain
        self._plane_thr = np.array([(t.plane_fraction or 0.0) * STANDARD_GRAVITY_MS2 for t in tuns])
        self._plane_alpha = np.array([-np.expm1(-TWO_PI * t.plane_cutoff_hz * dt) for t in tuns])
        self._k_plane = np.array([float(steady_state_gain(t.r_out_of_plane, dt, t.q_angle,
                                                          t.q_bias)[0]) for t in tuns])  # fmt: skip
        self._r_plane = np.array([t.r_out_of_plane for t in tuns])
        self._log_r = _gain_table(dt, tuns[0].q_angle, tuns[0].q_bias)[0] if tuns else np.zeros(2)
        # the start-up (module doc): the prior (angle, bias) standard deviations, Q and the
        # gravity R per segment, and the bias variance at which the scheduled gains take over
        self.start_prior = start_prior
        self._q = np.array([[t.q_angle, t.q_bias] for t in tuns]).reshape(len(tuns), 2)
        self._r_grav = np.array([t.r_live_gravity for t in tuns])
        self._r_factor = np.array([t.start_r_factor for t in tuns])
        self._start_c = np.array([t.start_gravity_rad_s for t in tuns])
        self._start_static = np.array([t.start_static for t in tuns], dtype=bool)
        self._stride_r = np.array([t.stride_sigma_rad**2 for t in tuns])
        # whose foot-flat onsets mark the strides (none without a foot column)
        self._stride_foot = (
            self.segments.index("foot") if "foot" in self.segments and self._stride_r.any() else -1
        )
        self._p_end = np.array([
            (END_ANGLE_RAD**2, END_FACTOR * _steady_bias_var(
                dt, float(t.q_angle), float(t.q_bias),
                float(t.start_r_factor
                      * np.array([t.r_live_gravity if t.live_gravity_hz is not None
                                  else t.r_static])[0]),
                float(lag[j]),
            ))
            for j, t in enumerate(tuns)
        ]).reshape(len(tuns), 2)  # fmt: skip
        self._gains = np.ascontiguousarray(
            np.stack([_gain_table(dt, t.q_angle, t.q_bias)[1] for t in tuns], axis=1)
            if tuns else np.zeros((2, 0, 2))
        )  # fmt: skip
        self.reset()

    def reset(self) -> None:
        s = len(self.segments)
        self._bias: np.ndarray | None = None
        # the covariance (P00, P01, P11) of the exact start-up, and where it is in force
        self._cov = np.zeros((s, 3))
        self._exact = np.zeros(s, dtype=bool)
        if self.start_prior is not None:
            self._cov[:, 0] = self.start_prior[0] ** 2
            self._cov[:, 2] = self.start_prior[1] ** 2
            self._exact[:] = True
        self._restart()

    def restart(self) -> None:
        """Start the angle again from the next measurement, keeping the learnt gyro bias (after
        a link outage the old angle and motion windows are stale; the bias is not).

        With the start-up prior (``start_prior``) the exact gain takes the first measurements
        after the gap, from the prior's angle variance and the bias variance the filter had
        (at least its steady state's): a gap of 5 s adds q_bias x 500 = 5e-6 (rad/s)^2 to it,
        less than that steady level, so the gap's length is not needed (the offline first pass,
        which knows only where the restarts are, stays bit-identical to the live filter)."""
        if self.start_prior is not None:
            self._cov[:, 2] = np.maximum(self._cov[:, 2], self._p_end[:, 1] / END_FACTOR)
            self._cov[:, 0] = self.start_prior[0] ** 2
            self._cov[:, 1] = 0.0
            self._exact[:] = True
        self._restart()

    def _restart(self) -> None:
        # the motion windows' last samples (dev, |w|): none yet
        self._tail = np.full((max(1, int(self._n_win.max(initial=1))) - 1, 2,
                              len(self.segments)), -np.inf)  # fmt: skip
        for grav, _ in self._gravity:
            grav.reset()
        self._theta: np.ndarray | None = None
        # the stride-periodic bias: the gyro integrals since the last foot-flat onset, and
        # (the time since it, -1 = none yet; whether the foot was flat at the last sample: taken
        # as flat at the start, so a subject standing from the first sample gives no onset)
        self._stride_int = np.zeros(len(self.segments))
        self._stride_state = np.array([-1.0, 1.0])
        # the out-of-plane test's low-passed |a| (module doc, "Out of plane"): 1 g again
        self._plane_lp = np.full(len(self.segments), STANDARD_GRAVITY_MS2)

    @property
    def bias_rad_s(self) -> np.ndarray | None:
        return None if self._bias is None else self._bias.copy()

    def shift_bias(self, delta_rad_s: np.ndarray | float) -> None:
        """Add ``delta`` to the bias state (the gyro input got a new fixed offset)."""
        delta = np.broadcast_to(np.asarray(delta_rad_s, dtype=np.float64), (len(self.segments),))
        if self._bias is not None:
            self._bias = self._bias + delta
        for grav, cols in self._gravity:
            grav.offset_rad_s = grav.offset_rad_s - delta[cols]
        # the stride's gyro integral so far, as if its samples had had the new offset too (the
        # input moves by ``delta`` from here on): its mean rate stays the bias's measurement
        if self._stride_state[0] > 0.0:
            self._stride_int = self._stride_int + delta * self._stride_state[0]

    def _inputs(self, ax: np.ndarray, az: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, ...]:
        """The update's per-sample inputs (N, S) in numpy: the gravity tilt, its bias gain
        and R, |a| and the motion windows (dev, rate)."""
        n, s = ax.shape
        mag = ax * ax
        mag += az * az
        np.sqrt(mag, out=mag)  # (|a|: sqrt(ax^2 + az^2), as the compiled loop)
        dev = np.abs(mag - STANDARD_GRAVITY_MS2)
        z_grav = np.zeros((n, s))
        h_grav = np.zeros((n, s))
        r_grav = np.broadcast_to(self._r_grav, (n, s)).copy()
        for grav, cols in self._gravity:
            h_grav[:, cols] = grav.bias_gain(grav.count, n)[:, None]
            age_s = (grav.count + np.arange(1, n + 1)) * self.dt_s
            r_grav[:, cols] += (self._start_c[cols][None, :] / age_s[:, None]) ** 2
            z_grav[:, cols] = grav.process(ax[:, cols], az[:, cols], w[:, cols])
        win_d, win_r = kernels.motion_windows(self._tail, dev, np.abs(w), self._win_groups)
        return z_grav, h_grav, r_grav, mag, win_d, win_r

    def _inputs_compiled(
        self, module: Any, ax: np.ndarray, az: np.ndarray, w: np.ndarray
    ) -> tuple[np.ndarray, ...]:
        """:meth:`_inputs` by numba's compiled loops (gaitmon.dsp.loops.gravity_average and
        gait_aware_inputs: one pass each, no temporaries); the same numbers, to rounding."""
        n, s = ax.shape
        covered = sum(len(cols) for _, cols in self._gravity) == s
        z_grav = np.empty((n, s)) if covered else np.zeros((n, s))
        h_grav = np.empty((n, s)) if covered else np.zeros((n, s))
        r_grav = np.empty((n, s))
        if not covered:
            r_grav[...] = self._r_grav
        for grav, cols in self._gravity:
            if len(cols) == s:  # every column (the default tunings): no copies
                z_grav = grav.process_compiled(module, ax, az, w, cols, h_grav, r_grav,
                                               self._r_grav, self._start_c)  # fmt: skip
                continue
            z_grav[:, cols] = grav.process_compiled(module, ax[:, cols], az[:, cols], w[:, cols],
                                                    cols, h_grav, r_grav, self._r_grav,
                                                    self._start_c)  # fmt: skip
        mag, win_d, win_r = np.empty((n, s)), np.empty((n, s)), np.empty((n, s))
        module.gait_aware_inputs(ax, az, w, self._n_win, STANDARD_GRAVITY_MS2, self._tail, mag,
                                 win_d, win_r)  # fmt: skip
        return z_grav, h_grav, r_grav, mag, win_d, win_r

    def process(
        self, acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray
    ) -> np.ndarray:
        ax = np.asarray(acc_x_ms2, dtype=np.float64)
        was_1d = ax.ndim == 1
        ax = ax.reshape(ax.shape[0], -1 if ax.size else len(self.segments))
        az = np.asarray(acc_z_ms2, dtype=np.float64).reshape(ax.shape)
        w = np.asarray(gyro_rad_s, dtype=np.float64).reshape(ax.shape)
        n, s = ax.shape
        if s != len(self.segments):
            raise ValueError(f"expected {len(self.segments)} segment columns, got {s}")
        out = np.empty((n, s))
        if n == 0:
            return out[:, 0] if was_1d else out
        # (the pipeline's columns come column-major: row-major copies, so that every compiled
        # loop sees one layout, the one the cache holds)
        ax, az, w = np.ascontiguousarray(ax), np.ascontiguousarray(az), np.ascontiguousarray(w)
        z_acc = np.arctan2(az, ax)
        module = kernels.compiled_for(n, count=False)
        if module is not None and all(kernels.plain(a) for a in (ax, az, w)):
            z_grav, h_grav, r_grav, mag, win_d, win_r = self._inputs_compiled(module, ax, az, w)
        else:
            z_grav, h_grav, r_grav, mag, win_d, win_r = self._inputs(ax, az, w)
        start = self._theta is None
        theta = np.zeros(s) if self._theta is None else self._theta.copy()
        bias = np.zeros(s) if self._bias is None else self._bias.copy()  # a restart keeps it
        ps = self._per_segment
        kernels.gait_aware_update(
            win_d, win_r, w, z_acc, z_grav, self._gravity_on, self._gated,
            ps["static_acc_ms2"], ps["static_rate_rad_s"], self._k_static, self._k_grav,
            ps["r_static"], ps["r_moving"], ps["acc_scale_ms2"],
            ps["moving_rate_scale_rad_s"], self._log_r, self._gains, self.dt_s, start, theta,
            bias, out, mag, self._plane_thr, self._plane_alpha, self._k_plane, self._plane_lp,
            self._r_plane, h_grav, self._cov, self._exact, self._q, r_grav, self._p_end,
            self._r_factor, START_HUBER,
            self._start_static, self._stride_foot, self._stride_r, self._stride_int,
            self._stride_state, STRIDE_LIMITS,
        )  # fmt: skip
        self._theta, self._bias = theta, bias
        return out[:, 0] if was_1d else out
