"""The review window's Analysis ▸ Exclude / Include / Clear: the selected range on the timeline
becomes rows, and the rows change the document's exclusions (:meth:`Document.exclude`, which
keeps them through :mod:`gaitmon.io.session.exclusions` and emits the change). The part says in
the status bar where they were kept; the timeline, the strides and the Both legs tab follow the
document's event themselves."""

from __future__ import annotations

import functools

import numpy as np
from PySide6.QtCore import QObject

from gaitmon.review.events import ExclusionsChanged
from gaitmon.review.model import Document
from gaitmon.text import count
from gaitmon.ui.actions import guarded
from gaitmon.ui.review.part import Host, Part
from gaitmon.ui.review.timeline import Timeline


class ExclusionsPart(Part):
    """Exclusion editing of the document shown (see the module docstring)."""

    def __init__(self, host: Host, timeline: Timeline, parent: QObject | None = None) -> None:
        super().__init__(host, parent)
        self.timeline = timeline

    def document_set(self, doc: Document | None) -> None:
        if doc is not None:
            doc.events.exclusions.connect(functools.partial(self._changed, doc))

    def _changed(self, doc: Document, event: ExclusionsChanged) -> None:
        sp = event.kept_in
        if sp is None:
            where = f"not kept: {event.problem}; they apply until the file is closed"
        elif sp.parent == doc.path.parent:
            where = f"kept in {sp.name}"
        else:
            where = f"kept in {sp} (the recording's folder is read-only)"
        self.status.message(f"{count(len(event.exclusions), 'excluded range')}, {where}", 8000)

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
        if self.doc is not None:
            self.doc.exclude(start, stop, label)

    @guarded
    def include_selection(self) -> None:
        rows = self._selection_rows()
        if rows is None or self.doc is None:
            return
        # the selection is cleared first, as the shading follows the document's event
        self.timeline.clear_selection()
        self.doc.include(*rows)

    @guarded
    def clear_exclusions(self) -> None:
        if self.doc is not None:
            self.doc.clear_exclusions()
