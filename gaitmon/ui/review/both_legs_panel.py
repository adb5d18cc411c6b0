"""The review window's Both legs tab: the bilateral measures of a file that records both legs.

One table, a row a measure (step and stride time, stance, swing, initial and terminal double
support, single support): each side's mean as % of the stride and in seconds, and the symmetry
ratio SR = L / R and index SI; above it the measured cadence and the strides that count. The
cells are
:class:`gaitmon.review.both_legs.BothLegs`'s (the numbers ``gaitmon info`` prints);
:class:`~gaitmon.ui.review.legs.LegsControl` computes them on a worker. Beside the table, both
legs' mean cycles overlaid (:class:`~gaitmon.ui.review.both_legs_cycles.BothLegsCycles`).
"""

from __future__ import annotations

import html

from PySide6.QtCore import QSize, Qt
from PySide6.QtGui import QResizeEvent
from PySide6.QtWidgets import (
    QAbstractItemView,
    QFrame,
    QHeaderView,
    QLabel,
    QScrollArea,
    QSplitter,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

from gaitmon.review.both_legs import COLUMNS, BothLegs, fmt
from gaitmon.ui.review.both_legs_cycles import BothLegsCycles
from gaitmon.ui.theme import Colours, current_colours

NOTE = ("SR = left / right of the means (1 symmetric); SI = 2 |L − R| / (L + R) (0 % "
        "symmetric). On the common time line, from the recorded gait events; each leg's "
        "excluded strides are left out (the leg shown: the exclusions in force here; the "
        "other: those kept for it).")  # fmt: skip
TIPS = (
    "Mean over the strides that count",
    "Left leg: % of its stride time (phases of the stride)",
    "Left leg: mean, seconds",
    "Right leg: % of its stride time (phases of the stride)",
    "Right leg: mean, seconds",
    "Symmetry ratio: left / right of the means (1 is symmetric)",
    "Symmetry index: 2 |L − R| / (L + R) × 100 % (0 is symmetric; it does not say which side "
    "is larger). One leg's terminal double support is the other's initial one",
)


def _table(headers: tuple[str, ...], tips: tuple[str, ...] = ()) -> QTableWidget:
    t = QTableWidget(0, len(headers))
    t.setHorizontalHeaderLabels(list(headers))
    for i, tip in enumerate(tips):
        item = t.horizontalHeaderItem(i)
        if item is not None:
            item.setToolTip(tip)
    t.verticalHeader().setVisible(False)
    t.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
    t.setSelectionMode(QAbstractItemView.SelectionMode.NoSelection)
    t.setAlternatingRowColors(True)
    t.setWordWrap(False)
    t.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
    return t


def _fill(t: QTableWidget, rows: list[tuple[str, ...]]) -> None:  # cells right-aligned
    t.setRowCount(len(rows))
    for r, cells in enumerate(rows):
        for c, text in enumerate(cells):
            item = QTableWidgetItem(text)
            if c:
                item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
            t.setItem(r, c, item)


def _fit_columns(t: QTableWidget) -> None:
    """Every column as wide as its widest cell, and the table as wide as its columns: its text
    is never cut, the cycles beside it take the rest of the tab."""
    h = t.horizontalHeader()
    t.resizeColumnsToContents()
    t.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
    t.setMinimumWidth(h.length() + 2 * t.frameWidth())


def _fit_rows(t: QTableWidget) -> None:
    """Tall enough for the header and every row (the last row was cut at the window's
    default size): the table never scrolls, the layout gives the room or the tab scrolls."""
    t.resizeRowsToContents()
    h = t.horizontalHeader().height() + t.verticalHeader().length() + 2 * t.frameWidth()
    if t.horizontalScrollBar().isVisible():
        h += t.horizontalScrollBar().height()
    t.setMinimumHeight(h)
    t.setVerticalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)


class _WrappedLine(QLabel):
    """A word-wrapped label at least as tall as its lines at its width, which does not ask its
    layout for height-for-width: a scroll area gives such a layout its preferred height (here
    twice the room there was, and a scroll bar), not the room there is; and a layout that
    knows its labels' heights does not squeeze them over the table."""

    def __init__(self) -> None:
        super().__init__()
        self.setWordWrap(True)
        self.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop)
        self._fit()

    def resizeEvent(self, event: QResizeEvent) -> None:
        super().resizeEvent(event)
        self._fit()

    def setText(self, text: str) -> None:
        super().setText(text)
        self._fit()

    def sizeHint(self) -> QSize:  # as tall as its lines (QLabel's: as at a narrow width)
        return QSize(super().sizeHint().width(), self.minimumHeight())

    def _fit(self) -> None:
        policy = self.sizePolicy()  # (QLabel sets height-for-width again with each text)
        if policy.hasHeightForWidth():
            policy.setHeightForWidth(False)
            self.setSizePolicy(policy)
        h = self.heightForWidth(self.width()) if self.text() else 0
        if h != self.minimumHeight():
            self.setMinimumHeight(h)


class BothLegsPanel(QWidget):
    """The tab's widgets; :meth:`set_result` fills them, :meth:`show_message` says why not."""

    def __init__(self, colours: Colours | None = None, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.result: BothLegs | None = None
        colours = colours or current_colours()
        # what may make the figures misleading (BothLegs.caveats), above them all, the tab's
        # width (fewer lines); hidden if none
        self.caveats = _WrappedLine()
        self.caveats.setStyleSheet(f"color: {colours.alert}; font-weight: bold")
        self.caveats.setVisible(False)
        self.headline = _WrappedLine()
        self.headline.setTextFormat(Qt.TextFormat.RichText)
        self.table = _table(COLUMNS, TIPS)
        self.note = _WrappedLine()
        self.note.setText(NOTE)
        self.note.setStyleSheet("color: gray")
        self.cycles = BothLegsCycles(colours)
        self.cycles.setMinimumWidth(240)
        measures = QWidget()
        v = QVBoxLayout(measures)
        v.setContentsMargins(0, 0, 0, 0)
        v.addWidget(self.headline)
        v.addWidget(self.table, 1)
        v.addWidget(self.note)
        # the table keeps the width its cells need; the cycles take the rest
        self.splitter = QSplitter(Qt.Orientation.Horizontal)
        self.splitter.addWidget(measures)
        self.splitter.addWidget(self.cycles)
        self.splitter.setStretchFactor(0, 0)
        self.splitter.setStretchFactor(1, 1)
        self.splitter.setChildrenCollapsible(False)
        inner = QWidget()
        v = QVBoxLayout(inner)
        v.setContentsMargins(2, 2, 2, 2)
        v.addWidget(self.caveats)
        v.addWidget(self.splitter, 1)
        # when the tab is lower than its content (the caveats' lines, a small window) it
        # scrolls: squeezed, the note was drawn over the table's last rows
        self.area = QScrollArea()
        self.area.setWidgetResizable(True)
        self.area.setFrameShape(QFrame.Shape.NoFrame)
        self.area.setWidget(inner)
        outer = QVBoxLayout(self)
        outer.setContentsMargins(0, 0, 0, 0)
        outer.addWidget(self.area)
        self.show_message("")

    def show_message(self, text: str) -> None:
        """No figures: empty tables and ``text`` (computing, a failure, a one-unit file)."""
        self.result = None
        self._show_caveats(())
        self.headline.setText(html.escape(text))
        _fill(self.table, [])
        self.cycles.clear_data()

    def set_result(self, both: BothLegs) -> None:
        self.result = both
        n = both.n_strides
        if not both.comparable:
            self.show_message(
                f"Too few strides on both legs to compare (strides that count: left {n['L']}, "
                f"right {n['R']})."
            )
            self.result = both
            self._show_caveats(both.caveats)
            return
        self._show_caveats(both.caveats)
        user = both.excluded_by_user()
        excluded = ", ".join(f"{'left' if s == 'L' else 'right'} {k}"
                             for s, k in user.items() if k)  # fmt: skip
        tail = f"; left out for a range you excluded: {excluded}" if excluded else ""
        clear = both.clearance_text()
        if clear:
            tail += f"<br>Foot clearance {html.escape(clear)}"
        self.headline.setText(
            f"<b>Both legs</b> — cadence <b>{fmt(both.cadence_steps_min, 0)}</b> steps/min "
            f"(measured: both legs' steps); strides that count: left <b>{n['L']}</b>, right "
            f"<b>{n['R']}</b>{tail}"
        )
        _fill(self.table, both.rows())
        _fit_columns(self.table)
        _fit_rows(self.table)
        self.cycles.set_cycles(both.cycles)

    def _show_caveats(self, caveats: tuple[str, ...]) -> None:
        self.caveats.setText("\n".join(f"Caution: {c}" for c in caveats))
        self.caveats.setVisible(bool(caveats))

    def cell(self, measure: str, column: str) -> str:
        """The text shown for ``measure`` (e.g. "step time") in ``column`` (e.g. "SR (L/R)")."""
        t, c = self.table, COLUMNS.index(column)
        for r in range(t.rowCount()):
            first = t.item(r, 0)
            if first is not None and first.text() == measure:
                item = t.item(r, c)
                return item.text() if item is not None else ""
        raise KeyError(f"no row {measure!r}")
