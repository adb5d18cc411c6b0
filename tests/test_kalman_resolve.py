"""The gait-aware filter's wrap rule: paper 000's wrap(z - theta-), in any chunking.

On the simulated walk the foot's accelerometer tilt jumps by a turn about twice a stride (at the
impacts). The filter's per-sample part is a compiled loop in time order, checked here against
the whole filter written out in Python from its module doc, and the result is bit-for-bit the
same whole, a row at a time and in blocks cut anywhere, on the walk and on a segment held across
+-180 deg.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import gaitmon.dsp.motion_kalman as mk
from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.channels import (
    ACC_X_IDX,
    ACC_Z_IDX,
    GYRO_IDX,
    SEGMENTS,
    STANDARD_GRAVITY_MS2,
    ChannelTable,
)
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate


@pytest.fixture(scope="module")
def walk() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    counts = simulate(6000, GaitModel(GaitConfig(seed=1)), SensorConfig(seed=1)).counts
    phys = ChannelTable().to_physical(counts)  # the pipeline's inputs to the filter
    return phys[:, ACC_X_IDX], phys[:, ACC_Z_IDX], phys[:, GYRO_IDX]


def reference_filter(
    ax: np.ndarray, az: np.ndarray, w: np.ndarray, fs: float = 100.0,
    tuning: dict[str, mk.SegmentTuning] | None = None, start: bool = True,
):  # fmt: skip
    """The gait-aware filter written out in Python from its module doc, one sample at a time:
    the out-of-plane test, the motion window's maxima, the measurement and gain chosen by the
    segment's tuning, the prediction, the innovation wrapped into [-pi, pi), the update; with
    ``start``, the start-up's exact gain (2x2 matrices) from the prior until the bias variance
    reaches its end (out of plane: the angle alone, the bias left alone).
    Returns (tilts, wraps, samples out of plane, stride-periodic bias updates)."""
    from scipy import signal

    dt = 1.0 / fs
    n, s = ax.shape
    out = np.empty((n, s))
    wraps = planes = strides = 0
    f_mat = np.array([[1.0, -dt], [0.0, 1.0]])
    # the stride-periodic bias: the foot's foot-flat onsets (the foot taken as flat before the
    # first sample; none within STRIDE_LIMITS[0] of the last), and at each, the stride's span
    # when it is at most STRIDE_LIMITS[1] (0: none)
    tf = (tuning or {}).get("foot") or mk.tuning_for("foot")
    fc, fw = SEGMENTS.index("foot"), tf.window_samples(fs)
    f_dev = np.abs(np.hypot(ax[:, fc], az[:, fc]) - STANDARD_GRAVITY_MS2)
    flat = np.array([f_dev[max(0, k - fw + 1) : k + 1].max() < tf.static_acc_ms2
                     and np.abs(w[max(0, k - fw + 1) : k + 1, fc]).max() < tf.static_rate_rad_s
                     for k in range(n)])  # fmt: skip
    span = np.zeros(n)
    since = np.zeros(n, dtype=np.int64)  # the previous onset's sample
    last = None
    for k in range(n):
        if flat[k] and not (flat[k - 1] if k else True):
            if last is not None and (k - last) * dt < mk.STRIDE_LIMITS[0]:
                continue
            if last is not None and (k - last) * dt <= mk.STRIDE_LIMITS[1]:
                span[k], since[k] = (k - last) * dt, last
            last = k
    for c, seg in enumerate(SEGMENTS):
        t = (tuning or {}).get(seg) or mk.tuning_for(seg)
        nw = t.window_samples(fs)
        dev = np.abs(np.hypot(ax[:, c], az[:, c]) - STANDARD_GRAVITY_MS2)
        rate = np.abs(w[:, c])
        k_static = mk.steady_state_gain(t.r_static, dt, t.q_angle, t.q_bias)
        lag = 0.0
        if t.live_gravity_hz is not None:
            grav = mk.GravityReference(t.live_gravity_hz, fs, 1)
            z_grav = grav.process(ax[:, c : c + 1], az[:, c : c + 1], w[:, c : c + 1])[:, 0]
            lag = grav.lag_s
            k_grav = mk.gravity_gain(t.r_live_gravity, dt, t.q_angle, t.q_bias, lag)
            # h_k: the ramp's lag behind its mean (the low-pass from rest over its step response)
            bb, aa = signal.butter(2, t.live_gravity_hz, fs=fs)
            ramp = np.arange(n) * dt
            h_k = ramp - signal.lfilter(bb, aa, ramp) / signal.lfilter(bb, aa, np.ones(n))
        # out of plane: the planar |a| low-passed by one pole from 1 g
        alpha = 1.0 - np.exp(-2 * np.pi * t.plane_cutoff_hz * dt)
        lp = STANDARD_GRAVITY_MS2
        k_plane = np.array([mk.steady_state_gain(t.r_out_of_plane, dt, t.q_angle, t.q_bias)[0],
                            0.0])  # fmt: skip
        r_end = t.r_live_gravity if t.live_gravity_hz is not None else t.r_static
        p_end = (
            mk.END_ANGLE_RAD**2,
            mk.END_FACTOR * mk.prior_covariance(
                dt, t.q_angle, t.q_bias, np.array([r_end * t.start_r_factor]), lag
            )[0, 1, 1],
        )
        exact = start
        p_mat = np.diag(np.square(mk.START_PRIOR))
        q_mat = np.diag([t.q_angle, t.q_bias])
        th, b = None, 0.0
        for k in range(n):
            lo = max(0, k - nw + 1)
            md, mr = dev[lo : k + 1].max(), rate[lo : k + 1].max()
            z, h, r_k = float(np.arctan2(az[k, c], ax[k, c])), 0.0, t.r_static
            plane = False
            lp += alpha * (np.hypot(ax[k, c], az[k, c]) - lp)
            if t.plane_fraction is not None and lp < t.plane_fraction * STANDARD_GRAVITY_MS2:
                gain = k_plane
                planes += 1
                plane = True
            elif (
                md < t.static_acc_ms2 and mr < t.static_rate_rad_s and (t.start_static or not exact)
            ):
                gain = k_static
            elif t.live_gravity_hz is not None:
                # its R grows by (c / t)^2 at the start, t the time since the reference started
                r_k = t.r_live_gravity + (t.start_gravity_rad_s / ((k + 1) * dt)) ** 2
                z, h, gain = float(z_grav[k]), float(h_k[k]), k_grav
            elif t.r_moving is None:
                gain, r_k = np.zeros(2), np.inf
            else:
                r_k = float(mk.measurement_variance(np.array(md), np.array(mr), t))
                gain = mk.steady_state_gain(r_k, dt, t.q_angle, t.q_bias)
            if th is None:
                th = float(wrap_angle(z))
            pred = th + (w[k, c] - b) * dt
            e = z - pred - h * b
            if abs(e) > np.pi:
                e = (e + np.pi) % (2 * np.pi) - np.pi
                wraps += 1
            if exact:
                p_mat = f_mat @ p_mat @ f_mat.T + q_mat
                if plane:  # the angle alone: gain (k0, 0), Joseph form
                    k0 = p_mat[0, 0] / (p_mat[0, 0] + t.r_out_of_plane)
                    gain = np.array([k0, 0.0])
                    i_kh = np.array([[1.0 - k0, 0.0], [0.0, 1.0]])
                    p_mat = i_kh @ p_mat @ i_kh.T + np.outer(gain, gain) * t.r_out_of_plane
                elif np.isfinite(r_k):
                    hv = np.array([1.0, h])
                    sv = hv @ p_mat @ hv + r_k * t.start_r_factor
                    sv = max(sv, e * e / mk.START_HUBER**2)  # Huber: at most START_HUBER sigmas
                    gain = p_mat @ hv / sv
                    p_mat = p_mat - np.outer(gain, hv @ p_mat)
                else:
                    gain = np.zeros(2)
                exact = not (p_mat[0, 0] <= p_end[0] and p_mat[1, 1] <= p_end[1])
            th, b = pred + gain[0] * e, b + gain[1] * e
            if span[k] > 0 and exact and t.stride_sigma_rad > 0:
                # a whole stride ended: its mean gyro rate measures the bias (H = [0, 1])
                strides += 1
                eb = w[since[k] + 1 : k + 1, c].sum() * dt / span[k] - b
                sv = p_mat[1, 1] + (t.stride_sigma_rad / span[k]) ** 2
                sv = max(sv, eb * eb / mk.START_HUBER**2)
                gain = p_mat[:, 1] / sv
                th, b = th + gain[0] * eb, b + gain[1] * eb
                p_mat = p_mat - np.outer(gain, p_mat[1])
            out[k, c] = th
    return out, wraps, planes, strides


def test_the_filter_is_its_module_doc_written_out(walk) -> None:
    """The compiled filter against the same filter written out in Python (float rounding
    apart: the gains are interpolated in another order)."""
    ax, az, w = (a[:3000].copy() for a in walk)
    # the foot's board turned out of the sagittal plane for 6 s: its planar |a| drops well below 1 g
    ax[1000:1600, 3] *= 0.6
    az[1000:1600, 3] *= 0.6
    ref, _wraps, planes, _ = reference_filter(ax, az, w)
    assert planes > 200, "the out-of-plane rule was never used (the test would be moot)"
    got = mk.GaitAwareKalman().process(ax, az, w)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
    # out of plane from the first sample: the start-up's angle-only update
    ax2, az2 = ax.copy(), az.copy()
    ax2[:400, 3] *= 0.6
    az2[:400, 3] *= 0.6
    ref, _wraps, planes, _ = reference_filter(ax2, az2, w)
    assert planes > 300
    got = mk.GaitAwareKalman().process(ax2, az2, w)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
    # the foot weighted by its motion while moving (no gravity measurement): its accelerometer
    # tilt jumps by a turn at the impacts, so this path wraps innovations
    table = dict(mk.SEGMENT_TUNING, foot=mk.SegmentTuning(r_moving=1.0))
    ref, wraps, _, _ = reference_filter(ax, az, w, tuning=table)
    assert wraps > 10, "the walk never wrapped an innovation (the test would be moot)"
    got = mk.GaitAwareKalman(tuning=table).process(ax, az, w)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
    # started mid-walk: the start-up takes the stride-periodic bias at the foot-flat onsets
    ref, _, _, strides = reference_filter(*(a[1500:4500] for a in walk))
    assert strides >= 6, "no stride-periodic bias update (the test would be moot)"
    got = mk.GaitAwareKalman().process(*(a[1500:4500] for a in walk))
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
    # without the start-up: the scheduled gains from the first sample
    ref, _, _, _ = reference_filter(ax, az, w, start=False)
    got = mk.GaitAwareKalman(start_prior=None).process(ax, az, w)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)


def test_the_block_solve_is_the_row_at_a_time_result(walk) -> None:
    ax, az, w = walk
    whole = mk.GaitAwareKalman().process(ax, az, w)
    k = mk.GaitAwareKalman()
    rows = np.vstack([k.process(ax[i : i + 1], az[i : i + 1], w[i : i + 1])
                      for i in range(len(ax))])  # fmt: skip
    np.testing.assert_array_equal(whole, rows)
    # started mid-walk (the start-up's stride-periodic bias at the foot-flat onsets), in blocks
    # that cut the strides anywhere
    mid = [a[1500:4500] for a in walk]
    whole = mk.GaitAwareKalman().process(*mid)
    k = mk.GaitAwareKalman()
    cuts = np.r_[0, np.sort(np.random.default_rng(3).choice(np.arange(1, 3000), 60, False)), 3000]
    parts = np.vstack([k.process(*(c[a:b] for c in mid)) for a, b in itertools.pairwise(cuts)])
    np.testing.assert_array_equal(whole, parts)


def test_a_segment_near_the_wrap_with_impacts_is_the_row_at_a_time_result() -> None:
    """Every path of the rule: a segment held near +-180 deg (its accelerometer tilt crosses
    the wrap back and forth while the gyro sees a slow sway), single-sample impacts, and a
    stretch where the accelerometer stays a turn off for a while; in blocks that cut the
    solve's windows anywhere."""
    fs, n = 100.0, 4000
    t = np.arange(n) / fs
    rng = np.random.default_rng(7)
    tilt = np.pi - 0.05 + 0.12 * np.sin(2 * np.pi * 0.7 * t)  # radians, across +-pi
    w = np.gradient(tilt, 1 / fs) + rng.normal(0, 0.01, n)
    g = 9.81
    ax, az = g * np.cos(tilt), g * np.sin(tilt)
    ax, az = ax + rng.normal(0, 0.3, n), az + rng.normal(0, 0.3, n)
    hits = rng.choice(np.arange(50, n - 50), 60, replace=False)
    ax[hits] *= -1.0  # an impact: the accelerometer tilt a half turn off for one sample
    az[hits] *= -1.0
    ax[2000:2040], az[2000:2040] = -ax[2000:2040], -az[2000:2040]  # and for 0.4 s
    cols = [np.tile(a[:, None], (1, 4)) for a in (ax, az, w)]
    whole = mk.GaitAwareKalman(fs).process(*cols)
    k = mk.GaitAwareKalman(fs)
    rows = np.vstack([k.process(*(c[i : i + 1] for c in cols)) for i in range(n)])
    np.testing.assert_array_equal(whole, rows)
    k = mk.GaitAwareKalman(fs)  # and in blocks that split the windows anywhere
    cuts = np.r_[0, np.sort(rng.choice(np.arange(1, n), 40, replace=False)), n]
    parts = np.vstack([k.process(*(c[a:b] for c in cols)) for a, b in itertools.pairwise(cuts)])
    np.testing.assert_array_equal(whole, parts)
