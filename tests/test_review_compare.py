"""The review window's Compare view and patient list, driven like a user would (pytest-qt, real
widgets): File ▸ Compare sessions… on a normal and a stiff-knee session shows both sessions'
cycles and the measures with the knee changes in red; File ▸ Open folder… lists recordings by
patient and date, compares two of them or opens one."""

import shutil

import numpy as np
import pytest
from conftest import write_simulated_session
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFileDialog

from gaitmon.compare import MEASURES
from gaitmon.finish import open_session
from gaitmon.report import gather_report

WAIT_MS = 20_000


@pytest.fixture
def win(review_win):
    return review_win  # tests/conftest.py: a real window, checked for errors and leftover threads


def _pick_files(monkeypatch, paths):
    monkeypatch.setattr(QFileDialog, "getOpenFileNames",
                        staticmethod(lambda *a, **k: ([str(p) for p in paths], "")))  # fmt: skip


def _row(view, label):
    for r in range(view.table.rowCount()):
        if view.table.verticalHeaderItem(r).text() == label:
            return [view.table.item(r, c) for c in range(view.table.columnCount())]
    raise AssertionError(label)


def test_compare_sessions_shows_cycles_and_changes(win, qtbot, monkeypatch, tmp_path,
                                                   normal_and_stiff_knee):  # fmt: skip
    normal, stiff = normal_and_stiff_knee
    _pick_files(monkeypatch, [stiff, normal])  # newest first: shown oldest first
    assert "compare_sessions" in win.act and "open_folder" in win.act
    assert win.act["compare_sessions"].isEnabled()  # no document needed
    with qtbot.waitSignal(win.comparer.compared, timeout=WAIT_MS):
        win.act["compare_sessions"].trigger()
    view = win.comparer.view
    assert view is not None and view.isVisible()
    text = view.sessions.text()
    assert text.index("visit1_normal.h5") < text.index("visit2_stiff.h5") and "P001" in text
    assert not view.warnings.isVisible()
    # each session's curves are its own analysis's mean (as its report draws it)
    for k, path in enumerate((normal, stiff)):
        with open_session(path) as s:
            rep = gather_report(s)
        for j in range(3):
            x, y = view.curves[j][k].getData()
            assert len(x) == 101
            np.testing.assert_allclose(y, rep.mean_deg[:, j])
    # the true direction of a stiff knee: lower knee flexion in swing, drawn lower
    knee_normal, knee_stiff = (view.curves[1][k].getData()[1].max() for k in (0, 1))
    assert knee_stiff < knee_normal - 15
    # the table: every measure; the knee changes are red and bold, the hip's are not
    assert view.table.rowCount() == len(MEASURES) and view.table.columnCount() == 3
    cells = _row(view, "Peak knee flexion in swing (deg)")
    with open_session(normal) as s:
        base = gather_report(s).knee_peak_swing
    assert cells[0].text().startswith(f"{base.mean_deg:.1f} ±")
    assert cells[2].text().endswith("*") and cells[2].text().startswith("−")
    assert cells[2].font().bold() and "beyond" in cells[2].toolTip()
    marked = view.beyond_cells()
    assert ("Peak knee flexion in swing (deg)", "Δ 2 − 1") in marked
    assert ("ROM knee (deg)", "Δ 2 − 1") in marked
    assert not [m for m in marked if m[0] in ("ROM hip (deg)", "Stride time (s)")]
    assert "within" in _row(view, "ROM hip (deg)")[2].toolTip()
    # and the same comparison as a PDF
    out = tmp_path / "from_view.pdf"
    with qtbot.waitSignal(view.saved, timeout=WAIT_MS):
        view.save_pdf(out)
    assert out.stat().st_size > 1000


def test_cancel_stops_a_comparison(win, qtbot, monkeypatch, normal_and_stiff_knee):
    _pick_files(monkeypatch, normal_and_stiff_knee)
    win.act["compare_sessions"].trigger()
    assert win.status.cancel_button.isVisible()  # the status bar's progress, with Cancel
    qtbot.mouseClick(win.status.cancel_button, Qt.MouseButton.LeftButton)
    win.comparer.worker.wait_idle(WAIT_MS / 1000)
    qtbot.wait(200)
    assert win.comparer.view is None and not win.status.cancel_button.isVisible()


@pytest.mark.parametrize("case", ["one", "damaged"])
def test_compare_problems_are_one_line_in_the_banner(case, win, qtbot, monkeypatch, tmp_path,
                                                     normal_and_stiff_knee):  # fmt: skip
    normal = normal_and_stiff_knee[0]
    if case == "one":
        _pick_files(monkeypatch, [normal])
        win.act["compare_sessions"].trigger()
        words = "two or more"
    else:
        junk = tmp_path / "junk.h5"
        junk.write_bytes(b"junk" * 100)
        _pick_files(monkeypatch, [normal, junk])
        win.act["compare_sessions"].trigger()
        words = "junk.h5"
    qtbot.waitUntil(lambda: words in win.last_problem, timeout=WAIT_MS)
    assert "\n" not in win.last_problem
    assert win.comparer.view is None


def test_open_folder_lists_by_patient_and_compares_or_opens(win, qtbot, monkeypatch, tmp_path,
                                                            normal_and_stiff_knee):  # fmt: skip
    folder = tmp_path / "clinic"
    folder.mkdir()
    for p in normal_and_stiff_knee:
        shutil.copy(p, folder / p.name)
    write_simulated_session(folder / "other.h5", patient_id="A7", n=1500,
                            created_utc="2026-12-01T09:00:00Z")  # fmt: skip
    (folder / "broken.h5").write_bytes(b"junk")
    monkeypatch.setattr(QFileDialog, "getExistingDirectory",
                        staticmethod(lambda *a, **k: str(folder)))  # fmt: skip
    with qtbot.waitSignal(win.comparer.listed, timeout=WAIT_MS):
        win.act["open_folder"].trigger()
    pl = win.comparer.patients
    assert pl is not None and pl.isVisible()
    t = pl.table
    col = [t.horizontalHeaderItem(c).text() for c in range(t.columnCount())]
    names = [t.item(r, col.index("File")).text() for r in range(t.rowCount())]
    assert names == ["other.h5", "visit1_normal.h5", "visit2_stiff.h5", "broken.h5"]
    assert [t.item(r, 0).text() for r in range(3)] == ["A7", "P001", "P001"]
    knee = [float(t.item(r, col.index("Peak knee in swing (deg)")).text()) for r in (1, 2)]
    assert knee[0] - knee[1] > 15  # the stiff knee's visit flexes less
    assert t.item(3, col.index("Note")).text()  # the broken file says why
    assert not pl.compare_button.isEnabled() and not pl.open_button.isEnabled()
    pl.select(["visit2_stiff.h5", "broken.h5"])
    assert not pl.compare_button.isEnabled() and "broken.h5" in pl.compare_button.toolTip()
    pl.select(["visit1_normal.h5", "visit2_stiff.h5"])
    assert pl.compare_button.isEnabled() and not pl.open_button.isEnabled()
    with qtbot.waitSignal(win.comparer.compared, timeout=WAIT_MS):
        qtbot.mouseClick(pl.compare_button, Qt.MouseButton.LeftButton)
    assert [s.path.name for s in win.comparer.view.comparison.sessions] == [
        "visit1_normal.h5", "visit2_stiff.h5"]  # fmt: skip
    pl.select(["other.h5"])
    assert pl.open_button.isEnabled() and not pl.compare_button.isEnabled()
    with qtbot.waitSignal(win.document_opened, timeout=WAIT_MS):
        qtbot.mouseClick(pl.open_button, Qt.MouseButton.LeftButton)
    assert win.doc is not None and win.doc.path.name == "other.h5"
    qtbot.waitUntil(lambda: win.analysis is not None, timeout=WAIT_MS)
