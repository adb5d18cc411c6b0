"""Issue 28, the stride measures' cost: the strapdown pass in its three forms gives the same
numbers (to the bit where numpy's sines are the C library's, as on Linux; else to 1e-9), and
the foot board's units come from the raw counts as before.

The numpy pass (gaitmon.dsp.stride_integrate ``_Batch``, itself pinned to the per-stride spec
by tests/test_stride_batched.py) and the loop gaitmon.dsp.loops.stride_pass, run by the
interpreter on memoryviews (at the very call site: ``_compiled_loops`` hands it over, as the
rule hands over numba's module) and compiled by numba, on a simulated walk in every variant of
test_stride_batched (the board yawed 30 deg on the foot: the bisection; pauses, first steps,
near-still stances, lost frames) and on the real foot-IMU walks (gdins, three with the board
yawed ~25 deg; the x-io loops). And ``foot_imu_from_counts`` (each foot column on its own, the
bias subtracted a run of rows at a time) against the formula it had, with calibration changes
before, inside and after the block, two at one row."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from gaitmon.dsp import loops, stride_integrate
from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX, SEGMENTS
from gaitmon.dsp.gyro_events import gyro_gait_events
from gaitmon.dsp.stride_length import foot_imu_from_counts, stride_measures
from tests.test_stride_batched import _assert_same, _variants, _walk


def _numpy_sines_are_the_c_librarys() -> bool:
    """Whether numpy's float64 sine and cosine give the C library's bits (math.sin, what the
    loop calls in both forms): then every form gives numpy's numbers to the bit; where numpy
    has sines of its own (another platform's build), to rounding (1e-9)."""
    import math

    x = np.linspace(-2.0, 2.0, 20001)
    return (np.sin(x).tobytes() == np.array([math.sin(v) for v in x]).tobytes()
            and np.cos(x).tobytes() == np.array([math.cos(v) for v in x]).tobytes())


def _assert_form(got, want):
    if _numpy_sines_are_the_c_librarys():
        _assert_same(got, want)
        return
    for name in ("heel_strike_idx", "foot_flat_idx", "flags"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    for name in ("stride_length_m", "foot_clearance_m", "stride_time_s"):
        np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-9,
                                   atol=1e-12, err_msg=name)  # fmt: skip


def _interpreted(*args):
    loops.stride_pass(*[memoryview(a) if type(a) is np.ndarray else a for a in args])


def _forms():
    """(name, the loops _compiled_loops hands over) of each form the pass runs in."""
    forms = [("numpy", None), ("interpreted", SimpleNamespace(stride_pass=_interpreted))]
    try:
        from gaitmon.dsp import kernels_numba
    except ImportError:
        return forms
    return [*forms, ("compiled", kernels_numba)]


def _measures_in_each_form(monkeypatch, args, kwargs, forms):
    calls = {"n": 0}
    out = {}
    for name, module in forms:
        def pick(rows, module=module):
            calls["n"] += module is not None
            return module

        monkeypatch.setattr(stride_integrate, "_compiled_loops", pick)
        out[name] = stride_measures(*args, **kwargs)
    assert calls["n"] >= len(forms) - 1  # the loops ran (each form but numpy)
    return out


@pytest.mark.parametrize("seed", [41, 42])
def test_the_pass_gives_numpys_numbers_in_every_form_on_simulated_walks(monkeypatch, seed):
    opts = ({"turn_every_strides": 6.0, "turn_in_swing": True} if seed == 41 else
            {"stance_micro_rad": 0.15, "cadence_steps_min": 130.0})  # fmt: skip
    ax, az, gy, hs = _walk(seed, **opts)
    n = 0
    for args, kwargs in _variants(ax, az, gy, hs, seed):
        got = _measures_in_each_form(monkeypatch, args, kwargs, _forms())
        for name in got:
            _assert_form(got[name], got["numpy"])
        n += int(np.isfinite(got["numpy"].stride_length_m).sum())
    assert n >= 200


def test_the_pass_gives_numpys_numbers_on_real_walks(monkeypatch, shared_data):
    """Every gdins trial and x-io loop, numpy and compiled (the interpreter on two trials, one
    with the board yawed on the foot, for time); as it is and with the board yawed 30 deg more
    (the bisection)."""
    from gaitmon.lab import datasets
    from gaitmon.lab.real_gait import gyro_bias_at_start

    trials = datasets.read_gdins(shared_data) + datasets.read_xio(shared_data)
    if len(trials) < 18:
        pytest.skip("gdins_footprints or xio_closed_loop_walks is not complete")
    forms = _forms()
    c = np.cos(np.radians(30.0))
    n = 0
    for k, t in enumerate(trials):
        gy = t.gyro_y - gyro_bias_at_start(t)
        hs, _ = gyro_gait_events(gy, t.fs_hz)
        use = forms if k in (0, 8) else [f for f in forms if f[0] != "interpreted"]
        for args in ((t.acc_x, t.acc_z, gy, t.fs_hz, hs), (t.acc_x, c * t.acc_z, c * gy,
                                                           t.fs_hz, hs)):  # fmt: skip
            got = _measures_in_each_form(monkeypatch, args, {"first_steps": True}, use)
            for name in got:
                _assert_form(got[name], got["numpy"])
            n += int(np.isfinite(got["numpy"].stride_length_m).sum())
    assert n >= 2000


def _old_foot_imu(adc, first_row, table, calibration, changes):
    """foot_imu_from_counts as it was before issue 28's change (the spec)."""
    foot = SEGMENTS.index("foot")
    cols = [int(ACC_X_IDX[foot]), int(ACC_Z_IDX[foot]), int(GYRO_IDX[foot])]
    counts = np.asarray(adc)[:, cols].astype(np.float64)
    phys = (counts - table.zero_counts[cols]) * table.units_per_count[cols]
    bias = np.full(len(phys), float(calibration.gyro_bias_rad_s[foot]))
    for row, cal in sorted(changes, key=lambda x: x[0]):
        bias[max(0, row - first_row):] = float(cal.gyro_bias_rad_s[foot])
    return phys[:, 0], phys[:, 1], phys[:, 2] - bias


def test_foot_units_from_counts_as_before():
    rng = np.random.default_rng(5)
    adc = rng.integers(0, 1 << 16, (5000, len(DEFAULT_TABLE.zero_counts)), dtype=np.uint16)
    foot = SEGMENTS.index("foot")

    def cal(bias):
        b = np.zeros(len(SEGMENTS))
        b[foot] = bias
        return Calibration(np.zeros(len(SEGMENTS)), b)

    base = cal(0.013)
    cases = [
        [],
        [(2500, cal(-0.02))],
        [(7000, cal(0.5)), (100, cal(0.03)), (100, cal(-0.07)), (4999, cal(0.2))],
        [(0, cal(0.1)), (200, cal(0.05))],
    ]
    for first_row in (0, 150, 3000):
        for changes in cases:
            got = foot_imu_from_counts(adc, first_row, DEFAULT_TABLE, base, changes)
            want = _old_foot_imu(adc, first_row, DEFAULT_TABLE, base, changes)
            for a, b in zip(got, want, strict=True):
                assert a.dtype == np.float64 and a.tobytes() == np.ascontiguousarray(b).tobytes()


def test_the_cache_fill_compiles_the_signature_a_records_strides_call():
    """numba compiles a signature it has not cached at the call (seconds): after the fill's
    ``compile_all``, the stride measures of a simulated record read a block at a time (as
    ``/strides`` is stored at a close) add none to the pass."""
    pytest.importorskip("numba")
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    code = """
import numpy as np
from gaitmon.dsp import kernel_fill, kernels, kernels_numba
from gaitmon.dsp.stride_length import record_stride_measures
from tests.test_stride_batched import _walk

kernel_fill.compile_all()
before = set(kernels_numba.stride_pass.signatures)
ax, az, gy, hs = _walk(41)
with kernels.use("compiled"):
    m = record_stride_measures(lambda a, b: (ax[a:b], az[a:b], gy[a:b]), len(gy), 100.0, hs,
                               strides_per_block=16)
print(len(before), int(np.isfinite(m.stride_length_m).sum()))
print([str(s) for s in set(kernels_numba.stride_pass.signatures) - before])
"""
    env = {**os.environ, "PYTHONPATH": str(root)}
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=900, cwd=root)  # fmt: skip
    assert run.returncode == 0, run.stderr[-3000:]
    counts, added = run.stdout.strip().splitlines()[-2:]
    n_sigs, n_strides = map(int, counts.split())
    assert n_sigs == 1 and n_strides >= 40
    assert added == "[]"
