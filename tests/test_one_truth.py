"""One recording, one answer everywhere (issue 25, defects 7 and 10): the side nobody entered,
the unit of a per-stride export's count, and a recording's duration read the same in
``gaitmon info``, the report (its PDF's text), the review window, ``compare`` (its PDF and the
review's Compare view) and the export's summary line.

The sessions are the simulator's walk written with SessionWriter (tests/conftest.py), 2537
samples at 100 Hz: 25.37 s, not a whole second, so a rounding ("25 s") cannot pass. The unit
itself says "R" in its IDENTITY (/device side), as the simulated unit does; nobody entered a
side (/session side "").
"""

from __future__ import annotations

import csv
import re
import shutil
import subprocess
from pathlib import Path

import h5py
import pytest
from conftest import write_simulated_session
from PySide6.QtWidgets import QFileDialog

from gaitmon.cli import main

N = 2537  # 25.37 s at 100 Hz
WAIT_MS = 20_000


def _session(path: Path, n: int, side: str, created_utc: str) -> Path:
    write_simulated_session(path, n=n, side=side, created_utc=created_utc)
    with h5py.File(path, "a") as f:
        f["device"].attrs["side"] = "R"  # the unit's own idea (the simulator says R)
    return path


@pytest.fixture(scope="module")
def sessions(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two visits of one patient, no side entered: 25.37 s and 26.04 s."""
    d = tmp_path_factory.mktemp("truth")
    return (_session(d / "visit1.h5", N, "", "2026-10-01T09:00:00Z"),
            _session(d / "visit2.h5", 2604, "", "2026-11-01T09:00:00Z"))  # fmt: skip


def _duration(path: Path) -> str:
    """The stored duration, to a tenth of a second, by hand (not gaitmon's formatter)."""
    with h5py.File(path) as f:
        d = float(f.attrs["duration_s"])
    assert abs(d - N / 100.0) < 0.02 or abs(d - 26.04) < 0.02  # not a whole second
    return f"{d:.1f} s"


def _pdf_text(pdf: Path) -> str:
    if not shutil.which("pdftotext"):
        pytest.skip("pdftotext (poppler-utils) is not installed")
    out = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True,
                         text=True, check=True)  # fmt: skip
    return " ".join(out.stdout.split())


def _info(capsys: pytest.CaptureFixture[str], path: Path) -> str:
    capsys.readouterr()
    assert main(["info", str(path)]) == 0
    return capsys.readouterr().out


def _report_text(path: Path, tmp_path: Path) -> str:
    pdf = tmp_path / f"{path.stem}.pdf"
    assert main(["report", str(path), "-o", str(pdf), "-q"]) == 0
    return _pdf_text(pdf)


# ---------------------------------------------------------------------------------------------
# 7. A side nobody entered
# ---------------------------------------------------------------------------------------------


def test_a_side_nobody_entered_reads_not_recorded_in_info_and_the_report(
        qapp, sessions, tmp_path, capsys):  # fmt: skip
    path = sessions[0]
    info = _info(capsys, path)
    assert re.search(r"\bside not recorded\b", info), info
    text = _report_text(path, tmp_path)
    # the header's cells: "SIDE MEASURED" over its value (pdftotext -layout: the labels'
    # row, then the values' row, in the same order)
    assert "SIDE MEASURED" in text
    assert "Right" not in text and "right" not in text.split("SIDE MEASURED")[1][:200], text
    assert "not recorded" in text.split("SIDE MEASURED")[1][:200], text


def test_an_entered_side_reads_the_same_in_info_and_the_report(qapp, tmp_path, capsys):
    path = _session(tmp_path / "left.h5", N, "L", "2026-10-01T09:00:00Z")
    info = _info(capsys, path)
    assert re.search(r"\bside left\b", info), info
    from gaitmon.report import report_from_file

    assert report_from_file(path).header.side == "left"  # though the unit says R
    text = _report_text(path, tmp_path)
    assert "left" in text.split("SIDE MEASURED")[1][:200], text


# ---------------------------------------------------------------------------------------------
# 10. The unit of the count, and one duration
# ---------------------------------------------------------------------------------------------


def test_strides_export_counts_strides_not_samples(sessions, tmp_path, capsys):
    out = tmp_path / "walk.strides.csv"
    capsys.readouterr()
    assert main(["export", str(sessions[0]), "--format", "strides", "-o", str(out)]) == 0
    line = capsys.readouterr().out
    with open(out, newline="", encoding="utf-8") as f:
        n_rows = sum(1 for _ in csv.reader(f)) - 1  # the header
    assert n_rows > 10
    assert f"exported {n_rows} strides (raw mode)" in line, line
    assert "samples" not in line
    # a sample export still counts samples
    assert main(["export", str(sessions[0]), "--format", "csv", "-o",
                 str(tmp_path / "walk.csv")]) == 0  # fmt: skip
    assert f"exported {N:,} samples (raw mode)" in capsys.readouterr().out


def test_one_duration_in_info_the_report_and_compare(qapp, sessions, tmp_path, capsys):
    first, second = sessions
    d1, d2 = _duration(first), _duration(second)
    assert d1 == "25.4 s" and d2 == "26.0 s"
    assert f", {d1}, " in _info(capsys, first)
    assert "DURATION" in (rep := _report_text(first, tmp_path)) and d1 in rep, rep
    pdf = tmp_path / "compare.pdf"
    assert main(["compare", str(first), str(second), "-o", str(pdf), "-q"]) == 0
    text = _pdf_text(pdf)
    assert d1 in text and d2 in text, text


def test_one_duration_in_the_review_window_and_its_compare_view(
        review_win, qtbot, monkeypatch, sessions):  # fmt: skip
    first, second = sessions
    d1, d2 = _duration(first), _duration(second)
    win = review_win
    with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
        win.open_file(first)
    msg = win.statusBar().currentMessage()
    assert f"({d1})" in msg and "side not recorded" in msg, msg
    monkeypatch.setattr(QFileDialog, "getOpenFileNames",
                        staticmethod(lambda *a, **k: ([str(first), str(second)], "")))
    with qtbot.waitSignal(win.comparer.compared, timeout=WAIT_MS):
        win.act["compare_sessions"].trigger()
    text = win.comparer.view.sessions.text()
    assert f"visit1.h5 · {d1}" in text and f"visit2.h5 · {d2}" in text, text


def test_a_side_nobody_entered_is_not_the_units_side_in_c3d_and_bids(sessions, tmp_path, capsys):
    """The C3D and BIDS exports took the unit's IDENTITY side ("R") when nobody entered one,
    while info and the report say "not recorded": they now follow the session's side too."""
    ezc3d = pytest.importorskip("ezc3d")
    path = sessions[0]
    c3d = tmp_path / "walk.c3d"
    assert main(["export", str(path), "--format", "c3d", "-o", str(c3d), "-q"]) == 0
    c = ezc3d.c3d(str(c3d))
    P = c["parameters"]
    assert P["GAITMON"]["SIDE"]["value"] == ["unknown"]
    labels = P["POINT"]["LABELS"]["value"]
    assert not [x for x in labels if x.startswith(("R", "L")) and x[1].isupper()], labels
    contexts = set(P["EVENT"]["CONTEXTS"]["value"]) if "EVENT" in P else set()
    assert "Right" not in contexts and "Left" not in contexts, contexts
    assert main(["export", str(path), "--format", "bids", "-o", str(tmp_path / "b"), "-q",
                 "--subject", "01"]) == 0  # fmt: skip
    [chans] = list((tmp_path / "b").rglob("*_channels.tsv"))
    rows = [line.split("\t") for line in chans.read_text().splitlines()]
    col = rows[0].index("tracked_point")
    points = {r[col] for r in rows[1:]}
    assert not [p for p in points if p.startswith(("Right", "Left"))], points
    # an entered side is still used
    left = _session(tmp_path / "left.h5", N, "L", "2026-10-01T09:00:00Z")
    lc3d = tmp_path / "left.c3d"
    assert main(["export", str(left), "--format", "c3d", "-o", str(lc3d), "-q"]) == 0
    assert ezc3d.c3d(str(lc3d))["parameters"]["GAITMON"]["SIDE"]["value"] == ["L"]
