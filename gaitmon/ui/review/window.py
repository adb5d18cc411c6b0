"""The review window: open a recorded session, inspect it, analyse the strides, reprocess.

Layout: a red banner for problems; the timeline (readout, whole-session overview, detail lanes);
below it the stride table, the summary and the cycle-normalised plots. Every one of them shows
the angles of one source, switched with View ▸ Angles: the zero-lag smoothed angles stored with
a raw-mode recording (the default, as ``gaitmon info``, the report and export read them) or the
live filter's, as shown while recording; the status bar names the method in force.

This module is the window's shell: it builds the widgets, keeps the document, exclusions,
navigation and the optional parts (export, report, filters, normative band). The actions and
menus are declared in :mod:`~gaitmon.ui.review.actions`, the banner and progress bar live in
:mod:`~gaitmon.ui.review.status`, and everything slow runs as request -> response in
:mod:`~gaitmon.ui.review.jobs`. Every slot is guarded: an unexpected exception becomes one line
in the banner (and a logged traceback), never a crash.

User exclusions are kept beside the recording in ``FILE.review.json``, or in the user's gaitmon
data folder when the recording's folder is read-only (both owned by
:mod:`gaitmon.io.session.exclusions`, so ``gaitmon info`` and the report see them too). The
recording itself is never written.

A file that records both legs is shown one leg at a time (:mod:`~gaitmon.ui.review.legs`): its
exclusions (``FILE.L|R.review.json``), export, report and Filters view are that leg's.
"""

from __future__ import annotations

import functools
import logging
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from PySide6.QtCore import QSettings, Qt, QTimer
from PySide6.QtGui import QAction, QCloseEvent, QDragEnterEvent, QDropEvent
from PySide6.QtWidgets import QFileDialog, QLabel, QSplitter, QTabWidget, QVBoxLayout, QWidget

from gaitmon import __version__
from gaitmon.dsp.channel_table import JOINTS
from gaitmon.io.session import exclusions as excl
from gaitmon.review.model import Document, angles_caption
from gaitmon.text import count, no_gait_events, num
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.jobs import QtWorker
from gaitmon.ui.review import recent
from gaitmon.ui.review.actions import (
    ANGLES_MENU,
    RECENT,
    SAVE_REPROCESSED,
    available,
    build_actions,
    build_menus,
    update_enabled,
)
from gaitmon.ui.review.both_legs_panel import BothLegsPanel
from gaitmon.ui.review.compare_actions import SessionComparer
from gaitmon.ui.review.cycles import CyclePlots
from gaitmon.ui.review.jobs import ReviewJobs
from gaitmon.ui.review.legs import NOT_SAVED, LegBar, LegsControl
from gaitmon.ui.review.status import StatusArea
from gaitmon.ui.review.strides import StrideTable, SummaryLabel, summary_html
from gaitmon.ui.review.timeline import Timeline
from gaitmon.ui.theme import Colours, configure_pyqtgraph, current_colours

if TYPE_CHECKING:
    from gaitmon.normative import NormativeBands
    from gaitmon.ui.review.export_dialog import ExportDialog
    from gaitmon.ui.review.filters_view import FiltersView
    from gaitmon.ui.review.reprocess_dialog import ReprocessDialog

log = logging.getLogger("gaitmon.ui.review")

FILE_FILTER = "gaitmon sessions (*.h5 *.hdf5);;All files (*)"


class ReviewWindow(ReviewJobs):
    """Review of recorded sessions. ``settings`` is injected so tests can isolate it."""

    def __init__(self, settings: QSettings, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.settings = settings
        self.errors: list[str] = []  # unexpected exceptions (tests assert it stays empty)
        self.doc = None
        self.analysis = None
        self.before = None  # recorded-series analysis after a reprocessing
        self.normative = None
        self._closing = False
        self._job_label = ""
        self._angles_label = ""
        self._filters_window: FiltersView | None = None
        self._export_dialog: ExportDialog | None = None
        self._settings_dialog: ReprocessDialog | None = None
        self.colours: Colours = current_colours()
        configure_pyqtgraph(self.colours)
        self.setWindowTitle("gaitmon — review")
        self.setAcceptDrops(True)
        self.resize(1400, 920)

        self.job = QtWorker("review-job", latest=True, parent=self)  # open, reprocess, save
        self.analyser = QtWorker("review-analysis", latest=True, parent=self)
        self.job.progressed.connect(self._job_progress)
        self.angles_job = QtWorker("review-angles", latest=True, parent=self)
        self.angles_job.progressed.connect(self._angles_progress)

        self.status = StatusArea(self, self.cancel_job)
        self.banner, self.banner_box = self.status.banner, self.status.banner_box
        self._build_central()
        self.comparer = SessionComparer(self, settings, self.status, self.colours, self.open_file)
        self.act: dict[str, QAction] = build_actions(self)
        self.act_exclude = self.act["exclude"]
        menus = build_menus(self, self.act)
        self.file_menu, self.view_menu = menus["&File"], menus["&View"]
        self.analysis_menu = menus["&Analysis"]
        self.angles_menu = menus[ANGLES_MENU]
        self.recent_menu = menus[RECENT]
        self.recent_menu.aboutToShow.connect(self._fill_recent)
        self._attach_plot_export()
        self._update_actions()

    # -- construction --------------------------------------------------------------------------

    def _build_central(self) -> None:
        self.timeline = Timeline(self.colours)
        self.timeline.failed.connect(self.show_problem)
        self.timeline.progress.connect(lambda f: self.status.show_progress("Loading the view", f))
        self.timeline.busy_changed.connect(self._view_busy)
        self.timeline.selection_changed.connect(lambda *_: self._update_actions())

        self.table = StrideTable(self.colours)
        self.table.stride_picked.connect(self.show_stride)
        self.summary = SummaryLabel()
        self.summary.setMinimumWidth(250)
        self.cycles = CyclePlots(self.colours)
        self.cycles.setMinimumWidth(300)
        self.leg_bar = LegBar()
        self.both_legs = BothLegsPanel()

        left = QWidget()
        lv = QVBoxLayout(left)
        lv.setContentsMargins(0, 0, 0, 0)
        title = QLabel("<b>Strides</b> — click one to show it; greyed rows are not in the "
                       "statistics")  # fmt: skip
        lv.addWidget(title)
        lv.addWidget(self.table, 1)
        # the strides of the leg shown | both legs' measures (a bilateral file only)
        self.tabs = QTabWidget()
        self.tabs.addTab(left, "Strides")
        self.tabs.addTab(self.both_legs, "Both legs")
        self.legs = LegsControl(self.leg_bar, self.both_legs, self.tabs, self.timeline,
                                lambda: self.doc, self.open_file, self.set_angles, self)
        self.tabs.setTabVisible(1, False)
        bottom = QSplitter(Qt.Orientation.Horizontal)
        bottom.addWidget(self.tabs)
        bottom.addWidget(self.summary)
        bottom.addWidget(self.cycles)
        bottom.setStretchFactor(0, 5)
        bottom.setStretchFactor(1, 2)
        bottom.setStretchFactor(2, 3)
        bottom.setSizes([760, 250, 400])
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
        v.addWidget(self.status.banner_box)
        v.addWidget(self.status.notes)
        v.addWidget(self.leg_bar)
        v.addWidget(split, 1)
        self.setCentralWidget(central)

    # -- messages ------------------------------------------------------------------------------

    def report_exception(self, where: str, exc: BaseException) -> None:
        """An unexpected exception (from a `guarded` slot): one line in the banner, and logged."""
        log.error("review: %s failed", where, exc_info=exc)
        self.errors.append(f"{where}: {exc}")
        self.show_problem(f"Unexpected error in {where}: {one_line(exc)}")

    def show_problem(self, text: str) -> None:
        self.status.show_problem(text)

    def hide_problem(self) -> None:
        self.status.hide_problem()

    @property
    def last_problem(self) -> str:
        return self.status.last_problem

    def _view_busy(self, busy: bool) -> None:
        if not busy:
            self._hide_progress()

    def _update_actions(self) -> None:
        doc = self.doc
        update_enabled(self.act, {
            "document": doc is not None,
            "selection": doc is not None and self.timeline.selection is not None,
            "raw": doc is not None and doc.session.mode == "raw",
            "reprocessed": doc is not None and doc.reprocessed is not None,
            "angles": doc is not None and len(doc.angle_sources) > 1,
            "bilateral": doc is not None and doc.bilateral,
        })  # fmt: skip
        self.legs.update_actions(self.act, SAVE_REPROCESSED.tip)

    def _show_angles(self) -> None:
        """The angles shown: checked in View ▸ Angles, named in the status bar."""
        doc = self.doc
        for angles in ("smoothed", "live"):
            action = self.act.get(f"angles_{angles}")
            if action is not None and doc is not None:
                action.setChecked(doc.angle_source == angles)
        self.status.show_angles(*angles_caption(doc) if doc is not None else ("", ""))

    # -- the document ----------------------------------------------------------------------------

    @guarded
    def open_dialog(self) -> None:
        folder = str(self.settings.value("review/last_folder", str(Path.home())))
        path, _ = QFileDialog.getOpenFileName(self, "Open a session", folder, FILE_FILTER)
        if path:
            self.open_file(path)

    def _set_document(self, doc: Document) -> None:
        self._drop_document()
        self.doc = doc
        s = doc.session
        who = s.meta.patient_id or "no patient id"
        state = "complete" if s.complete else ("recovered" if s.recovered else "incomplete")
        leg = f" — {doc.leg_name}" if doc.bilateral else ""
        self.setWindowTitle(f"gaitmon — review — {doc.path.name}{leg}")
        self.status.message(
            f"{doc.path.name}{leg}: {who}, side {s.meta.side or '-'}, "
            f"{count(doc.n_rows, 'frame')} "
            f"({num(s.duration_s or doc.n_rows / doc.fs_hz, 0)} s), mode {s.mode}, {state}; "
            f"{count(len(s.gaps), 'gap')}, {count(len(s.markers), 'marker')}"
            + (f"; no gait events: {no_gait_events(s.mode)}" if no_gait_events(s.mode) else ""),
            20_000,
        )
        if not doc.n_rows:
            doc.notes.append("the session holds no samples")
        self.status.show_notes(doc.shown_notes())
        self.timeline.set_fsr_threshold(doc.current.config.fsr_threshold)
        self.timeline.set_document(doc)
        self.legs.document_set(doc)
        self._update_actions()
        self._show_angles()
        self.run_analysis()

    def _drop_document(self) -> None:
        old = self.doc
        self.doc = None
        self.analysis = self.before = None
        self.analyser.cancel()
        self.angles_job.cancel()
        self.legs.drop()
        self.timeline.clear()
        # the workers may still be reading the old file: close it once they are idle
        self.timeline.loader.wait_idle(5.0)
        self.analyser.wait_idle(5.0)
        self.angles_job.wait_idle(5.0)
        if old is not None:
            old.close()
        self.table.set_rows([], [])
        self.cycles.clear_data()
        self.summary.setText(summary_html(None))
        self.status.show_notes([])

    @guarded
    def close_document(self) -> None:
        self.job.cancel()
        self._drop_document()
        self.setWindowTitle("gaitmon — review")
        self.legs.document_set(None)
        self._update_actions()
        self._show_angles()

    # -- recent files, drag and drop -------------------------------------------------------------

    def recent_files(self) -> list[str]:
        return recent.recent_files(self.settings)

    def _add_recent(self, path: Path) -> None:
        recent.add_recent(self.settings, path)

    def _fill_recent(self) -> None:
        recent.fill_recent(self.recent_menu, self.settings, self.open_file)

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

    def show_leg(self, side: str, on: bool = True) -> None:  # View ▸ Leg: reopen on that leg
        if on:
            self.legs.show_leg(side)

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

    def set_lane_visible(self, key: str, on: bool) -> None:
        self.timeline.set_lane_visible(key, on)

    def set_method(self, method: str, on: bool) -> None:
        self.timeline.set_method(method, on)

    def fit_y(self) -> None:
        self.timeline.fit_y()

    def clear_selection(self) -> None:
        self.timeline.clear_selection()

    # -- exclusions ------------------------------------------------------------------------------

    def _selection_rows(self) -> tuple[int, int] | None:
        doc, sel = self.doc, self.timeline.selection
        if doc is None or sel is None or not doc.n_rows:
            return None

        a = int(np.searchsorted(doc.t_s, sel[0], side="left"))
        b = int(np.searchsorted(doc.t_s, sel[1], side="right"))
        return (a, b) if b > a else None

    @guarded
    def exclude_selection(self) -> None:
        rows = self._selection_rows()
        if rows is None or self.doc is None:
            self.status.message("Select a range first: Shift+drag on the timeline", 8000)
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

    def _exclusions_changed(self) -> None:
        doc = self.doc
        assert doc is not None
        try:
            sp = excl.save(doc.exclusions_key, doc.exclusions, doc.session.created_utc,
                           doc.n_rows, doc.t_s)  # fmt: skip
            where = (f"kept in {sp.name}" if sp.parent == doc.path.parent
                     else f"kept in {sp} (the recording's folder is read-only)")  # fmt: skip
        except OSError as e:
            where = f"not kept: {e.strerror or e}; they apply until the file is closed"
        n = len(doc.exclusions)
        self.status.message(f"{count(n, 'excluded range')}, {where}", 8000)
        self.timeline.refresh_shading()
        self._update_actions()
        self.run_analysis()
        self.legs.exclusions_changed(doc)

    # -- reprocessing ----------------------------------------------------------------------------

    @guarded
    def reprocess_dialog(self) -> None:
        if self.doc is None:
            return
        from gaitmon.ui.review.reprocess_dialog import ReprocessDialog, review_notes

        note, angles_note = review_notes(self.doc.angle_source == "smoothed", self.doc.bilateral)
        dlg = ReprocessDialog(self, self.doc.current.config, note=note, angles_note=angles_note)
        dlg.accepted.connect(lambda: self._reprocess_accepted(dlg))
        dlg.open()
        self._settings_dialog = dlg

    def _reprocess_accepted(self, dlg: ReprocessDialog) -> None:
        if dlg.config is not None:
            self.start_reprocess(dlg.config)

    @guarded
    def revert_reprocessing(self) -> None:
        if self.doc is None or self.doc.reprocessed is None:
            return
        self.doc.set_replay(None)
        self._source_changed()

    @guarded
    def save_reprocessed_dialog(self) -> None:
        doc = self.doc
        if doc is None or doc.reprocessed is None:
            return
        if doc.bilateral:
            self.status.message(NOT_SAVED, 10_000)
            return
        suggestion = doc.path.with_name(doc.path.stem + "_reprocessed.h5")
        path, _ = QFileDialog.getSaveFileName(
            self, "Save reprocessed session as", str(suggestion), FILE_FILTER
        )
        if path:
            self.save_reprocessed(path)

    # -- report, export, plot export, filters, normative bands ----------------------------------

    def _attach_plot_export(self) -> None:
        """Right-click any plot ▸ Save plot as PNG / SVG (the plot as shown)."""
        if not available("gaitmon.ui.review.plot_export"):
            return
        from gaitmon.ui.review.plot_export import attach_export_action

        tl = self.timeline
        attach_export_action(tl.overview, self, "overview.png")
        for key, lane in tl.lanes.items():
            attach_export_action(lane.plot, self, f"{key}.png")
        for plot, key in zip(self.cycles.plots, JOINTS, strict=True):
            attach_export_action(plot, self, f"cycle_{key}.png")

    @guarded
    def export_dialog(self) -> None:
        if self.doc is None:
            return
        from gaitmon.ui.review.export_dialog import ExportDialog

        # the angles shown are the ones exported (and named in the export's metadata)
        doc = self.doc
        dlg = ExportDialog(doc.path, self, angles=doc.angle_source,
                           angle_method=doc.angle_method_of(doc.angle_source),
                           side=doc.side or None)  # fmt: skip
        # the status line repeats the dialog's own summary ("Exported N samples to 8 files in
        # DIR"), not the tuple of paths
        dlg.export_finished.connect(
            lambda _r: self.status.message(dlg.status_label.text(), 10_000)
        )
        dlg.open()
        self._export_dialog = dlg

    @guarded
    def report_dialog(self) -> None:
        doc = self.doc
        if doc is None:
            return
        # the report is of the leg shown: both.h5 -> both_L.pdf, as export names its files
        stem = f"{doc.path.stem}_{doc.side}" if doc.bilateral else doc.path.stem
        suggestion = doc.path.with_name(stem + ".pdf")
        path, _ = QFileDialog.getSaveFileName(
            self, "Save the report as", str(suggestion), "PDF (*.pdf)"
        )
        if path:
            self.write_report(path)

    @guarded
    def show_filters(self) -> None:
        doc = self.doc
        if doc is None:
            return
        from gaitmon.ui.review.filters_view import filters_window

        if self._filters_window is None:
            self._filters_window = filters_window(
                self.colours, lambda m: self.status.message(f"Filters: {m}", 10_000))
        fw = self._filters_window
        if fw.source != (doc.path, doc.side or None):  # the leg shown, of a bilateral file
            fw.load_session(doc.path, side=doc.side or None)
        fw.set_range(*self.timeline.view_range())
        fw.show()
        fw.raise_()

    @guarded
    def normative_dialog(self) -> None:
        folder = str(self.settings.value("review/normative_folder", str(Path.home())))
        path, _ = QFileDialog.getOpenFileName(
            self, "Load a normative band", folder,
            "Normative bands (*.csv *.gcd *.GCD);;All files (*)",
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

    def set_normative(self, bands: NormativeBands | None) -> None:
        self.normative = bands
        self.cycles.set_normative(bands)
        self.refresh_summary()
        if bands is not None:
            self.status.message(
                f"Normative band: {bands.label} (source: {bands.source or 'not given'})", 10_000
            )

    def compare_sessions_dialog(self) -> None:  # File ▸ Compare sessions… (compare_actions)
        self.comparer.compare_dialog()

    def open_folder_dialog(self) -> None:  # File ▸ Open folder…: the patient list
        self.comparer.folder_dialog()

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
        self.comparer.shutdown()
        self.legs.shutdown()
        self.job.stop()
        self.analyser.stop()
        self.angles_job.stop()
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
        side = getattr(args, "side", None)
        QTimer.singleShot(0, functools.partial(win.open_file, args.file, side))
    return exec_until_closed(app, win)
