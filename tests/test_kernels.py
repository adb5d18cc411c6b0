"""Issue 28: the inner loops have one source (gaitmon.dsp.loops) run two ways, interpreted or
compiled by numba (gaitmon.dsp.kernels), and both give the same numbers (1e-9) on simulated
and real walks in any chunking; the numpy windows give scipy.ndimage's numbers; a live block
imports no numba; without numba, ``gaitmon process`` writes the same file.

Subprocess tests run a fresh interpreter: whether numba is imported is a property of a process.
"""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import numeric_datasets

from gaitmon.dsp import kernels
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX, SEGMENTS
from gaitmon.dsp.motion_kalman import GaitAwareKalman
from gaitmon.dsp.smoother import release_factors, smooth_map, smooth_tilts
from gaitmon.dsp.windows import sliding_max, sliding_mean

ROOT = Path(__file__).resolve().parents[1]
TOL = 1e-9


def _simulated(n: int = 6000, seed: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import simulate

    counts = simulate(n, GaitModel(GaitConfig(seed=seed, standing_s=2.0))).counts
    t = DEFAULT_TABLE
    return (t.to_physical(counts, ACC_X_IDX), t.to_physical(counts, ACC_Z_IDX),
            t.to_physical(counts, GYRO_IDX))  # fmt: skip


def _real(shared_data: Path, dataset: str, name: str) -> tuple[np.ndarray, ...]:
    """One real foot IMU in all four columns (each segment's tuning reads it its own way)."""
    from gaitmon.lab import datasets

    read = {"gdins": datasets.read_gdins, "xio": datasets.read_xio,
            "broad": datasets.read_broad}[dataset]  # fmt: skip
    trial = next(t for t in read(shared_data) if t.name == name)
    rows = slice(0, min(len(trial), 12_000))
    return tuple(np.repeat(a[rows, None], 4, axis=1)
                 for a in (trial.acc_x, trial.acc_z, trial.gyro_y - np.median(trial.gyro_y)))


def _filter(form: str, data: tuple[np.ndarray, ...], block: int) -> np.ndarray:
    """The filter over ``data`` in blocks of ``block`` rows, restarted with a new calibration's
    bias shift at row 1100 (as after a link outage)."""
    ax, az, w = data
    n = len(ax)
    cuts = sorted({*range(0, n, block), n, *([1100] if n > 1100 else [])})
    with kernels.use(form):
        kf = GaitAwareKalman(100.0)
        parts = []
        for a, b in itertools.pairwise(cuts):
            if a == 1100:
                kf.restart()
                kf.shift_bias(np.full(4, 0.002))
            parts.append(kf.process(ax[a:b], az[a:b], w[a:b]))
        return np.concatenate(parts)


def _smooth(form: str, data: tuple[np.ndarray, ...], first: np.ndarray) -> np.ndarray:
    ax, az, w = data
    release_factors()  # (each form factors the matrix itself)
    with kernels.use(form):
        return smooth_tilts(ax, az, w, 100.0, SEGMENTS, first_pass=first)


def _both_forms(data: tuple[np.ndarray, ...]) -> tuple[float, float, float]:
    """(the largest filter difference over the block sizes, the smoother's, the compiled
    tilts' peak-to-peak) of the interpreted form against the compiled one on ``data``."""
    compiled = _filter("compiled", data, 1 << 20)
    worst = 0.0
    for block in (1, 7, 250, 4096):  # live ticks to batch chunks
        rows = 1500 if block == 1 else len(compiled)  # (1-row blocks: a 15-s head)
        py = _filter("python", tuple(a[:rows] for a in data), block)
        worst = max(worst, float(np.abs(py - compiled[:rows]).max()))
    smoothed = _smooth("python", data, compiled)
    smoothed_diff = np.abs(smoothed - _smooth("compiled", data, compiled))
    return worst, float(smoothed_diff.max()), float(np.ptp(compiled))


def test_both_forms_give_the_same_tilts_on_a_simulated_walk():
    filter_diff, smooth_diff, ptp = _both_forms(_simulated())
    assert ptp > 0.5  # a walk, not a still board
    assert filter_diff <= TOL and smooth_diff <= TOL  # NaN fails too


REAL = [("gdins", "exp33"), ("xio", "short_walk"), ("broad", "02_undisturbed_slow_rotation_B")]


@pytest.mark.parametrize(("dataset", "name"), REAL)
def test_both_forms_give_the_same_tilts_on_real_recordings(shared_data, dataset, name):
    """Real walks, and a BROAD trial whose foot leaves the sagittal plane (the smoother's
    out-of-plane solve: the general banded factorisation)."""
    data = _real(shared_data, dataset, name)
    if dataset == "broad":
        from gaitmon.dsp.smoother import out_of_plane, tuning_for

        assert out_of_plane(data[0][:, 3], data[1][:, 3], 100.0, tuning_for("foot")) is not None
    filter_diff, smooth_diff, ptp = _both_forms(data)
    assert ptp > 0.5
    assert filter_diff <= TOL and smooth_diff <= TOL


def test_the_banded_solve_is_lapacks_in_both_forms():
    from scipy.linalg import solveh_banded

    from gaitmon.dsp.smoother_map import _measurement_weights, _normal_band, _normal_rhs

    rng = np.random.default_rng(3)
    n = 3000
    z = np.cumsum(rng.normal(0, 0.01, n))
    w = rng.normal(0, 0.5, n)
    r = np.where(rng.random(n) < 0.2, np.inf, 10 ** rng.uniform(-4, -1, n))
    qa = 1e-5 * (1 + rng.random(n))
    ab = _normal_band(_measurement_weights(r), qa, 1e-7, 0.01)
    x = solveh_banded(ab, _normal_rhs(z, w, _measurement_weights(r), qa, 0.01, None))
    for form in ("python", "compiled"):
        with kernels.use(form):
            theta, bias = smooth_map(z, w, r, qa, 1e-7, 0.01)
        np.testing.assert_allclose(theta, x[0::2], rtol=0, atol=1e-10)
        np.testing.assert_allclose(bias, x[1::2], rtol=0, atol=1e-10)


@pytest.mark.parametrize("size", [1, 2, 5, 8, 61, 150])
def test_the_numpy_windows_are_scipys(size):
    from scipy.ndimage import maximum_filter1d, uniform_filter1d

    rng = np.random.default_rng(size)
    for n in (1, 3, 40, 5000):
        x = 9.8 + 3.0 * rng.standard_normal((3, n))
        for mode, cval in (("nearest", 0.0), ("constant", -np.inf), ("constant", 0.0)):
            got = sliding_max(x, size, mode=mode, cval=cval)
            assert np.array_equal(got, maximum_filter1d(x, size, axis=-1, mode=mode, cval=cval))
        for mode in ("nearest", "constant"):
            want = uniform_filter1d(x, size, axis=-1, mode=mode)
            np.testing.assert_allclose(sliding_mean(x, size, mode=mode), want, rtol=1e-13,
                                       atol=1e-12)  # fmt: skip
        for form in ("python", "compiled"):
            with kernels.use(form):
                got = kernels.running_mean(x, size)
            np.testing.assert_allclose(got, uniform_filter1d(x, size, axis=-1, mode="constant"),
                                       rtol=1e-13, atol=1e-12)  # fmt: skip
            with kernels.use(form):  # (one row: the gravity pass of one segment)
                got = kernels.running_mean(x[0], size)
            np.testing.assert_allclose(got, uniform_filter1d(x[0], size, mode="constant"),
                                       rtol=1e-13, atol=1e-12)  # fmt: skip


def _run(code: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), **(env or {})}
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          timeout=300, cwd=ROOT)  # fmt: skip


LIVE = """
import sys
import numpy as np
from gaitmon.dsp.channels import DEFAULT_TABLE
from gaitmon.dsp.pipeline import Pipeline
from gaitmon.engine.warmup import prepare_filters
from gaitmon.dsp.pipeline import PipelineConfig
prepare_filters(PipelineConfig())  # what a connect runs first
p = Pipeline()
rows = np.rint(np.tile(DEFAULT_TABLE.zero_counts, (5, 1))).astype(np.uint16)
blk = p.process(rows)
assert np.all(np.isfinite(blk.tilt_kalman_continuous_rad))
print(sorted(m for m in sys.modules if m.split(".")[0] in ("numba", "llvmlite")))
"""


def test_a_live_block_imports_no_numba(tmp_path):
    """Live blocks run the interpreted loops: a first connect after an install waits for no
    compile (on the old code the warm-up compiled or loaded numba's loop)."""
    run = _run(LIVE, {"NUMBA_CACHE_DIR": str(tmp_path / "empty")})
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip().splitlines()[-1] == "[]", run.stdout


def test_the_loops_smoother_and_gyro_events_import_no_scipy():
    """scipy.ndimage's windows and scipy.linalg's banded solves are numpy and the loops now
    (the modules' own imports, also inside functions; the filters' design is another
    module's)."""
    import ast

    for name in ("kernels", "kernel_cache", "kernel_fill", "loops", "windows", "smoother",
                 "gyro_events", "motion_kalman"):  # fmt: skip
        tree = ast.parse((ROOT / "gaitmon" / "dsp" / f"{name}.py").read_text())
        found = [n.module if isinstance(n, ast.ImportFrom) else n.names[0].name
                 for n in ast.walk(tree) if isinstance(n, ast.Import | ast.ImportFrom)]
        assert not [m for m in found if (m or "").startswith("scipy")], (name, found)


def test_loading_the_compiled_loops_imports_no_scipy_linalg(tmp_path):
    """numba's numpy registry, loaded with the first compiled loop, imported scipy.linalg
    (~24 MB resident, in every long ``process``, recovery and close) only to ask whether BLAS
    is there for ``np.convolve``; the loops use none. numba's own linear algebra still works
    in that process (it imports scipy.linalg when a function of it is compiled)."""
    pytest.importorskip("numba")
    code = """
import sys
import numpy as np
from gaitmon.dsp import kernels
from gaitmon.dsp.smoother import smooth_map
z = np.sin(np.linspace(0, 20, 3000))[:, None].repeat(2, axis=1)
with kernels.use("compiled"):
    a = smooth_map(z, 0.1 * z, 0.01, 1e-4, 1e-6, 0.01)[0]
with kernels.use("python"):
    b = smooth_map(z, 0.1 * z, 0.01, 1e-4, 1e-6, 0.01)[0]
print("linalg after the loops", "scipy.linalg" in sys.modules, float(np.max(np.abs(a - b))))
import numba
x = np.arange(6.0).reshape(2, 3)
print("numba's dot", numba.njit(lambda p, q: np.dot(p, q))(x, x.T).tolist())
"""
    run = _run(code, {"NUMBA_CACHE_DIR": str(tmp_path / "cache")})
    assert run.returncode == 0, run.stderr[-2000:]
    first, dot = run.stdout.strip().splitlines()[-2:]
    what, loaded, diff = first.rsplit(" ", 2)
    assert (what, loaded) == ("linalg after the loops", "False")
    assert float(diff) < 1e-9
    assert dot == "numba's dot [[5.0, 14.0], [14.0, 50.0]]"


# numba (and llvmlite) cannot be imported in the child: a finder that refuses them
NO_NUMBA = """
import importlib.abc, sys
class _Refuse(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("numba", "llvmlite"):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None
sys.meta_path.insert(0, _Refuse())
"""


@pytest.fixture(scope="module")
def walk_file(tmp_path_factory, record_simulated) -> Path:
    return record_simulated(tmp_path_factory.mktemp("walk") / "walk.h5", duration_s=40)


def test_without_numba_process_writes_the_same_numbers(tmp_path, walk_file):
    """``gaitmon process`` where numba cannot be imported (the interpreted loops) against one
    where numba's compiled loops are forced: every processed dataset the same within 1e-9."""
    plain, compiled = tmp_path / "plain.h5", tmp_path / "compiled.h5"
    code = NO_NUMBA + f"""
from gaitmon.cli import main
rc = main(["process", {str(walk_file)!r}, "-o", {str(plain)!r}])
assert "numba" not in sys.modules
sys.exit(rc)
"""
    run = _run(code)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "Traceback" not in run.stderr and "pip install" not in run.stderr
    code = f"""
import sys
from gaitmon.cli import main
from gaitmon.dsp import kernels
with kernels.use("compiled"):
    rc = main(["process", {str(walk_file)!r}, "-o", {str(compiled)!r}])
assert "numba" in sys.modules
sys.exit(rc)
"""
    run = _run(code)
    assert run.returncode == 0, run.stderr[-2000:]
    a, b = numeric_datasets(plain), numeric_datasets(compiled)
    assert a.keys() == b.keys()
    # (format 2 stores the angles quantised: equal within 1e-9 is equal)
    assert {"processed/tilt_deg", "smoothed/tilt_deg", "strides/stride_length_m"} <= a.keys()
    for name in a:
        assert a[name].shape == b[name].shape, name
        np.testing.assert_allclose(a[name].astype(float), b[name].astype(float), rtol=0,
                                   atol=TOL, err_msg=name)  # fmt: skip
    # and the walk was processed (not an empty file compared with another)
    assert len(a["events/heel_strike"]) > 20 and np.ptp(a["smoothed/tilt_deg"]) > 1000


def test_long_batch_work_goes_over_to_the_cached_compiled_loops(tmp_path):
    """The rule (gaitmon.dsp.kernels): short work stays interpreted and imports no numba; past
    FILL_ROWS a background process fills an empty cache (nothing compiles in this one), and
    once it is ready, work past LOAD_ROWS runs compiled: the loops the filler built ahead of
    time where it could (then numba is not even imported), else numba's cached ones."""
    code = """
import sys
import numpy as np
from gaitmon.dsp import kernels, kernel_cache
from gaitmon.dsp.motion_kalman import GaitAwareKalman
rng = np.random.default_rng(0)
def block(n):
    return (9.81 + 0.1 * rng.standard_normal((n, 4)), 0.1 * rng.standard_normal((n, 4)),
            0.1 * rng.standard_normal((n, 4)))
kf = GaitAwareKalman(100.0)
kf.process(*block(kernels.FILL_ROWS - 100))
print("short", "numba" in sys.modules, kernel_cache._fill is not None)
kf.process(*block(2000))  # past FILL_ROWS: the filler starts, this process goes on
print("filling", "numba" in sys.modules, kernel_cache._fill is not None)
print("filled", kernel_cache.wait_fill(240), kernel_cache.cache_ready())
kf.process(*block(kernels.LOAD_ROWS))
print("loaded", "numba" in sys.modules, kernels.compiled_loaded())
import os
print("aot", os.path.exists(kernel_cache.aot_file()), type(kernels._compiled).__name__)
"""
    run = _run(code, {"NUMBA_CACHE_DIR": str(tmp_path / "cache")})
    assert run.returncode == 0, run.stderr[-2000:]
    lines = run.stdout.split("\n")
    assert lines[0] == "short False False"
    assert lines[1] == "filling False True"
    assert lines[2] == "filled 0 True"
    aot = lines[4].split()[1] == "True"
    assert lines[3] == f"loaded {not aot} True"
    assert lines[4].split()[2] == ("Loops" if aot else "module")


def test_a_half_imported_compiled_module_is_not_used(monkeypatch):
    """While one thread imports numba's kernels (a recording's close), the module is already in
    ``sys.modules`` without its functions: a live engine in another thread took it from there
    and failed ("partially initialized module ... has no attribute 'lfilter'")."""
    import types

    half = types.ModuleType("gaitmon.dsp.kernels_numba")  # (no functions yet)
    monkeypatch.setitem(sys.modules, "gaitmon.dsp.kernels_numba", half)
    monkeypatch.setattr(kernels, "_compiled", None, raising=False)
    monkeypatch.setattr(kernels, "_aot_file", [None])  # (no module built ahead of time)
    monkeypatch.setattr(kernels, "_batch_rows", 0)
    assert not kernels.compiled_loaded()
    assert kernels.compiled_for(4000) is None
    data = _simulated(3000)
    got = GaitAwareKalman(100.0).process(*data)  # (old code: AttributeError)
    with kernels.use("python"):
        assert np.array_equal(got, GaitAwareKalman(100.0).process(*data))


def test_a_live_engine_runs_interpreted_after_the_process_loaded_numba():
    """A recording's close (or any long batch work) may load numba's kernels in a process
    whose live engine is streaming: the engine's blocks go on interpreted (no switch of form
    mid-connection, no compile or import on the live path), even big catch-up blocks."""
    pytest.importorskip("numba")
    import threading

    from helpers import make_engine, wait_for

    from gaitmon.dsp import kernels_numba

    with kernels.use("compiled"):  # loads numba's kernels in this process
        GaitAwareKalman(100.0).process(*_simulated(200))
    assert kernels.compiled_loaded()
    seen: list[str] = []
    real = kernels_numba.gait_aware_update

    def recorded(*args):  # type: ignore[no-untyped-def]
        seen.append(threading.current_thread().name)
        return real(*args)

    import unittest.mock

    with unittest.mock.patch.object(kernels_numba, "gait_aware_update", recorded):
        _, eng = make_engine(speed=40.0)
        with eng:
            wait_for(lambda: eng.samples_total >= 3000, what="data")
        assert kernels.compiled_for(5000) is not None  # (other work still takes them)
    assert seen == []  # (neither the engine nor the unit it reads)


def test_a_numba_that_cannot_cache_leaves_the_interpreted_loops_serving(monkeypatch, caplog):
    """numba raises RuntimeError ("cannot cache function ... no locator available"), not an
    ImportError, where it cannot write its cache folder or make a temporary file to test it: a
    long ``process`` failed with that line; now the interpreted loops serve, and it is logged."""
    import importlib.abc
    import logging

    name = "gaitmon.dsp.kernels_numba"

    class Unwritable(importlib.abc.MetaPathFinder):
        def find_spec(self, fullname, path, target=None):  # type: ignore[no-untyped-def]
            if fullname == name:
                raise RuntimeError("cannot cache function 'gait_aware_update': no locator "
                                   "available for file 'loops.py'")  # fmt: skip
            return None

    import gaitmon.dsp

    monkeypatch.delitem(sys.modules, name, raising=False)
    monkeypatch.delattr(gaitmon.dsp, "kernels_numba", raising=False)  # (imported before)
    monkeypatch.setattr(sys, "meta_path", [Unwritable(), *sys.meta_path])
    monkeypatch.setattr(kernels, "_compiled", None)
    monkeypatch.setattr(kernels, "_jit", None)
    monkeypatch.setattr(kernels, "_aot_file", [None])  # (no module built ahead of time)
    monkeypatch.setattr(kernels, "_unavailable", False)
    monkeypatch.setattr(kernels, "_batch_rows", kernels.LOAD_ROWS)
    monkeypatch.setattr(kernels, "cache_ready", lambda: True)
    data = _simulated(3000)
    with caplog.at_level(logging.WARNING, logger="gaitmon.dsp"):
        got = GaitAwareKalman(100.0).process(*data)  # (the old code: RuntimeError)
    assert not kernels.numba_available() and not kernels.compiled_loaded()
    assert "cannot cache function" in caplog.text
    with kernels.use("python"):
        assert np.array_equal(got, GaitAwareKalman(100.0).process(*data))

