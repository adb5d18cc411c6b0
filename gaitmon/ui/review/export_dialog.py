"""The export dialog: a session to CSV, MATLAB .mat or C3D, on a worker with Cancel.

``gaitmon.io.export.export_session`` does the work (the same code as ``gaitmon export``) on a
:class:`gaitmon.ui.jobs.QtWorker`. It reports ``progress(fraction)`` as it goes and asks
``cancel()`` at the same points; once Cancel was clicked it discards every temporary output and
raises ``ExportCancelled`` (a :class:`gaitmon.errors.Cancelled`): nothing is left under the
final name. Progress is reported per chunk (16 384
rows for CSV, per series for MAT, per part for C3D); opening the file (which may first recover
an interrupted recording) and writing the last MAT/C3D piece cannot be interrupted, so a
cancel waits for the next progress call. The cancelled request is still the one the dialog
waits for (Cancel is a flag the request reads, not :meth:`QtWorker.cancel`), so its
``Cancelled`` response arrives and the dialog says so. The GUI stays responsive throughout: the
worker touches no widget. One worker per export; it ends when the export's response arrives.

The review window passes the angles it shows (``angles``: smoothed | live, and their method):
the export holds those angles, names them in the dialog and in its metadata ("angles").
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import Qt, Signal, Slot
from PySide6.QtGui import QCloseEvent
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QFileDialog,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QProgressBar,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from gaitmon.errors import Cancelled
from gaitmon.io.export import FORMATS, ExportError, ExportResult, export_session
from gaitmon.jobs import Response, Ticket
from gaitmon.ui.jobs import QtWorker


class ExportDialog(QDialog):
    """Pick a format, an output file and de-identification; Export runs in a worker thread."""

    export_finished = Signal(object)  # ExportResult
    export_failed = Signal(str)  # one-line message ("cancelled" included)

    def __init__(
        self,
        session_path: str | Path,
        parent: QWidget | None = None,
        *,
        export_fn: Callable[..., ExportResult] | None = None,
        angles: str = "smoothed",
        angle_method: str = "",
    ) -> None:
        super().__init__(parent)
        self.setWindowTitle("Export session")
        self.session_path = Path(session_path)
        # the angles exported: the review's (smoothed where the session has them, else live)
        self.angles = angles
        self.angle_method = angle_method
        # the export function is injectable so tests can slow it down or gate it
        self._export_fn = export_fn or export_session
        self._worker: QtWorker | None = None  # while an export runs
        self._cancel = threading.Event()
        self.result_: ExportResult | None = None
        self._build()
        self._on_format_changed()

    # -- layout -------------------------------------------------------------------------------

    def _build(self) -> None:
        self.source_label = QLabel(str(self.session_path))
        self.source_label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.format_combo = QComboBox()
        for f in FORMATS.values():
            self.format_combo.addItem(f.description, f.name)
        self.format_combo.currentIndexChanged.connect(self._on_format_changed)
        self.output_edit = QLineEdit()
        self.browse_button = QPushButton("Browse…")
        self.browse_button.clicked.connect(self._browse)
        out_row = QHBoxLayout()
        out_row.addWidget(self.output_edit, 1)
        out_row.addWidget(self.browse_button)
        self.deidentify_check = QCheckBox("De-identify (leave out patient ID, operator and notes)")
        self.overwrite_check = QCheckBox("Replace existing files")
        what = "zero-lag, offline" if self.angles == "smoothed" else "as shown while recording"
        if self.angle_method:
            text = f"{self.angle_method} ({what}), as shown in review"
        elif self.angles == "smoothed":
            text = "the smoothed ones (zero-lag, offline) where the session has them, else live"
        else:
            text = "the live ones (as shown while recording)"
        self.angles_label = QLabel(text)
        self.angles_label.setWordWrap(True)
        self.angles_label.setToolTip(
            "The tilt and joint angles exported are those the review window shows; switch "
            "them with View ▸ Angles. The export's metadata names them ('angles')."
        )
        form = QFormLayout()
        form.addRow("Session", self.source_label)
        form.addRow("Angles", self.angles_label)
        form.addRow("Format", self.format_combo)
        form.addRow("Save as", out_row)
        form.addRow("", self.deidentify_check)
        form.addRow("", self.overwrite_check)
        self.progress_bar = QProgressBar()
        self.progress_bar.setRange(0, 1000)
        self.progress_bar.setTextVisible(True)
        self.progress_bar.setFormat("%p %")
        self.progress_bar.setValue(0)
        self.status_label = QLabel("")
        self.status_label.setWordWrap(True)
        self.buttons = QDialogButtonBox()
        self.export_button = self.buttons.addButton(
            "Export", QDialogButtonBox.ButtonRole.AcceptRole
        )
        self.cancel_button = self.buttons.addButton(QDialogButtonBox.StandardButton.Cancel)
        self.close_button = self.buttons.addButton(QDialogButtonBox.StandardButton.Close)
        self.export_button.clicked.connect(self.start_export)
        self.cancel_button.clicked.connect(self.cancel)
        self.close_button.clicked.connect(self.close)
        # the box's own accepted/rejected would close the dialog mid-export: not connected
        layout = QVBoxLayout(self)
        layout.addLayout(form)
        layout.addWidget(self.progress_bar)
        layout.addWidget(self.status_label)
        layout.addWidget(self.buttons)
        self._set_running(False)

    @property
    def fmt(self) -> str:
        return str(self.format_combo.currentData())

    def set_format(self, fmt: str) -> None:
        idx = self.format_combo.findData(fmt)
        if idx < 0:
            raise ValueError(f"unknown export format {fmt!r}")
        self.format_combo.setCurrentIndex(idx)

    @Slot()
    def _on_format_changed(self) -> None:
        current = self.output_edit.text().strip()
        base = Path(current) if current else self.session_path
        self.output_edit.setText(str(base.with_suffix(FORMATS[self.fmt].suffix)))

    @Slot()
    def _browse(self) -> None:
        ext = FORMATS[self.fmt].suffix
        path, _ = QFileDialog.getSaveFileName(
            self, "Export to", self.output_edit.text(), f"{self.fmt.upper()} (*{ext})"
        )
        if path:
            p = Path(path)
            self.output_edit.setText(str(p if p.suffix.lower() == ext else p.with_suffix(ext)))

    def _set_running(self, running: bool) -> None:
        for w in (
            self.format_combo,
            self.output_edit,
            self.browse_button,
            self.deidentify_check,
            self.overwrite_check,
            self.export_button,
            self.close_button,
        ):
            w.setEnabled(not running)
        self.cancel_button.setEnabled(running)

    # -- the worker -----------------------------------------------------------------------------

    @property
    def is_running(self) -> bool:
        return self._worker is not None

    @Slot()
    def start_export(self) -> None:
        if self.is_running:
            return
        out_text = self.output_edit.text().strip()
        if not out_text:
            self._fail("choose a file to export to")
            return
        # the request: everything the worker needs, captured now (it never reads widgets)
        src, fmt, out = self.session_path, self.fmt, Path(out_text)
        deidentify = self.deidentify_check.isChecked()
        force = self.overwrite_check.isChecked()
        angles = self.angles
        self._cancel.clear()
        self.result_ = None
        self.progress_bar.setValue(0)
        self.status_label.setText(f"Exporting to {out.name}…")
        self._set_running(True)
        cancel, export_fn = self._cancel, self._export_fn

        def job(ticket: Ticket) -> ExportResult:
            return export_fn(src, fmt, out, deidentify=deidentify, force=force, angles=angles,
                             progress=ticket.progress, cancel=cancel.is_set)  # fmt: skip

        self._worker = QtWorker("export", latest=False, parent=self)
        self._worker.progressed.connect(self._on_progress)
        self._worker.submit(job, self._on_done)

    @Slot()
    def cancel(self) -> None:
        """Ask the running export to stop at its next progress call."""
        if self.is_running:
            self._cancel.set()
            self.status_label.setText("Cancelling…")
            self.cancel_button.setEnabled(False)

    def wait(self, timeout_s: float = 30.0) -> bool:
        """Wait for the running export (used when closing); True if none is left running."""
        worker = self._worker
        if worker is not None:
            return worker.wait_idle(timeout_s)
        return True

    @Slot(float)
    def _on_progress(self, fraction: float) -> None:
        self.progress_bar.setValue(round(1000 * min(max(fraction, 0.0), 1.0)))

    def _on_done(self, response: Response[ExportResult]) -> None:
        worker, self._worker = self._worker, None
        if worker is not None:
            worker.stop()  # idle: the request has answered; this ends its thread
        self._set_running(False)
        exc = response.error
        result = response.value
        if exc is None and result is not None:
            self.result_ = result
            self.progress_bar.setValue(1000)
            names = ", ".join(p.name for p in result.paths)
            note = f" (note: {'; '.join(result.problems)})" if result.problems else ""
            self.status_label.setText(f"Exported {result.n_samples} samples to {names}{note}")
            self.export_finished.emit(result)
        elif isinstance(exc, Cancelled):
            self.progress_bar.setValue(0)
            self._fail("export cancelled; no file was written")
        elif isinstance(exc, ExportError):
            self._fail(str(exc))
        else:
            # an unexpected failure still reaches the user as one line, never a traceback
            self._fail(f"export failed: {type(exc).__name__}: {exc}")

    def _fail(self, message: str) -> None:
        self.status_label.setText(message)
        self.export_failed.emit(message)

    def closeEvent(self, event: QCloseEvent) -> None:
        if self.is_running:
            self.cancel()
            event.ignore()  # closes once the worker has stopped; Close is disabled meanwhile
            return
        super().closeEvent(event)

    def reject(self) -> None:  # Esc: cancel a running export instead of hiding the dialog
        if self.is_running:
            self.cancel()
            return
        super().reject()
