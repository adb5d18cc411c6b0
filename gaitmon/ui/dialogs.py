"""The window's dialogs: session form, filter settings, keyboard shortcuts.

Dialogs are opened with ``open()`` (window-modal, non-blocking) and report through
``accepted``; they validate on OK and stay open with a one-line message when something is
wrong, so nothing half-valid ever reaches the engine.
"""

from __future__ import annotations

import datetime as _dt
import re
from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QFileDialog,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPlainTextEdit,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.review.settings import PIPELINE_SETTINGS

ERROR_STYLE = "color: palette(bright-text); background: #b3261e; padding: 4px; border-radius: 3px"


def _error_label() -> QLabel:
    label = QLabel()
    label.setWordWrap(True)
    label.setStyleSheet(ERROR_STYLE)
    label.setVisible(False)
    label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
    return label


# ------------------------------------------------------------------------------------------
# Session form
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SessionForm:
    patient_id: str
    side: str  # "L", "R" or ""
    operator: str
    notes: str
    path: Path


_SAFE = re.compile(r"[^A-Za-z0-9._-]+")


def default_file_name(patient_id: str, side: str, now: _dt.datetime | None = None) -> str:
    """``<patient>_<side>_<YYYYmmdd-HHMMSS>.h5`` with only file-name-safe characters."""
    now = now or _dt.datetime.now()
    who = _SAFE.sub("-", patient_id.strip()).strip("-") or "session"
    parts = [who, side] if side else [who]
    return "_".join([*parts, now.strftime("%Y%m%d-%H%M%S")]) + ".h5"


class SessionDialog(QDialog):
    """Patient ID, side, operator, notes and the file to record to."""

    def __init__(
        self,
        parent: QWidget | None,
        *,
        folder: Path,
        patient_id: str = "",
        side: str = "",
        operator: str = "",
    ) -> None:
        super().__init__(parent)
        self.setWindowTitle("Record a session")
        self.folder = folder
        self.result_form: SessionForm | None = None
        self._path_edited = False
        self.patient = QLineEdit(patient_id)
        self.patient.setPlaceholderText("identifier only, no names (e.g. P017)")
        self.patient.setToolTip("Patient identifier stored in the file. Do not enter names.")
        self.side = QComboBox()
        for text, value in (("not set", ""), ("Left", "L"), ("Right", "R")):
            self.side.addItem(text, value)
        self.side.setCurrentIndex(max(self.side.findData(side), 0))
        self.side.setToolTip("Leg the unit is worn on")
        self.operator = QLineEdit(operator)
        self.operator.setToolTip("Who runs the session (remembered)")
        self.notes = QPlainTextEdit()
        self.notes.setPlaceholderText("condition, footwear, walking aid, speed instruction…")
        self.notes.setFixedHeight(64)
        self.path = QLineEdit()
        self.path.setToolTip("HDF5 session file (.h5); the folder is remembered")
        browse = QPushButton("Browse…")
        browse.clicked.connect(self._browse)
        row = QHBoxLayout()
        row.addWidget(self.path, 1)
        row.addWidget(browse)
        form = QFormLayout()
        form.addRow("Patient ID", self.patient)
        form.addRow("Side", self.side)
        form.addRow("Operator", self.operator)
        form.addRow("Notes", self.notes)
        form.addRow("File", row)
        self.error = _error_label()
        buttons = QDialogButtonBox(
            QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel
        )
        buttons.button(QDialogButtonBox.StandardButton.Ok).setText("Start recording")
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        self.buttons = buttons
        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addWidget(self.error)
        lay.addWidget(buttons)
        self.patient.textChanged.connect(self._refresh_default_path)
        self.side.currentIndexChanged.connect(self._refresh_default_path)
        self.path.textEdited.connect(self._mark_path_edited)
        self._refresh_default_path()
        self.patient.selectAll()
        self.resize(520, self.sizeHint().height())

    def _mark_path_edited(self) -> None:
        self._path_edited = True

    def _refresh_default_path(self) -> None:
        if self._path_edited:
            return
        name = default_file_name(self.patient.text(), self.side.currentData() or "")
        self.path.setText(str(self.folder / name))

    def _browse(self) -> None:
        chosen, _ = QFileDialog.getSaveFileName(
            self, "Record to", self.path.text(), "gaitmon sessions (*.h5)"
        )
        if chosen:
            if not chosen.endswith(".h5"):
                chosen += ".h5"
            self.path.setText(chosen)
            self._path_edited = True

    def show_error(self, text: str) -> None:
        self.error.setText(text)
        self.error.setVisible(True)

    def accept(self) -> None:
        text = self.path.text().strip()
        if not text:
            self.show_error("Choose a file to record to.")
            return
        path = Path(text).expanduser()
        if path.suffix.lower() != ".h5":
            path = path.with_name(path.name + ".h5")
        if path.exists():
            self.show_error(f"{path.name} already exists; choose another name.")
            return
        if not path.parent.is_dir():
            if path.parent == self.folder:
                try:
                    path.parent.mkdir(parents=True, exist_ok=True)
                except OSError as exc:
                    self.show_error(f"cannot create folder {path.parent}: {exc.strerror or exc}")
                    return
            else:
                self.show_error(f"folder {path.parent} does not exist.")
                return
        self.result_form = SessionForm(
            patient_id=self.patient.text().strip(),
            side=self.side.currentData() or "",
            operator=self.operator.text().strip(),
            notes=self.notes.toPlainText().strip(),
            path=path,
        )
        super().accept()


# ------------------------------------------------------------------------------------------
# Settings
# ------------------------------------------------------------------------------------------

# (field, label, tooltip) of each setting, as named once in gaitmon.review.settings
SETTINGS_FIELDS = tuple((f.name, f.label, f.tip) for f in PIPELINE_SETTINGS)


class SettingsDialog(QDialog):
    """Filter and gait-event settings, validated by PipelineConfig itself."""

    def __init__(self, parent: QWidget | None, config: PipelineConfig, *, note: str = "") -> None:
        super().__init__(parent)
        self.setWindowTitle("Processing settings")
        self.base = config
        self.config: PipelineConfig | None = None
        self.edits: dict[str, QLineEdit] = {}
        form = QFormLayout()
        for f in PIPELINE_SETTINGS:
            edit = QLineEdit(f"{getattr(config, f.name):g}")
            edit.setToolTip(f.tip)
            self.edits[f.name] = edit
            form.addRow(f.label, edit)
        info = QLabel(
            note
            or "Applied live from the next block; a running recording logs the change. "
            "These settings drive the PC processing (mode “PC computes”)."
        )
        info.setWordWrap(True)
        self.error = _error_label()
        buttons = QDialogButtonBox(
            QDialogButtonBox.StandardButton.Ok
            | QDialogButtonBox.StandardButton.Cancel
            | QDialogButtonBox.StandardButton.RestoreDefaults
        )
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        buttons.button(QDialogButtonBox.StandardButton.RestoreDefaults).setToolTip(
            "the paper's values"
        )
        buttons.button(QDialogButtonBox.StandardButton.RestoreDefaults).clicked.connect(
            self._defaults
        )
        self.buttons = buttons
        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addWidget(info)
        lay.addWidget(self.error)
        lay.addWidget(buttons)

    def _defaults(self) -> None:
        d = PipelineConfig(fs_hz=self.base.fs_hz)
        for name, edit in self.edits.items():
            edit.setText(f"{getattr(d, name):g}")

    def show_error(self, text: str) -> None:
        self.error.setText(text)
        self.error.setVisible(True)

    def parsed(self) -> PipelineConfig:
        """The config the fields describe; ValueError with a message naming the field."""
        changes: dict[str, float] = {}
        for f in PIPELINE_SETTINGS:
            text = self.edits[f.name].text().strip().replace(",", ".")
            try:
                changes[f.name] = float(text)
            except ValueError:
                raise ValueError(f"{f.label}: {text!r} is not a number") from None
        if not 0.0 < changes["fsr_threshold"] < 4095.0:
            raise ValueError(
                f"FSR contact threshold must be above 0 and below 4095 counts (12-bit ADC), "
                f"got {changes['fsr_threshold']:g}"
            )
        return self.base.replace(**changes)

    def accept(self) -> None:
        try:
            self.config = self.parsed()
        except (ValueError, TypeError) as exc:
            self.show_error(str(exc).splitlines()[0] if str(exc) else "invalid settings")
            return
        super().accept()


# ------------------------------------------------------------------------------------------
# Shortcuts
# ------------------------------------------------------------------------------------------


def shortcuts_dialog(parent: QWidget | None, rows: list[tuple[str, str]]) -> QDialog:
    dlg = QDialog(parent)
    dlg.setWindowTitle("Keyboard shortcuts")
    html = ["<table cellspacing='6'>"]
    for key, what in rows:
        html.append(f"<tr><td><b>{key}</b></td><td>{what}</td></tr>")
    html.append("</table>")
    label = QLabel("".join(html))
    label.setTextFormat(Qt.TextFormat.RichText)
    buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Close)
    buttons.rejected.connect(dlg.reject)
    lay = QVBoxLayout(dlg)
    lay.addWidget(label)
    lay.addWidget(buttons)
    return dlg
