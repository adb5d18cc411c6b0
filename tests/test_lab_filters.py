"""The companion papers' filters against independent computations: closed forms, hand-expanded
first steps, plain reference loops written here, scipy, and the papers' own published numbers."""

import math

import numpy as np
import pytest
from scipy import integrate, linalg

from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.complementary import AdaptiveCutoff, ComplementaryFilter, complementary_alpha
from gaitmon.dsp.exponential import ExponentialFilter, TrapezoidIntegrator, exponential_alpha
from gaitmon.dsp.kalman_models import (
    LinearKalman,
    accel_tilt_angles,
    akurasi_pct,
    angle_from_rate_kalman,
    constant_rate_kalman,
    constant_rate_q,
    enu_to_ned,
    galat_pct,
    gravity_compensate,
    observer_poles,
    position_from_accel_kalman,
    pva_kalman,
    pva_matrices,
    stability_verdict,
    steady_state_gain,
)
from gaitmon.dsp.lab_filters import TILT_FILTERS, TiltFilter, make_tilt_filter

CHUNKS = [0, 1, 2, 5, 17, 64, 333, 1000]


def chunked(fn, arrays, seed=0):
    """Run fn over random chunks (including empty and single-sample ones) and concatenate."""
    rng = np.random.default_rng(seed)
    n = arrays[0].shape[0]
    outs, i = [], 0
    while i < n:
        c = int(rng.choice(CHUNKS))
        outs.append(fn(*(a[i : i + c] for a in arrays)))
        i += c
    return np.concatenate(outs)


# ------------------------------------------------------------------------------ exponential
def test_exponential_alpha_is_eq20():
    assert exponential_alpha(5.0, 100.0) == pytest.approx(1.0 / (1.0 + 2.0 * math.pi * 0.05))
    with pytest.raises(ValueError, match="cut-off"):
        exponential_alpha(0.0, 100.0)


def test_exponential_order1_step_response_is_closed_form():
    alpha = 0.8
    y = ExponentialFilter(alpha).process(np.ones(50))
    n = np.arange(50)
    np.testing.assert_allclose(y, 1.0 - alpha ** (n + 1), rtol=1e-13)


def test_exponential_orderM_is_M_passes_of_eq17():
    rng = np.random.default_rng(1)
    x = rng.normal(size=300)
    alpha, order = 0.7, 3
    ref = x.copy()
    for _ in range(order):  # eq. 17 by hand, y(-1) = 0
        out, prev = [], 0.0
        for v in ref:
            prev = (1.0 - alpha) * v + alpha * prev
            out.append(prev)
        ref = np.array(out)
    np.testing.assert_allclose(ExponentialFilter(alpha, order=order).process(x), ref, atol=1e-13)


def test_exponential_first_initial_holds_a_constant_and_dc_gain_is_one():
    y = ExponentialFilter(cutoff_hz=1.0, fs_hz=100.0, order=4, initial="first").process(
        np.full(100, 3.5)
    )
    np.testing.assert_allclose(y, 3.5, rtol=1e-13)


def test_exponential_chunking_and_reset():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(2000, 3))
    f = ExponentialFilter(0.9, order=2, initial="first")
    whole = f.process(x)
    f.reset()
    np.testing.assert_allclose(chunked(f.process, [x]), whole, rtol=0, atol=1e-12)


def test_trapezoid_matches_scipy_and_is_chunk_invariant():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(1500, 2))
    ref = integrate.cumulative_trapezoid(x, dx=0.01, axis=0, initial=0.0) + np.array([1.0, -2.0])
    ti = TrapezoidIntegrator(0.01)
    np.testing.assert_allclose(ti.process(x, initial=[1.0, -2.0]), ref, atol=1e-12)
    ti.reset()
    rng2 = np.random.default_rng(4)
    outs, i, first = [], 0, True
    while i < len(x):
        c = int(rng2.choice(CHUNKS))
        if c and first:
            outs.append(ti.process(x[i : i + c], initial=[1.0, -2.0]))
            first = False
        else:
            outs.append(ti.process(x[i : i + c]))
        i += c
    np.testing.assert_allclose(np.concatenate(outs), ref, atol=1e-12)


# ------------------------------------------------------------------------------ complementary
def complementary_reference(z, w, dt, alpha):
    """Paper 003 eq. 2-1 with the wrapped error term, one plain Python step at a time."""
    theta = z[0]
    out = []
    for zk, wk in zip(z, w, strict=True):
        pred = theta + wk * dt
        err = (zk - pred + math.pi) % (2 * math.pi) - math.pi
        if err == -math.pi:
            err = math.pi
        theta = pred + (1 - alpha) * err
        out.append(theta)
    return np.array(out)


def test_complementary_alpha_is_eq22():
    tau = 1.0 / (2.0 * math.pi * 3.0)
    assert complementary_alpha(3.0, 0.005) == pytest.approx(tau / (tau + 0.005))


def test_complementary_first_steps_by_hand():
    dt, fc = 0.01, 2.0
    a = complementary_alpha(fc, dt)
    z = np.array([0.10, 0.12, 0.05])
    w = np.array([1.0, -0.5, 0.2])
    y = ComplementaryFilter(dt, fc).process(z, w)
    t0 = a * (0.10 + 1.0 * dt) + (1 - a) * 0.10  # theta(-1) = z0
    t1 = a * (t0 - 0.5 * dt) + (1 - a) * 0.12
    t2 = a * (t1 + 0.2 * dt) + (1 - a) * 0.05
    np.testing.assert_allclose(y, [t0, t1, t2], rtol=1e-14)


def test_complementary_wraps_the_error_term_across_the_atan2_jump():
    dt = 0.01
    a = complementary_alpha(3.0, dt)
    # true angle rises through pi; the accelerometer tilt jumps to -pi, the estimate must not
    truth = np.linspace(3.0, 3.4, 200)
    z = wrap_angle(truth)
    w = np.gradient(truth, dt)
    y = ComplementaryFilter(dt, 3.0).process(z, w)
    assert np.max(np.abs(wrap_angle(y - truth))) < 0.01
    np.testing.assert_allclose(y, complementary_reference(z, w, dt, a), atol=1e-12)


def test_complementary_equals_reference_loop_on_hostile_data_in_any_chunking():
    rng = np.random.default_rng(5)
    n = 3000
    # large noise and a full-circle uniform stretch force many real wraps
    z = wrap_angle(np.cumsum(rng.normal(0, 0.3, n)))
    z[1000:1300] = rng.uniform(-np.pi, np.pi, 300)
    w = rng.normal(0, 2.0, n)
    dt = 0.005
    ref = complementary_reference(z, w, dt, complementary_alpha(3.0, dt))
    f = ComplementaryFilter(dt, 3.0)
    np.testing.assert_allclose(f.process(z, w), ref, atol=1e-11)
    f.reset()
    np.testing.assert_allclose(chunked(f.process, [z, w], seed=6), ref, atol=1e-11)


def test_complementary_noise_reduction_at_rest_matches_the_first_order_closed_form():
    """Accelerometer white noise, perfect still gyro: variance ratio (1 - a)/(1 + a)."""
    dt, fc = 0.005, 3.0
    a = complementary_alpha(fc, dt)
    rng = np.random.default_rng(7)
    z = 0.2 + rng.normal(0, 0.01, 100_000)
    y = ComplementaryFilter(dt, fc).process(z, np.zeros_like(z))
    ratio = np.std(z[1000:]) / np.std(y[1000:])
    assert ratio == pytest.approx(math.sqrt((1 + a) / (1 - a)), rel=0.03)


def test_adaptive_cutoff_follows_the_motion_frequency():
    dt = 0.01
    t = np.arange(0, 30, dt)
    f_true = np.where(t < 15, 1.0, 2.5)
    phase = 2 * np.pi * np.cumsum(f_true) * dt
    rate = 1.5 * np.cos(phase)
    tilt = np.cumsum(rate) * dt
    cfg = AdaptiveCutoff(window_s=4.0, update_s=2.0)
    f = ComplementaryFilter(dt, cutoff_hz=3.0, adaptive=cfg)
    f.process(tilt, rate)
    hist = dict(f.cutoff_history)
    assert hist[0][0] == 3.0
    assert all(k % 200 == 0 for k in hist)  # refreshed on multiples of update_s only
    fc_at = {k: v[0] for k, v in hist.items()}

    def fc_in_force(sample):
        return fc_at[max(k for k in fc_at if k <= sample)]

    assert fc_in_force(1400) == pytest.approx(1.0, abs=0.1)  # window 10..14 s: 1 Hz motion
    assert fc_in_force(2900) == pytest.approx(2.5, abs=0.1)  # window 25..29 s: 2.5 Hz motion


def test_adaptive_cutoff_keeps_its_value_at_rest_and_is_chunk_invariant():
    dt = 0.01
    rng = np.random.default_rng(8)
    n = 3000
    rate = np.where(np.arange(n) < 1500, 0.8 * np.sin(2 * np.pi * 1.5 * np.arange(n) * dt), 0.0)
    rate = rate + rng.normal(0, 0.002, n)
    tilt = np.cumsum(rate) * dt + rng.normal(0, 0.01, n)
    f = ComplementaryFilter(dt, 3.0, adaptive=AdaptiveCutoff())
    whole = f.process(tilt, rate)
    hist = f.cutoff_history
    fc_at = {k: v[0] for k, v in hist}
    assert fc_at[1400] == pytest.approx(1.5, abs=0.1)  # window 10..14 s: all motion
    # windows that end after 19 s are all rest (RMS < 0.05 rad/s): the cut-off stays put
    assert max(fc_at) <= 1800
    assert f.cutoff_hz[0] == fc_at[max(fc_at)]
    f.reset()
    np.testing.assert_allclose(chunked(f.process, [tilt, rate], seed=9), whole, atol=1e-12)
    assert [k for k, _ in f.cutoff_history] == [k for k, _ in hist]


# ------------------------------------------------------------------------------ Kalman models
def test_paper004_angle_kalman_first_steps_by_hand():
    dt, su, sy = 0.1, 0.5, 0.2
    q, r = (dt * su) ** 2, sy**2
    kf = angle_from_rate_kalman(dt, su, sy, x0=0.3, p0=0.04)
    y = np.array([0.35, 0.41, 0.38])
    u = np.array([1.0, -0.2, 0.5])
    out = kf.process(y, u)[:, 0]
    # x0 / p0 are the estimate one sample before the first; the input before it is zero
    x, p = 0.3, 0.04
    expect = []
    u_prev = 0.0
    for yk, uk in zip(y, u, strict=True):
        xm, pm = x + dt * u_prev, p + q
        k = pm / (pm + r)
        x, p = xm + k * (yk - xm), (1 - k) * pm
        expect.append(x)
        u_prev = uk
    np.testing.assert_allclose(out, expect, rtol=1e-14)
    assert kf.covariance_at(2)[0, 0] == pytest.approx(p, rel=1e-14)


def test_paper004_position_kalman_matches_a_plain_numpy_filter_and_chunks():
    dt = 0.01
    rng = np.random.default_rng(10)
    n = 800
    u = rng.normal(size=n)
    y = rng.normal(size=n)
    kf = position_from_accel_kalman(dt, 0.7, 0.3, x0=(0.1, -0.2), P0=np.eye(2) * 0.01)
    got = kf.process(y, u)
    a = np.array([[1, dt], [0, 1]])
    b = np.array([dt * dt / 2, dt])
    q = 0.7**2 * np.outer(b, b)
    x, p, up = np.array([0.1, -0.2]), np.eye(2) * 0.01, 0.0
    ref = []
    for k in range(n):
        x = a @ x + b * up
        p = a @ p @ a.T + q
        gain = p[:, 0] / (p[0, 0] + 0.09)
        x = x + gain * (y[k] - x[0])
        p = p - np.outer(gain, p[0, :])
        ref.append(x.copy())
        up = u[k]
    np.testing.assert_allclose(got, ref, atol=1e-12)
    kf.reset()
    np.testing.assert_allclose(chunked(kf.process, [y, u], seed=11), got, atol=0)


def test_paper001_six_state_equals_three_independent_two_state_filters():
    dt = 1 / 15
    rng = np.random.default_rng(12)
    n = 400
    meas = rng.normal(size=(n, 3))
    rate = rng.normal(size=(n, 3))
    r = np.array([0.04, 0.09, 0.16])
    six = constant_rate_kalman(dt, r, q=2.0).process(meas, rate)
    assert six.shape == (n, 6)
    for ax in range(3):
        two = constant_rate_kalman(dt, r[ax], q=2.0, n_axes=1).process(
            meas[:, ax : ax + 1], rate[:, ax : ax + 1]
        )
        np.testing.assert_allclose(six[:, 2 * ax : 2 * ax + 2], two, atol=1e-13)


def test_paper001_model_matrices_and_two_state_first_step_by_hand():
    dt = 0.05
    kf = constant_rate_kalman(dt, [0.1, 0.2, 0.3], q=1.0)
    a_i = np.array([[1, dt], [0, 0]])
    assert np.array_equal(kf.A[2:4, 2:4], a_i)
    assert np.array_equal(kf.B[:, 1], [0, 0, 0, 1, 0, 0])
    np.testing.assert_allclose(kf.Q[4:6, 4:6], [[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    assert np.array_equal(kf.H, [[1, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], [0, 0, 0, 0, 1, 0]])
    np.testing.assert_array_equal(np.diag(kf.R), [0.1, 0.2, 0.3])
    # one axis, first step from x = 0, P = 0: P- = Q; x- = [0, u0]
    one = constant_rate_kalman(dt, 0.1, q=1.0, n_axes=1)
    z0, u0 = 0.2, 1.5
    out = one.process(np.array([[z0]]), np.array([[u0]]))[0]
    q = constant_rate_q(dt)
    k = q[:, 0] / (q[0, 0] + 0.1)
    np.testing.assert_allclose(out, np.array([0.0, u0]) + k * (z0 - 0.0), rtol=1e-14)


def test_enu_to_ned_swaps_x_y_and_negates_z():
    v = np.array([[1.0, 2.0, 3.0]])
    np.testing.assert_array_equal(enu_to_ned(v), [[2.0, 1.0, -3.0]])
    np.testing.assert_array_equal(enu_to_ned(enu_to_ned(v)), v)


def test_paper001_accuracy_metric_reproduces_the_papers_table():
    # Table 1 from the angles printed in the text (T = orientation reference, P = estimate).
    # The paper truncates rather than rounds in places (2e-3); yaw angles are printed to 2
    # decimals, which alone moves galat by up to 0.006 % (1e-2)
    cases = [  # (T, P before, P after, galat before, galat after, tolerance)
        (88.207, 97.337, 88.522, 10.351, 0.357, 2e-3),  # roll
        (-89.292, -86.584, -87.995, 3.032, 1.452, 2e-3),  # pitch
        (-161.71, -168.89, -162.69, 4.444, 0.605, 1e-2),  # yaw: raw angles, as the paper did
    ]
    for t, before, after, g_before, g_after, tol in cases:
        assert galat_pct(t, before) == pytest.approx(g_before, abs=tol)
        assert galat_pct(t, after) == pytest.approx(g_after, abs=tol)
        assert akurasi_pct(t, after) == pytest.approx(100 - g_after, abs=tol)
    # with the start angles subtracted (the rotation the text reports) yaw reads differently
    assert galat_pct(-86.263, -91.595) == pytest.approx(6.181, abs=2e-3)
    assert np.isnan(galat_pct(0.0, 1.0))  # undefined for a zero reference
    assert np.isnan(akurasi_pct(1e-12, 0.0))
    assert akurasi_pct(10.0, 25.0) == pytest.approx(50.0)  # |100 - 150|: the metric's quirk


def test_paper002_published_gain_gives_the_published_poles():
    ts = 1e-3
    a, h, _ = pva_matrices(ts, 1.0)
    k = np.array([0.68, 469.69, 194152.84])
    poles = observer_poles(a, k, h, form="paper")
    # independent: det(zI - (A - K H)) with w = z - 1 is
    # w^3 + k1 w^2 + (T k2 + T^2 k3 / 2) w + T^2 k3
    w = np.roots([1.0, k[0], ts * k[1] + ts**2 * k[2] / 2, ts**2 * k[2]])
    np.testing.assert_allclose(np.sort_complex(poles), np.sort_complex(1 + w), atol=1e-12)
    cplx = poles[np.abs(poles.imag) > 1e-9]
    real = poles[np.abs(poles.imag) <= 1e-9].real
    assert cplx.real == pytest.approx([0.871, 0.871], abs=1e-3)
    assert sorted(np.abs(cplx.imag)) == pytest.approx([0.664, 0.664], abs=1e-3)
    assert real == pytest.approx([0.576], abs=1e-3)
    # ... but 0.871 +- 0.664i lies OUTSIDE the unit circle (|z| = 1.096), unlike the paper says
    assert np.abs(cplx[0]) == pytest.approx(math.hypot(0.8719, 0.6647), abs=1e-3)
    assert stability_verdict(poles) == "unstable"
    assert stability_verdict(observer_poles(a, k, h, form="filter")) == "stable"


def test_paper002_steady_state_gain_solves_the_dare_and_equals_the_iterated_riccati():
    ts, r = 1e-3, 0.00005
    for q in (1e-5, 1.0, 1000.0):
        a, h, qm = pva_matrices(ts, q)
        k = steady_state_gain(a, h, qm, [[r]])
        # iterate the Riccati recursion by hand to its fixed point
        p = np.eye(3)
        for _ in range(200_000):
            pm = a @ p @ a.T + qm
            kk = pm @ h.T / (h @ pm @ h.T + r)
            p_new = (np.eye(3) - kk @ h) @ pm
            if np.allclose(p_new, p, rtol=1e-14, atol=0):
                break
            p = p_new
        np.testing.assert_allclose(k, kk, rtol=1e-6)
        # and the filter's own schedule converges to the same gain
        np.testing.assert_allclose(pva_kalman(ts, q, r).steady_state_gain, k, rtol=1e-6)
        # the DARE itself: P = A P A^T - A P H^T (H P H^T + R)^-1 H P A^T + Q
        pm = linalg.solve_discrete_are(a.T, h.T, qm, [[r]])
        resid = a @ pm @ a.T - a @ pm @ h.T @ np.linalg.inv(h @ pm @ h.T + r) @ h @ pm @ a.T + qm
        np.testing.assert_allclose(resid, pm, rtol=1e-8, atol=1e-18)
        assert stability_verdict(observer_poles(a, k, h, form="filter")) == "stable"


def test_paper002_unobservable_model_has_no_steady_state_gain():
    a, h, qm = pva_matrices(1e-3, 1.0, measured="acceleration")
    with pytest.raises(ValueError, match="steady-state"):
        steady_state_gain(a, h, qm, [[5e-5]])


def test_paper002_gravity_compensation():
    rng = np.random.default_rng(13)
    # at rest, any orientation: |A| = 1 g -> nothing left
    v = rng.normal(size=(50, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    np.testing.assert_allclose(gravity_compensate(v), 0.0, atol=1e-12)
    # the closed form A (1 - 1/|A|) x 980 for arbitrary vectors (Az > 0 and < 0)
    w = rng.normal(size=(50, 3)) * 1.5
    norm = np.linalg.norm(w, axis=1, keepdims=True)
    np.testing.assert_allclose(gravity_compensate(w), w * (1 - 1 / norm) * 980.0, atol=1e-9)
    # the angles of eq. 13 for a known vector
    rho, phi, theta = accel_tilt_angles(np.array([0.5, 0.5, math.sqrt(0.5)]))
    assert rho == pytest.approx(math.atan(0.5 / math.sqrt(0.75)))
    assert phi == pytest.approx(math.atan(0.5 / math.sqrt(0.75)))
    assert theta == pytest.approx(math.pi / 4)


def test_linear_kalman_rejects_bad_shapes():
    with pytest.raises(ValueError, match="R must be"):
        LinearKalman(A=np.eye(2), H=[[1, 0]], Q=np.eye(2), R=np.eye(2))
    kf = angle_from_rate_kalman(0.1, 1.0, 1.0)
    with pytest.raises(ValueError, match="input"):
        kf.process(np.zeros(3))


# ------------------------------------------------------------------------------ the registry
@pytest.mark.parametrize("name", list(TILT_FILTERS))
def test_registry_filters_share_the_interface_track_clean_data_and_chunk(name):
    dt = 0.01
    t = np.arange(0, 20, dt)
    truth = np.stack([0.5 * np.sin(2 * np.pi * 0.8 * t + s) for s in range(4)], axis=1)
    rate = np.stack([0.5 * 2 * np.pi * 0.8 * np.cos(2 * np.pi * 0.8 * t + s) for s in range(4)], 1)
    f = make_tilt_filter(name, dt)
    assert isinstance(f, TiltFilter)
    whole = f.process(truth, rate)
    assert whole.shape == truth.shape
    # Euler integration of a clean rate is off by O(rate dt); everything else is better
    assert np.max(np.abs(whole - truth)) < 0.05
    f.reset()
    np.testing.assert_allclose(chunked(f.process, [truth, rate], seed=14), whole, atol=1e-10)
    f.reset()
    one = f.process(truth[:, 2], rate[:, 2])
    assert one.shape == (len(t),)


def test_unknown_registry_name_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown tilt filter"):
        make_tilt_filter("madgwick")
