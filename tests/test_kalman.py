"""The paper's tilt Kalman filter against a hand-expanded reference written from SPEC section 4."""

import math

import numpy as np
import pytest

from gaitmon.dsp.kalman import TiltKalman


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def reference(z, w, dt=0.01, qa=0.001, qg=0.003, r=0.3, discrete=False):
    """Scalar transcription of the paper's equations (one segment), P = 0 initially."""
    th, b = z[0], 0.0
    p1 = p2 = p3 = p4 = 0.0
    out, gains, bias = [], [], []
    for zk, wk in zip(z, w, strict=True):
        th = th + (wk - b) * dt
        if discrete:
            p1 = p1 + dt * (dt * p4 - p2 - p3 + qa)
        else:
            p1 = p1 + (qa - p3 - p2) * dt
        p2 = p2 - p4 * dt
        p3 = p3 - p4 * dt
        p4 = p4 + qg * dt
        e = p1 + r
        k0, k1 = p1 / e, p3 / e
        err = wrap(zk - th)
        th = th + k0 * err
        b = b + k1 * err
        p1, p2, p3, p4 = p1 - k0 * p1, p2 - k0 * p2, p3 - k1 * p1, p4 - k1 * p2
        out.append(th)
        gains.append((k0, k1))
        bias.append(b)
    return np.array(out), np.array(gains), np.array(bias), np.array([[p1, p2], [p3, p4]])


def walking_like(n, seed, offset=0.0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    true = offset + 0.6 * np.sin(2 * np.pi * 0.9 * t) + 0.2 * np.sin(2 * np.pi * 1.8 * t + 1)
    w = np.gradient(true, 0.01) + 0.05 + 0.03 * rng.standard_normal(n)
    z = np.angle(np.exp(1j * (true + 0.15 * rng.standard_normal(n))))
    return true, z, w


def test_first_steps_by_hand():
    # step 1 from P = 0: P1- = Qa dt, P3- = 0 -> K0 = Qa dt / (Qa dt + R), K1 = 0
    kf = TiltKalman()
    z = np.array([0.1, 0.2])
    w = np.array([1.0, 1.0])
    out = kf.process(z[:1], w[:1])
    k0 = 0.001 * 0.01 / (0.001 * 0.01 + 0.3)
    pred = 0.1 + 1.0 * 0.01
    assert out[0] == pytest.approx(pred + k0 * (0.1 - pred), abs=1e-15)
    np.testing.assert_allclose(kf.K, [k0, 0.0], atol=1e-18)
    # step 2: P3 after step 1 is 0, P4 = Qg dt, so P3- = -Qg dt^2 and K1 = P3- / (P1- + R)
    kf.process(z[1:], w[1:])
    p1 = (1 - k0) * 0.001 * 0.01
    p1m = p1 + (0.001 - 0.0 - 0.0) * 0.01
    p3m = 0.0 - 0.003 * 0.01 * 0.01
    np.testing.assert_allclose(kf.K, [p1m / (p1m + 0.3), p3m / (p1m + 0.3)], rtol=1e-12)


@pytest.mark.parametrize("form", ["paper", "discrete"])
def test_matches_reference_to_1e9_over_a_long_record(form):
    _true, z, w = walking_like(30000, seed=3)
    ref, gains, bias, p_ref = reference(z, w, discrete=form == "discrete")
    kf = TiltKalman(form=form)
    out = kf.process(z, w)
    assert np.max(np.abs(out - ref)) < 1e-9
    assert kf.bias_rad_s[0] == pytest.approx(bias[-1], abs=1e-9)
    np.testing.assert_allclose(kf.K, gains[-1], rtol=1e-9)
    np.testing.assert_allclose(kf.P, p_ref, rtol=1e-9)


def test_steady_state_gain_matches_spec():
    g = TiltKalman().steady_state_gain
    assert g[0] == pytest.approx(0.015, abs=0.001)
    assert g[1] == pytest.approx(-0.0099, abs=0.0005)


def test_multi_segment_equals_single_segments_and_chunks_are_exact():
    rng = np.random.default_rng(4)
    cols = [walking_like(8000, seed=s, offset=o) for s, o in ((5, 0.0), (6, 1.0), (7, -0.5))]
    z = np.stack([c[1] for c in cols], axis=1)
    w = np.stack([c[2] for c in cols], axis=1)
    whole = TiltKalman().process(z, w)
    for j in range(3):  # the same filter per column (BLAS may round differently: not bitwise)
        np.testing.assert_allclose(TiltKalman().process(z[:, j], w[:, j]), whole[:, j], atol=1e-12)
    kf = TiltKalman()
    parts, i = [], 0
    while i < len(z):
        c = int(rng.choice([0, 1, 2, 7, 64, 333, 2500]))
        parts.append(kf.process(z[i : i + c], w[i : i + c]))
        i += c
    np.testing.assert_array_equal(np.concatenate(parts), whole)


def test_converges_on_a_static_tilt():
    n = 3000
    rng = np.random.default_rng(8)
    z = 0.7 + 0.05 * rng.standard_normal(n)
    w = 0.02 * rng.standard_normal(n)
    out = TiltKalman().process(z, w)
    assert abs(np.mean(out[-500:]) - 0.7) < 0.01
    assert np.std(out[-500:]) < np.std(z) / 3  # smoother than the accelerometer


def test_tracks_an_injected_gyro_bias():
    n = 6000
    true = 0.3 * np.sin(2 * np.pi * 0.5 * np.arange(n) * 0.01)
    w = np.gradient(true, 0.01) + 0.2  # 0.2 rad/s bias
    kf = TiltKalman()
    out = kf.process(true, w)
    assert kf.bias_rad_s[0] == pytest.approx(0.2, abs=0.005)
    assert np.max(np.abs(out[-1000:] - true[-1000:])) < 0.01


def test_crosses_plus_minus_180_degrees_without_a_jump():
    n = 4000
    t = np.arange(n) * 0.01
    true = np.pi - 0.5 + 0.03 * t  # crosses +180 deg at t ~ 16.7 s
    z = np.angle(np.exp(1j * true))  # the accelerometer tilt jumps from +pi to -pi
    w = np.full(n, 0.03)
    out = TiltKalman().process(z, w)
    assert np.max(np.abs(np.diff(out))) < 0.01
    err = np.angle(np.exp(1j * (out - true)))
    assert np.max(np.abs(err)) < 1e-3
    ref, *_ = reference(z, w)
    assert np.max(np.abs(out - ref)) < 1e-9


def test_exact_fallback_when_the_accelerometer_flips_by_more_than_pi():
    # the accelerometer says "upside down" for a while: innovations beyond +-pi must be wrapped
    # exactly as the paper's loop does, in every chunking
    _true, z, w = walking_like(12000, seed=9)
    z = z.copy()
    z[5000:5300] = np.angle(np.exp(1j * (z[5000:5300] + 3.0)))
    z[9000:9010] += 3.5
    ref, *_ = reference(z, w)
    whole = TiltKalman().process(z, w)
    assert np.max(np.abs(whole - ref)) < 1e-9
    kf = TiltKalman()
    parts = [kf.process(z[i : i + 173], w[i : i + 173]) for i in range(0, len(z), 173)]
    np.testing.assert_array_equal(np.concatenate(parts), whole)


@pytest.mark.parametrize(
    "kwargs", [{"dt_s": 0.0}, {"r": -1.0}, {"q_angle": -0.1}, {"form": "other"}, {"r": np.nan}]
)
def test_bad_parameters_are_refused(kwargs):
    with pytest.raises(ValueError):
        TiltKalman(**kwargs)


def test_step_by_step_mode_is_the_reference_and_agrees_with_the_fast_path():
    _, z, w = walking_like(6000, seed=12)
    ref, *_ = reference(z, w)
    slow = TiltKalman(fast_path=False).process(z, w)
    assert np.max(np.abs(slow - ref)) < 1e-12
    assert np.max(np.abs(TiltKalman().process(z, w) - slow)) < 1e-9
