"""The review window: open a recorded session, inspect it, analyse the strides, reprocess.

Layout: a red banner for problems; the timeline (readout, whole-session overview, detail lanes);
below it the stride table, the summary and the cycle-normalised plots. Every one of them shows
the angles of one source, switched with View ▸ Angles: the zero-lag smoothed angles stored with
a raw-mode recording (the default, as ``gaitmon info``, the report and export read them) or the
live filter's, as shown while recording; the status bar names the method in force.

The window is composed of parts (has-a), each owning its widgets and slots
(:mod:`~gaitmon.ui.review.part`); this module builds them, lays them out, keeps the document
(:class:`gaitmon.review.model.Document`) and hands it to each part, which listens to its change
events (exclusions, angles, settings) instead of being updated by hand:

* ``status`` (:mod:`~gaitmon.ui.review.status`): the banner, notes, progress bar and Cancel;
* ``timeline`` (:mod:`~gaitmon.ui.review.timeline`) and ``nav``
  (:mod:`~gaitmon.ui.review.navigation`): the overview and lanes, and the View menu over them;
* ``strides`` (:mod:`~gaitmon.ui.review.strides_part`): the stride table, the summary, the cycle
  plots, their analysis worker and the normative band;
* ``exclusions`` (:mod:`~gaitmon.ui.review.exclusions_part`): Analysis ▸ Exclude / Include;
* ``jobs`` (:mod:`~gaitmon.ui.review.jobs`): open, reprocess, switch angles, save, report;
* ``outputs`` (:mod:`~gaitmon.ui.review.outputs`): the export, report, reprocess and Filters
  dialogs and the plots' Save plot as;
* ``legs`` (:mod:`~gaitmon.ui.review.legs`): the leg chooser and the Both legs tab;
* ``comparer`` (:mod:`~gaitmon.ui.review.compare_actions`): Compare sessions, Open folder.

The actions and menus are declared in :mod:`~gaitmon.ui.review.actions` (each names its part's
slot). Every slot is guarded: an unexpected exception becomes one line in the banner (and a
logged traceback), never a crash.

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
from pathlib import Path
from typing import TYPE_CHECKING, Any

from PySide6.QtCore import QSettings, Qt, QTimer, Signal
from PySide6.QtGui import QAction, QCloseEvent, QDragEnterEvent, QDropEvent
from PySide6.QtWidgets import (
    QFileDialog,
    QLabel,
    QMainWindow,
    QSplitter,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from gaitmon import __version__
from gaitmon.review.model import Document, angles_caption
from gaitmon.review.settings import ReviewKey
from gaitmon.text import count, duration_text, no_gait_events, side_text
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.review import recent
from gaitmon.ui.review.actions import (
    ANGLES_MENU,
    RECENT,
    SAVE_REPROCESSED,
    build_actions,
    build_menus,
    update_enabled,
)
from gaitmon.ui.review.both_legs_panel import BothLegsPanel
from gaitmon.ui.review.compare_actions import SessionComparer
from gaitmon.ui.review.exclusions_part import ExclusionsPart
from gaitmon.ui.review.jobs import ReviewJobs
from gaitmon.ui.review.legs import LegBar, LegsControl
from gaitmon.ui.review.navigation import Navigator
from gaitmon.ui.review.outputs import FILE_FILTER, Outputs
from gaitmon.ui.review.status import StatusArea
from gaitmon.ui.review.strides_part import StridesPart
from gaitmon.ui.review.timeline import Timeline
from gaitmon.ui.theme import Colours, configure_pyqtgraph, current_colours

if TYPE_CHECKING:
    from gaitmon.review.model import Analysis

log = logging.getLogger("gaitmon.ui.review")

__all__ = ["FILE_FILTER", "ReviewWindow", "run"]


class ReviewWindow(QMainWindow):
    """Review of recorded sessions. ``settings`` is injected so tests can isolate it."""

    # the parts' signals, passed on (tests and the benchmark wait on them)
    document_opened = Signal(str)
    open_failed = Signal(str)
    analysis_done = Signal()
    reprocessed = Signal()
    angles_changed = Signal(str)  # the angle source now shown: smoothed | live
    report_written = Signal(str)
    saved = Signal(str)

    def __init__(self, settings: QSettings, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.settings = settings
        self.errors: list[str] = []  # unexpected exceptions (tests assert it stays empty)
        self._doc: Document | None = None
        self._closing = False
        self.colours: Colours = current_colours()
        configure_pyqtgraph(self.colours)
        self.setWindowTitle("gaitmon — review")
        self.setAcceptDrops(True)
        # the width the bottom row is laid out for (its sizes below): at 1400 px the stride
        # table scrolled sideways and clipped its status column (issue 25, walk-through)
        self.resize(1500, 920)

        self.status = StatusArea(self, lambda: self.jobs.cancel_job())
        self.banner, self.banner_box = self.status.banner, self.status.banner_box
        self.timeline = Timeline(self.colours)
        self.nav = Navigator(self, self.timeline, self)
        self.strides = StridesPart(self, self.colours, self)
        self.table, self.summary, self.cycles = (self.strides.table, self.strides.summary,
                                                 self.strides.cycles)  # fmt: skip
        self.exclusions = ExclusionsPart(self, self.timeline, self)
        self.jobs = ReviewJobs(self, self.timeline, self._set_document, self._show_angles, self)
        self.jobs.normative = lambda: self.strides.normative
        self.outputs = Outputs(self, self, self.jobs, self.timeline, self.colours)
        self._build_central()
        self.comparer = SessionComparer(self, settings, self.status, self.colours,
                                        self.jobs.open_file)  # fmt: skip
        self._wire()
        self.act: dict[str, QAction] = build_actions(self)
        self.act_exclude = self.act["exclude"]
        menus = build_menus(self, self.act)
        self.file_menu, self.view_menu = menus["&File"], menus["&View"]
        self.analysis_menu = menus["&Analysis"]
        self.angles_menu = menus[ANGLES_MENU]
        self.recent_menu = menus[RECENT]
        self.recent_menu.aboutToShow.connect(
            lambda: recent.fill_recent(self.recent_menu, self.settings, self.jobs.open_file))
        self.outputs.attach_plot_export(self.cycles)
        self._update_actions()

    # -- construction --------------------------------------------------------------------------

    def _build_central(self) -> None:
        self.leg_bar = LegBar()
        self.both_legs = BothLegsPanel(self.colours)
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
                                lambda: self.doc, self.jobs.open_file, self.jobs.set_angles,
                                self)  # fmt: skip
        self.tabs.setTabVisible(1, False)
        bottom = QSplitter(Qt.Orientation.Horizontal)
        bottom.addWidget(self.tabs)
        bottom.addWidget(self.summary)
        bottom.addWidget(self.cycles)
        bottom.setStretchFactor(0, 5)
        bottom.setStretchFactor(1, 2)
        bottom.setStretchFactor(2, 3)
        # the stride table (its 14 columns, the foot clearance and the status whole) fits
        # beside the summary and the cycle plots at 1500 px (tests/test_messages.py)
        bottom.setSizes([800, 250, 360])
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

    def _wire(self) -> None:
        """The parts' signals to each other and to the window's."""
        tl = self.timeline
        tl.failed.connect(self.status.show_problem)
        tl.progress.connect(lambda f: self.status.show_progress("Loading the view", f))
        tl.busy_changed.connect(lambda busy: None if busy else self.jobs.hide_progress())
        tl.selection_changed.connect(lambda *_: self._update_actions())
        self.table.stride_picked.connect(
            lambda row: self.nav.show_stride(self.strides.analysis, row))
        self.strides.compare_changed.connect(tl.set_compare)
        self.strides.analysed.connect(self.analysis_done)
        j = self.jobs
        for mine, theirs in ((self.document_opened, j.document_opened),
                             (self.open_failed, j.open_failed), (self.reprocessed, j.reprocessed),
                             (self.angles_changed, j.angles_changed),
                             (self.report_written, j.report_written), (self.saved, j.saved)):
            theirs.connect(mine)  # fmt: skip

    # -- state the parts read --------------------------------------------------------------------

    @property
    def doc(self) -> Document | None:
        """The document shown (None: none); changed by :meth:`_set_document` only."""
        return self._doc

    @property
    def analysis(self) -> Analysis | None:
        """The stride analysis shown (the strides part's)."""
        return self.strides.analysis

    def open_file(self, path: str | Path, side: str | None = None) -> None:
        """Open ``path`` (of a bilateral file, the leg ``side``) in the background."""
        self.jobs.open_file(path, side)

    # -- messages ------------------------------------------------------------------------------

    def report_exception(self, where: str, exc: BaseException) -> None:
        """An unexpected exception (from a `guarded` slot): one line in the banner, and logged."""
        log.error("review: %s failed", where, exc_info=exc)
        self.errors.append(f"{where}: {exc}")
        self.status.show_problem(f"Unexpected error in {where}: {one_line(exc)}")

    @property
    def last_problem(self) -> str:
        return self.status.last_problem

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

    def _source_changed(self) -> None:
        """The document's angles or settings changed (its events): the window's own state."""
        doc = self.doc
        if doc is not None:
            self._show_angles()
            self.status.show_notes(doc.shown_notes())
            self._update_actions()

    # -- the document ----------------------------------------------------------------------------

    @guarded
    def open_dialog(self) -> None:
        folder = recent.folder(self.settings, ReviewKey.LAST_FOLDER)
        path, _ = QFileDialog.getOpenFileName(self, "Open a session", folder, FILE_FILTER)
        if path:
            self.jobs.open_file(path)

    def _set_document(self, doc: Document) -> None:
        self._drop_document()
        self._doc = doc
        s = doc.session
        who = s.meta.patient_id or "no patient id"
        state = "complete" if s.complete else ("recovered" if s.recovered else "incomplete")
        leg = f" — {doc.leg_name}" if doc.bilateral else ""
        self.setWindowTitle(f"gaitmon — review — {doc.path.name}{leg}")
        self.status.message(
            f"{doc.path.name}{leg}: {who}, side {side_text(s.meta.side)}, "
            f"{count(doc.n_rows, 'frame')} "
            f"({duration_text(s.duration_s or doc.n_rows / doc.fs_hz)}), mode {s.mode}, {state}; "
            f"{count(len(s.gaps), 'gap')}, {count(len(s.markers), 'marker')}"
            + (f"; no gait events: {no_gait_events(s.mode)}" if no_gait_events(s.mode) else ""),
            20_000,
        )
        if not doc.n_rows:
            doc.notes.append("the session holds no samples")
        self.status.show_notes(doc.shown_notes())
        # every part follows the document's events from now on (the window's first: its
        # actions and caption are right when the views redraw)
        doc.events.exclusions.connect(lambda _e: self._update_actions())
        doc.events.angles.connect(lambda _e: self._source_changed())
        doc.events.settings.connect(lambda _e: self._source_changed())
        self.timeline.set_document(doc)
        self.exclusions.document_set(doc)
        self.jobs.document_set(doc)
        self.legs.document_set(doc)
        self._update_actions()
        self._show_angles()
        self.strides.document_set(doc)

    def _drop_document(self) -> None:
        old = self._doc
        self._doc = None
        self.strides.analyser.cancel()
        self.jobs.angles_job.cancel()
        self.legs.drop()
        self.timeline.clear()
        # the workers may still be reading the old file: close it once they are idle
        self.timeline.loader.wait_idle(5.0)
        self.strides.clear()
        self.jobs.drop()
        if old is not None:
            old.close()  # (its listeners go with it)
        self.status.show_notes([])

    @guarded
    def close_document(self) -> None:
        self.jobs.job.cancel()
        self._drop_document()
        self.setWindowTitle("gaitmon — review")
        self.legs.document_set(None)
        self._update_actions()
        self._show_angles()

    # -- recent files, drag and drop -------------------------------------------------------------

    def recent_files(self) -> list[str]:
        return recent.recent_files(self.settings)

    def dragEnterEvent(self, ev: QDragEnterEvent) -> None:
        if ev.mimeData().hasUrls() and any(u.isLocalFile() for u in ev.mimeData().urls()):
            ev.acceptProposedAction()

    def dropEvent(self, ev: QDropEvent) -> None:
        files = [u.toLocalFile() for u in ev.mimeData().urls() if u.isLocalFile()]
        if files:
            ev.acceptProposedAction()
            self.jobs.open_file(files[0])

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
        self.outputs.shutdown()
        self.comparer.shutdown()
        self.legs.shutdown()
        self.jobs.shutdown()
        self.strides.shutdown()
        self.timeline.shutdown()
        if self._doc is not None:
            self._doc.close()
            self._doc = None

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
