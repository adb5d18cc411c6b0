"""Butterworth low-pass and gyro integration against the paper and scipy."""

import numpy as np
import pytest
from scipy import signal

from gaitmon.dsp.filters import Butterworth, GyroIntegrator


def random_chunks(n, rng, max_chunk=97):
    i = 0
    while i < n:
        c = int(rng.integers(0, max_chunk))
        yield slice(i, min(n, i + c))
        i += c


def test_paper_coefficients_at_100_hz():
    # paper 000: y(k) = A x(k) + B x(k-1) + C x(k-2) + D y(k-1) + E y(k-2)
    paper = {"A": 0.013359, "B": 0.026718, "C": 0.013359, "D": 1.647462, "E": -0.700899}
    got = Butterworth(cutoff_hz=4.0, fs_hz=100.0, order=2).paper_coefficients
    for k, v in paper.items():
        assert got[k] == pytest.approx(v, abs=1e-5), k


def test_designed_from_arguments_not_hard_coded():
    b200, a200 = Butterworth(4.0, 200.0, 2).coefficients
    b_ref, a_ref = signal.butter(2, 4.0, fs=200.0)
    np.testing.assert_allclose(b200, b_ref, rtol=1e-12)
    np.testing.assert_allclose(a200, a_ref, rtol=1e-12)
    # DC gain 1, -3 dB at the cut-off
    b, a = Butterworth(6.0, 100.0, 4).coefficients
    _w, h = signal.freqz(b, a, worN=[0.0, 6.0], fs=100.0)
    assert abs(h[0]) == pytest.approx(1.0, abs=1e-12)
    assert abs(h[1]) == pytest.approx(1 / np.sqrt(2), abs=1e-9)


def test_difference_equation_by_hand_zero_initial():
    x = np.random.default_rng(0).standard_normal(50)
    f = Butterworth(initial="zero")
    c = f.paper_coefficients
    y = np.zeros_like(x)
    for k in range(len(x)):
        xm1 = x[k - 1] if k >= 1 else 0.0
        xm2 = x[k - 2] if k >= 2 else 0.0
        ym1 = y[k - 1] if k >= 1 else 0.0
        ym2 = y[k - 2] if k >= 2 else 0.0
        y[k] = c["A"] * x[k] + c["B"] * xm1 + c["C"] * xm2 + c["D"] * ym1 + c["E"] * ym2
    np.testing.assert_allclose(f.process(x), y, atol=1e-13)


def test_first_sample_initialisation_has_no_start_up_ramp():
    x = np.full(300, 9.81)
    np.testing.assert_allclose(Butterworth().process(x), 9.81, rtol=1e-12)
    assert Butterworth(initial="zero").process(x)[0] < 1.0


def test_multichannel_equals_per_channel_and_chunking_is_exact():
    rng = np.random.default_rng(1)
    x = rng.standard_normal((2000, 5)).cumsum(axis=0)
    whole = Butterworth().process(x)
    for ch in range(5):
        np.testing.assert_array_equal(Butterworth().process(x[:, ch]), whole[:, ch])
    f = Butterworth()
    chunked = np.concatenate([f.process(x[s]) for s in random_chunks(len(x), rng)])
    np.testing.assert_array_equal(chunked, whole)
    f.reset()
    np.testing.assert_array_equal(f.process(x), whole)


@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"cutoff_hz": 60.0}, "Nyquist"),
        ({"cutoff_hz": -1.0}, "Nyquist"),
        ({"order": 0}, "order"),
        ({"fs_hz": 0.0}, "sample rate"),
    ],
)
def test_bad_parameters_get_clear_errors(kwargs, word):
    with pytest.raises(ValueError, match=word):
        Butterworth(**kwargs)


def test_gyro_integration_closed_form_and_chunks():
    dt = 0.01
    t = np.arange(1000) * dt
    rate = 2.0 * np.cos(2.0 * t)  # integral: sin(2t)
    g = GyroIntegrator(dt)
    theta = g.process(rate, initial_rad=0.3)
    # rectangle rule theta_k = 0.3 + dt * sum_{i<=k} rate_i
    np.testing.assert_allclose(theta, 0.3 + dt * np.cumsum(rate), atol=1e-12)
    # right-rectangle rule: within dt * max|rate| (+ rounding) of the true integral
    assert np.max(np.abs(theta - (0.3 + np.sin(2 * t)))) < dt * 2.0 * 1.01
    rng = np.random.default_rng(2)
    g2 = GyroIntegrator(dt)
    parts = [g2.process(rate[s], initial_rad=0.3) for s in random_chunks(len(rate), rng)]
    np.testing.assert_array_equal(np.concatenate(parts), theta)


def test_constant_bias_drifts_linearly():
    theta = GyroIntegrator(0.01).process(np.full(6000, 0.01))  # 0.01 rad/s for 60 s
    assert theta[-1] == pytest.approx(0.6, rel=1e-9)
