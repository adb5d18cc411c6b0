"""No text cut short (issue 25 #9), checked against the width it is drawn in.

* the two-leg report's DEVICES cell ("serials L 1001, R 1002 (gaitmon-sim f…"): the PDF's own
  text, read back with ``pdftotext`` (an independent reader), holds the whole value;
* the review's stride table: every status ("excluded: settling after a gap") fits its column,
  measured in the cell's own (italic) font minus the style's margins;
* the review's Both legs tab: every row is on screen (the last was cut), every cell fits;
* the live two-leg plots: "right leg: no data" over an outage that began a moment ago is drawn
  whole inside the plot (it ran past the plot's right edge: "righ").
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import QPointF
from PySide6.QtGui import QFont, QFontMetrics

from gaitmon.cli import main

GOLDEN = Path(__file__).parent / "data" / "golden" / "two_legs.h5"
WAIT_MS = 30_000


@pytest.fixture
def two_legs(tmp_path: Path) -> Path:
    p = tmp_path / "two_legs.h5"
    shutil.copyfile(GOLDEN, p)
    return p


# -- the report ----------------------------------------------------------------------------------


@pytest.mark.skipif(shutil.which("pdftotext") is None, reason="poppler-utils not installed")
def test_two_leg_report_devices_cell_is_whole(qapp: object, two_legs: Path) -> None:
    from gaitmon.report import bilateral_report_from_file

    units = bilateral_report_from_file(two_legs).units
    assert units.startswith("serials L 1001, R 1002 (") and len(units) > 45  # a long value
    out = two_legs.with_name("report.pdf")
    assert main(["report", str(two_legs), "-o", str(out), "-q"]) == 0
    text = subprocess.run(["pdftotext", str(out), "-"], check=True, capture_output=True,
                          text=True).stdout  # fmt: skip
    flat = " ".join(text.split())
    assert units in flat, re.findall(r"serials[^\n]*\n?[^\n]*", text)
    assert "…" not in text  # nothing on the pages is elided


# -- the review window ---------------------------------------------------------------------------


def _italic(widget) -> QFontMetrics:
    f = QFont(widget.font())
    f.setItalic(True)
    return QFontMetrics(f)


def test_review_stride_status_fits_its_column(qtbot, review_win, gap_recording: Path) -> None:
    from gaitmon.analysis import SETTLING

    w = review_win
    with qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):
        w.open_file(gap_recording)
    qtbot.waitUntil(lambda: w.timeline.applied_requests > 0, timeout=WAIT_MS)
    table, m = w.table, w.table.model()
    col = m.columnCount() - 1
    texts = [m.index(r, col).data() for r in range(m.rowCount())]
    assert f"excluded: {SETTLING}" in texts  # the longest reason is in this session
    margin = table.text_margin_px()
    # the column as laid out at its narrowest (the width it is given, before any stretch)
    room = table.status_width_px - 2 * margin
    for r, text in enumerate(texts):
        fm = _italic(table) if not w.analysis.rows[r].included else QFontMetrics(table.font())
        assert fm.horizontalAdvance(text) <= room, (text, fm.horizontalAdvance(text), room)
        assert fm.horizontalAdvance(text) <= table.columnWidth(col) - 2 * margin
        reason = w.analysis.rows[r].excluded
        if reason:  # and its tooltip holds the reason whole
            assert m.index(r, col).data(3) == f"Not in the statistics: {reason}"


def test_review_both_legs_tab_shows_every_row_whole(qtbot, review_win, two_legs: Path) -> None:
    w = review_win
    with qtbot.waitSignal(w.legs.computed, timeout=WAIT_MS), \
            qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):  # fmt: skip
        w.open_file(two_legs)
    w.tabs.setCurrentIndex(1)
    qtbot.waitUntil(lambda: w.both_legs.isVisible())
    qtbot.wait(50)
    t = w.both_legs.table
    assert t.rowCount() == 7
    seen = t.viewport().visibleRegion().boundingRect()
    fm = QFontMetrics(t.font())
    margin = t.style().pixelMetric(t.style().PixelMetric.PM_FocusFrameHMargin, None, t) + 1
    for r in range(t.rowCount()):
        top, h = t.rowViewportPosition(r), t.rowHeight(r)
        assert top >= 0 and top + h <= seen.bottom() + 1, (r, top, h, seen)
        for c in range(t.columnCount()):
            text = t.item(r, c).text()
            assert fm.horizontalAdvance(text) <= t.columnWidth(c) - 2 * margin, (r, c, text)
    # the tab shows the table whole: no part of it clipped by the tab or the splitter
    vis = t.visibleRegion().boundingRect()
    assert vis.height() >= t.height() - 1 and vis.width() >= t.width() - 1


# -- the live two-leg plots ----------------------------------------------------------------------


def test_live_two_leg_lost_label_is_drawn_whole_in_the_plot(qtbot) -> None:
    from gaitmon.ui.plots.bilateral import BilateralPlots
    from gaitmon.ui.theme import current_colours

    plots = BilateralPlots(current_colours())
    qtbot.addWidget(plots)
    plots.resize(700, 500)
    plots.show()
    qtbot.waitExposed(plots)
    # an outage of the right leg that began 0.2 s ago (the newest rows are lost)
    x = np.linspace(-10.0, 0.0, 1001)
    lost = x > -0.2
    plots._label_lost("R", x, lost)  # what _update_leg calls with the leg's newest rows
    plots.sets["hip"].commit()
    plots.grab()  # paint
    label = plots.legs["R"].lost_label
    assert label is not None and label.visible and label.text == "right leg: no data"
    assert label.drawn is not None
    vb = plots.plots["hip"].getViewBox()
    edge = plots.mapFromScene(vb.mapViewToScene(QPointF(0.0, 0.0))).x()
    left = plots.mapFromScene(vb.mapViewToScene(QPointF(-plots.window_s, 0.0))).x()
    width = QFontMetrics(label._doc.defaultFont()).horizontalAdvance(label.text)
    assert label.drawn.width() >= width  # the text's own width, no less
    assert left - 1 <= label.drawn.left() and label.drawn.right() <= edge + 1, (
        label.drawn, left, edge)


def test_live_marker_label_dropped_just_now_is_drawn_whole_in_the_plot(qtbot) -> None:
    """The one-leg live plots: a marker dropped a moment ago had its label start at "now",
    the plot's right edge, so all but its first letters ran past it."""
    from gaitmon.ui.plots.live import LivePlots
    from gaitmon.ui.theme import current_colours

    plots = LivePlots(current_colours())
    qtbot.addWidget(plots)
    plots.resize(900, 600)
    plots.show()
    qtbot.waitExposed(plots)
    t_now = 100.0
    plots._update_marker_labels([(t_now - 0.1, "asked to turn")], t_now)  # as update_from does
    for name in ("body", "hip"):
        plots.plots[name].traces.commit()
    plots.grab()  # paint
    [(label, name), *_] = [(lb, n) for lb, n in plots._marker_labels if lb.visible]
    assert label.text == "asked to turn" and label.drawn is not None
    vb = plots.plots[name].plot.getViewBox()
    edge = plots.mapFromScene(vb.mapViewToScene(QPointF(0.0, 0.0))).x()
    width = QFontMetrics(label._doc.defaultFont()).horizontalAdvance(label.text)
    assert label.drawn.width() >= width
    assert label.drawn.right() <= edge + 1, (label.drawn, edge)
