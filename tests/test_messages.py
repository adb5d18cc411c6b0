"""Messages a clinician understands, the same on every surface.

* numbers never print a negative zero, and counts agree with their noun ("1 gap");
* a recording in the unit's tilt mode (no foot-sensor data, by the protocol) says it has no
  gait events in ``gaitmon info``, review, the report and the live window's gait panel;
* review: the time axis names its unit, the readout never shows "-0.0°", the "walk start"
  marker's label is drawn inside the plot, and the stride table (status column included)
  fits at 1500 px without horizontal scrolling;
* live: the Pause banner leaves the legend and the gait dock alone, also after a restart.

Real parts throughout: sessions recorded from the simulated unit (the cut over a real pty),
the real windows under pytest-qt.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import QSettings

from gaitmon.cli import main
from gaitmon.finish import open_session
from gaitmon.text import count, no_gait_events, num

WAIT_MS = 20_000


def test_num_never_prints_a_negative_zero_and_count_agrees() -> None:
    assert num(-0.02) == "0.0" and num(-0.0) == "0.0" and num(0.04, sign=True) == "0.0"
    assert num(-0.06) == "-0.1" and num(2.25, 1, sign=True) == "+2.2"
    assert num(-3.0, 0, minus="−") == "−3" and num(float("nan")) == "–"
    assert count(1, "gap") == "1 gap" and count(2, "gap") == "2 gaps"
    assert count(0, "reconnect") == "0 reconnects" and count(1, "CRC failure") == "1 CRC failure"
    assert no_gait_events("raw") == no_gait_events("joint") == ""
    assert "no gait events" in no_gait_events("tilt")


@pytest.fixture(scope="module")
def tilt_file(tmp_path_factory, record_simulated) -> Path:
    return record_simulated(tmp_path_factory.mktemp("tilt") / "tilt.h5", "--mode", "tilt",
                            duration_s=8, standing_s=1)  # fmt: skip


def test_info_says_tilt_mode_has_no_gait_events(tilt_file: Path, capsys) -> None:
    assert main(["info", str(tilt_file)]) == 0
    out = capsys.readouterr().out
    gait = next(line for line in out.splitlines() if line.strip().startswith("gait"))
    assert "no gait events" in gait and "tilt mode" in gait
    assert "too few" not in out and "0 heel strikes" not in out


def test_info_counts_agree_with_their_nouns(cut_recording: Path, capsys) -> None:
    with open_session(cut_recording) as s:
        assert len(s.gaps) == 1 and s.link["reconnects"] == 1
    assert main(["info", str(cut_recording)]) == 0
    out = capsys.readouterr().out
    assert " in 1 gap," in out and "1 reconnect" in out
    assert "1 gaps" not in out and "1 reconnects" not in out


def test_report_says_tilt_mode_has_no_gait_events(qapp, tilt_file: Path, tmp_path) -> None:
    if not shutil.which("pdftotext"):
        pytest.skip("pdftotext (poppler-utils) is not installed")
    out = tmp_path / "tilt.pdf"
    assert main(["report", str(tilt_file), "-o", str(out)]) == 0
    text = re.sub(r"\s+", " ", subprocess.run(["pdftotext", str(out), "-"], capture_output=True,
                                              text=True, check=True).stdout)  # fmt: skip
    assert "No gait events: the unit's tilt mode sends no foot-sensor data" in text
    assert "too few" not in text and "nothing to average" not in text


# -- review ------------------------------------------------------------------------------------


@pytest.fixture
def review(qtbot, tmp_path):
    from gaitmon.ui.review.window import ReviewWindow

    w = ReviewWindow(QSettings(str(tmp_path / "s.ini"), QSettings.Format.IniFormat))
    qtbot.addWidget(w)
    w.resize(1500, 950)
    w.show()
    yield w
    w.close()
    assert w.errors == []


def _open(qtbot, w, path: Path) -> None:
    with qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):
        w.open_file(path)
    qtbot.waitUntil(lambda: w.timeline.applied_requests > 0, timeout=WAIT_MS)


def test_review_says_tilt_mode_has_no_gait_events(qtbot, review, tilt_file: Path) -> None:
    _open(qtbot, review, tilt_file)
    assert "No gait events" in review.summary.text()
    assert "tilt mode sends no foot-sensor data" in review.summary.text()
    fsr = review.timeline.lanes["fsr"].missing
    assert fsr.isVisible() and "no gait events" in fsr.textItem.toPlainText()
    assert "no gait events" in review.statusBar().currentMessage()


def test_review_small_text(qtbot, review, cut_recording: Path, tmp_path: Path) -> None:
    from conftest import CUT_MARKER

    path = tmp_path / "cut.h5"
    shutil.copyfile(cut_recording, path)
    _open(qtbot, review, path)
    # the status line's counts agree with their nouns
    assert re.search(r"; 1 gap, 1 marker\b", review.statusBar().currentMessage())
    tl = review.timeline
    # the time axis names its unit
    axis = tl.visible_lanes()[-1].plot.getAxis("bottom")
    assert axis.labelText == "time (s)"
    # the readout: a value that rounds to zero has no minus sign
    with open_session(path) as s:
        joints = s.read("processed/joint_deg")
        t_s = s.read("timeline/t_s")
    rows = np.flatnonzero(((joints > -0.05) & (joints < 0)).any(axis=1))
    assert len(rows), "no row with a value in (-0.05, 0) to read out"
    tl.set_cursor(float(t_s[rows[0]]))
    assert re.search(r" 0\.0°", tl.readout.text()) and "-0.0" not in tl.readout.text()
    # the marker's label is drawn inside the hip lane's view (it was placed above it)
    labels = [it for it in tl._marker_labels if it.textItem.toPlainText() == CUT_MARKER]
    assert len(labels) == 1
    item = labels[0]
    vb = tl.lanes["hip"].plot.getViewBox()
    qtbot.waitUntil(lambda: vb.viewRect().contains(item.pos()), timeout=WAIT_MS)
    assert item.isVisible()
    qtbot.waitUntil(  # (the view moves its children when it next lays out)
        lambda: vb.sceneBoundingRect().intersects(item.mapRectToScene(item.boundingRect())),
        timeout=WAIT_MS,
    )
    # also for a y range whose rectangle's top, rounded, lies below its upper limit
    vb.setYRange(-5.1, 61.7, padding=0)
    lo, hi = vb.viewRange()[1]
    assert lo + (hi - lo) < hi, "the view did not keep the rounding-prone range"
    assert vb.viewRect().contains(item.pos())
    # the stride table fits at 1500 px: no horizontal scrolling, the status column whole
    table = review.table
    qtbot.waitUntil(lambda: table.model().rowCount() > 0, timeout=WAIT_MS)
    assert table.horizontalScrollBar().maximum() == 0
    status_col = table.model().columnCount() - 1
    fm = table.fontMetrics()
    longest = max(fm.horizontalAdvance(table.model().index(r, status_col).data())
                  for r in range(table.model().rowCount()))  # fmt: skip
    statuses = {table.model().index(r, status_col).data() for r in range(table.model().rowCount())}
    # a long status is among them (which of the two depends on where the cut fell in a stride)
    assert statuses & {"excluded: crosses a gap", "excluded: settling after a gap"}, statuses
    assert table.columnWidth(status_col) >= longest + 8


# -- live window -------------------------------------------------------------------------------


def _live(qtbot, settings: QSettings, mode: str = "raw"):
    from gaitmon.io.sim.config import SimConfig
    from gaitmon.live.connection import SIMULATED_PORT
    from gaitmon.ui.live import MainWindow

    win = MainWindow(settings, sim=SimConfig(standing_s=1.0), autoconnect=SIMULATED_PORT,
                     mode=mode, confirm_close=False)  # fmt: skip
    win.resize(1500, 900)
    win.show()
    qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
    return win


def _settle(qtbot, ms: int = 400) -> None:
    deadline = time.monotonic() + ms / 1000
    while time.monotonic() < deadline:
        qtbot.wait(20)


def test_live_gait_panel_says_tilt_mode_has_no_gait_events(qtbot, tmp_path) -> None:
    settings = QSettings(str(tmp_path / "live.ini"), QSettings.Format.IniFormat)
    win = _live(qtbot, settings, mode="tilt")
    try:
        qtbot.waitUntil(lambda: win.engine.samples_total > 50, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: "No gait events" in win.gait_panel.cycle_title.text(),
                        timeout=WAIT_MS)  # fmt: skip
        assert "tilt mode" in win.gait_panel.cycle_title.text()
    finally:
        win.close()
    assert win.errors == []


def test_pause_banner_leaves_the_legend_and_the_gait_dock_alone(qtbot, tmp_path) -> None:
    settings = QSettings(str(tmp_path / "live.ini"), QSettings.Format.IniFormat)
    legends = None
    widths = []
    for _start in range(2):  # and again after a restart with the saved layout
        win = _live(qtbot, settings)
        try:
            _settle(qtbot)
            legends = [w for w in (win.phase_legend, *win.method_boxes.values())]
            dock = win.gait_dock.width()
            widths.append(dock)
            win.view_part.set_paused(True)
            _settle(qtbot)
            assert win.pause_label.isVisible()
            for w in legends:  # not squeezed below what its text needs
                assert w.width() >= w.sizeHint().width(), (w, w.width(), w.sizeHint().width())
            assert win.gait_dock.width() == dock
            win.view_part.set_paused(False)
            _settle(qtbot)
            assert win.gait_dock.width() == dock
        finally:
            win.close()
        assert win.errors == []
    assert widths[1] == widths[0]
