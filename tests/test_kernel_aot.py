"""Issue 28: the loops compiled ahead of time (gaitmon.dsp.kernel_aot): built by the cache
filler from the one source (gaitmon.dsp.loops), loaded by the rule in place of numba's, so a
``gaitmon process`` imports no numba and writes the numbers the interpreted loops write (1e-9);
a call whose arguments the built types do not fit (another dtype, a read-only array) runs in
another form, never in the module (whose wrappers would read the memory as the wrong type);
a damaged module is not used.

The filler runs once per module into a cache folder of its own (``NUMBA_CACHE_DIR``).
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba")

from helpers import numeric_datasets

from gaitmon.dsp import kernel_aot, loops

ROOT = Path(__file__).resolve().parents[1]


def _run(code: str, cache: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(cache)}
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          timeout=600, cwd=ROOT)  # fmt: skip


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> tuple[Path, Path]:
    """(the cache folder, the module's file) after the filler ran."""
    cache = tmp_path_factory.mktemp("numba-cache")
    run = _run("from gaitmon.dsp.kernel_fill import main; main([])\n"
               "from gaitmon.dsp.kernel_cache import aot_file, cache_ready\n"
               "print(aot_file()); print(cache_ready())", cache)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    path, ready = run.stdout.split()
    assert ready == "True"
    if not os.path.exists(path):
        pytest.skip("numba's pycc could not build the loops here (no C compiler or Python "
                    "headers): numba's cached loops serve")  # fmt: skip
    assert os.path.exists(path + ".json")  # (the types each call is checked against)
    return cache, Path(path)


def test_process_runs_the_built_loops_without_numba_and_writes_the_interpreted_numbers(
    built, tmp_path, record_simulated
):  # fmt: skip
    cache, _ = built
    walk = record_simulated(tmp_path / "walk.h5", duration_s=40)
    fast, plain = tmp_path / "fast.h5", tmp_path / "plain.h5"
    code = f"""
import sys
from gaitmon.cli import main
from gaitmon.dsp import kernels
rc = main(["process", {str(walk)!r}, "-o", {str(fast)!r}, "--quiet"])
print("numba" in sys.modules, type(kernels._compiled).__name__)
sys.exit(rc)
"""
    run = _run(code, cache)
    assert run.returncode == 0, run.stderr[-2000:]
    # a 40-s record: the built module serves it (before, the interpreted loops: loading
    # numba's would have cost more than it saved), and numba is never imported
    assert run.stdout.split() == ["False", "Loops"]
    code = f"""
import sys
from gaitmon.cli import main
from gaitmon.dsp import kernels
with kernels.use("python"):
    rc = main(["process", {str(walk)!r}, "-o", {str(plain)!r}, "--quiet"])
sys.exit(rc)
"""
    run = _run(code, cache)
    assert run.returncode == 0, run.stderr[-2000:]
    a, b = numeric_datasets(fast), numeric_datasets(plain)
    assert a.keys() == b.keys()
    assert {"processed/tilt_deg", "smoothed/tilt_deg", "strides/stride_length_m"} <= a.keys()
    for name in a:
        np.testing.assert_allclose(a[name].astype(float), b[name].astype(float), rtol=0,
                                   atol=1e-9, err_msg=name)  # fmt: skip
    assert len(a["events/heel_strike"]) > 10 and np.ptp(a["smoothed/tilt_deg"]) > 1000


def _spd_band(m: int) -> np.ndarray:
    """A symmetric positive definite matrix with two off-diagonals, in upper band form."""
    ab = np.zeros((3, m))
    ab[2] = 4.0 + np.arange(m) % 3
    ab[1, 1:] = -1.0
    ab[0, 2:] = 0.5
    return ab


def test_a_call_the_built_types_do_not_fit_runs_in_another_form(built):
    """The module's wrappers convert without checking: a float32 array would be read as
    float64 memory (a crash, or wrong numbers), a read-only one written. Such calls go to the
    fallback; arrays of the right type in any layout run in the module, with the interpreted
    loop's numbers."""
    _, path = built
    refused: list[str] = []

    def fallback(name: str):  # type: ignore[no-untyped-def]
        return lambda *args: refused.append(name)  # (each call the module refused)

    mod = kernel_aot.load(str(path), fallback)
    assert mod is not None
    want = _spd_band(40)
    loops.band_cholesky(memoryview(want))  # the interpreted loop: the reference
    got = _spd_band(40)
    mod.band_cholesky(got)
    assert refused == [] and np.abs(got - want).max() < 1e-12
    strided = np.asfortranarray(_spd_band(40))  # (another layout: the same numbers)
    mod.band_cholesky(strided)
    assert refused == [] and np.abs(strided - want).max() < 1e-12
    single = _spd_band(40).astype(np.float32)
    mod.band_cholesky(single)
    frozen = _spd_band(40)
    frozen.flags.writeable = False
    mod.band_cholesky(frozen)
    mod.band_cholesky(_spd_band(40)[None])  # (another number of dimensions)
    mod.band_cholesky(_spd_band(40), 1)  # (another number of arguments)
    swapped = _spd_band(40).astype(">f8")  # float64, but big-endian: other bytes
    mod.band_cholesky(swapped)
    assert refused == ["band_cholesky"] * 5
    assert np.array_equal(swapped, _spd_band(40))  # (untouched)
    assert np.array_equal(single, _spd_band(40).astype(np.float32))  # (untouched)


def test_a_damaged_module_is_not_used(tmp_path, caplog):
    path = tmp_path / "gaitmon_loops_0123456789abcdef.so"
    path.write_bytes(b"\x7fELF not a library")
    (tmp_path / (path.name + ".json")).write_text("{}")
    with caplog.at_level(logging.WARNING, logger="gaitmon.dsp"):
        assert kernel_aot.load(str(path), lambda name: None) is None
    assert "are not used" in caplog.text
    assert kernel_aot.load(str(tmp_path / "absent.so"), lambda name: None) is None
