"""The review window's background requests: open, reprocess, switch the angles shown, save
reprocessed, report; and :class:`ReviewJobs`, the window's part that runs them.

Each request is built on the GUI thread from everything it needs (a request never reads the
window) and runs on one of the part's :class:`gaitmon.ui.jobs.QtWorker` s, newest wins:
``job`` (open, reprocess, save, report: one at a time, with the status bar's progress bar and
Cancel) and ``angles_job`` (the overview of the other angle source, smoothed | live, built
before the window switches to it); the stride analysis runs in
:mod:`~gaitmon.ui.review.strides_part`. Each returns a frozen response (:class:`Opened`,
:class:`Reprocessed`, ...) that :class:`ReviewJobs` applies on the GUI thread, by changing the
document (a reprocessing shown, the angles switched): the views follow its events. A report
being prepared listens too: when the exclusions change it is gathered again, with them. A
response overtaken by a newer request or a Cancel never arrives.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from PySide6.QtCore import QObject, Signal

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.errors import output_error_text
from gaitmon.finish import rewrite_processed
from gaitmon.io.session import SessionError, journal_path
from gaitmon.jobs import Response, Ticket
from gaitmon.review.events import ExclusionsChanged
from gaitmon.review.model import (
    Document,
    Replay,
    build_overview,
    changed_settings,
    open_document,
    reprocess,
)
from gaitmon.review.settings import ReviewKey
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.jobs import QtWorker
from gaitmon.ui.review import recent
from gaitmon.ui.review.part import Host, Part
from gaitmon.ui.review.timeline import Timeline

if TYPE_CHECKING:
    from gaitmon.normative import NormativeBands
    from gaitmon.report import ReportData

log = logging.getLogger("gaitmon.ui.review")

REPROCESS_SHARE = 0.9  # of a reprocessing's progress bar; the rest builds the overview


# -- responses -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Opened:
    path: Path
    doc: Document

    def close(self) -> None:
        self.doc.close()


@dataclass(frozen=True)
class Reprocessed:
    replay: Replay


@dataclass(frozen=True)
class AnglesReady:
    angles: str  # smoothed | live, their sources' overviews built


@dataclass(frozen=True)
class Saved:
    path: Path
    n_frames: int


@dataclass(frozen=True)
class ReportReady:
    doc: Document
    data: ReportData
    angle_method: str  # the angles the report analysed (those shown when it was asked for)


# -- requests (run on a worker thread) ----------------------------------------------------------


def open_request(path: Path, side: str | None = None) -> Callable[[Ticket], Opened]:
    def job(ticket: Ticket) -> Opened:
        return Opened(path, open_document(path, progress=ticket.progress, side=side))

    return job


def reprocess_request(doc: Document, config: PipelineConfig) -> Callable[[Ticket], Reprocessed]:
    angles = doc.angle_source

    def job(ticket: Ticket) -> Reprocessed:
        replay = reprocess(doc, config, progress=lambda f: ticket.progress(REPROCESS_SHARE * f))
        rest = 1.0 - REPROCESS_SHARE
        build_overview(doc, angles, replay, lambda f: ticket.progress(REPROCESS_SHARE + rest * f))
        return Reprocessed(replay)

    return job


def angles_request(doc: Document, angles: str) -> Callable[[Ticket], AnglesReady]:
    """The recorded (and reprocessed) series with the angles of ``angles``, their whole-session
    overview built (the smoothed angles of a file that does not store them are computed here)."""
    replay = doc.replay

    def job(ticket: Ticket) -> AnglesReady:
        share = 0.5 if replay is not None else 1.0
        build_overview(doc, angles, None, lambda f: ticket.progress(share * f))
        if replay is not None:
            build_overview(doc, angles, replay, lambda f: ticket.progress(share + share * f))
        return AnglesReady(angles)

    return job


def save_request(src: Path, dst: Path, config: PipelineConfig) -> Callable[[Ticket], Saved]:
    """A new session file: the recording's raw counts reprocessed with ``config``
    (:func:`gaitmon.finish.rewrite_processed`, as ``gaitmon process``); its progress goes to
    the window's bar, and Cancel (the request no longer wanted) makes it delete the partial
    file and raise :class:`gaitmon.errors.Cancelled`."""

    def job(ticket: Ticket) -> Saved:
        result = rewrite_processed(
            src, dst, config, progress=ticket.progress, cancel=lambda: not ticket.wanted,
            overwrite=True,
        )  # fmt: skip
        return Saved(result.path, result.n_frames)

    return job


def report_request(doc: Document, bands: NormativeBands | None) -> Callable[[Ticket], ReportReady]:
    from gaitmon.report import gather_report

    ranges = list(doc.exclusions)  # with their labels: the report gives them as the reasons
    session = doc.session_view()  # the angles shown: the report analyses and names them
    method = doc.angle_method_of(doc.angle_source)  # of the recording, as the report

    def job(ticket: Ticket) -> ReportReady:
        data = gather_report(session, normative=bands, excluded_ranges=ranges)
        return ReportReady(doc, data, method)

    return job


# -- the window's part ---------------------------------------------------------------------------


class ReviewJobs(Part):
    """The review window's requests and how their responses change it (see the module
    docstring): a part of :class:`gaitmon.ui.review.window.ReviewWindow`, which passes what it
    needs: the timeline (its loader is cancelled with the job), ``set_document`` (an opened
    document shown), ``show_angles`` (the angles menu and caption back to those shown)."""

    document_opened = Signal(str)
    open_failed = Signal(str)
    reprocessed = Signal()
    angles_changed = Signal(str)  # the angle source now shown: smoothed | live
    report_written = Signal(str)
    saved = Signal(str)

    def __init__(
        self,
        host: Host,
        timeline: Timeline,
        set_document: Callable[[Document], None],
        show_angles: Callable[[], None],
        parent: QObject | None = None,
    ) -> None:
        super().__init__(host, parent)
        self.timeline = timeline
        self._set_document = set_document
        self._show_angles = show_angles
        self.normative: Callable[[], NormativeBands | None] = lambda: None
        self._job_label = ""
        self._angles_label = ""
        self._report_path: Path | None = None  # the report being prepared, if any
        self.job = QtWorker("review-job", latest=True, parent=self)  # open, reprocess, save
        self.job.progressed.connect(self._job_progress)
        self.angles_job = QtWorker("review-angles", latest=True, parent=self)
        self.angles_job.progressed.connect(self._angles_progress)

    # -- progress --------------------------------------------------------------------------------

    def document_set(self, doc: Document | None) -> None:
        if doc is not None:
            doc.events.exclusions.connect(self._exclusions_changed)

    def _exclusions_changed(self, _event: ExclusionsChanged) -> None:
        # a report being prepared is gathered again: it leaves out the ranges in force when it
        # is written (the request overtaken never arrives)
        if self._report_path is not None:
            self.write_report(self._report_path)

    def _start_job(self, label: str) -> None:
        self._report_path = None  # (a new job overtakes a report being prepared)
        self._job_label = label
        self.status.show_progress(label, 0.0)

    def _job_progress(self, fraction: float) -> None:
        self.status.show_progress(self._job_label, fraction)

    def hide_progress(self) -> None:
        if not self.job.busy:
            self.status.hide_progress()

    def cancel_job(self) -> None:
        was = self._job_label
        if self.angles_job.busy:  # the angles shown stay as they were
            was = self._angles_label
            self.angles_job.cancel()
            self._show_angles()
        self.job.cancel()
        self._report_path = None
        self.timeline.loader.cancel()
        self.status.hide_progress()
        if was.startswith("Recovering"):
            self.status.show_problem("Recovery cancelled; the journal is kept: open the file "
                                     "again to recover it.")  # fmt: skip
        else:
            self.status.message(f"{was or 'Loading'} cancelled", 8000)

    # -- opening ---------------------------------------------------------------------------------

    @guarded
    def open_file(self, path: str | Path, side: str | None = None) -> None:
        """Open ``path`` in the background (recovering it first if it was interrupted); of a
        file that records both legs, the leg ``side`` ("L" | "R"; None: the left)."""
        path = Path(path)
        self.status.hide_problem()
        self.timeline.loader.cancel()
        recovering = journal_path(path).exists()
        leg = {"L": " (left leg)", "R": " (right leg)"}.get(side or "", "")
        label = f"Recovering {path.name}" if recovering else f"Opening {path.name}{leg}"
        self._start_job(label)
        self.status.message(
            f"{label}…" + (" (the recording was interrupted; rebuilding it from its journal)"
                           if recovering else ""),
        )  # fmt: skip
        self.job.submit(open_request(path, side), functools.partial(self._opened, path),
                        Opened.close)  # fmt: skip

    @guarded
    def _opened(self, path: Path, response: Response[Opened]) -> None:
        self.hide_progress()
        exc = response.error
        if exc is not None or response.value is None:
            why = one_line(exc) if exc else "unknown error"
            msg = str(exc) if isinstance(exc, SessionError) else f"cannot open {path.name}: {why}"
            if not isinstance(exc, SessionError) and exc is not None:
                log.error("opening %s failed", path, exc_info=exc)
            self.status.show_problem(f"Cannot open: {msg}")
            self.status.message(msg, 15_000)
            self.open_failed.emit(msg)
            return
        self._set_document(response.value.doc)
        recent.add_recent(self.settings, path)
        recent.remember(self.settings, ReviewKey.LAST_FOLDER, path.parent)
        self.document_opened.emit(str(path))

    # -- reprocessing ----------------------------------------------------------------------------

    @guarded
    def start_reprocess(self, config: PipelineConfig) -> None:
        doc = self.doc
        if doc is None:
            return
        self._start_job("Reprocessing")
        self.job.submit(reprocess_request(doc, config), functools.partial(self._reprocessed, doc))

    @guarded
    def _reprocessed(self, doc: Document, response: Response[Reprocessed]) -> None:
        self.hide_progress()
        if doc is not self.doc:
            return
        if response.error is not None:
            self.status.show_problem(f"Reprocessing failed: {one_line(response.error)}")
            return
        replay = response.result().replay
        doc.set_replay(replay)  # the views follow the document's settings event
        kept = (" The smoothed angles shown are the recording's: they do not depend on these "
                "settings (View ▸ Angles ▸ Live shows the reprocessed filter's)."
                if doc.angle_source == "smoothed" else "")  # fmt: skip
        self.status.message(
            f"Reprocessed with {changed_settings(doc.recorded.config, replay.config)}; "
            f"{len(replay.heel_strike_idx)} heel strikes (recorded: "
            f"{len(doc.recorded.heel_strike_idx)}).{kept}", 15_000,
        )  # fmt: skip
        src = doc.reprocessed
        if src is not None and not src.overview.has_pyramid("processed/joint_deg"):
            # the angles were switched while it ran: build the shown ones' overview too
            self.angles_job.submit(angles_request(doc, doc.angle_source),
                                   functools.partial(self._angles_ready, doc))  # fmt: skip
        self.reprocessed.emit()

    @guarded
    def revert_reprocessing(self) -> None:
        if self.doc is None or self.doc.reprocessed is None:
            return
        self.doc.set_replay(None)

    # -- the angles shown ------------------------------------------------------------------------

    @guarded
    def set_angles(self, angles: str, on: bool = True) -> None:
        """Show the ``angles`` (smoothed | live) of the recording (and of a reprocessing): the
        lanes, the overview, the strides, the cycles and the summary follow once the other
        source's overview is built (in the background, with progress)."""
        doc = self.doc
        if not on or doc is None:
            return
        if angles not in doc.angle_sources:
            self._show_angles()
            self.status.message(f"{doc.path.name} has only the {doc.angle_method} angles", 8000)
            return
        label = "Reading the live angles" if angles == "live" else "Reading the smoothed angles"
        self._angles_label = label
        self.status.show_progress(label, 0.0)
        self.angles_job.submit(angles_request(doc, angles),
                               functools.partial(self._angles_ready, doc))  # fmt: skip

    def _angles_progress(self, fraction: float) -> None:
        self.status.show_progress(self._angles_label, fraction)

    @guarded
    def _angles_ready(self, doc: Document, response: Response[AnglesReady]) -> None:
        if not self.job.busy:
            self.status.hide_progress()
        if doc is not self.doc:
            return
        if response.error is not None:
            self._show_angles()  # the menu goes back to the angles still shown
            self.status.show_problem(f"Cannot show those angles: {one_line(response.error)}")
            return
        angles = response.result().angles
        changed = angles != doc.angle_source
        doc.use_angles(angles)  # the views follow the document's angles event
        if changed:
            what = ("the smoothed angles (zero-lag, offline)" if angles == "smoothed"
                    else "the live angles (as shown while recording)")  # fmt: skip
            self.status.message(f"Showing {what}: {doc.angle_method}", 10_000)
            self.angles_changed.emit(angles)

    @guarded
    def save_reprocessed(self, path: str | Path) -> None:
        """Write a new session file with the reprocessed settings, with progress and Cancel."""
        doc = self.doc
        if doc is None or doc.reprocessed is None or doc.bilateral:  # (not offered: legs.py)
            return
        dst = Path(path)
        self._start_job(f"Saving {dst.name}")
        self.job.submit(save_request(doc.path, dst, doc.reprocessed.config), self._saved)

    @guarded
    def _saved(self, response: Response[Saved]) -> None:
        self.hide_progress()
        if response.error is not None:
            self.status.show_problem(f"Cannot save: {one_line(response.error)}")
            return
        saved = response.result()
        self.status.message(f"Saved {saved.path}", 10_000)
        self.saved.emit(str(saved.path))

    # -- report ----------------------------------------------------------------------------------

    @guarded
    def write_report(self, path: str | Path) -> None:
        """Gather the report in the background (recorded series, exclusions in force,
        normative band if loaded) and write the PDF on the GUI thread."""
        if self.doc is None:
            return
        self._start_job("Preparing the report")
        self._report_path = Path(path)
        self.job.submit(
            report_request(self.doc, self.normative()),
            functools.partial(self._report_ready, Path(path)),
        )

    @guarded
    def _report_ready(self, path: Path, response: Response[ReportReady]) -> None:
        from gaitmon.ui.report_pdf import write_report_pdf

        self._report_path = None
        self.hide_progress()
        if response.error is not None:
            self.status.show_problem(f"Cannot make the report: {one_line(response.error)}")
            return
        r = response.result()
        try:
            out = write_report_pdf(r.data, path)
        except OSError as e:
            what = output_error_text(e, e.filename or path) if e.errno else one_line(e)
            self.status.show_problem(f"The report: {what}")
            return
        note = " (recorded series; reprocessing is not in the report)" if (
            r.doc.reprocessed is not None) else ""  # fmt: skip
        self.status.message(f"Report written to {out}{note}; angles: {r.angle_method}", 15_000)
        self.report_written.emit(str(out))

    def drop(self) -> None:
        """Before the document closes: the angles job is not wanted any more."""
        self.angles_job.cancel()
        self.angles_job.wait_idle(5.0)

    def shutdown(self) -> None:
        self.job.stop()
        self.angles_job.stop()
