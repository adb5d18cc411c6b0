"""Review of a file that records both legs: the leg chooser and the Both legs tab's worker.

The review window shows one leg at a time (a :class:`gaitmon.review.model.Document` is one
unit): its traces, strides, cycles and exclusions (``FILE.L|R.review.json``). :class:`LegBar`
is the chooser above the timeline (Left leg / Right leg, shown for a bilateral file only).
Choosing a leg reopens the file on that leg, with the same angles and the same moment in view
(the view's times moved through the common time line: each unit counts from its own start).
:class:`LegsControl` keeps the Both legs tab
(:class:`~gaitmon.ui.review.both_legs_panel.BothLegsPanel`) up to date: the bilateral measures
are computed on their own worker (``review-bilateral``) when a leg is opened and whenever its
exclusions change.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QObject, Signal
from PySide6.QtGui import QAction
from PySide6.QtWidgets import (
    QButtonGroup,
    QHBoxLayout,
    QLabel,
    QTabWidget,
    QToolButton,
    QWidget,
)

from gaitmon.io.session.parts import SIDE_NAMES, SIDES
from gaitmon.jobs import Response, Ticket
from gaitmon.review.both_legs import BothLegs, both_legs
from gaitmon.review.model import Document
from gaitmon.ui import one_line
from gaitmon.ui.jobs import QtWorker
from gaitmon.ui.review.both_legs_panel import BothLegsPanel
from gaitmon.ui.review.timeline import Timeline

NOT_SAVED = ("Not for a file that records both legs yet: gaitmon can reprocess one-unit sessions "
             "only (gaitmon process says the same). The reprocessed leg is shown here until "
             "the file is closed.")  # fmt: skip


class LegBar(QWidget):
    """Left leg | Right leg: which leg of a bilateral file the window shows."""

    leg_chosen = Signal(str)  # "L" | "R", chosen by the user

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.label = QLabel("<b>Both legs recorded</b> — showing:")
        self.buttons: dict[str, QToolButton] = {}
        self.group = QButtonGroup(self)
        self.group.setExclusive(True)
        h = QHBoxLayout(self)
        h.setContentsMargins(0, 0, 0, 0)
        h.addWidget(self.label)
        for side in SIDES:
            b = QToolButton()
            b.setText(f"{SIDE_NAMES[side].capitalize()} leg ({side})")
            b.setCheckable(True)
            b.setToolTip(f"Show the {SIDE_NAMES[side]} leg: its traces, strides, cycles and "
                         f"exclusions (kept in FILE.{side}.review.json)")  # fmt: skip
            b.clicked.connect(functools.partial(self._clicked, side))
            self.group.addButton(b)
            self.buttons[side] = b
            h.addWidget(b)
        # the leg shown stands out: the chooser is the one thing that says which leg this is
        self.setStyleSheet("QToolButton { padding: 2px 12px; } QToolButton:checked { "
                           "background: palette(highlight); color: palette(highlighted-text); "
                           "font-weight: bold; }")  # fmt: skip
        self.hint = QLabel("the Both legs tab below compares them (symmetry, measured cadence)")
        self.hint.setStyleSheet("color: gray")
        h.addWidget(self.hint)
        h.addStretch(1)
        self.setVisible(False)

    def _clicked(self, side: str, _checked: bool = False) -> None:
        self.leg_chosen.emit(side)

    def set_document(self, doc: Document | None) -> None:
        """Shown for a bilateral file, with its leg checked; hidden otherwise."""
        on = doc is not None and doc.bilateral
        self.setVisible(on)
        if doc is None or not on:
            return
        for side, b in self.buttons.items():
            b.setEnabled(side in doc.sides)
            b.setChecked(side == doc.side)

    @property
    def shown(self) -> str:
        """The leg checked ("" when none is)."""
        return next((s for s, b in self.buttons.items() if b.isChecked()), "")


class LegsControl(QObject):
    """The leg chooser and the Both legs tab of one window. :meth:`document_set` shows them
    for a bilateral file (and asks for the measures of its file), :meth:`exclusions_changed`
    (the document's exclusions event) asks again; only the answer for the document still
    shown is applied (``computed`` is emitted then). Choosing a leg calls
    ``open_leg(path, side)``."""

    computed = Signal()

    def __init__(self, bar: LegBar, panel: BothLegsPanel, tabs: QTabWidget, timeline: Timeline,
                 current: Callable[[], Document | None],
                 open_leg: Callable[[Path, str], None], set_angles: Callable[[str], None],
                 parent: QObject) -> None:  # fmt: skip
        super().__init__(parent)
        self.bar, self.panel, self.tabs, self.timeline = bar, panel, tabs, timeline
        self._current = current
        self._open_leg = open_leg
        self._set_angles = set_angles
        # what the other leg opens with: (file, angles, time range in view)
        self._carry: tuple[Path, str, tuple[float, float]] | None = None
        self.worker = QtWorker("review-bilateral", latest=True, parent=self)
        bar.leg_chosen.connect(self.show_leg)

    def show_leg(self, side: str) -> None:
        """Reopen the file on ``side`` (nothing to do when it is shown already)."""
        doc = self._current()
        if doc is None or not doc.bilateral or side == doc.side or side not in doc.sides:
            self.bar.set_document(doc)  # the chooser goes back to the leg shown
            return
        x0, x1 = self.timeline.view_range()
        both = self.panel.result
        if both is not None and both.path == doc.path:  # the same moment on the other's clock
            x0, x1 = (both.moved_to(doc.side, side, x) for x in (x0, x1))
        self._carry = (doc.path, doc.angle_source, (x0, x1))
        self._open_leg(doc.path, side)

    def leg_chosen(self, side: str, on: bool = True) -> None:
        """View ▸ Leg ▸ Left | Right: reopen on that leg."""
        if on:
            self.show_leg(side)

    def document_set(self, doc: Document | None) -> None:
        """Show ``doc`` 's legs and ask for its file's measures, again whenever its exclusions
        change (its event)."""
        self.worker.cancel()
        self.bar.set_document(doc)
        on = doc is not None and doc.bilateral
        index = self.tabs.indexOf(self.panel)
        if not on and self.tabs.currentIndex() == index:
            self.tabs.setCurrentIndex(0)
        self.tabs.setTabVisible(index, on)
        if doc is None or not on:
            self.panel.show_message("")
            return
        doc.events.exclusions.connect(lambda _e: self.exclusions_changed(doc))
        # the cycles are of the angles shown: switched, they are computed again
        doc.events.angles.connect(lambda _e: self.exclusions_changed(doc))
        self.panel.show_message("Computing both legs' measures…")
        self._mark_tab()
        carry, self._carry = self._carry, None
        if carry is not None and carry[0] == doc.path:
            self.timeline.set_view(*carry[2])
            if carry[1] != doc.angle_source and carry[1] in doc.angle_sources:
                self._set_angles(carry[1])
        self.refresh(doc)

    def update_actions(self, act: dict[str, QAction], save_tip: str) -> None:
        """View ▸ Leg follows the leg shown; File ▸ Save reprocessed as… is off for a
        bilateral file, its tooltip saying why."""
        doc = self._current()
        both = doc is not None and doc.bilateral
        save = act.get("save_reprocessed")
        if save is not None:
            if both:
                save.setEnabled(False)
            save.setToolTip(NOT_SAVED if both else save_tip)
            save.setStatusTip(NOT_SAVED if both else save_tip)
        for side in SIDES:
            leg = act.get(f"leg_{side}")
            if leg is not None:
                leg.setEnabled(both and doc is not None and side in doc.sides)
                leg.setChecked(both and doc is not None and doc.side == side)

    def exclusions_changed(self, doc: Document) -> None:
        if doc.bilateral:
            self.refresh(doc)

    def refresh(self, doc: Document) -> None:
        # the leg shown counts its ranges as they are in force here (the request captures them)
        path, side, ranges = Path(doc.path), doc.side, list(doc.exclusions)
        angles = doc.angle_source

        def job(ticket: Ticket) -> BothLegs:
            return both_legs(path, side, ranges, angles)

        self.worker.submit(job, functools.partial(self._done, doc))

    def _done(self, doc: Document, response: Response[BothLegs]) -> None:
        if doc is not self._current():
            return
        if response.error is not None:
            self.panel.show_message(f"Cannot compute both legs' measures: "
                                    f"{one_line(response.error)}")  # fmt: skip
        else:
            self.panel.set_result(response.result())
        self._mark_tab()
        self.computed.emit()

    def _mark_tab(self) -> None:
        """The tab says there is a caution inside (the Strides tab may be the one in view)."""
        caveats = self.panel.result.caveats if self.panel.result is not None else ()
        index = self.tabs.indexOf(self.panel)
        self.tabs.setTabText(index, "Both legs (caution)" if caveats else "Both legs")
        self.tabs.setTabToolTip(index, "\n".join(caveats))

    def drop(self) -> None:
        """Before the document closes: no answer for it is wanted any more."""
        self.worker.cancel()
        self.worker.wait_idle(5.0)

    def shutdown(self) -> None:
        self.worker.stop()
