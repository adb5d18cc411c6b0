"""The export dialog: a session to CSV, MATLAB .mat, C3D, per-stride CSV or a BIDS dataset,
on a worker with Cancel.

``gaitmon.export.export_session`` does the work (the same code as ``gaitmon export``) on a
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
the export holds those angles, names them in the dialog and in its metadata ("angles"). Of a
file that records both legs it passes the leg shown (``side``: "L" | "R"), exported as
``gaitmon export --side`` does it (default names ``FILE_L.csv`` ...).

De-identification starts at each format's own default, as ``gaitmon export`` has it
(:attr:`Format.deidentify_default`: on for BIDS, off for the others). For BIDS the output is a
dataset folder, and the dialog asks what ``gaitmon export --format bids`` takes: the subject
label (``01``, a label typed, a subject map file, or the patient id only when its box is ticked,
with a warning), the session and the task. The labels are checked by
:class:`gaitmon.export.writers.bids_labels.BidsOptions`, as on the command line, before the worker
starts, so a bad label is the command line's one-line message.
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
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QProgressBar,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from gaitmon.errors import Cancelled
from gaitmon.export import FORMATS, ExportError, ExportResult, default_output, export_session
from gaitmon.export.writers.bids_labels import DEFAULT_SUBJECT, DEFAULT_TASK, BidsOptions
from gaitmon.jobs import Response, Ticket
from gaitmon.ui.jobs import QtWorker


class ExportDialog(QDialog):
    """Pick a format, an output (a file, or a folder for BIDS) and de-identification; Export
    runs in a worker thread."""

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
        side: str | None = None,
    ) -> None:
        super().__init__(parent)
        self.setWindowTitle("Export session")
        self.session_path = Path(session_path)
        # one leg of a bilateral file (None: a one-unit file); named as export names it
        self.side = side
        p = self.session_path
        self._named = p if side is None else p.with_name(f"{p.stem}_{side}{p.suffix}")
        # the angles exported: the review's (smoothed where the session has them, else live)
        self.angles = angles
        self.angle_method = angle_method
        # the export function is injectable so tests can slow it down or gate it
        self._export_fn = export_fn or export_session
        self._worker: QtWorker | None = None  # while an export runs
        self._cancel = threading.Event()
        self.result_: ExportResult | None = None
        # the output last chosen for a file format and for a folder format (BIDS), so that
        # switching between them does not turn a folder into a file name or back
        self._file_output = ""
        self._folder_output = ""
        self._format_shown: str | None = None
        self._build()
        self._on_format_changed()

    # -- layout -------------------------------------------------------------------------------

    def _build(self) -> None:
        leg = {"L": " — left leg", "R": " — right leg"}.get(self.side or "", "")
        self.source_label = QLabel(f"{self.session_path}{leg}")
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
        self._build_bids()
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
        self.save_label = QLabel("Save as")
        form.addRow(self.save_label, out_row)
        form.addRow("", self.deidentify_check)
        form.addRow("", self.overwrite_check)
        form.addRow(self.bids_box)
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

    def _build_bids(self) -> None:
        """The BIDS options (shown for BIDS only): subject, session and task labels."""
        self.bids_box = QGroupBox("BIDS dataset")
        self.subject_edit = QLineEdit(DEFAULT_SUBJECT)
        self.subject_edit.setToolTip("letters and digits; the files are named sub-<label>")
        self.subject_map_edit = QLineEdit()
        self.subject_map_edit.setPlaceholderText("none: the label above is used")
        self.subject_map_edit.setToolTip(
            "a file of 'patient_id<TAB>label' rows you keep: this session's label is looked "
            "up by its patient id (the id itself is not written)"
        )
        self.subject_map_edit.textChanged.connect(self._on_subject_source_changed)
        self.subject_map_button = QPushButton("Choose…")
        self.subject_map_button.clicked.connect(self._browse_subject_map)
        map_row = QHBoxLayout()
        map_row.addWidget(self.subject_map_edit, 1)
        map_row.addWidget(self.subject_map_button)
        self.patient_id_check = QCheckBox("Use the patient ID as the subject label")
        self.patient_id_check.toggled.connect(self._on_subject_source_changed)
        self.patient_id_warning = QLabel(
            "⚠ The dataset will identify the patient: the patient ID becomes its folder and "
            "file names (sub-<patient ID>), whatever De-identify says."
        )
        self.patient_id_warning.setWordWrap(True)
        self.patient_id_warning.setStyleSheet("color: #b00020;")
        self.session_edit = QLineEdit()
        self.session_edit.setPlaceholderText("none (no ses- level)")
        self.task_edit = QLineEdit(DEFAULT_TASK)
        form = QFormLayout(self.bids_box)
        form.addRow("Subject", self.subject_edit)
        form.addRow("Subject map", map_row)
        form.addRow("", self.patient_id_check)
        form.addRow("", self.patient_id_warning)
        form.addRow("Session", self.session_edit)
        form.addRow("Task", self.task_edit)
        self._on_subject_source_changed()

    @property
    def fmt(self) -> str:
        return str(self.format_combo.currentData())

    @property
    def is_folder(self) -> bool:
        """The chosen format writes a folder (BIDS), not a file."""
        return FORMATS[self.fmt].folder

    def set_format(self, fmt: str) -> None:
        idx = self.format_combo.findData(fmt)
        if idx < 0:
            raise ValueError(f"unknown export format {fmt!r}")
        self.format_combo.setCurrentIndex(idx)

    @Slot()
    def _on_format_changed(self) -> None:
        form = FORMATS[self.fmt]
        shown = self._format_shown
        current = self.output_edit.text().strip()
        if shown is not None and current:  # remember what was chosen for that kind of output
            if FORMATS[shown].folder:
                self._folder_output = current
            else:
                self._file_output = current
        if form.folder:
            # gaitmon export's own default folder unless one was chosen: never a file name
            text = self._folder_output or str(
                default_output(self._named, form.name, deidentify=form.deidentify_default)
            )
        else:
            base = Path(self._file_output) if self._file_output else self._named
            text = str(base.with_suffix(form.suffix))
        self.output_edit.setText(text)
        self.save_label.setText("Folder" if form.folder else "Save as")
        # each format starts de-identified or not as gaitmon export does without --deidentify
        self.deidentify_check.setChecked(form.deidentify_default)
        self.bids_box.setVisible(form.name == "bids")
        self._format_shown = form.name
        self.adjustSize()

    @Slot()
    def _on_subject_source_changed(self) -> None:
        from_pid = self.patient_id_check.isChecked()
        has_map = bool(self.subject_map_edit.text().strip())
        running = self.is_running
        self.subject_edit.setEnabled(not running and not from_pid and not has_map)
        self.subject_map_edit.setEnabled(not running and not from_pid)
        self.subject_map_button.setEnabled(not running and not from_pid)
        self.patient_id_warning.setVisible(from_pid)

    @Slot()
    def _browse(self) -> None:
        if self.is_folder:
            path = QFileDialog.getExistingDirectory(
                self, "Export to the BIDS dataset folder", self.output_edit.text()
            )
            if path:
                self.output_edit.setText(path)
            return
        ext = FORMATS[self.fmt].suffix
        path, _ = QFileDialog.getSaveFileName(
            self, "Export to", self.output_edit.text(), f"{self.fmt.upper()} (*{ext})"
        )
        if path:
            p = Path(path)
            self.output_edit.setText(str(p if p.name.lower().endswith(ext) else p.with_suffix(ext)))

    @Slot()
    def _browse_subject_map(self) -> None:
        path, _ = QFileDialog.getOpenFileName(
            self, "Subject map (patient_id <TAB> label)", str(self.session_path.parent),
            "Subject map (*.tsv *.csv *.txt);;All files (*)",
        )
        if path:
            self.subject_map_edit.setText(path)

    def bids_options(self) -> dict[str, object]:
        """What ``gaitmon export --format bids`` would be given: one subject source (the
        patient id only if its box is ticked), the session if typed, the task."""
        options: dict[str, object] = {}
        map_text = self.subject_map_edit.text().strip()
        if self.patient_id_check.isChecked():
            options["subject_from_patient_id"] = True
        elif map_text:
            options["subject_map"] = Path(map_text)
        else:
            options["subject"] = self.subject_edit.text().strip() or DEFAULT_SUBJECT
        session = self.session_edit.text().strip()
        if session:
            options["session"] = session
        options["task"] = self.task_edit.text().strip() or DEFAULT_TASK
        return options

    def _set_running(self, running: bool) -> None:
        for w in (
            self.format_combo,
            self.output_edit,
            self.browse_button,
            self.deidentify_check,
            self.overwrite_check,
            self.export_button,
            self.close_button,
            self.patient_id_check,
            self.session_edit,
            self.task_edit,
        ):
            w.setEnabled(not running)
        self.cancel_button.setEnabled(running)
        self._on_subject_source_changed()

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
            self._fail("choose a folder to export to" if self.is_folder
                       else "choose a file to export to")  # fmt: skip
            return
        options: dict[str, object] | None = None
        if self.fmt == "bids":
            options = self.bids_options()
            try:  # the command line's checks and messages (letters and digits only, ...)
                BidsOptions.from_mapping(options)
            except ExportError as exc:
                self._fail(str(exc))
                return
        # the request: everything the worker needs, captured now (it never reads widgets)
        src, fmt, out = self.session_path, self.fmt, Path(out_text)
        deidentify = self.deidentify_check.isChecked()
        force = self.overwrite_check.isChecked()
        angles = self.angles
        side = self.side
        self._cancel.clear()
        self.result_ = None
        self.progress_bar.setValue(0)
        self.status_label.setText(f"Exporting to {out.name}…")
        self._set_running(True)
        cancel, export_fn = self._cancel, self._export_fn

        def job(ticket: Ticket) -> ExportResult:
            return export_fn(src, fmt, out, deidentify=deidentify, force=force, angles=angles,
                             progress=ticket.progress, cancel=cancel.is_set,
                             options=options, side=side)  # fmt: skip

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
            if FORMATS[self.fmt].folder and result.paths:
                names = f"{len(result.paths)} files in {self.output_edit.text().strip()}"
            else:
                names = ", ".join(p.name for p in result.paths)
            note = f" (note: {'; '.join(result.problems)})" if result.problems else ""
            self.status_label.setText(f"Exported {result.amount} to {names}{note}")
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
