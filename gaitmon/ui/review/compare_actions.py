"""The review window's File ▸ Compare sessions… and File ▸ Open folder…: picking the files or
the folder, running :func:`gaitmon.compare.compare_sessions` / :func:`~gaitmon.compare.
list_recordings` on a worker (newest wins; the status bar's progress), and showing the
:class:`CompareView` or the :class:`PatientList` (one of each, reused).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QObject, QSettings, Qt, Signal
from PySide6.QtWidgets import QFileDialog, QWidget

from gaitmon.compare import Comparison, Recording, compare_sessions, list_recordings
from gaitmon.jobs import Response, Ticket
from gaitmon.review.settings import ReviewKey
from gaitmon.text import count
from gaitmon.ui import one_line
from gaitmon.ui.jobs import QtWorker
from gaitmon.ui.review import recent
from gaitmon.ui.review.compare_view import CompareView
from gaitmon.ui.review.patient_list import PatientList
from gaitmon.ui.review.status import StatusArea
from gaitmon.ui.theme import Colours

FILE_FILTER = "gaitmon sessions (*.h5 *.hdf5);;All files (*)"


class SessionComparer(QObject):
    """Owned by the review window; ``open_file`` opens one recording there."""

    compared = Signal()  # the Compare view shows a new comparison
    listed = Signal()  # the patient list shows a folder

    def __init__(self, window: QWidget, settings: QSettings, status: StatusArea,
                 colours: Colours, open_file: Callable[[str], None]) -> None:  # fmt: skip
        super().__init__(window)
        self.window = window
        self.settings = settings
        self.status = status
        self.colours = colours
        self.open_file = open_file
        self.worker = QtWorker("review-compare", latest=True, parent=self)
        self.worker.progressed.connect(self._progress)
        # the status bar's one Cancel stops a comparison or a folder listing too
        status.cancel_button.clicked.connect(self.worker.cancel)
        self.view: CompareView | None = None
        self.patients: PatientList | None = None
        self._label = ""

    def _folder(self) -> str:
        return recent.folder(self.settings, ReviewKey.LAST_FOLDER)

    def _progress(self, fraction: float) -> None:
        self.status.show_progress(self._label, fraction)

    # -- compare -------------------------------------------------------------------------------

    def compare_dialog(self) -> None:
        paths, _ = QFileDialog.getOpenFileNames(self.window, "Compare sessions (pick two or more)",
                                                self._folder(), FILE_FILTER)  # fmt: skip
        if paths:
            self.compare(paths)

    def compare(self, paths: list[str]) -> None:
        if len(paths) < 2:
            self.status.show_problem("Compare needs two or more sessions: pick them together "
                                     "(Ctrl/Shift+click)")  # fmt: skip
            return
        self._label = f"Comparing {count(len(paths), 'session')}"
        self.status.hide_problem()
        self.status.show_progress(self._label, 0.0)
        files = list(paths)

        def job(ticket: Ticket) -> Comparison:
            return compare_sessions(files, progress=ticket.progress)

        self.worker.submit(job, self._compared)

    def _compared(self, response: Response[Comparison]) -> None:
        self.status.hide_progress()
        if response.cancelled:
            return
        if response.error is not None:
            self.status.show_problem(f"Cannot compare: {one_line(response.error)}")
            return
        c = response.result()
        if self.view is None:
            self.view = CompareView(self.colours)
            self.view.setWindowFlag(Qt.WindowType.Window, True)
            self.view.failed.connect(self.status.show_problem)
            self.view.saved.connect(lambda p: self.status.message(f"Wrote {p}", 10_000))
        self.view.set_comparison(c)
        self.view.show()
        self.view.raise_()
        self.status.message(f"Compared {count(len(c.sessions), 'session')}: "
                            f"{count(c.n_beyond(), 'change')} from the baseline beyond the "
                            "minimal detectable change (MDC95)", 15_000)  # fmt: skip
        self.compared.emit()

    # -- the patient list ----------------------------------------------------------------------

    def folder_dialog(self) -> None:
        folder = QFileDialog.getExistingDirectory(self.window, "Open a folder of recordings",
                                                  self._folder())  # fmt: skip
        if folder:
            self.open_folder(folder)

    def open_folder(self, folder: str | Path) -> None:
        d = Path(folder)
        self._label = f"Reading the recordings in {d.name or d}"
        self.status.hide_problem()
        self.status.show_progress(self._label, 0.0)

        def job(ticket: Ticket) -> list[Recording]:
            return list_recordings(d, progress=ticket.progress)

        self.worker.submit(job, functools.partial(self._listed, d))

    def _listed(self, folder: Path, response: Response[list[Recording]]) -> None:
        self.status.hide_progress()
        if response.cancelled:
            return
        if response.error is not None:
            self.status.show_problem(f"Cannot list the folder: {one_line(response.error)}")
            return
        recent.remember(self.settings, ReviewKey.LAST_FOLDER, folder)
        if self.patients is None:
            self.patients = PatientList()
            self.patients.setWindowFlag(Qt.WindowType.Window, True)
            self.patients.compare_requested.connect(self.compare)
            self.patients.open_requested.connect(self._open_one)
        recs = response.result()
        self.patients.set_recordings(folder, recs)
        self.patients.show()
        self.patients.raise_()
        if not recs:
            self.status.message(f"No session files (.h5) in {folder}", 10_000)
        self.listed.emit()

    def _open_one(self, path: str) -> None:
        self.open_file(path)
        self.window.raise_()
        self.window.activateWindow()

    def shutdown(self) -> None:
        self.worker.stop()
        for w in (self.view, self.patients):
            if w is not None:
                w.close()
