"""The stride table (one row per stride, exclusions greyed with their reason) and the summary.

The model serves rows on demand, so an 8-hour session's ~26 000 strides cost nothing until
scrolled to. Clicking a row emits ``stride_picked(row)``; the window moves the timeline there.
"""

from __future__ import annotations

import html
import math
from typing import TYPE_CHECKING, Any

from PySide6.QtCore import QAbstractTableModel, QModelIndex, QPersistentModelIndex, Qt, Signal
from PySide6.QtGui import QColor, QFont, QFontMetrics
from PySide6.QtWidgets import (
    QAbstractItemView,
    QHeaderView,
    QLabel,
    QStyle,
    QTableView,
    QWidget,
)

from gaitmon.analysis import STRIDE_COLUMNS, StrideRow, spatial_summary, stride_cells
from gaitmon.dsp.channel_table import JOINTS
from gaitmon.review.model import Analysis
from gaitmon.text import no_gait_events, num
from gaitmon.ui.theme import Colours

if TYPE_CHECKING:
    from gaitmon.normative import NormativeBands

# (header, tooltip, widest value): two-line headers and widths from the widest value, so the
# whole table, status included, fits beside the summary at 1500 px without scrolling
COLUMNS = tuple((c.title, c.tip, c.sample) for c in STRIDE_COLUMNS)

_Index = QModelIndex | QPersistentModelIndex


def _f(x: float, spec: str) -> str:
    """``x`` with the decimals of ``spec`` (".2f"): the shared formatter (no "-0.0", a dash
    for NaN)."""
    return num(x, int(spec.strip(".f")))


class StrideModel(QAbstractTableModel):
    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.rows: list[StrideRow] = []
        self.start_t_s: list[float] = []
        grey = QColor(colours.foreground)
        grey.setAlpha(120)
        self._grey = grey
        bg = QColor(colours.foreground)
        bg.setAlpha(22)
        self._grey_bg = bg
        self._italic = QFont()
        self._italic.setItalic(True)

    def set_rows(self, rows: list[StrideRow], start_t_s: list[float]) -> None:
        self.beginResetModel()
        self.rows = list(rows)
        self.start_t_s = list(start_t_s)
        self.endResetModel()

    def rowCount(self, parent: _Index = QModelIndex()) -> int:  # noqa: B008
        return 0 if parent.isValid() else len(self.rows)

    def columnCount(self, parent: _Index = QModelIndex()) -> int:  # noqa: B008
        return 0 if parent.isValid() else len(COLUMNS)

    def headerData(self, section: int, orientation: Qt.Orientation, role: int = 0) -> Any:
        if orientation != Qt.Orientation.Horizontal:
            return None
        if role == Qt.ItemDataRole.DisplayRole:
            return COLUMNS[section][0]
        if role == Qt.ItemDataRole.ToolTipRole:
            return COLUMNS[section][1]
        return None

    def text(self, row: int, col: int) -> str:
        return stride_cells(self.rows[row], row + 1, self.start_t_s[row])[col]

    def data(self, index: _Index, role: int = Qt.ItemDataRole.DisplayRole) -> Any:
        if not index.isValid():
            return None
        row, col = index.row(), index.column()
        r = self.rows[row]
        if role == Qt.ItemDataRole.DisplayRole:
            return self.text(row, col)
        if role == Qt.ItemDataRole.TextAlignmentRole:
            align = Qt.AlignmentFlag.AlignLeft if col == len(COLUMNS) - 1 else (
                Qt.AlignmentFlag.AlignRight)  # fmt: skip
            return int(align | Qt.AlignmentFlag.AlignVCenter)
        if not r.included:
            if role == Qt.ItemDataRole.ForegroundRole:
                return self._grey
            if role == Qt.ItemDataRole.BackgroundRole:
                return self._grey_bg
            if role == Qt.ItemDataRole.FontRole:
                return self._italic
            if role == Qt.ItemDataRole.ToolTipRole:
                return f"Not in the statistics: {r.excluded}"
        return None


class StrideTable(QTableView):
    stride_picked = Signal(int)

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.model_ = StrideModel(colours, self)
        self.setModel(self.model_)
        self.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.setAlternatingRowColors(False)
        self.verticalHeader().setVisible(False)
        self.verticalHeader().setDefaultSectionSize(20)
        self.verticalHeader().setSectionResizeMode(QHeaderView.ResizeMode.Fixed)
        hh = self.horizontalHeader()
        hh.setSectionResizeMode(QHeaderView.ResizeMode.Interactive)
        hh.setStretchLastSection(True)
        # widths from the header text and the widest value (resizeColumnsToContents would
        # measure every one of an 8-hour session's ~26 000 rows), the values measured in the
        # cells' own fonts (excluded rows are italic: wider) plus the margins the style leaves
        # each side of a cell's text ("excluded: settling afte" was cut)
        fm = hh.fontMetrics()
        cell_fms = [QFontMetrics(self.font())]
        italic = QFont(self.font())
        italic.setItalic(True)
        cell_fms.append(QFontMetrics(italic))
        pad = 2 * self.text_margin_px() + 6
        for col, (title, _tip, sample) in enumerate(COLUMNS):
            head = max(fm.horizontalAdvance(t) for t in title.split("\n")) + 10
            cell = max(m.horizontalAdvance(sample) for m in cell_fms) + pad
            self.setColumnWidth(col, max(head, cell))
        self.status_width_px = self.columnWidth(len(COLUMNS) - 1)
        self.setToolTip("Click a stride to show it on the timeline. Greyed: not in the statistics.")
        self.clicked.connect(lambda idx: self.stride_picked.emit(idx.row()))
        self.activated.connect(lambda idx: self.stride_picked.emit(idx.row()))

    def text_margin_px(self) -> int:
        """The margin the style leaves each side of a cell's text (Qt's item view delegate:
        the focus frame's margin + 1)."""
        style = self.style()
        return style.pixelMetric(QStyle.PixelMetric.PM_FocusFrameHMargin, None, self) + 1

    def set_rows(self, rows: list[StrideRow], start_t_s: list[float]) -> None:
        self.model_.set_rows(rows, start_t_s)


def summary_html(
    a: Analysis | None,
    before: Analysis | None = None,
    note: str = "",
    mode: str = "",
    normative: NormativeBands | None = None,
    two_legs: bool = False,
) -> str:
    """The summary panel's text: included strides only (derived cadence labelled as such);
    for a recording in a mode without foot-sensor data, why there are no strides; with a
    normative band, the deviation of the mean cycle from it per joint. ``two_legs``: the leg
    shown is one of a file that records both, whose steps are measured (the Both legs tab)."""
    if a is None:
        return "<i>No session open.</i>"
    none = no_gait_events(mode)
    if none and not a.rows:
        return f"<p><b>No gait events.</b> {none[0].upper()}{none[1:]}.</p>"
    s = a.summary
    n_all = len(a.rows)

    def cmp(now: float, was: float | None, spec: str) -> str:
        if was is None or not math.isfinite(was) or not math.isfinite(now):
            return _f(now, spec)
        return f"{_f(now, spec)} <span style='color:gray'>(was {_f(was, spec)})</span>"

    b = before.summary if before is not None else None
    if s.n_strides == 0:
        body = (
            f"<p><b>{n_all}</b> strides found, none usable for statistics"
            + (f" ({a.n_excluded} excluded)" if n_all else "")
            + ".</p>"
        )
    else:
        sd = "" if not math.isfinite(s.stride_time_sd_s) else f" ± {num(s.stride_time_sd_s, 3)}"
        knee = [r.knee_peak_swing_deg for r in a.rows if r.included]
        knee_ok = [k for k in knee if math.isfinite(k)]
        knee_mean = sum(knee_ok) / len(knee_ok) if knee_ok else math.nan
        rows = [
            ("Strides analysed", f"<b>{s.n_strides}</b> of {n_all} ({a.n_excluded} excluded)"),
            ("Stride time", f"{num(s.stride_time_mean_s, 3)}{sd} s"),
            ("CV of stride time",
             cmp(s.stride_time_cv_pct, b.stride_time_cv_pct if b else None, ".1f") + " %"),
            ("Stance",
             cmp(s.stance_pct_mean, b.stance_pct_mean if b else None, ".1f") + " % of stride"),
            ("Swing", cmp(s.swing_pct_mean, b.swing_pct_mean if b else None, ".1f") + " %"),
            ("Cadence (derived)",
             cmp(s.cadence_derived_steps_per_min,
                 b.cadence_derived_steps_per_min if b else None, ".0f") + " steps/min"),
            ("Knee peak in swing", _f(knee_mean, ".1f") + "°"),
        ]  # fmt: skip
        sp = spatial_summary(a.rows)
        if sp.n_strides:
            bs = spatial_summary(before.rows) if before is not None else None
            rows += [
                ("Stride length", cmp(sp.stride_length_mean_m,
                                      bs.stride_length_mean_m if bs else None, ".2f")
                 + f" ± {_f(sp.stride_length_sd_m, '.2f')} m"
                 + f" (CV {_f(sp.stride_length_cv_pct, '.1f')} %)"),
                ("Gait speed", cmp(sp.speed_mean_m_s, bs.speed_mean_m_s if bs else None, ".2f")
                 + f" ± {_f(sp.speed_sd_m_s, '.2f')} m/s (CV {_f(sp.speed_cv_pct, '.1f')} %)"),
                ("Foot clearance", sp.clearance_text()),
            ]  # fmt: skip
        body = "<table cellspacing=2>" + "".join(
            f"<tr><td>{k}&nbsp;&nbsp;</td><td>{v}</td></tr>" for k, v in rows
        ) + "</table>"
    foot = f"<p style='color:gray'>{cadence_note(two_legs)}</p>"
    src = "" if a.source_label == "recorded" else "<p><b>Reprocessed</b> " + note + "</p>"
    angles = (f"<p>Angles: {a.angle_method}"
              + (" (zero-lag, offline)" if a.angles == "smoothed" else "") + "</p>"
              if a.angle_method else "")  # fmt: skip
    return src + angles + body + _deviation_html(a, normative) + foot


def cadence_note(two_legs: bool) -> str:
    """What the derived cadence rests on: with one unit, an assumption (two equal steps per
    stride); with both legs recorded the steps are measured, per leg, in the Both legs tab."""
    if two_legs:
        return ("Cadence is 120 / this leg's stride time; both legs were recorded, so steps "
                "are measured per leg (Both legs tab).")  # fmt: skip
    return ("Cadence is derived as 120 / stride time: one unit measures one leg, so two equal "
            "steps per stride are assumed.")  # fmt: skip


def _deviation_html(a: Analysis, bands: NormativeBands | None) -> str:
    """Per joint, the RMS distance of the included strides' mean cycle from the band's mean
    (``gaitmon.normative.deviation_deg``), named after the band. Kept to three lines: the
    caveat is in the cycle plots' tooltips and this panel's."""
    if bands is None or a.summary.n_strides == 0:
        return ""
    from gaitmon.normative import DEVIATION_LABEL, deviation_deg

    dev = deviation_deg(a.mean_deg, bands)
    per = " · ".join(f"{title} <b>{_f(float(d), '.1f')}</b>"
                     for title, d in zip(JOINTS, dev, strict=True)
                     if math.isfinite(d))  # fmt: skip
    if not per:
        return ""
    return (
        f"<p style='margin-top:6px'>{DEVIATION_LABEL[0].upper()}{DEVIATION_LABEL[1:]}: {per}"
        f"<br><span style='color:gray'>RMS over the cycle from {html.escape(bands.label)} "
        "(hover for the caveat)</span></p>"
    )


class SummaryLabel(QLabel):
    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setTextFormat(Qt.TextFormat.RichText)
        self.setWordWrap(True)
        self.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.setText(summary_html(None))
