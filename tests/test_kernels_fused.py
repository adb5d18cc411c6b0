"""Issue 28 (batch pipeline + smoother >= 1.2 M frames per CPU s): the compiled passes that took
over whole per-block work (counts to physical units, the gravity reference's turn and low-pass,
the gait-aware filter's motion inputs, second-order low-passes two channels at a time, the
zeroed tilts and joints, the smoother's turn, right-hand side and wrap) have one source
(gaitmon.dsp.loops) run two ways, and both give the numpy path's numbers (1e-9) on simulated
and real walks in any chunking; the cache fill compiles every signature real work calls; batch
work readies the C heap once.

The interpreted form runs at the very call sites of the compiled one: ``kernels._load`` is
handed a stand-in module whose functions are the loops run on memoryviews.
"""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from gaitmon.dsp import kernels, loops

ROOT = Path(__file__).resolve().parents[1]
TOL = 1e-9
# the loops numba compiles (gaitmon.dsp.kernels_numba), by name
COMPILED = ("gait_aware_update", "constant_map_solve", "band_cholesky", "band_solve",
            "running_mean", "lfilter", "physical", "constant_rhs", "zeroed_tilts",
            "gravity_average", "gait_aware_inputs", "turned", "gyro_angle", "reduced",
            "stride_pass")  # fmt: skip


def _interpreted_module() -> SimpleNamespace:
    """The loops as numba's module offers them, run by the interpreter on memoryviews."""

    def wrap(f: Any) -> Any:
        def call(*args: Any) -> None:
            f(*[memoryview(a) if type(a) is np.ndarray else a for a in args])

        return call

    return SimpleNamespace(**{name: wrap(getattr(loops, name)) for name in COMPILED})


def _walk(n: int = 9000, seed: int = 7) -> np.ndarray:
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import simulate

    return simulate(n, GaitModel(GaitConfig(seed=seed, standing_s=2.0))).counts


def _real_counts(shared_data: Path, dataset: str, name: str) -> np.ndarray:
    """A real foot IMU's walk as raw counts of all four segments (each tuning reads it its own
    way; the force sensors at rest)."""
    from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX
    from gaitmon.lab import datasets

    read = {"gdins": datasets.read_gdins, "xio": datasets.read_xio}[dataset]
    trial = next(t for t in read(shared_data) if t.name == name)
    rows = slice(0, min(len(trial), 9000))
    phys = np.zeros((rows.stop, len(DEFAULT_TABLE.channels)))
    for idx, a in ((ACC_X_IDX, trial.acc_x), (ACC_Z_IDX, trial.acc_z),
                   (GYRO_IDX, trial.gyro_y - np.median(trial.gyro_y))):  # fmt: skip
        phys[:, idx] = a[rows, None]
    return DEFAULT_TABLE.to_counts(phys)


def _run(counts: np.ndarray, block: int, module: Any) -> dict[str, np.ndarray]:
    """The pipeline over ``counts`` in blocks of ``block`` rows (a new calibration at row 3000),
    and the smoother over the record from the pipeline's filter, with the loops of ``module``
    (None: the numpy path, numba not used)."""
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import DEFAULT_TABLE
    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.dsp.smoother import release_factors
    from gaitmon.finish.smoothed import smoothed_blocks

    n = len(counts)
    cal = Calibration(np.full(4, 0.05), np.full(4, 0.003))
    out: dict[str, list[np.ndarray]] = {}
    form = "python" if module is None else "compiled"
    saved = kernels._load
    if module is not None:
        kernels._load = lambda jit=False: module  # type: ignore[assignment]
    try:
        with kernels.use(form):
            p = Pipeline()
            for a, b in itertools.pairwise(sorted({*range(0, n, block), 3000, n})):
                if a == 3000:
                    p.set_calibration(cal)
                blk = p.process(counts[a:b])
                for name in ("acc_ms2", "fsr_counts", "tilt_acc_rad", "tilt_gyro_rad",
                             "tilt_kalman_rad", "tilt_kalman_continuous_rad",
                             "joint_kalman_rad"):  # fmt: skip
                    out.setdefault(name, []).append(getattr(blk, name))
            first = np.concatenate(out["tilt_kalman_continuous_rad"])
            release_factors()
            smoothed = [t for _, t in smoothed_blocks(
                lambda a, b: counts[a:b], n, DEFAULT_TABLE, Calibration.identity(),
                [(3000, cal)], np.empty(0), 100.0, lambda a, b, rows: first[a:b])]  # fmt: skip
    finally:
        kernels._load = saved  # type: ignore[method-assign]
        release_factors()
    res = {k: np.concatenate(v) for k, v in out.items()}
    res["smoothed"] = np.concatenate(smoothed)
    return res


def _worst(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> float:
    assert a.keys() == b.keys()
    return max(float(np.max(np.abs(a[k] - b[k]))) for k in a)


def _both_forms(counts: np.ndarray) -> dict[str, float]:
    """The worst differences between the forms over ``counts`` (and the smoothed range, to
    tell a walk from a still board): the compiled passes against the numpy path, the
    interpreted against the compiled, and small blocks (live ticks to batch chunks, the
    interpreted form, a head) against one whole block."""
    pytest.importorskip("numba")
    numpy_path = _run(counts, 4096, None)
    compiled = _run(counts, 16384, kernels._load())
    interpreted = _run(counts, 16384, _interpreted_module())
    blocks = 0.0
    for block in (1, 7, 250):
        rows = 1200 if block == 1 else 4000
        head = _run(counts[:rows], block, _interpreted_module())
        blocks = max(blocks, _worst(head, _run(counts[:rows], rows, kernels._load())))
    return {"smoothed_range": float(np.ptp(compiled["smoothed"])),
            "compiled_vs_numpy": _worst(compiled, numpy_path),
            "interpreted_vs_compiled": _worst(interpreted, compiled),
            "blocks_vs_whole": blocks}  # fmt: skip


def _differing(worst: dict[str, float]) -> list[str]:
    """The comparisons of :func:`_both_forms` beyond TOL (NaN included)."""
    return [key for key in ("compiled_vs_numpy", "interpreted_vs_compiled", "blocks_vs_whole")
            if not worst[key] <= TOL]  # fmt: skip


def test_the_fused_passes_give_the_numpy_numbers_in_both_forms_on_a_simulated_walk():
    worst = _both_forms(_walk())
    assert worst["smoothed_range"] > 0.5  # a walk, not a still board
    assert _differing(worst) == [], worst


@pytest.mark.parametrize(("dataset", "name"), [("gdins", "exp33"), ("xio", "short_walk")])
def test_the_fused_passes_give_the_numpy_numbers_in_both_forms_on_real_walks(
    shared_data, dataset, name
):
    worst = _both_forms(_real_counts(shared_data, dataset, name))
    assert worst["smoothed_range"] > 0.5  # a walk, not a still board
    assert _differing(worst) == [], worst


def test_the_loops_with_odd_channels_and_wrapped_angles():
    """The pair-wise second-order low-pass with an odd channel count, and the wrap at the
    boundaries (+-pi, a turn and more, NaN and inf) against numpy's wrap_angle."""
    from gaitmon.dsp.angles import JOINT_MINUS, JOINT_PLUS, joint_angles, wrap_angle
    from gaitmon.dsp.iir import LinearFilter, butter_lowpass

    rng = np.random.default_rng(4)
    x = rng.standard_normal((500, 3))
    b, a = butter_lowpass(2, 4.0, 100.0)
    want = LinearFilter(b, a, 3).process(x)  # the numpy block form
    z = np.zeros((2, 3))
    got = np.empty_like(x)
    loops.lfilter(memoryview(b), memoryview(a), memoryview(x), memoryview(z), memoryview(got))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    tilt = np.array([[np.pi, -np.pi, 3 * np.pi, -7.5], [np.nan, np.inf, 1e-3, 50.0],
                     *rng.uniform(-20, 20, (40, 4))])  # fmt: skip
    out_t, out_j = np.empty_like(tilt), np.empty((len(tilt), 3))
    offset = np.array([0.1, -0.2, 0.0, 0.3])
    loops.zeroed_tilts(*map(memoryview, (tilt, offset, JOINT_PLUS, JOINT_MINUS, out_t, out_j)))
    with np.errstate(invalid="ignore"):  # (inf - inf: NaN, as the loop gives)
        want_t = wrap_angle(tilt - offset)
    np.testing.assert_array_equal(out_t, want_t)
    np.testing.assert_array_equal(out_j, joint_angles(want_t))


def test_the_cache_fill_compiles_every_signature_real_work_calls():
    """numba compiles a signature it has not cached at the call (seconds): after the fill's
    ``compile_all``, a pipeline streamed over a walk in replay chunks and the smoother over
    it add no signature to any compiled loop (a column-major input or a read-only array would
    have added one)."""
    pytest.importorskip("numba")
    code = """
import itertools, sys
import numpy as np
from gaitmon.dsp import kernel_fill, kernels, kernels_numba
from gaitmon.io.sim import GaitConfig, GaitModel
from gaitmon.io.sim.sensors import simulate
from gaitmon.commands.bench_passes import both

kernel_fill.compile_all()
names = [n for n in dir(kernels_numba) if hasattr(getattr(kernels_numba, n), "signatures")]
before = {n: set(getattr(kernels_numba, n).signatures) for n in names}
counts = simulate(30000, GaitModel(GaitConfig(seed=3, standing_s=2.0))).counts
with kernels.use("compiled"):
    both(counts)
after = {n: set(getattr(kernels_numba, n).signatures) for n in names}
print(sorted(names))
print({n: [str(s) for s in after[n] - before[n]] for n in names if after[n] - before[n]})
"""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=900, cwd=ROOT)  # fmt: skip
    assert run.returncode == 0, run.stderr[-3000:]
    names, added = run.stdout.strip().splitlines()[-2:]
    assert set(COMPILED) <= set(eval(names))  # every loop is compiled by the fill
    assert added == "{}"


def test_batch_work_readies_the_heap_once_and_live_work_not(monkeypatch):
    """``kernels.expect`` of batch work (the replay's and the smoother's) readies the C heap
    once per process (``batch_heap``: its effect, ~100 000 fewer page faults per hour of
    record, is the bench's to show, not a test's); a live block's size does not."""
    made: list[int] = []
    real_empty = np.empty

    def empty(shape: Any, *args: Any, **kwargs: Any) -> np.ndarray:
        if shape == kernels.HEAP_BYTES:
            made.append(shape)
        return real_empty(shape, *args, **kwargs)

    monkeypatch.setattr(kernels, "_heap_ready", False)
    monkeypatch.setattr(kernels.np, "empty", empty)
    with kernels.use("python"):  # (the form does not matter: no loop runs)
        kernels.expect(10)
        assert made == []
        kernels.expect(kernels.BATCH_CALL_ROWS)
        kernels.expect(1_000_000)
    assert made == [kernels.HEAP_BYTES]
