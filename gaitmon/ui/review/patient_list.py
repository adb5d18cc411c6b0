"""The patient list: the recordings of a folder by patient id and date, with their key
measures (:func:`gaitmon.compare.list_recordings`); pick two or more to compare, or one to open.

A file that cannot be compared (damaged, tilt mode, no strides) is listed greyed with its
problem; it can still be opened (the review window says what is wrong with it).
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QColor, QPalette
from PySide6.QtWidgets import (
    QAbstractItemView,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QPushButton,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

from gaitmon.compare import Recording
from gaitmon.text import count, num

COLUMNS = ("Patient", "Recorded", "File", "Duration (s)", "Strides", "Cadence (steps/min)",
           "Peak knee in swing (deg)", "Note")  # fmt: skip


class PatientList(QWidget):
    """A folder's recordings; ``compare_requested`` (two or more paths) and ``open_requested``
    (one path) say what the user picked."""

    compare_requested = Signal(list)  # [str]
    open_requested = Signal(str)

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("gaitmon — recordings")
        self.resize(1000, 520)
        self.recordings: list[Recording] = []
        self.folder: Path | None = None
        self.caption = QLabel()
        self.table = QTableWidget(0, len(COLUMNS))
        self.table.setHorizontalHeaderLabels(list(COLUMNS))
        self.table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QAbstractItemView.SelectionMode.ExtendedSelection)
        self.table.setAlternatingRowColors(True)
        self.table.verticalHeader().setVisible(False)
        self.table.horizontalHeader().setSectionResizeMode(
            len(COLUMNS) - 1, QHeaderView.ResizeMode.Stretch
        )
        self.table.itemSelectionChanged.connect(self._selection_changed)
        self.table.cellDoubleClicked.connect(lambda row, _col: self._open_row(row))
        self.compare_button = QPushButton("Compare selected")
        self.compare_button.setToolTip("Compare the selected recordings (two or more)")
        self.compare_button.clicked.connect(self.compare_selected)
        self.open_button = QPushButton("Open")
        self.open_button.setToolTip("Open the selected recording in the review window")
        self.open_button.clicked.connect(self.open_selected)
        self.hint = QLabel("Select two or more recordings to compare (Ctrl/Shift+click), or "
                           "one to open; double-click opens.")  # fmt: skip
        self.hint.setStyleSheet(f"color: {self._muted().name(QColor.NameFormat.HexArgb)};")
        buttons = QHBoxLayout()
        buttons.addWidget(self.hint, 1)
        buttons.addWidget(self.open_button)
        buttons.addWidget(self.compare_button)
        v = QVBoxLayout(self)
        v.addWidget(self.caption)
        v.addWidget(self.table, 1)
        v.addLayout(buttons)
        self._selection_changed()

    def set_recordings(self, folder: Path, recordings: list[Recording]) -> None:
        self.folder = folder
        self.recordings = list(recordings)
        patients = {r.patient_id for r in recordings if r.patient_id}
        self.caption.setText(
            f"<b>{folder}</b>: {count(len(recordings), 'recording')} of "
            f"{count(len(patients), 'patient')}, by patient id and date"
        )
        self.table.setRowCount(len(recordings))
        right = Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter
        for r, rec in enumerate(recordings):
            ok = not rec.problem
            cells = (
                rec.patient_id or "(none)",
                rec.recorded_utc or "unknown",
                rec.path.name,
                num(rec.duration_s, 1),  # as text.duration_text: to a tenth of a second
                str(rec.n_strides) if ok else "–",
                num(rec.cadence_steps_min, 0),
                num(rec.knee_peak_swing_deg, 1),
                rec.problem,
            )
            for c, text in enumerate(cells):
                item = QTableWidgetItem(text)
                if 3 <= c <= 6:
                    item.setTextAlignment(right)
                if not ok:
                    item.setForeground(self._muted())
                item.setToolTip(rec.problem or str(rec.path))
                self.table.setItem(r, c, item)
        self.table.resizeColumnsToContents()
        self._selection_changed()

    def _muted(self) -> QColor:
        """The text colour, faded (readable on a light or a dark theme)."""
        c = QColor(self.palette().color(QPalette.ColorRole.WindowText))
        c.setAlpha(150)
        return c

    def selected(self) -> list[Recording]:
        rows = sorted({i.row() for i in self.table.selectionModel().selectedRows()})
        return [self.recordings[r] for r in rows if r < len(self.recordings)]

    def select(self, names: list[str]) -> None:
        """Select the recordings with these file names (tests, and a caller's preselection)."""
        self.table.clearSelection()
        mode = self.table.selectionMode()
        self.table.setSelectionMode(QAbstractItemView.SelectionMode.MultiSelection)
        for r, rec in enumerate(self.recordings):
            if rec.path.name in names:
                self.table.selectRow(r)
        self.table.setSelectionMode(mode)

    def _selection_changed(self) -> None:
        sel = self.selected()
        self.open_button.setEnabled(len(sel) == 1)
        bad = [r for r in sel if r.problem]
        self.compare_button.setEnabled(len(sel) >= 2 and not bad)
        self.compare_button.setToolTip(
            f"{bad[0].path.name} cannot be compared: {bad[0].problem}" if bad else
            "Compare the selected recordings (two or more)"
        )  # fmt: skip

    def compare_selected(self) -> None:
        sel = self.selected()
        if len(sel) >= 2 and not any(r.problem for r in sel):
            self.compare_requested.emit([str(r.path) for r in sel])

    def open_selected(self) -> None:
        sel = self.selected()
        if len(sel) == 1:
            self.open_requested.emit(str(sel[0].path))

    def _open_row(self, row: int) -> None:
        if 0 <= row < len(self.recordings):
            self.open_requested.emit(str(self.recordings[row].path))
