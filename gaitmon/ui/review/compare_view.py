"""The Compare view: two or more sessions of one patient, from one
:class:`gaitmon.compare.Comparison` (the same as ``gaitmon compare``'s PDF).

Top: the sessions (colour, date, file, strides, angles, gaps and excluded strides) and the
warnings; middle: hip, knee and ankle cycles with each session's mean ± SD band in its colour
(the PDF's colours); bottom: the measures table, one column per session and each later
session's changes from the baseline and from the previous one, each with its minimal
detectable change beside it, a change beyond it in red and bold (the one rule of
:mod:`gaitmon.compare`, with the figures in its tooltip). *Save as PDF…*
writes the comparison as ``gaitmon compare`` does.
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QColor, QFont
from PySide6.QtWidgets import (
    QFileDialog,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QPushButton,
    QSplitter,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

from gaitmon.compare import JOINTS, MEASURES, RULE_TEXT, Comparison
from gaitmon.text import duration_text, num
from gaitmon.ui import one_line
from gaitmon.ui.report_pdf.compare import (
    AXIS_LABELS,
    MARK,
    SESSION_COLOURS,
    change_text,
    measure_label,
    table_columns,
    value_text,
)
from gaitmon.ui.theme import Colours

N_POINTS = 101


def colour(k: int, alpha: int = 255) -> QColor:
    c = QColor(SESSION_COLOURS[k % len(SESSION_COLOURS)])
    c.setAlpha(alpha)
    return c


class CompareView(QWidget):
    """A window showing one comparison (:meth:`set_comparison`)."""

    saved = Signal(str)  # the PDF written
    failed = Signal(str)  # one line

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.comparison: Comparison | None = None
        self.setWindowTitle("gaitmon — compare sessions")
        self.resize(1300, 900)
        self.sessions = QLabel()
        self.sessions.setTextFormat(Qt.TextFormat.RichText)
        self.sessions.setWordWrap(True)
        self.warnings = QLabel()
        self.warnings.setWordWrap(True)
        self.warnings.setStyleSheet(f"color: {'#ff7b72' if colours.dark else '#a4261b'};")
        self.plots = pg.GraphicsLayoutWidget()
        self.plot_items: list[pg.PlotItem] = []
        for j, name in enumerate(JOINTS):
            p = self.plots.addPlot(row=0, col=j, title=f"<b>{name}</b>")
            p.showGrid(x=True, y=True, alpha=colours.grid_alpha)
            p.setMouseEnabled(x=False, y=False)
            p.hideButtons()
            p.setXRange(0, 100, padding=0)
            p.getAxis("left").setLabel(AXIS_LABELS[j])
            p.getAxis("bottom").setLabel("gait cycle (%)")
            self.plot_items.append(p)
        self.curves: list[list[pg.PlotCurveItem]] = [[] for _ in JOINTS]  # [joint][session]
        self.table = QTableWidget()
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        self.table.setAlternatingRowColors(True)
        self.table.verticalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.rule = QLabel(f"{MARK} beyond its minimal detectable change (red). {RULE_TEXT} "
                           "Δ = later − earlier, the MDC95 in brackets. See docs/compare.md.")
        self.rule.setWordWrap(True)
        self.save_button = QPushButton("Save as PDF…")
        self.save_button.clicked.connect(self.save_dialog)

        muted = "#9aa3ad" if colours.dark else "#5b6470"
        self.rule.setStyleSheet(f"color: {muted};")
        self.table.setSizeAdjustPolicy(QTableWidget.SizeAdjustPolicy.AdjustToContents)
        # below the plots: the table at its own width, and beside it who, what and the rule
        side = QWidget()
        sv = QVBoxLayout(side)
        sv.setContentsMargins(8, 0, 0, 0)
        sv.addWidget(self.sessions)
        sv.addWidget(self.warnings)
        sv.addWidget(self.rule)
        sv.addStretch(1)
        sv.addWidget(self.save_button, 0, Qt.AlignmentFlag.AlignRight)
        lower = QWidget()
        lh = QHBoxLayout(lower)
        lh.setContentsMargins(0, 0, 0, 0)
        lh.addWidget(self.table, 0)
        lh.addWidget(side, 1)
        split = QSplitter(Qt.Orientation.Vertical)
        split.addWidget(self.plots)
        split.addWidget(lower)
        split.setSizes([560, 400])
        v = QVBoxLayout(self)
        v.addWidget(split, 1)

    # -- content -------------------------------------------------------------------------------

    def set_comparison(self, c: Comparison) -> None:
        self.comparison = c
        self.setWindowTitle(f"gaitmon — compare {len(c.sessions)} sessions — "
                            f"{c.who}")  # fmt: skip
        rows = []
        muted = "#9aa3ad" if self.colours.dark else "#5b6470"
        for k, s in enumerate(c.sessions):
            role = " (baseline)" if k == 0 else ""
            rows.append(
                f"<span style='color:{colour(k).name()}; font-size:14pt'>■</span> "
                f"<b>{k + 1}{role}</b> {html.escape(s.recorded_utc)}<br>"
                f"&nbsp;&nbsp;&nbsp;&nbsp;{html.escape(s.file_name)} · "
                f"{duration_text(s.duration_s)}"
                f" · {s.n_included} of {s.n_strides_total} strides<br>&nbsp;&nbsp;&nbsp;&nbsp;"
                f"{html.escape(s.quality.text())}<br>&nbsp;&nbsp;&nbsp;&nbsp;"
                f"<span style='color:{muted}'>{html.escape(s.angle_method)}</span>"
            )
        who = html.escape(c.who)
        self.sessions.setText(f"<span style='font-size:12pt'><b>Patient {who}</b></span><br>"
                              + "<br>".join(rows))  # fmt: skip
        self.warnings.setText("\n".join(f"⚠ {w}" for w in c.warnings))
        self.warnings.setVisible(bool(c.warnings))
        self._draw_cycles(c)
        self._fill_table(c)

    def _draw_cycles(self, c: Comparison) -> None:
        x = np.linspace(0.0, 100.0, N_POINTS)
        for j, p in enumerate(self.plot_items):
            p.clear()
            self.curves[j] = []
            vals = []
            for k, s in enumerate(c.sessions):
                m, sd = s.mean_deg[:, j], s.sd_deg[:, j]
                if np.isfinite(sd).all():
                    lo = pg.PlotCurveItem(x, m - sd, pen=pg.mkPen(None))
                    hi = pg.PlotCurveItem(x, m + sd, pen=pg.mkPen(None))
                    p.addItem(pg.FillBetweenItem(lo, hi, brush=colour(k, 60)))
                    vals += [m - sd, m + sd]
                curve = pg.PlotCurveItem(x, m, pen=pg.mkPen(colour(k), width=2),
                                         name=s.label)  # fmt: skip
                p.addItem(curve)
                self.curves[j].append(curve)
                vals.append(m)
                if np.isfinite(s.stance_pct):
                    toe = pg.InfiniteLine(pos=s.stance_pct, angle=90,
                                          pen=pg.mkPen(colour(k, 160), width=1,
                                                       style=Qt.PenStyle.DashLine))  # fmt: skip
                    toe.setToolTip(f"{s.label}: mean toe off {num(s.stance_pct)} %")
                    p.addItem(toe)
            v = np.concatenate(vals) if vals else np.empty(0)
            v = v[np.isfinite(v)]
            if v.size:
                pad = 0.08 * max(float(v.max() - v.min()), 5.0)
                p.setYRange(float(v.min()) - pad, float(v.max()) + pad, padding=0)
        # the legend is the session list beside the table (colour, number, date, file): a
        # legend inside a plot hid the curves it names

    def _fill_table(self, c: Comparison) -> None:
        cols = table_columns(c, range(1, len(c.sessions)))
        self.table.clear()
        self.table.setRowCount(len(MEASURES))
        self.table.setColumnCount(len(cols))
        self.table.setVerticalHeaderLabels([measure_label(m) for m in MEASURES])
        for j, (t1, t2, k, since) in enumerate(cols):
            head = QTableWidgetItem(f"{t1}\n{t2}")
            if since is None:
                head.setForeground(colour(k))
            self.table.setHorizontalHeaderItem(j, head)
        bold = QFont()
        bold.setBold(True)
        red = QColor("#ff7b72" if self.colours.dark else "#a4261b")
        right = Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter
        for r, m in enumerate(MEASURES):
            for j, (_t1, _t2, k, since) in enumerate(cols):
                if since is None:
                    item = QTableWidgetItem(value_text(c.sessions[k], m))
                else:
                    text, beyond = change_text(c, k, m, since)
                    item = QTableWidgetItem(text)
                    ch = c.change(k, m.key, since)
                    if beyond:
                        item.setForeground(red)
                        item.setFont(bold)
                    figures = (f"|Δ| {num(abs(ch.delta), 3)} {'>' if ch.beyond else '≤'} MDC95 "
                               f"{num(ch.mdc, 3)} = 1.96 · √2 · pooled stride-to-stride SD "
                               f"{num(ch.pooled_sd, 3)}")  # fmt: skip
                    item.setToolTip(
                        f"beyond the minimal detectable change: {figures}" if ch.beyond else
                        f"within the minimal detectable change: {figures}"
                        if ch.beyond is False else
                        "not judged (a count or a ratio, or fewer than 2 strides)"
                    )  # fmt: skip
                item.setTextAlignment(right)
                self.table.setItem(r, j, item)
        self.table.resizeColumnsToContents()
        # every row shown, no blank rows' worth of table: the plots take the height left (room
        # for a horizontal scroll bar, which many sessions need)
        self.table.setFixedHeight(self.table.horizontalHeader().height()
                                  + self.table.verticalHeader().length()
                                  + self.table.horizontalScrollBar().sizeHint().height() + 4)

    def beyond_cells(self) -> list[tuple[str, str]]:
        """(measure label, column title) of every cell marked beyond (what a user sees red)."""
        out = []
        for r in range(self.table.rowCount()):
            for j in range(self.table.columnCount()):
                item = self.table.item(r, j)
                if item is not None and item.font().bold():
                    head = self.table.horizontalHeaderItem(j)
                    label = self.table.verticalHeaderItem(r)
                    out.append((label.text() if label else "",
                                head.text().split("\n")[0] if head else ""))  # fmt: skip
        return out

    # -- PDF -----------------------------------------------------------------------------------

    def save_dialog(self) -> None:
        c = self.comparison
        if c is None:
            return
        suggestion = c.sessions[-1].path.with_name("compare.pdf")
        path, _ = QFileDialog.getSaveFileName(self, "Save the comparison as", str(suggestion),
                                              "PDF (*.pdf)")  # fmt: skip
        if path:
            self.save_pdf(path)

    def save_pdf(self, path: str | Path) -> None:
        from gaitmon.ui.report_pdf.compare import write_comparison_pdf

        if self.comparison is None:
            return
        try:
            out = write_comparison_pdf(self.comparison, path)
        except OSError as e:
            self.failed.emit(f"Cannot write the comparison: {one_line(e)}")
            return
        self.saved.emit(str(out))
