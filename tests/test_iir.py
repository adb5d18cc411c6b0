"""gaitmon.dsp.iir against scipy (the independent reference), and no scipy on the filter path."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from scipy import linalg, signal

from gaitmon.dsp import iir
from gaitmon.dsp.kalman_models import pva_matrices, steady_state_gain

RNG = np.random.default_rng(28)
# the block tables are built in extended precision where numpy has it (x86 Linux/macOS); with
# plain doubles (Windows, ARM) a 0.25-Hz low-pass lands at ~1.2e-12 of its scale, not ~1.3e-13
TOL = 1e-12 if np.finfo(np.longdouble).eps < np.finfo(np.float64).eps else 3e-12

FILTERS = {
    "butter2 4/100": signal.butter(2, 4.0, fs=100.0),
    "butter1 4/100": signal.butter(1, 4.0, fs=100.0),
    "butter2 0.25/100": signal.butter(2, 0.25, fs=100.0),
    "butter4 10/100": signal.butter(4, 10.0, fs=100.0),
    "integrator": ([0.01], [1.0, -1.0]),
    "exponential": ([0.2], [1.0, -0.8]),
    "fir": ([1.0, 0.5, -0.25], [1.0]),
    "a0 not 1": ([0.4, 0.4], [2.0, -1.2]),
}


def walk(n: int, c: int) -> np.ndarray:
    return RNG.standard_normal((n, c)).cumsum(axis=0)


@pytest.mark.parametrize("order", range(1, 9))
@pytest.mark.parametrize("cutoff_hz, fs_hz", [(4.0, 100.0), (0.25, 100.0), (40.0, 100.0),
                                              (1.0, 1000.0), (12.5, 200.0)])  # fmt: skip
def test_butterworth_coefficients_are_scipys(order, cutoff_hz, fs_hz):
    b, a = iir.butter_lowpass(order, cutoff_hz, fs_hz)
    b_ref, a_ref = signal.butter(order, cutoff_hz, fs=fs_hz)
    np.testing.assert_allclose(b, b_ref, rtol=1e-12, atol=0)
    np.testing.assert_allclose(a, a_ref, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("name", FILTERS)
@pytest.mark.parametrize("n", [1, 5, 127, 128, 129, 300, 1000, 6000])
def test_lfilter_is_scipys_along_either_axis_with_a_start_state(name, n):
    b, a = FILTERS[name]
    p = max(len(a), len(b)) - 1
    x = walk(n, 6)
    zi = RNG.standard_normal((p, 6))
    y_ref, zf_ref = signal.lfilter(b, a, x, axis=0, zi=zi)
    y, zf = iir.lfilter(b, a, x, axis=0, zi=zi)
    scale = max(1.0, np.abs(y_ref).max())
    np.testing.assert_allclose(y, y_ref, rtol=0, atol=TOL * scale)
    np.testing.assert_allclose(zf, zf_ref, rtol=0, atol=TOL * scale)
    y1, zf1 = iir.lfilter(b, a, x.T, axis=1, zi=zi.T)
    np.testing.assert_allclose(y1, y_ref.T, rtol=0, atol=TOL * scale)
    np.testing.assert_allclose(zf1, zf_ref.T, rtol=0, atol=TOL * scale)
    np.testing.assert_allclose(iir.lfilter(b, a, x[:, 0]), signal.lfilter(b, a, x[:, 0]),
                               rtol=0, atol=TOL * scale)  # fmt: skip


def test_a_running_sum_is_scipys_bit_for_bit():
    x = walk(5000, 3)
    zi = RNG.standard_normal((1, 3))
    y_ref, zf_ref = signal.lfilter([0.01], [1.0, -1.0], x, axis=0, zi=zi)
    y, zf = iir.lfilter([0.01], [1.0, -1.0], x, axis=0, zi=zi)
    np.testing.assert_array_equal(y, y_ref)
    np.testing.assert_array_equal(zf, zf_ref)


@pytest.mark.parametrize("name", ["butter2 4/100", "butter1 4/100", "butter4 10/100", "fir"])
def test_any_chunking_and_any_channel_count_give_the_same_numbers(name):
    b, a = FILTERS[name]
    x = walk(20000, 5)  # 156 blocks of 128: ~10 groups of the block start states' chain
    zi = RNG.standard_normal((max(len(a), len(b)) - 1, 5))
    whole = iir.LinearFilter(b, a, 5, zi).process(x)
    for sizes in ([0, 1, 3, 10, 57, 128, 640, 2100], [127, 129, 1], [2047, 2049, 1], [7000]):
        f = iir.LinearFilter(b, a, 5, zi)
        parts, i = [], 0
        while i < len(x):
            c = int(RNG.choice(sizes))
            parts.append(f.process(x[i : i + c]))
            i += c
        np.testing.assert_array_equal(np.concatenate(parts), whole)
        np.testing.assert_allclose(f.state, signal.lfilter(b, a, x, axis=0, zi=zi)[1],
                                   rtol=0, atol=TOL * np.abs(whole).max())  # fmt: skip
    for ch in range(5):
        alone = iir.LinearFilter(b, a, 1, zi[:, ch : ch + 1]).process(x[:, ch : ch + 1])
        np.testing.assert_array_equal(alone[:, 0], whole[:, ch])


@pytest.mark.parametrize("name", ["butter2 4/100", "butter1 4/100", "butter4 10/100",
                                  "exponential", "a0 not 1"])  # fmt: skip
def test_lfilter_zi_is_scipys(name):
    b, a = FILTERS[name]
    np.testing.assert_allclose(iir.lfilter_zi(b, a), signal.lfilter_zi(b, a), rtol=1e-12,
                               atol=1e-15)  # fmt: skip


def test_ss2tf_is_scipys_for_the_tilt_kalman_model():
    k0, k1, dt = 0.015, -0.0099, 0.01
    f = np.array([[1 - k0, -(1 - k0) * dt], [-k1, 1 + k1 * dt]])
    g = np.array([[(1 - k0) * dt, k0], [-k1 * dt, k1]])
    for inp in range(2):
        num, den = iir.ss2tf(f, g, f[:1], g[:1], inp)
        num_ref, den_ref = signal.ss2tf(f, g, f[:1], g[:1], inp)
        np.testing.assert_allclose(num, num_ref, rtol=0, atol=1e-15)
        np.testing.assert_allclose(den, den_ref, rtol=0, atol=1e-15)


def _dare_cases():
    cases = []
    a, h, q = pva_matrices(1e-3, 1.0, "position")
    cases.append((a.T, h.T, q, np.array([[5e-5]])))
    dt = 0.01
    cases.append((np.array([[1.0, 0.0], [-dt, 1.0]]), np.array([[1.0], [0.0]]),
                  np.diag([1e-3 * dt, 3e-3 * dt]), np.array([[0.3]])))  # fmt: skip
    rng = np.random.default_rng(5)
    for _ in range(12):
        n, m = int(rng.integers(1, 5)), int(rng.integers(1, 3))
        qh, rh = rng.standard_normal((n, n)), rng.standard_normal((m, m))
        cases.append((rng.standard_normal((n, n)), rng.standard_normal((n, m)), qh @ qh.T,
                      rh @ rh.T + 0.1 * np.eye(m)))  # fmt: skip
    return cases


@pytest.mark.parametrize("case", range(14))
def test_dare_is_scipys(case):
    a, b, q, r = _dare_cases()[case]
    x_ref = linalg.solve_discrete_are(a, b, q, r)
    x = iir.solve_discrete_are(a, b, q, r)
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=1e-10 * np.abs(x_ref).max())


def test_dare_without_a_stabilising_solution_raises_what_the_caller_catches():
    a, h, q = pva_matrices(1e-3, 1.0, "acceleration")  # position and velocity unobservable
    with pytest.raises(np.linalg.LinAlgError):
        linalg.solve_discrete_are(a.T, h.T, q, np.array([[5e-5]]))
    with pytest.raises(np.linalg.LinAlgError):
        iir.solve_discrete_are(a.T, h.T, q, np.array([[5e-5]]))
    with pytest.raises(ValueError, match="no steady-state gain"):
        steady_state_gain(a, h, q, np.array([[5e-5]]))
    with pytest.raises(ValueError, match="singular"):
        iir.solve_discrete_are(np.eye(2), np.ones((2, 1)), np.eye(2), np.zeros((1, 1)))


# the filters of the live and ``process`` paths, run in a fresh interpreter
_RUN_FILTERS = """
import json, sys
import numpy as np
from gaitmon.dsp.complementary import AdaptiveCutoff, ComplementaryFilter
from gaitmon.dsp.exponential import ExponentialFilter, TrapezoidIntegrator
from gaitmon.dsp.filters import Butterworth, GyroIntegrator
from gaitmon.dsp.gravity_reference import GravityReference
from gaitmon.dsp.kalman import TiltKalman
from gaitmon.dsp.kalman_models import pva_matrices, steady_state_gain
x = np.random.default_rng(0).standard_normal((3000, 4)).cumsum(axis=0) * 0.01
Butterworth().process(x)
GyroIntegrator().process(x)
TiltKalman().process(x, x)
ComplementaryFilter(adaptive=AdaptiveCutoff()).process(x, x)
ExponentialFilter(cutoff_hz=3.0, fs_hz=100.0, order=2).process(x)
TrapezoidIntegrator(0.01).process(x)
GravityReference(0.25, 100.0, 4).process(x, x + 1.0, x)
a, h, q = pva_matrices(1e-3, 1.0, "position")
steady_state_gain(a, h, q, np.array([[5e-5]]))
print(json.dumps(sorted(m for m in sys.modules if m == "scipy" or m.startswith("scipy."))))
"""

_RUN_PIPELINE = """
import json, sys
import numpy as np
from gaitmon.dsp.pipeline import Pipeline
Pipeline().process(np.load(sys.argv[1]))
print(json.dumps(sorted(m for m in sys.modules if m == "scipy" or m.startswith("scipy."))))
"""


def _scipy_modules(script: str, *args: str) -> list[str]:
    out = subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True,
                         check=True, timeout=300)  # fmt: skip
    return list(json.loads(out.stdout.strip().splitlines()[-1]))


def test_the_filters_import_no_scipy():
    assert _scipy_modules(_RUN_FILTERS) == []


def test_the_pipeline_runs_its_filters_without_scipy_signal(tmp_path):
    from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
    from gaitmon.io.sim.sensors import simulate

    counts = simulate(1500, GaitModel(GaitConfig(seed=3)), SensorConfig(seed=3)).counts
    np.save(tmp_path / "counts.npy", counts)
    mods = _scipy_modules(_RUN_PIPELINE, str(tmp_path / "counts.npy"))
    # no scipy.signal (nor scipy.linalg for the filters: kalman_models no longer imports it);
    # whatever scipy remains here comes from the gait events' scipy.ndimage (which imports
    # scipy.linalg itself), which the kernels change removes
    assert not any(m.startswith("scipy.signal") for m in mods)
    assert "scipy.linalg" not in mods or "scipy.ndimage" in mods


@pytest.mark.parametrize("order", [3, 4, 6, 8])
@pytest.mark.parametrize("cutoff_hz", [0.25, 1.0])
def test_every_order_the_settings_allow_filters_as_scipy_does_at_a_low_cutoff(
    order: int, cutoff_hz: float
) -> None:
    """Orders 1-8 are allowed (Butterworth.check). The block form's companion powers lost every
    digit above order 2 with poles near 1 (order 4 at 0.25 Hz / 100 Hz: 1e-3 of scale off
    scipy, order 6: 1e91): those orders run scipy's recursion itself, in any chunking."""
    b, a = iir.butter_lowpass(order, cutoff_hz, 100.0)
    x = np.random.default_rng(order).standard_normal((6000, 3)).cumsum(axis=0)
    want = signal.lfilter(b, a, x, axis=0)
    scale = np.abs(want).max()
    assert np.abs(iir.lfilter(b, a, x, axis=0) - want).max() <= 1e-12 * scale
    f = iir.LinearFilter(b, a, 3)
    got = np.concatenate([f.process(x[i : i + 977]) for i in range(0, len(x), 977)])
    assert np.abs(got - want).max() <= 1e-12 * scale
    _y, zf = signal.lfilter(b, a, x, axis=0, zi=np.zeros((order, 3)))
    assert np.abs(f.state - zf).max() <= 1e-12 * max(1.0, np.abs(zf).max())
