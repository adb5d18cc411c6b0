"""The review window: open a recorded session, inspect it, analyse the strides, reprocess.

Layout: a red banner for problems; the timeline (readout, whole-session overview, detail lanes);
below it the stride table, the summary and the cycle-normalised plots. Everything slow runs in
background workers as request -> response (see :mod:`gaitmon.ui.review.workers`): opening
(recovery of an interrupted recording, the overview), the stride analysis, reprocessing and
saving. Progress and a Cancel button live in the status bar. Every slot is guarded: an
unexpected exception becomes one line in the banner (and a logged traceback), never a crash.

User exclusions are kept beside the recording in ``FILE.review.json`` (see
:mod:`gaitmon.ui.review.exclusions`); when that folder is read-only they are kept in the
application settings instead. The recording itself is never written.
"""

from __future__ import annotations

import argparse
import functools
import importlib.util
import json
import logging
import math
from pathlib import Path
from typing import Any

from PySide6.QtCore import QSettings, Qt, QTimer, Signal
from PySide6.QtGui import QAction, QCloseEvent, QDragEnterEvent, QDropEvent
from PySide6.QtWidgets import (
    QFileDialog,
    QHBoxLayout,
    QLabel,
    QMainWindow,
    QProgressBar,
    QPushButton,
    QSplitter,
    QToolButton,
    QVBoxLayout,
    QWidget,
)

from gaitmon import __version__
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.io.session import SessionError, journal_path
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded, make_action
from gaitmon.ui.dialogs import ERROR_STYLE, SettingsDialog
from gaitmon.ui.review import exclusions as excl
from gaitmon.ui.review.cycles import CyclePlots
from gaitmon.review.model import (
    Analysis,
    Document,
    analyse,
    changed_settings,
    open_document,
    reprocess,
)
from gaitmon.ui.review.strides import StrideTable, SummaryLabel, summary_html
from gaitmon.ui.review.timeline import Timeline
from gaitmon.ui.review.workers import LatestWorker, Ticket
from gaitmon.ui.theme import Colours, configure_pyqtgraph, current_colours

log = logging.getLogger("gaitmon.ui.review")

MAX_RECENT = 8
FILE_FILTER = "gaitmon sessions (*.h5 *.hdf5);;All files (*)"


def _available(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


class ReviewWindow(QMainWindow):
    """Review of recorded sessions. ``settings`` is injected so tests can isolate it."""

    document_opened = Signal(str)
    open_failed = Signal(str)
    analysis_done = Signal()
    reprocessed = Signal()
    report_written = Signal(str)

    def __init__(self, settings: QSettings, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.settings = settings
        self.errors: list[str] = []  # unexpected exceptions (tests assert it stays empty)
        self.doc: Document | None = None
        self.analysis: Analysis | None = None
        self.before: Analysis | None = None  # recorded-series analysis after a reprocessing
        self.last_problem = ""
        self._closing = False
        self.colours: Colours = current_colours()
        configure_pyqtgraph(self.colours)
        self.setWindowTitle("gaitmon — review")
        self.setAcceptDrops(True)
        self.resize(1400, 920)

        self.job = LatestWorker("job", self)  # open, reprocess, save: one at a time
        self.analyser = LatestWorker("analysis", self)
        self._job_label = ""

        self._build_central()
        self._build_actions()
        self._build_menus()
        self._build_statusbar()
        self._update_actions()

    # -- construction --------------------------------------------------------------------------

    def _build_central(self) -> None:
        self.banner = QLabel()
        self.banner.setWordWrap(True)
        self.banner.setStyleSheet(ERROR_STYLE)
        self.banner.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.banner_close = QToolButton()
        self.banner_close.setText("✕")
        self.banner_close.setToolTip("Hide this message")
        self.banner_close.clicked.connect(self.hide_problem)
        banner_row = QHBoxLayout()
        banner_row.setContentsMargins(0, 0, 0, 0)
        banner_row.addWidget(self.banner, 1)
        banner_row.addWidget(self.banner_close)
        self.banner_box = QWidget()
        self.banner_box.setLayout(banner_row)
        self.banner_box.setVisible(False)
        self.notes = QLabel()
        self.notes.setWordWrap(True)
        self.notes.setVisible(False)

        self.timeline = Timeline(self.colours)
        self.timeline.failed.connect(self.show_problem)
        self.timeline.progress.connect(lambda f: self._show_progress("Loading the view", f))
        self.timeline.busy_changed.connect(self._view_busy)
        self.timeline.selection_changed.connect(lambda *_: self._update_actions())

        self.table = StrideTable(self.colours)
        self.table.stride_picked.connect(self.show_stride)
        self.summary = SummaryLabel()
        self.summary.setMinimumWidth(250)
        self.cycles = CyclePlots(self.colours)
        self.cycles.setMinimumWidth(300)

        left = QWidget()
        lv = QVBoxLayout(left)
        lv.setContentsMargins(0, 0, 0, 0)
        title = QLabel("<b>Strides</b> — click one to show it; greyed rows are not in the "
                       "statistics")  # fmt: skip
        lv.addWidget(title)
        lv.addWidget(self.table, 1)
        bottom = QSplitter(Qt.Orientation.Horizontal)
        bottom.addWidget(left)
        bottom.addWidget(self.summary)
        bottom.addWidget(self.cycles)
        bottom.setStretchFactor(0, 5)
        bottom.setStretchFactor(1, 2)
        bottom.setStretchFactor(2, 3)
        bottom.setSizes([700, 260, 420])
        self.bottom = bottom
        split = QSplitter(Qt.Orientation.Vertical)
        split.addWidget(self.timeline)
        split.addWidget(bottom)
        split.setStretchFactor(0, 3)
        split.setStretchFactor(1, 2)
        split.setSizes([560, 330])
        self.splitter = split
        central = QWidget()
        v = QVBoxLayout(central)
        v.setContentsMargins(4, 4, 4, 2)
        v.setSpacing(3)
        v.addWidget(self.banner_box)
        v.addWidget(self.notes)
        v.addWidget(split, 1)
        self.setCentralWidget(central)

    _action = make_action  # a method: the window owns its actions

    def _build_actions(self) -> None:
        A = self._action
        self.act_open = A("&Open…", self.open_dialog, "Ctrl+O", "Open a recorded session (.h5)")
        self.act_close = A("&Close", self.close_document, "Ctrl+W", "Close the session")
        self.act_save_reprocessed = A(
            "Save reprocessed as…", self.save_reprocessed_dialog, None,
            "Write a new session file with the reprocessed series (as gaitmon process does); "
            "the recording is not modified",
        )  # fmt: skip
        self.act_quit = A("&Quit", self.close, "Ctrl+Q")
        self.act_whole = A("Whole session", self.show_whole, "Ctrl+0", "Zoom out to everything")
        self.act_zoom_in = A("Zoom in", lambda: self.zoom(0.5), "=", "Zoom in around the cursor")
        self.act_zoom_out = A("Zoom out", lambda: self.zoom(2.0), "-", "Zoom out")
        self.act_left = A("Pan left", lambda: self.pan(-0.5), "[", "Half a view back")
        self.act_right = A("Pan right", lambda: self.pan(0.5), "]", "Half a view forward")
        self.act_fit = A("Fit y ranges", self.timeline.fit_y, "Home", "Fit every lane's y range")
        self.lane_actions: dict[str, QAction] = {}
        for key, label, on in (("tilt", "Segment tilt lane", True), ("fsr", "Foot sensor lane",
                               True), ("raw", "Raw channels lane", False)):  # fmt: skip
            self.lane_actions[key] = A(
                label, functools.partial(self.timeline.set_lane_visible, key), None, "",
                True, on,
            )  # fmt: skip
        self.method_actions = {
            "acc": A("Joint angles from the accelerometer (red)",
                     functools.partial(self.timeline.set_method, "acc"), None, "", True, False),
            "gyro": A("Joint angles from gyro integration (blue)",
                      functools.partial(self.timeline.set_method, "gyro"), None, "", True, False),
        }  # fmt: skip
        self.act_compare = A(
            "Show recorded under reprocessed", self.set_compare, None,
            "After a reprocessing, draw the recorded series (grey, dashed) for comparison",
            True, True,
        )  # fmt: skip
        self.act_exclude = A(
            "&Exclude selected range", self.exclude_selection, "E",
            "Leave the selected range (Shift+drag on the timeline, e.g. a turn) out of the "
            "statistics",
        )  # fmt: skip
        self.act_include = A(
            "&Include selected range again", self.include_selection, "Shift+E",
            "Remove exclusions inside the selected range",
        )  # fmt: skip
        self.act_clear_excl = A("Clear all exclusions", self.clear_exclusions)
        self.act_clear_sel = A("Clear selection", self.timeline.clear_selection, "Esc")
        self.act_reprocess = A(
            "&Reprocess with settings…", self.reprocess_dialog, "Ctrl+P",
            "Recompute angles and gait events from the raw counts with other filter settings",
        )  # fmt: skip
        self.act_revert = A("Back to the recorded series", self.revert_reprocessing)
        self.act_about = A("About", self.show_about)
        # the report, export, plot export, normative and filters parts (their own modules)
        self.doc_actions: list[QAction] = []
        self.act_export = self.act_report = self.act_filters = None
        self.act_normative = self.act_no_normative = None
        self.normative: Any = None
        if _available("gaitmon.ui.review.export_dialog"):
            self.act_export = A("&Export…", self.export_dialog, "Ctrl+Shift+E",
                                "Export the session to CSV, MATLAB .mat or C3D")  # fmt: skip
            self.doc_actions.append(self.act_export)
        if _available("gaitmon.ui.report_pdf") and _available("gaitmon.report"):
            self.act_report = A(
                "&Report (PDF)…", self.report_dialog, "Ctrl+Shift+R",
                "One-page clinical report of the recorded series, with the exclusions in force",
            )  # fmt: skip
            self.doc_actions.append(self.act_report)
        if _available("gaitmon.ui.review.filters_view"):
            self.act_filters = A("&Filters…", self.show_filters, "Ctrl+F",
                                 "Compare tilt filters on the range in view")  # fmt: skip
            self.doc_actions.append(self.act_filters)
        if _available("gaitmon.normative"):
            self.act_normative = A(
                "Load &normative band…", self.normative_dialog, None,
                "Draw a reference mean ± SD band behind the cycle plots",
            )  # fmt: skip
            self.act_no_normative = A("Remove normative band", lambda: self.set_normative(None))
        self._filters_window: QWidget | None = None

    def _build_menus(self) -> None:
        mb = self.menuBar()
        f = mb.addMenu("&File")
        f.addAction(self.act_open)
        self.recent_menu = f.addMenu("Open &recent")
        self.recent_menu.aboutToShow.connect(self._fill_recent)
        f.addAction(self.act_close)
        f.addSeparator()
        self.file_menu = f
        for a in (self.act_export, self.act_report):
            if a is not None:
                f.addAction(a)
        f.addAction(self.act_save_reprocessed)
        f.addSeparator()
        f.addAction(self.act_quit)
        v = mb.addMenu("&View")
        for a in (self.act_whole, self.act_zoom_in, self.act_zoom_out, self.act_left,
                  self.act_right, self.act_fit):  # fmt: skip
            v.addAction(a)
        v.addSeparator()
        for a in self.lane_actions.values():
            v.addAction(a)
        for a in self.method_actions.values():
            v.addAction(a)
        v.addAction(self.act_compare)
        if self.act_filters is not None:
            v.addSeparator()
            v.addAction(self.act_filters)
        self.view_menu = v
        an = mb.addMenu("&Analysis")
        for a in (self.act_exclude, self.act_include, self.act_clear_excl, self.act_clear_sel):
            an.addAction(a)
        an.addSeparator()
        an.addAction(self.act_reprocess)
        an.addAction(self.act_revert)
        if self.act_normative is not None and self.act_no_normative is not None:
            an.addSeparator()
            an.addAction(self.act_normative)
            an.addAction(self.act_no_normative)
        self.analysis_menu = an
        self._attach_plot_export()
        h = mb.addMenu("&Help")
        h.addAction(self.act_about)

    def _build_statusbar(self) -> None:
        sb = self.statusBar()
        self.progress = QProgressBar()
        self.progress.setRange(0, 1000)
        self.progress.setMaximumWidth(220)
        self.progress.setTextVisible(False)
        self.progress_label = QLabel()
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setToolTip("Stop the running job")
        self.cancel_button.clicked.connect(self.cancel_job)
        for w in (self.progress_label, self.progress, self.cancel_button):
            sb.addPermanentWidget(w)
            w.setVisible(False)
        self.hint = QLabel("Shift+drag on the timeline selects a range; E excludes it.")
        sb.addWidget(self.hint)

    # -- messages ------------------------------------------------------------------------------

    def report_exception(self, where: str, exc: BaseException) -> None:
        """An unexpected exception (from a `guarded` slot): one line in the banner, and logged."""
        log.error("review: %s failed", where, exc_info=exc)
        self.errors.append(f"{where}: {exc}")
        self.show_problem(f"Unexpected error in {where}: {one_line(exc)}")

    def show_problem(self, text: str) -> None:
        self.last_problem = text
        self.banner.setText(text)
        self.banner_box.setVisible(True)
        self.statusBar().showMessage(text, 15_000)

    def hide_problem(self) -> None:
        self.banner_box.setVisible(False)

    def _show_notes(self) -> None:
        notes = self.doc.notes if self.doc is not None else []
        self.notes.setText(" · ".join(f"Note: {n}" for n in notes))
        self.notes.setVisible(bool(notes))

    def _show_progress(self, label: str, fraction: float) -> None:
        self.progress_label.setText(label)
        self.progress.setValue(int(1000 * max(0.0, min(1.0, fraction))))
        for w in (self.progress_label, self.progress, self.cancel_button):
            w.setVisible(True)

    def _hide_progress(self) -> None:
        if self.job.busy:
            return
        for w in (self.progress_label, self.progress, self.cancel_button):
            w.setVisible(False)

    def _view_busy(self, busy: bool) -> None:
        if not busy:
            self._hide_progress()

    def _update_actions(self) -> None:
        has = self.doc is not None
        raw = has and self.doc is not None and self.doc.session.mode == "raw"
        for a in (self.act_close, self.act_whole, self.act_zoom_in, self.act_zoom_out,
                  self.act_left, self.act_right, self.act_fit, self.act_clear_excl):  # fmt: skip
            a.setEnabled(has)
        sel = has and self.timeline.selection is not None
        self.act_exclude.setEnabled(sel)
        self.act_include.setEnabled(sel)
        self.act_reprocess.setEnabled(bool(raw))
        rep = has and self.doc is not None and self.doc.reprocessed is not None
        self.act_revert.setEnabled(bool(rep))
        self.act_save_reprocessed.setEnabled(bool(rep))
        for a in getattr(self, "doc_actions", []):
            a.setEnabled(has)

    # -- opening -------------------------------------------------------------------------------

    @guarded
    def open_dialog(self) -> None:
        folder = str(self.settings.value("review/last_folder", str(Path.home())))
        path, _ = QFileDialog.getOpenFileName(self, "Open a session", folder, FILE_FILTER)
        if path:
            self.open_file(path)

    @guarded
    def open_file(self, path: str | Path) -> None:
        """Open ``path`` in the background (recovering it first if it was interrupted)."""
        path = Path(path)
        self.hide_problem()
        self.timeline.loader.cancel()
        recovering = journal_path(path).exists()
        label = f"Recovering {path.name}" if recovering else f"Opening {path.name}"
        self._job_label = label
        self._show_progress(label, 0.0)
        self.statusBar().showMessage(
            f"{label}…" + (" (the recording was interrupted; rebuilding it from its journal)"
                           if recovering else ""),
        )  # fmt: skip

        def job(ticket: Ticket) -> Document:
            return open_document(path, progress=ticket.progress)

        self.job.progressed.connect(self._job_progress, Qt.ConnectionType.UniqueConnection)
        self.job.submit(job, functools.partial(self._opened, path), on_stale=Document.close)

    def _job_progress(self, fraction: float) -> None:
        self._show_progress(self._job_label, fraction)

    @guarded
    def _opened(self, path: Path, doc: Document | None, exc: BaseException | None) -> None:
        self._hide_progress()
        if exc is not None or doc is None:
            why = one_line(exc) if exc else "unknown error"
            msg = str(exc) if isinstance(exc, SessionError) else f"cannot open {path.name}: {why}"
            if not isinstance(exc, SessionError) and exc is not None:
                log.error("opening %s failed", path, exc_info=exc)
            self.show_problem(f"Cannot open: {msg}")
            self.statusBar().showMessage(msg, 15_000)
            self.open_failed.emit(msg)
            return
        self._set_document(doc)
        self._add_recent(path)
        self.settings.setValue("review/last_folder", str(path.parent))
        self.document_opened.emit(str(path))

    def _set_document(self, doc: Document) -> None:
        self._drop_document()
        self.doc = doc
        if not doc.exclusions:
            doc.exclusions = self._fallback_exclusions(doc)
        s = doc.session
        who = s.meta.patient_id or "no patient id"
        state = "complete" if s.complete else ("recovered" if s.recovered else "incomplete")
        self.setWindowTitle(f"gaitmon — review — {doc.path.name}")
        self.statusBar().showMessage(
            f"{doc.path.name}: {who}, side {s.meta.side or '-'}, {doc.n_rows} frames "
            f"({s.duration_s or doc.n_rows / doc.fs_hz:.0f} s), mode {s.mode}, {state}; "
            f"{len(s.gaps)} gaps, {len(s.markers)} markers",
            20_000,
        )
        if not doc.n_rows:
            doc.notes.append("the session holds no samples")
        self._show_notes()
        self.timeline.set_fsr_threshold(doc.current.config.fsr_threshold)
        self.timeline.set_document(doc)
        self._update_actions()
        self.run_analysis()

    def _drop_document(self) -> None:
        old = self.doc
        self.doc = None
        self.analysis = self.before = None
        self.analyser.cancel()
        self.timeline.clear()
        # the workers may still be reading the old file: close it once they are idle
        self.timeline.loader.wait_idle(5.0)
        self.analyser.wait_idle(5.0)
        if old is not None:
            old.close()
        self.table.set_rows([], [])
        self.cycles.clear_data()
        self.summary.setText(summary_html(None))
        self.notes.setVisible(False)

    @guarded
    def close_document(self) -> None:
        self.job.cancel()
        self._drop_document()
        self.setWindowTitle("gaitmon — review")
        self._update_actions()

    def cancel_job(self) -> None:
        was = self._job_label
        self.job.cancel()
        self.timeline.loader.cancel()
        self._hide_progress()
        for w in (self.progress_label, self.progress, self.cancel_button):
            w.setVisible(False)
        if was.startswith("Recovering"):
            self.show_problem("Recovery cancelled; the journal is kept: open the file again to "
                              "recover it.")  # fmt: skip
        else:
            self.statusBar().showMessage(f"{was or 'Loading'} cancelled", 8000)

    # -- recent files, drag and drop -------------------------------------------------------------

    def recent_files(self) -> list[str]:
        value = self.settings.value("review/recent", [])
        if isinstance(value, str):
            value = [value]
        return [str(v) for v in (value or [])]

    def _add_recent(self, path: Path) -> None:
        p = str(path.resolve())
        items = [p, *(r for r in self.recent_files() if r != p)][:MAX_RECENT]
        self.settings.setValue("review/recent", items)

    def _fill_recent(self) -> None:
        self.recent_menu.clear()
        items = self.recent_files()
        if not items:
            a = self.recent_menu.addAction("(none yet)")
            a.setEnabled(False)
            return
        for p in items:
            a = self.recent_menu.addAction(Path(p).name)
            a.setToolTip(p)
            a.setStatusTip(p)
            a.triggered.connect(functools.partial(self.open_file, p))
        self.recent_menu.addSeparator()
        clear = self.recent_menu.addAction("Clear the list")
        clear.triggered.connect(lambda: self.settings.setValue("review/recent", []))

    def dragEnterEvent(self, ev: QDragEnterEvent) -> None:
        if ev.mimeData().hasUrls() and any(u.isLocalFile() for u in ev.mimeData().urls()):
            ev.acceptProposedAction()

    def dropEvent(self, ev: QDropEvent) -> None:
        files = [u.toLocalFile() for u in ev.mimeData().urls() if u.isLocalFile()]
        if files:
            ev.acceptProposedAction()
            self.open_file(files[0])

    # -- navigation ------------------------------------------------------------------------------

    @guarded
    def show_stride(self, row: int) -> None:
        doc, a = self.doc, self.analysis
        if doc is None or a is None or not 0 <= row < len(a.rows):
            return
        s = a.rows[row].stride
        t0 = float(doc.t_s[min(s.start_idx, doc.n_rows - 1)])
        t1 = float(doc.t_s[min(s.end_idx, doc.n_rows - 1)])
        self.timeline.centre_on(t0, t1)
        self.timeline.highlight_span(t0, t1)
        self.timeline.set_cursor(t0)

    def show_whole(self) -> None:
        if self.doc is not None and self.doc.n_rows:
            self.timeline.set_view(float(self.doc.t_s[0]), float(self.doc.t_s[-1]))

    def zoom(self, factor: float) -> None:
        x0, x1 = self.timeline.view_range()
        c = self.timeline.cursor_t_s
        if not (math.isfinite(c) and x0 <= c <= x1):
            c = (x0 + x1) / 2
        self.timeline.set_view(c - (c - x0) * factor, c + (x1 - c) * factor)

    def pan(self, fraction: float) -> None:
        x0, x1 = self.timeline.view_range()
        d = (x1 - x0) * fraction
        self.timeline.set_view(x0 + d, x1 + d)

    def set_compare(self, on: bool) -> None:
        self.timeline.set_compare(on)
        self.cycles.set_analysis(self.analysis, self.before if on else None)

    # -- exclusions ------------------------------------------------------------------------------

    def _selection_rows(self) -> tuple[int, int] | None:
        doc, sel = self.doc, self.timeline.selection
        if doc is None or sel is None or not doc.n_rows:
            return None
        import numpy as np

        a = int(np.searchsorted(doc.t_s, sel[0], side="left"))
        b = int(np.searchsorted(doc.t_s, sel[1], side="right"))
        return (a, b) if b > a else None

    @guarded
    def exclude_selection(self) -> None:
        rows = self._selection_rows()
        if rows is None or self.doc is None:
            self.statusBar().showMessage("Select a range first: Shift+drag on the timeline", 8000)
            return
        self.exclude_rows(*rows)
        self.timeline.clear_selection()

    def exclude_rows(self, start: int, stop: int, label: str = "excluded range") -> None:
        doc = self.doc
        if doc is None:
            return
        doc.exclusions = excl.merge([*doc.exclusions, excl.Exclusion(start, stop, label)])
        self._exclusions_changed()

    @guarded
    def include_selection(self) -> None:
        rows = self._selection_rows()
        if rows is None or self.doc is None:
            return
        self.doc.exclusions = excl.subtract(self.doc.exclusions, *rows)
        self.timeline.clear_selection()
        self._exclusions_changed()

    @guarded
    def clear_exclusions(self) -> None:
        if self.doc is not None:
            self.doc.exclusions = []
            self._exclusions_changed()

    def _settings_key(self, doc: Document) -> str:
        return "review/exclusions/" + str(doc.path.resolve()).replace("/", "|")

    def _fallback_exclusions(self, doc: Document) -> list[excl.Exclusion]:
        raw = self.settings.value(self._settings_key(doc), "")
        if not raw:
            return []
        try:
            d = json.loads(str(raw))
            if d.get("created_utc") != doc.session.created_utc:
                return []
            return excl.merge([excl.Exclusion(int(a), int(b), str(lbl))
                               for a, b, lbl in d["ranges"]])  # fmt: skip
        except (ValueError, KeyError, TypeError):
            return []

    def _exclusions_changed(self) -> None:
        doc = self.doc
        assert doc is not None
        try:
            sp = excl.save(doc.path, doc.exclusions, doc.session.created_utc, doc.n_rows,
                           doc.t_s)  # fmt: skip
            self.settings.remove(self._settings_key(doc))
            where = f"kept in {sp.name}"
        except OSError as e:
            value = json.dumps({"created_utc": doc.session.created_utc, "ranges": [
                (r.start_idx, r.stop_idx, r.label) for r in doc.exclusions]})  # fmt: skip
            self.settings.setValue(self._settings_key(doc), value)
            where = f"kept in the application settings ({excl.side_path(doc.path).name}: " \
                    f"{e.strerror or e})"
        n = len(doc.exclusions)
        self.statusBar().showMessage(f"{n} excluded range{'s' if n != 1 else ''}, {where}", 8000)
        self.timeline.refresh_shading()
        self._update_actions()
        self.run_analysis()

    # -- analysis --------------------------------------------------------------------------------

    def run_analysis(self) -> None:
        doc = self.doc
        if doc is None:
            return
        ranges = list(doc.exclusions)
        cur, rec = doc.current, doc.recorded

        def job(ticket: Ticket) -> tuple[Analysis, Analysis | None]:
            a = analyse(doc, cur, ranges)
            b = analyse(doc, rec, ranges) if cur is not rec else None
            return a, b

        self.analyser.submit(job, functools.partial(self._analysed, doc))

    @guarded
    def _analysed(self, doc: Document, result: Any, exc: BaseException | None) -> None:
        if doc is not self.doc:
            return
        if exc is not None:
            self.show_problem(f"Stride analysis failed: {one_line(exc)}")
            return
        a, b = result
        self.analysis, self.before = a, b
        t = doc.t_s
        starts = [float(t[min(r.stride.start_idx, len(t) - 1)]) for r in a.rows]
        self.table.set_rows(a.rows, starts)
        note = ""
        if doc.reprocessed is not None:
            note = changed_settings(doc.recorded.config, doc.reprocessed.config)
        self.summary.setText(summary_html(a, b, note))
        self.cycles.set_analysis(a, b if self.act_compare.isChecked() else None)
        self.analysis_done.emit()

    # -- reprocessing ----------------------------------------------------------------------------

    @guarded
    def reprocess_dialog(self) -> None:
        if self.doc is None:
            return
        dlg = SettingsDialog(
            self,
            self.doc.current.config,
            note="Recomputes angles and gait events from the recorded raw counts (the whole "
            "session, standing calibrations replayed). The recording is not modified; use "
            "File ▸ Save reprocessed as… to keep the result.",
        )
        dlg.setWindowTitle("Reprocess with settings")
        dlg.accepted.connect(lambda: dlg.config is not None and self.start_reprocess(dlg.config))
        dlg.open()
        self._settings_dialog = dlg

    @guarded
    def start_reprocess(self, config: PipelineConfig) -> None:
        doc = self.doc
        if doc is None:
            return
        self._job_label = "Reprocessing"
        self._show_progress("Reprocessing", 0.0)

        def job(ticket: Ticket):
            src = reprocess(doc, config, progress=lambda f: ticket.progress(0.9 * f))
            src.overview.pyramid("processed/joint_deg", lambda f: ticket.progress(0.9 + 0.1 * f))
            return src

        self.job.progressed.connect(self._job_progress, Qt.ConnectionType.UniqueConnection)
        self.job.submit(job, functools.partial(self._reprocessed, doc))

    @guarded
    def _reprocessed(self, doc: Document, src: Any, exc: BaseException | None) -> None:
        self._hide_progress()
        if doc is not self.doc:
            return
        if exc is not None:
            self.show_problem(f"Reprocessing failed: {one_line(exc)}")
            return
        doc.reprocessed = src
        self.timeline.set_fsr_threshold(src.config.fsr_threshold)
        self.timeline.refresh_overview()
        self.timeline.set_compare(self.act_compare.isChecked())
        self.statusBar().showMessage(
            f"Reprocessed with {changed_settings(doc.recorded.config, src.config)}; "
            f"{len(src.heel_strike_idx)} heel strikes (recorded: "
            f"{len(doc.recorded.heel_strike_idx)})", 15_000,
        )  # fmt: skip
        self._update_actions()
        self.run_analysis()
        self.reprocessed.emit()

    @guarded
    def revert_reprocessing(self) -> None:
        if self.doc is None or self.doc.reprocessed is None:
            return
        self.doc.reprocessed = None
        self.timeline.set_fsr_threshold(self.doc.recorded.config.fsr_threshold)
        self.timeline.refresh_overview()
        self.timeline.set_compare(self.act_compare.isChecked())
        self._update_actions()
        self.run_analysis()

    @guarded
    def save_reprocessed_dialog(self) -> None:
        doc = self.doc
        if doc is None or doc.reprocessed is None:
            return
        suggestion = doc.path.with_name(doc.path.stem + "_reprocessed.h5")
        path, _ = QFileDialog.getSaveFileName(
            self, "Save reprocessed session as", str(suggestion), FILE_FILTER
        )
        if path:
            self.save_reprocessed(path)

    @guarded
    def save_reprocessed(self, path: str | Path) -> None:
        """Write a new session file with the reprocessed settings via ``gaitmon process``."""
        doc = self.doc
        if doc is None or doc.reprocessed is None:
            return
        from gaitmon.commands import process
        from gaitmon.errors import UserError

        cfg = doc.reprocessed.config
        ns = argparse.Namespace(
            file=str(doc.path), output=str(path), force=True,
            **{k: float(getattr(cfg, k)) for k in process.SETTINGS},
        )  # fmt: skip
        self._job_label = f"Saving {Path(path).name}"
        self._show_progress(self._job_label, 0.0)

        def job(ticket: Ticket) -> str:
            try:
                process.run(ns)
            except UserError as e:
                raise SessionError(str(e)) from None
            return str(path)

        def done(result: Any, exc: BaseException | None) -> None:
            self._hide_progress()
            if exc is not None:
                self.show_problem(f"Cannot save: {one_line(exc)}")
            else:
                self.statusBar().showMessage(f"Saved {result}", 10_000)

        self.job.submit(job, done)

    # -- report, export, plot export, filters, normative bands ----------------------------------

    def _attach_plot_export(self) -> None:
        """Right-click any plot ▸ Save plot as PNG / SVG (the plot as shown)."""
        if not _available("gaitmon.ui.review.plot_export"):
            return
        from gaitmon.ui.review.plot_export import attach_export_action

        tl = self.timeline
        attach_export_action(tl.overview, self, "overview.png")
        for key, lane in tl.lanes.items():
            attach_export_action(lane.plot, self, f"{key}.png")
        for plot, key in zip(self.cycles.plots, ("hip", "knee", "ankle"), strict=True):
            attach_export_action(plot, self, f"cycle_{key}.png")

    @guarded
    def export_dialog(self) -> None:
        if self.doc is None:
            return
        from gaitmon.ui.review.export_dialog import ExportDialog

        dlg = ExportDialog(self.doc.path, self)
        dlg.export_finished.connect(
            lambda r: self.statusBar().showMessage(f"Exported {getattr(r, 'paths', r)}", 10_000)
        )
        dlg.open()
        self._export_dialog = dlg

    @guarded
    def report_dialog(self) -> None:
        if self.doc is None:
            return
        suggestion = self.doc.path.with_suffix(".pdf")
        path, _ = QFileDialog.getSaveFileName(
            self, "Save the report as", str(suggestion), "PDF (*.pdf)"
        )
        if path:
            self.write_report(path)

    @guarded
    def write_report(self, path: str | Path) -> None:
        """Gather the report in the background (recorded series, exclusions in force,
        normative band if loaded) and write the PDF on the GUI thread."""
        doc = self.doc
        if doc is None:
            return
        from gaitmon.report import gather_report
        from gaitmon.ui.report_pdf import write_report_pdf

        ranges = [(r.start_idx, r.stop_idx) for r in doc.exclusions]
        bands = self.normative
        self._job_label = "Preparing the report"
        self._show_progress(self._job_label, 0.0)

        def job(ticket: Ticket) -> Any:
            return gather_report(doc.session, normative=bands, excluded_ranges=ranges)

        def done(data: Any, exc: BaseException | None) -> None:
            self._hide_progress()
            if exc is not None:
                self.show_problem(f"Cannot make the report: {one_line(exc)}")
                return
            try:
                out = write_report_pdf(data, path)
            except OSError as e:
                self.show_problem(f"Cannot write the report: {one_line(e)}")
                return
            note = " (recorded series; reprocessing is not in the report)" if (
                doc.reprocessed is not None) else ""  # fmt: skip
            self.statusBar().showMessage(f"Report written to {out}{note}", 15_000)
            self.report_written.emit(str(out))

        self.job.submit(job, done)

    @guarded
    def show_filters(self) -> None:
        doc = self.doc
        if doc is None:
            return
        from gaitmon.ui.review.filters_view import FiltersView

        if self._filters_window is None:
            fw = FiltersView(None, self.colours)
            fw.setWindowFlag(Qt.WindowType.Window, True)
            fw.setWindowTitle("gaitmon — filters")
            fw.resize(1100, 650)
            fw.failed.connect(lambda m: self.statusBar().showMessage(f"Filters: {m}", 10_000))
            self._filters_window = fw
            self._filters_path: Path | None = None
        fw = self._filters_window
        if getattr(self, "_filters_path", None) != doc.path:
            fw.load_session(doc.path)
            self._filters_path = doc.path
        fw.set_range(*self.timeline.view_range())
        fw.show()
        fw.raise_()

    @guarded
    def normative_dialog(self) -> None:
        folder = str(self.settings.value("review/normative_folder", str(Path.home())))
        path, _ = QFileDialog.getOpenFileName(
            self, "Load a normative band", folder, "Normative bands (*.csv);;All files (*)"
        )
        if path:
            self.load_normative(path)

    @guarded
    def load_normative(self, path: str | Path) -> None:
        from gaitmon.normative import NormativeError, load_normative

        try:
            bands = load_normative(path)
        except (NormativeError, OSError) as e:
            self.show_problem(f"Cannot load the normative band: {one_line(e)}")
            return
        self.settings.setValue("review/normative_folder", str(Path(path).parent))
        self.set_normative(bands)

    def set_normative(self, bands: Any) -> None:
        self.normative = bands
        self.cycles.set_normative(bands)
        if bands is not None:
            self.statusBar().showMessage(
                f"Normative band: {bands.label} (source: {bands.source or 'not given'})", 10_000
            )

    # -- misc ------------------------------------------------------------------------------------

    def show_about(self) -> None:
        from PySide6.QtWidgets import QMessageBox

        box = QMessageBox(self)
        box.setWindowTitle("About gaitmon review")
        box.setText(
            f"<b>gaitmon {__version__}</b> — review of recorded gait sessions.<br>"
            "Drag to pan, wheel to zoom, Shift+drag to select a range, E to exclude it."
        )
        box.open()

    def shutdown(self) -> None:
        if self._closing:
            return
        self._closing = True
        if self._filters_window is not None:
            self._filters_window.close()
        self.job.stop()
        self.analyser.stop()
        self.timeline.shutdown()
        if self.doc is not None:
            self.doc.close()
            self.doc = None

    def closeEvent(self, ev: QCloseEvent) -> None:
        self.shutdown()
        super().closeEvent(ev)


def run(args: Any) -> int:
    """Open the review window (``args.file``: a session to open at start, or None)."""
    from gaitmon.ui.app import exec_until_closed, make_application

    app = make_application("gaitmon review", log)
    win = ReviewWindow(QSettings())
    win.show()
    if getattr(args, "file", None):
        QTimer.singleShot(0, functools.partial(win.open_file, args.file))
    return exec_until_closed(app, win)
