"""``gaitmon bench --suite offline``: its CSV reference writes the export's columns, and without
pyarrow the benchmark says so in one line and still measures the export (not timed)."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest
from test_export import write_session

from gaitmon.commands import bench_offline
from gaitmon.export import export_session
from gaitmon.export.writers.outputs import csv_meta_path


def _rows(text: str) -> tuple[list[str], list[list[str]]]:
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], rows[1:]


def test_pyarrow_reference_writes_the_same_columns_and_values_as_the_csv_export(
    tmp_path: Path,
) -> None:
    pacsv = pytest.importorskip("pyarrow.csv")
    src = tmp_path / "walk.h5"
    write_session(src)  # events, a gap of 5 frames at row 300, three markers on two rows
    out = export_session(src, "csv", tmp_path / "x.csv", force=True).paths[0]
    head, rows = _rows(out.read_text(encoding="utf-8"))
    buf = io.BytesIO()
    pacsv.write_csv(bench_offline._pyarrow_table(src), buf)
    ref_head, ref_rows = _rows(buf.getvalue().decode("utf-8"))

    assert ref_head == head
    assert len(ref_rows) == len(rows) == 600
    ours = np.array([[float(v) for v in r[:-1]] for r in rows])
    theirs = np.array([[float(v) for v in r[:-1]] for r in ref_rows])
    # the export rounds each column to its stated decimals; pyarrow writes the value as read
    meta = json.loads(csv_meta_path(out).read_text(encoding="utf-8"))
    decimals = np.array([c["decimals"] for c in meta["columns"][:-1]], dtype=np.float64)
    assert np.all(np.abs(theirs - ours) <= 0.5 * 10.0**-decimals * (1 + 1e-6) + 1e-9)
    for name, want in (("heel_strike", 5), ("toe_off", 4), ("gap_lost_frames", 5)):
        assert theirs[:, head.index(name)].sum() == want
    assert [r[-1] for r in ref_rows] == [r[-1] for r in rows]
    assert ref_rows[150][-1] == rows[150][-1] != ""


def test_without_pyarrow_the_csv_row_runs_alone_and_says_how_to_install_it(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "pyarrow" else real(name, *a))
    ran: list[str] = []

    def fake_run(task: str, src: Path, outdir: Path) -> dict[str, float]:
        ran.append(task)
        return {"cpu_s": 1.0, "rss_mb": 50.0, "bytes": 10.0, "files": 2.0}

    monkeypatch.setattr(bench_offline, "_run", fake_run)
    monkeypatch.setattr(bench_offline, "session_file", lambda name: Path(__file__))
    assert bench_offline.suite(["1min"], 1, only="csv") == 0
    out = capsys.readouterr().out
    lines = [ln for ln in out.splitlines() if "pyarrow" in ln]
    assert lines[0] == ("pyarrow is not installed: the CSV row runs without its reference "
                        "(pip install '.[bench]' to measure pyarrow's write_csv beside it)")
    assert ran == ["csv"]
    assert "| CSV export | 1.00 |" in out


@pytest.mark.parametrize(("argv", "want"), [
    ([], (["1h", "8h"], 1)),
    (["--lengths", "1min,10min,1h,8h", "--repeat", "3"], (["1min", "10min", "1h", "8h"], 3)),
    (["--lengths", "8h"], (["8h"], 1)),
])
def test_memory_suite_takes_the_lengths_and_runs_asked_for(
    monkeypatch: pytest.MonkeyPatch, argv: list[str], want: tuple[list[str], int]
) -> None:
    """An explicit ``--lengths 1min,10min,1h,8h --repeat 3`` (the other suites' defaults)
    was taken for no option and became 1h,8h, one run."""
    from gaitmon.cli import main
    from gaitmon.commands import bench_memory

    got: list[tuple[list[str], int]] = []
    monkeypatch.setattr(bench_memory, "suite",
                        lambda lengths, repeat, only=None: got.append((lengths, repeat)) or 0)
    assert main(["bench", "--suite", "memory", *argv]) == 0
    assert got == [want]
