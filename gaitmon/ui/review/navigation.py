"""The review window's View menu over the timeline: whole session, zoom and pan around the
cursor, fit the y ranges, the lanes and joint-angle methods shown, and a stride picked in the
table shown on the timeline."""

from __future__ import annotations

import math

from PySide6.QtCore import QObject

from gaitmon.review.model import Analysis
from gaitmon.ui.actions import guarded
from gaitmon.ui.review.part import Host, Part
from gaitmon.ui.review.timeline import Timeline


class Navigator(Part):
    """Moves the timeline's view (see the module docstring)."""

    def __init__(self, host: Host, timeline: Timeline, parent: QObject | None = None) -> None:
        super().__init__(host, parent)
        self.timeline = timeline

    @guarded
    def show_stride(self, analysis: Analysis | None, row: int) -> None:
        """Centre the timeline on stride ``row`` of ``analysis``, shaded, the cursor at its
        start."""
        doc = self.doc
        if doc is None or analysis is None or not 0 <= row < len(analysis.rows):
            return
        s = analysis.rows[row].stride
        t0 = float(doc.t_s[min(s.start_idx, doc.n_rows - 1)])
        t1 = float(doc.t_s[min(s.end_idx, doc.n_rows - 1)])
        self.timeline.centre_on(t0, t1)
        self.timeline.highlight_span(t0, t1)
        self.timeline.set_cursor(t0)

    def show_whole(self) -> None:
        doc = self.doc
        if doc is not None and doc.n_rows:
            self.timeline.set_view(float(doc.t_s[0]), float(doc.t_s[-1]))

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

    def set_lane_visible(self, key: str, on: bool) -> None:
        self.timeline.set_lane_visible(key, on)

    def set_method(self, method: str, on: bool) -> None:
        self.timeline.set_method(method, on)

    def fit_y(self) -> None:
        self.timeline.fit_y()

    def clear_selection(self) -> None:
        self.timeline.clear_selection()
