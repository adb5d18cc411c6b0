"""The review window's analysis part: the stride table, the summary and the cycle plots, the
worker that analyses the strides (:func:`gaitmon.review.model.analyse`), and the normative band
drawn behind the cycles.

It listens to the document: a change of its exclusions, of the angles shown or of the settings
of the series shown (a reprocessing) analyses the strides again, in the background (newest
wins); the answer for a document no longer shown is dropped.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from PySide6.QtCore import QObject, Signal
from PySide6.QtWidgets import QFileDialog, QWidget

from gaitmon.analysis import stride_start_times
from gaitmon.jobs import Response, Ticket
from gaitmon.review.model import Analysis, Document, analyse, changed_settings
from gaitmon.review.settings import ReviewKey
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.jobs import QtWorker
from gaitmon.ui.review import recent
from gaitmon.ui.review.cycles import ReviewCyclePlots
from gaitmon.ui.review.part import Host, Part
from gaitmon.ui.review.strides import StrideTable, SummaryLabel, summary_html
from gaitmon.ui.theme import Colours

if TYPE_CHECKING:
    from gaitmon.normative import NormativeBands


@dataclass(frozen=True)
class Analysed:
    analysis: Analysis  # the series shown (reprocessed if there is one)
    before: Analysis | None  # the recorded series after a reprocessing


def analyse_request(doc: Document) -> Callable[[Ticket], Analysed]:
    """Captures the exclusions in force and the sources shown; runs on the analysis worker."""
    ranges = list(doc.exclusions)
    cur, rec = doc.current, doc.recorded

    def job(ticket: Ticket) -> Analysed:
        a = analyse(doc, cur, ranges)
        b = analyse(doc, rec, ranges) if cur is not rec else None
        return Analysed(a, b)

    return job


class StridesPart(Part):
    """Table, summary and cycles of the document shown (see the module docstring)."""

    analysed = Signal()  # an analysis was applied
    compare_changed = Signal(bool)  # draw the recorded series under a reprocessed one

    def __init__(self, host: Host, colours: Colours, parent: QObject | None = None) -> None:
        super().__init__(host, parent)
        self.analysis: Analysis | None = None
        self.before: Analysis | None = None  # the recorded series' after a reprocessing
        self.normative: NormativeBands | None = None
        self.compare = True
        self.table = StrideTable(colours)
        self.summary = SummaryLabel()
        self.summary.setMinimumWidth(250)
        self.cycles = ReviewCyclePlots(colours)
        self.cycles.setMinimumWidth(300)
        self.analyser = QtWorker("review-analysis", latest=True, parent=self)

    def document_set(self, doc: Document | None) -> None:
        if doc is None:
            return
        ev = doc.events
        ev.exclusions.connect(lambda _e: self.run())
        ev.angles.connect(lambda _e: self.run())
        ev.settings.connect(lambda _e: self.run())
        self.run()

    def clear(self) -> None:
        """Before the document closes: no answer for it is wanted, nothing of it is shown."""
        self.analysis = self.before = None
        self.analyser.cancel()
        self.analyser.wait_idle(5.0)
        self.table.set_rows([], [])
        self.cycles.clear_data()
        self.summary.setText(summary_html(None))

    # -- the analysis -----------------------------------------------------------------------------

    def run(self) -> None:
        doc = self.doc
        if doc is not None:
            self.analyser.submit(analyse_request(doc), functools.partial(self._analysed, doc))

    @guarded
    def _analysed(self, doc: Document, response: Response[Analysed]) -> None:
        if doc is not self.doc:
            return
        if response.error is not None:
            self.status.show_problem(f"Stride analysis failed: {one_line(response.error)}")
            return
        r = response.result()
        a, b = r.analysis, r.before
        self.analysis, self.before = a, b
        self.table.set_rows(a.rows, stride_start_times(a.rows, doc.t_s))
        self.refresh_summary()
        self.cycles.set_analysis(a, b if self.compare else None)
        self.analysed.emit()

    def refresh_summary(self) -> None:
        """The summary panel from the analysis in force and the normative band, if any."""
        doc = self.doc
        if doc is None or self.analysis is None:
            return
        note = ""
        if doc.reprocessed is not None:
            note = changed_settings(doc.recorded.config, doc.reprocessed.config)
        self.summary.setText(
            summary_html(self.analysis, self.before, note, doc.session.mode, self.normative,
                         two_legs=len(doc.sides) > 1)
        )
        self.summary.setToolTip(
            "" if self.normative is None else self.cycles.band_note(self.normative)
        )

    def set_compare(self, on: bool) -> None:
        """View ▸ Show recorded under reprocessed."""
        self.compare = bool(on)
        self.compare_changed.emit(self.compare)
        self.cycles.set_analysis(self.analysis, self.before if on else None)

    # -- the normative band -----------------------------------------------------------------------

    @guarded
    def normative_dialog(self) -> None:
        folder = recent.folder(self.settings, ReviewKey.NORMATIVE_FOLDER)
        parent = self.parent()
        path, _ = QFileDialog.getOpenFileName(
            parent if isinstance(parent, QWidget) else None, "Load a normative band", folder,
            "Normative bands (*.csv *.gcd *.GCD);;All files (*)",
        )  # fmt: skip
        if path:
            self.load_normative(path)

    @guarded
    def load_normative(self, path: str | Path) -> None:
        from gaitmon.normative import NormativeError, load_normative

        try:
            bands = load_normative(path)
        except (NormativeError, OSError) as e:
            self.status.show_problem(f"Cannot load the normative band: {one_line(e)}")
            return
        recent.remember(self.settings, ReviewKey.NORMATIVE_FOLDER, Path(path).parent)
        self.set_normative(bands)

    def set_normative(self, bands: NormativeBands | None) -> None:
        self.normative = bands
        self.cycles.set_normative(bands)
        self.refresh_summary()
        if bands is not None:
            self.status.message(
                f"Normative band: {bands.label} (source: {bands.source or 'not given'})", 10_000
            )

    def shutdown(self) -> None:
        self.analyser.stop()
