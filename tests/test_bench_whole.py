"""``gaitmon bench --suite whole`` (issue 28's goals): every row runs tiny and prints its
reference and ratio; the VQF reference reads a session and writes one quaternion per row and
segment, from the same physical units as gaitmon's channel table (nothing timed)."""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gaitmon.commands import bench_whole


@pytest.fixture(scope="module")
def one_minute(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from gaitmon.commands.bench_offline import write_session

    path = tmp_path_factory.mktemp("whole") / "one_minute.h5"
    write_session(path, 1 / 60)
    return path


def test_the_vqf_reference_writes_a_quaternion_per_row_and_segment_from_gaitmons_units(
    one_minute: Path, tmp_path: Path
) -> None:
    pytest.importorskip("vqf")
    import h5py

    from gaitmon.commands import bench_vqf
    from gaitmon.dsp.channels import DEFAULT_TABLE, SEGMENTS

    with h5py.File(one_minute, "r") as f:
        adc = f["raw/adc"][()]
        table = f["device/channels"][()]
    # the script converts from the file's table itself: the same numbers as gaitmon's
    np.testing.assert_allclose(bench_vqf.physical(adc, table), DEFAULT_TABLE.to_physical(adc),
                               rtol=1e-12, atol=1e-12)  # fmt: skip
    out = tmp_path / "vqf.h5"
    # run as the suite runs it: by path, -P, nothing of gaitmon imported
    probe = (f"import runpy, sys; sys.argv = ['x', {str(one_minute)!r}, {str(out)!r}]; "
             f"runpy.run_path({str(bench_whole.VQF_SCRIPT)!r}, run_name='__main__'); "
             "print(sorted(m for m in sys.modules if m.startswith('gaitmon')))")  # fmt: skip
    r = subprocess.run([sys.executable, "-P", "-c", probe], capture_output=True, text=True,
                       check=False, cwd=tmp_path)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"
    with h5py.File(out, "r") as f:
        assert sorted(f["vqf"]) == sorted(SEGMENTS)
        for seg in SEGMENTS:
            q = f[f"vqf/{seg}/quat6D"]
            assert q.shape == (len(adc), 4)
            assert q.dtype == np.float32 and q.compression == "gzip"
            np.testing.assert_allclose(np.linalg.norm(q[()], axis=1), 1.0, atol=1e-5)


def test_a_row_whose_package_is_missing_says_what_to_install(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name in ("vqf", "PySide6") else real(name, *a))
    rows = {r.key: r for r in bench_whole.ROWS}
    ctx = bench_whole.Context({"short": "1min", "long": "1min", "longest": "1min"},
                              Path("/nonexistent"), 1.0)  # fmt: skip
    results = [bench_whole._measure_row(rows[k], ctx, 1) for k in ("process", "live")]
    assert [r.skip for r in results] == [
        "skipped: pip install 'vqf>=2' (or '.[bench]'): the reference",
        "skipped: pip install PySide6-Essentials pyqtgraph",
    ]
    bench_whole.print_table(results, 1)
    out = capsys.readouterr().out
    assert "| whole `gaitmon process`, 1min | <= 1x | skipped: pip install 'vqf>=2'" in out


def test_goals_are_judged_on_the_ratio_or_the_figure_in_the_right_direction() -> None:
    rows = {r.key: r for r in bench_whole.ROWS}
    assert rows["process"].met(2.0, 2.0) and not rows["process"].met(2.1, 2.0)
    assert rows["process_short"].met(0.35, 0.01) and not rows["process_short"].met(0.36, 10.0)
    assert rows["pipeline"].met(1.2, 9.0) and not rows["pipeline"].met(1.19, 0.1)
    assert rows["info"].goal_text() == "<= 1.2x" and rows["pipeline"].goal_text() == (
        ">= 1.2 M frames/CPU s")


@pytest.mark.slow
@pytest.mark.timeout(900)  # eleven rows in whole processes, on a busy 2-core machine
def test_every_row_runs_tiny_and_prints_its_reference_and_ratio(tmp_path: Path) -> None:
    env = dict(os.environ, TMPDIR=str(tmp_path), QT_QPA_PLATFORM="offscreen",
               NUMBA_CACHE_DIR=os.environ.get("NUMBA_CACHE_DIR", ""))  # fmt: skip
    if not env["NUMBA_CACHE_DIR"]:
        del env["NUMBA_CACHE_DIR"]
    r = subprocess.run([sys.executable, "-m", "gaitmon", "bench", "--suite", "whole",
                        "--lengths", "1min,1min,1min", "--repeat", "1", "--gui-seconds", "2"],
                       capture_output=True, text=True, env=env, check=False, timeout=850)
    assert r.returncode == 0, r.stderr[-2000:]
    table = r.stdout[r.stdout.index("| measure | goal | gaitmon | reference | ratio |"):]
    body = table.splitlines()[2 : 2 + len(bench_whole.ROWS)]
    for row, line in zip(bench_whole.ROWS, body, strict=True):
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[:2] == [row.measure.format(short="1min", long="1min", longest="1min"),
                             row.goal_text()]  # fmt: skip
        if cells[2].startswith("skipped: pip install"):
            continue
        mine, ref = (float(c.split()[0]) for c in cells[2:4])
        assert row.reference in cells[3]
        assert math.isfinite(mine) and math.isfinite(ref) and ref > 0
        assert re.fullmatch(r"\d+\.\d\dx", cells[4])
        assert cells[5] in ("pass", "FAIL")
        assert re.fullmatch(r"\d+\.\d -> \d+\.\d", cells[6])
    assert re.search(r"at the end: load average \d", r.stdout)


@pytest.mark.parametrize(("lengths", "only", "says"), [
    ("1min,1h", "", "--lengths for --suite whole is SHORT,LONG,LONGEST"),
    ("1min,1h,9h", "", "got '1min,1h,9h'"),
    (None, "process,nope", "unknown row 'nope' for --only (choose from process, "),
])  # fmt: skip
def test_bad_lengths_or_rows_are_one_line_before_anything_runs(
    lengths: str | None, only: str, says: str, capsys: pytest.CaptureFixture[str]
) -> None:
    import argparse

    from gaitmon.errors import UserError

    args = argparse.Namespace(lengths=lengths, repeat=1, only=only, gui_seconds=1.0)
    with pytest.raises(UserError, match=re.escape(says)):
        bench_whole.suite(args)
    assert capsys.readouterr().out == ""
