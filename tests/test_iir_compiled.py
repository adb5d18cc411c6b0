"""Issue 28: gaitmon.dsp.iir's compiled form (numba's direct form II transposed,
gaitmon.dsp.loops.lfilter), which long batch work runs, gives scipy's numbers in any chunking and
the numpy block form's to 1e-12 of the signal's scale; the pipeline's filters run it when the
compiled loops serve (kernels.use("compiled")), and the gravity reference takes every segment in
one call with the numbers it gave per segment."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy import signal

from gaitmon.dsp import iir, kernels, loops

FILTERS = {
    "butter2 4/100": signal.butter(2, 4.0, fs=100.0),
    "butter2 0.25/100": signal.butter(2, 0.25, fs=100.0),
    "butter1 4/100": signal.butter(1, 4.0, fs=100.0),
    "butter4 10/100": signal.butter(4, 10.0, fs=100.0),
    "exponential": ([0.2], [1.0, -0.8]),
    "fir": ([1.0, 0.5, -0.25], [1.0]),
    "a0 not 1": ([0.4, 0.4], [2.0, -1.2]),
}
# the numpy block form against scipy (tests/test_iir.py: plain doubles on some platforms)
TOL = 1e-12 if np.finfo(np.longdouble).eps < np.finfo(np.float64).eps else 3e-12
RNG = np.random.default_rng(2028)

needs_numba = pytest.mark.skipif(not kernels.numba_available(), reason="numba is not installed")


def _chunked(form: str, b, a, x: np.ndarray, zi: np.ndarray, cuts) -> tuple[np.ndarray, ...]:
    with kernels.use(form):
        f = iir.LinearFilter(b, a, x.shape[1], zi)
        y = np.concatenate([f.process(x[i:j]) for i, j in itertools.pairwise(cuts)])
        return y, f.state


@pytest.mark.parametrize("name", FILTERS)
def test_the_loops_one_source_interpreted_is_scipys_recursion_bit_for_bit(name):
    b, a = FILTERS[name]
    bn, an = iir._normalised(b, a)
    x = RNG.standard_normal((300, 3)).cumsum(axis=0)
    zi = RNG.standard_normal((bn.size - 1, 3))
    y_ref, zf_ref = signal.lfilter(b, a, x, axis=0, zi=zi)
    z, y = zi.copy(), np.empty_like(x)
    loops.lfilter(memoryview(bn), memoryview(an), memoryview(x), memoryview(z), memoryview(y))
    # scipy's operations in its order (bit for bit where scipy's build fuses no multiply-add)
    scale = max(1.0, np.abs(y_ref).max())
    np.testing.assert_allclose(y, y_ref, rtol=0, atol=1e-14 * scale)
    np.testing.assert_allclose(z, zf_ref, rtol=0, atol=1e-14 * scale)


@needs_numba
@pytest.mark.parametrize("name", FILTERS)
def test_compiled_is_scipys_in_any_chunking_and_the_block_forms_to_rounding(name):
    b, a = FILTERS[name]
    p = max(len(a), len(b)) - 1
    x = RNG.standard_normal((6000, 5)).cumsum(axis=0)
    zi = RNG.standard_normal((p, 5))
    y_ref, zf_ref = signal.lfilter(b, a, x, axis=0, zi=zi)
    scale = max(1.0, np.abs(y_ref).max())
    whole = _chunked("compiled", b, a, x, zi, [0, len(x)])
    np.testing.assert_allclose(whole[0], y_ref, rtol=0, atol=1e-14 * scale)
    np.testing.assert_allclose(whole[1], zf_ref, rtol=0, atol=1e-14 * scale)
    for step in (1, 7, 128, 1000):
        rows = 700 if step == 1 else len(x)
        cuts = sorted({*range(0, rows, step), rows, len(x)})
        y, zf = _chunked("compiled", b, a, x, zi, cuts)
        np.testing.assert_array_equal(y, whole[0])  # the same numbers in any chunking
        np.testing.assert_array_equal(zf, whole[1])
    numpy_form = _chunked("python", b, a, x, zi, [0, len(x)])
    np.testing.assert_allclose(numpy_form[0], whole[0], rtol=0, atol=TOL * scale)
    np.testing.assert_allclose(numpy_form[1], whole[1], rtol=0, atol=TOL * scale)


@needs_numba
def test_a_filter_going_from_one_form_to_the_other_carries_its_state():
    b, a = FILTERS["butter2 0.25/100"]
    x = RNG.standard_normal((5000, 4)).cumsum(axis=0)
    y_ref, zf_ref = signal.lfilter(b, a, x, axis=0, zi=np.zeros((2, 4)))
    f = iir.LinearFilter(b, a, 4)
    parts = []
    for i, (lo, hi) in enumerate(itertools.pairwise([0, 300, 1900, 2000, 3333, 5000])):
        with kernels.use("compiled" if i % 2 else "python"):
            parts.append(f.process(x[lo:hi]))
    scale = np.abs(y_ref).max()
    np.testing.assert_allclose(np.concatenate(parts), y_ref, rtol=0, atol=TOL * scale)
    np.testing.assert_allclose(f.state, zf_ref, rtol=0, atol=TOL * scale)


def _walk(n: int) -> np.ndarray:
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import simulate

    return simulate(n, GaitModel(GaitConfig(seed=11, standing_s=2.0))).counts


@needs_numba
def test_the_pipelines_filters_run_the_compiled_loop_with_the_numpy_forms_numbers(monkeypatch):
    from gaitmon.dsp import kernels_numba
    from gaitmon.dsp.pipeline import Pipeline

    compiled = getattr(kernels_numba, "lfilter", None)  # (None before issue 28's change)
    calls: list[tuple[np.ndarray, ...]] = []

    def recorded(b, a, x, z, y):
        z_in = z.copy()
        compiled(b, a, x, z, y)
        calls.append((b.copy(), a.copy(), x.copy(), z_in, y.copy(), z.copy()))

    monkeypatch.setattr(kernels_numba, "lfilter", recorded, raising=False)
    # the gravity reference's low-pass runs in its own compiled pass (loops.gravity_average)
    gravity_calls: list[int] = []
    gravity_average = kernels_numba.gravity_average

    def gravity_recorded(*args):
        gravity_average(*args)
        gravity_calls.append(len(args[0]))

    monkeypatch.setattr(kernels_numba, "gravity_average", gravity_recorded)
    counts = _walk(8000)
    fields = ("acc_ms2", "fsr_counts", "tilt_acc_rad", "tilt_gyro_rad", "tilt_kalman_rad")
    with kernels.use("python"):
        ref = Pipeline().process(counts)
    assert not calls  # the numpy form: no compiled loop
    for step in (8000, 4096, 250, 1):
        rows = 1200 if step == 1 else len(counts)  # (1-row blocks: a 12-s head)
        calls.clear()
        gravity_calls.clear()
        with kernels.use("compiled"):
            pipe = Pipeline()
            blocks = [pipe.process(counts[i : i + step]) for i in range(0, rows, step)]
        # the acc (each axis), FSR and gyro-tilt low-passes, and the gravity reference, every
        # block
        assert len(calls) >= 4 * len(blocks), len(calls)
        assert sum(gravity_calls) == rows
        assert {c[2].shape[1] for c in calls} == {2, 4}
        for field in fields:
            got = np.concatenate([getattr(blk, field) for blk in blocks])
            want = getattr(ref, field)[:rows]
            scale = max(1.0, float(np.nanmax(np.abs(want))))
            # the Kalman tilt also runs the compiled gait-aware loop (tests/test_kernels.py: 1e-9)
            tol = 1e-9 if field == "tilt_kalman_rad" else 1e-12
            np.testing.assert_allclose(got, want, rtol=0, atol=tol * scale, err_msg=field)
    # each compiled call: the numpy form's numbers from the same state, and scipy's
    for b, a, x, z_in, y, z_out in calls[:40]:
        with kernels.use("python"):
            f = iir.LinearFilter(b, a, x.shape[1], z_in)
            y_np = f.process(x)
        scale = max(1.0, np.abs(y_np).max())
        np.testing.assert_allclose(y, y_np, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(z_out, f.state, rtol=0, atol=1e-12 * scale)
        y_ref, _ = signal.lfilter(b, a, x, axis=0, zi=z_in)
        np.testing.assert_allclose(y, y_ref, rtol=0, atol=1e-14 * scale)


def test_the_gravity_reference_takes_every_segment_in_one_call_with_the_same_numbers():
    from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX
    from gaitmon.dsp.gravity_reference import GravityReference
    from gaitmon.dsp.motion_kalman import GaitAwareKalman

    counts = _walk(3000)
    t = DEFAULT_TABLE
    ax, az, w = (t.to_physical(counts, i) for i in (ACC_X_IDX, ACC_Z_IDX, GYRO_IDX))
    kf = GaitAwareKalman(100.0)
    assert len(kf._gravity) == 1  # one cut-off (0.25 Hz) for the four segments: one reference
    with kernels.use("python"):
        together = GravityReference(0.25, 100.0, 4)
        alone = [GravityReference(0.25, 100.0, 1) for _ in range(4)]
        for lo, hi in itertools.pairwise([0, 130, 1000, 3000]):
            got = together.process(ax[lo:hi], az[lo:hi], w[lo:hi])
            for c, ref in enumerate(alone):
                one = ref.process(ax[lo:hi, c : c + 1], az[lo:hi, c : c + 1], w[lo:hi, c : c + 1])
                np.testing.assert_array_equal(got[:, c], one[:, 0])


def test_the_gravity_references_tables_are_the_same_numbers_with_the_compiled_loops_loaded(
    tmp_path,
):
    """The gravity reference's step-response tables are filtered by the interpreted loops
    whatever the process has loaded: with the compiled loops loaded (a batch job) they were
    the compiled recursion's, cut at another length, and a recording processed differed from
    the same recording made live by ~1e-12 rad. In a child process (loading the compiled
    loops there leaves this one as it is); numba's cache in ``tmp_path``."""
    import os
    import subprocess
    import sys

    if not kernels.numba_available():
        pytest.skip("numba is not installed")
    code = (
        "import numpy as np\n"
        "from gaitmon.dsp import kernels\n"
        "import gaitmon.dsp.gravity_reference as g\n"
        "with kernels.use('python'):\n"
        "    want = g._tables(0.5, 100.0)\n"
        "kernels._load()\n"
        "assert kernels.compiled_loaded()\n"
        "g._tables.cache_clear()\n"
        "got = g._tables(0.5, 100.0)\n"
        "print(all(np.array_equal(a, b) for a, b in zip(want, got)))\n"
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                       check=False, timeout=600)  # fmt: skip
    assert r.returncode == 0, r.stderr[-800:]
    assert r.stdout.strip() == "True"
