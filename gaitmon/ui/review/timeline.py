"""The review timeline: a whole-session overview over x-linked detail lanes, one shared cursor.

Only the visible range is ever read. A change of the detail range (pan, zoom, overview drag,
a stride picked in the table) becomes a :class:`~gaitmon.review.view.ViewRequest` for the rows
in view, answered by :func:`gaitmon.review.view.load_view` (from
:class:`gaitmon.io.overview.SessionOverview`: raw rows when few, min/max decimated otherwise, at
most ~2 points per pixel). A request that reads little (rows within the point budget, or a
pyramid already built: :func:`~gaitmon.review.view.answers_quickly`) is answered at once, in
the range change, so the new range is painted once, with its data; the others go to the view
worker and the response is applied on the GUI thread, unless a newer request overtook it.
Until then the previous data stay drawn (x is time, so they pan with the view).

Each lane's traces are drawn by one `TraceSet` (see :mod:`gaitmon.ui.plots`); gaps, user
exclusions, the selection and the picked stride are shaded by one
:class:`~gaitmon.ui.review.lanes.ShadeItem` per plot,
which draws only the spans in view. Gait events are drawn when the view is at most
``EVENTS_MAX_S`` wide, phase bands when the rows in view are at most ``PHASE_MAX_ROWS``.
"""

from __future__ import annotations

import functools
import math
import time

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QComboBox,
    QHBoxLayout,
    QLabel,
    QVBoxLayout,
    QWidget,
)

from gaitmon.dsp.channels import SEGMENTS
from gaitmon.errors import Cancelled
from gaitmon.io.overview import PeakWindow
from gaitmon.jobs import Response
from gaitmon.review.model import Document, ReviewSource
from gaitmon.review.view import (
    ViewData,
    ViewRequest,
    answers_quickly,
    load_view,
    readout_html,
)
from gaitmon.text import no_gait_events
from gaitmon.ui.jobs import QtWorker
from gaitmon.ui.plots import FSR_RANGE, TILT_RANGES_DEG, step_runs
from gaitmon.ui.plots import vertical_lines as _vlines
from gaitmon.ui.review.lanes import Lane
from gaitmon.ui.review.timeline_build import Plots, build_plots
from gaitmon.ui.theme import Colours

EVENTS_MAX_S = 180.0  # wider views would be solid with event lines
PHASE_MAX_ROWS = 30_000  # phase bands need every row; beyond this they are left out
MIN_POINTS, MAX_POINTS = 600, 4000
INITIAL_VIEW_S = 30.0


class Timeline(QWidget):
    """Overview + detail lanes of one document; see the module docstring."""

    range_changed = Signal(float, float)  # detail view, s
    cursor_moved = Signal(float)
    selection_changed = Signal(float, float)  # empty selection: (nan, nan)
    loaded = Signal(int)  # a view response was applied (its request id)
    progress = Signal(float)  # long loads (pyramid builds), fraction
    busy_changed = Signal(bool)
    failed = Signal(str)

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.doc: Document | None = None
        self.compare = True  # draw the recorded series under a reprocessed one
        self.methods_on = {"kalman": True, "acc": False, "gyro": False}
        self.segment = 1  # thigh
        self.cursor_t_s = math.nan
        self.selection: tuple[float, float] | None = None
        self.applied_requests = 0
        self.last_window: dict[tuple[str, str], PeakWindow] = {}
        self.request_log: list[tuple[int, float]] = []  # (request id, perf time of the request)
        self._moving_cursor = False
        self._syncing = False
        self._fitted_y = False
        self._request_id = 0
        self._applied_id = 0
        self.loader = QtWorker("review-view", latest=True, parent=self)
        self.loader.progressed.connect(self.progress)
        self.loader.busy_changed.connect(self.busy_changed)

        self.readout = QLabel("Open a session: File ▸ Open, or drop a .h5 file here.")
        self.readout.setTextFormat(Qt.TextFormat.RichText)
        self.readout.setMinimumHeight(22)
        self.readout.setToolTip(
            "Values at the cursor (click a plot or drag the line). Drag to pan, wheel to zoom, "
            "Shift+drag to select a range (then Analysis ▸ Exclude selected range)."
        )
        self.segment_combo = QComboBox()
        self.segment_combo.addItems([f"{s} tilt" for s in SEGMENTS])
        self.segment_combo.setCurrentIndex(self.segment)
        self.segment_combo.setToolTip("Segment shown in the tilt lane")
        self.segment_combo.currentIndexChanged.connect(self.set_segment)
        top = QHBoxLayout()
        top.addWidget(self.readout, 1)
        top.addWidget(self.segment_combo)
        self.glw = pg.GraphicsLayoutWidget()
        self.glw.ci.setContentsMargins(2, 2, 10, 2)
        self.glw.ci.layout.setVerticalSpacing(2)
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.setSpacing(2)
        lay.addLayout(top)
        lay.addWidget(self.glw, 1)

        self._marker_labels: list[pg.TextItem] = []
        self._connect(build_plots(self.glw, colours))
        self._load_timer = QTimer(self)
        self._load_timer.setSingleShot(True)
        self._load_timer.setInterval(0)  # coalesce the range changes of one event-loop pass
        self._load_timer.timeout.connect(self._request_view)

    def _connect(self, plots: Plots) -> None:
        """Keep the plots built and connect them to the timeline's slots."""
        assert plots.strip and plots.overview_cursor and plots.threshold_line
        self.lanes: dict[str, Lane] = plots.lanes
        self.strip, self.overview_cursor = plots.strip, plots.overview_cursor
        self.threshold_line = plots.threshold_line
        # overview: the knee over the whole session, the detail range as a draggable region
        self.overview, self.region = self.strip.plot, self.strip.region
        self.region.sigRegionChanged.connect(self._region_moved)
        self.overview.getViewBox().clicked.connect(self._overview_clicked)
        for lane in self.lanes.values():
            vb = lane.plot.getViewBox()
            vb.selection_dragged.connect(self._selection_dragged)
            vb.clicked.connect(self.set_cursor)
        for line in (self.overview_cursor, *(ln.cursor for ln in self.lanes.values())):
            if line is not None:
                line.sigPositionChanged.connect(lambda ln: self.set_cursor(ln.value()))
        self.set_lane_visible("raw", False)
        self.master.sigXRangeChanged.connect(self._detail_range_changed)
        self.master.sigYRangeChanged.connect(self._place_marker_labels)
        self._update_bottom_axes()

    @property
    def master(self) -> pg.PlotItem:
        return self.lanes["hip"].plot

    def visible_lanes(self) -> list[Lane]:
        return [ln for ln in self.lanes.values() if ln.plot.isVisible()]

    def _update_bottom_axes(self) -> None:
        vis = self.visible_lanes()
        for ln in self.lanes.values():
            last = bool(vis) and ln is vis[-1]
            ax = ln.plot.getAxis("bottom")
            ax.setStyle(showValues=last)
            ax.setHeight(None if last else 4)
            ax.set_titled(last)  # "time (s)", from the start of the session

    # -- options -------------------------------------------------------------------------------

    def set_lane_visible(self, key: str, on: bool) -> None:
        lane = self.lanes[key]
        lane.plot.setVisible(on)
        # a hidden PlotItem still takes its row; collapse it
        self.glw.ci.layout.setRowMaximumHeight(
            list(self.lanes).index(key) + 1, 100_000 if on else 0
        )
        self._update_bottom_axes()
        self._schedule()

    def set_method(self, method: str, on: bool) -> None:
        self.methods_on[method] = bool(on)
        self._schedule()

    def set_segment(self, index: int) -> None:
        self.segment = int(index)
        lane = self.lanes["tilt"]
        for spec, _tr in lane.specs:
            spec.column = self.segment
        for tr in lane.traces.traces:
            if tr.series:
                tr.column = self.segment
        seg = SEGMENTS[self.segment]
        lane.yrange = TILT_RANGES_DEG[seg]
        lane.plot.getAxis("left").setLabel(f"{seg} tilt (°)")
        if self.segment_combo.currentIndex() != self.segment:
            self.segment_combo.setCurrentIndex(self.segment)
        self._fitted_y = False
        self._schedule()

    def set_compare(self, on: bool) -> None:
        self.compare = bool(on)
        self._schedule()

    def set_fsr_threshold(self, counts: float) -> None:
        self.threshold_line.setValue(counts)
        self.threshold_line.setToolTip(f"contact threshold in force: {counts:g} counts")

    # -- document ------------------------------------------------------------------------------

    def clear(self) -> None:
        self.loader.cancel()
        self.doc = None
        self.last_window = {}
        for lane in self.lanes.values():
            for tr in lane.traces.traces:
                tr.clear()
            lane.traces.commit()
            lane.refresh_legend()  # nothing drawn: no entry
            lane.shade.layers.clear()
            lane.shade.update()
            if lane.cursor is not None:
                lane.cursor.setVisible(False)
        self.strip.clear()
        self.overview_cursor.setVisible(False)
        for item in self._marker_labels:
            self.lanes["hip"].plot.removeItem(item)
        self._marker_labels = []
        self.selection = None
        self.cursor_t_s = math.nan
        self.readout.setText("Open a session: File ▸ Open, or drop a .h5 file here.")

    def set_document(self, doc: Document) -> None:
        """Show ``doc``, and follow its events: its exclusions shaded, its series redrawn."""
        self.clear()
        self.doc = doc
        self.set_fsr_threshold(doc.current.config.fsr_threshold)
        doc.events.exclusions.connect(lambda _e: self.refresh_shading())
        doc.events.angles.connect(lambda _e: self._source_changed(doc))
        doc.events.settings.connect(lambda _e: self._source_changed(doc))
        self._fitted_y = False
        n = doc.n_rows
        t0 = float(doc.t_s[0]) if n else 0.0
        t1 = float(doc.t_s[-1]) if n else 1.0
        t1 = max(t1, t0 + 1.0)
        pad = 0.02 * (t1 - t0)
        for p in [self.overview, *(ln.plot for ln in self.lanes.values())]:
            p.getViewBox().setLimits(
                xMin=t0 - pad, xMax=t1 + pad, minXRange=0.2, maxXRange=t1 - t0 + 2 * pad
            )
        self.strip.set_extent(t0, t1, pad)
        src = doc.recorded
        for lane in self.lanes.values():
            primary = [s for s, _ in lane.specs if s.method in ("", "kalman") and not s.before]
            absent = bool(primary) and not any(src.has(s.series) for s in primary)
            if lane.missing is not None:
                why = f"not recorded in mode {doc.session.mode!r}"
                if lane.key == "fsr" and no_gait_events(doc.session.mode):
                    why = f"no gait events: {no_gait_events(doc.session.mode)}"
                lane.missing.setText(why if absent else "")
                lane.missing.setVisible(absent)
        self.refresh_overview()
        self.refresh_shading()
        self._draw_markers()
        self.set_cursor(t0)
        self.set_view(t0, min(t1, t0 + INITIAL_VIEW_S))
        self._schedule()

    def _source_changed(self, doc: Document) -> None:
        # the threshold line is the one in force in the series shown (a reprocessing's)
        self.set_fsr_threshold(doc.current.config.fsr_threshold)
        self.series_changed()

    def series_changed(self) -> None:
        """Other series are shown (the angles switched, a reprocessing): redraw the overview
        and the lanes, and fit each lane's y range to them again once they arrive."""
        self._fitted_y = False
        self.refresh_overview()
        self._schedule()

    def refresh_overview(self) -> None:
        if self.doc is not None:
            self.strip.draw(self.doc, self.glw.width())

    def refresh_shading(self) -> None:
        """Gaps, user exclusions, the selection and the picked stride, in every plot."""
        doc = self.doc
        if doc is None:
            return
        c = self.colours
        gap_c = QColor(c.alert)
        gap_c.setAlpha(70)
        settle_c = QColor(c.alert)
        settle_c.setAlpha(22)  # as faint as the live view's settling shade
        ex_c = QColor(c.foreground)
        ex_c.setAlpha(45 if not c.dark else 60)
        sel_c = QColor(c.marker)
        sel_c.setAlpha(55)
        ex = np.array(
            [(doc.t_s[r.start_idx], doc.t_s[r.stop_idx - 1]) for r in doc.exclusions
             if 0 <= r.start_idx < r.stop_idx <= doc.n_rows],
            dtype=np.float64,
        ).reshape(-1, 2)  # fmt: skip
        sel = np.array([self.selection] if self.selection else [], dtype=np.float64).reshape(-1, 2)
        for item in [self.strip.shade, *(ln.shade for ln in self.lanes.values())]:
            item.set_layer("gaps", doc.gap_spans_s, gap_c)
            item.set_layer("settling", doc.settling_spans_s, settle_c)
            item.set_layer("excluded", ex, ex_c)
            item.set_layer("selection", sel, sel_c)

    def highlight_span(self, t0: float, t1: float) -> None:
        c = QColor(self.colours.band)
        c.setAlpha(40)
        for ln in self.lanes.values():
            ln.shade.set_layer("stride", np.array([[t0, t1]]), c)

    def _draw_markers(self) -> None:
        doc = self.doc
        if doc is None:
            return
        ms = doc.session.markers
        xs = np.array([m.t_s for m in ms], dtype=np.float64)
        self.strip.set_markers(xs)
        hip = self.lanes["hip"].plot
        for m in ms:
            item = pg.TextItem(m.label or "marker", color=self.colours.marker, anchor=(0, 0))
            item.setToolTip(f"marker at {m.t_s:.2f} s: {m.label or '(no label)'}")
            hip.addItem(item, ignoreBounds=True)
            self._marker_labels.append(item)
        self._place_marker_labels()

    def _place_marker_labels(self, *_args: object) -> None:
        """Marker labels hang from the top of the hip lane's current y range (they were placed
        at its nominal top, above the fitted view, and never seen)."""
        if not self._marker_labels or self.doc is None:
            return
        y0, y1 = self.lanes["hip"].plot.getViewBox().viewRange()[1]
        # a hair below the top edge: exactly on it, rounding can put the label outside the view
        top = y1 - 1e-3 * (y1 - y0)
        for m, item in zip(self.doc.session.markers, self._marker_labels, strict=False):
            item.setPos(m.t_s, top)

    # -- view range ----------------------------------------------------------------------------

    def view_range(self) -> tuple[float, float]:
        (x0, x1), _ = self.master.getViewBox().viewRange()
        return float(x0), float(x1)

    def set_view(self, t0: float, t1: float) -> None:
        self.master.setXRange(t0, t1, padding=0)

    def centre_on(self, t0: float, t1: float) -> None:
        """Show ``[t0, t1]`` with half its width either side (e.g. a stride)."""
        w = max(t1 - t0, 0.2)
        self.set_view(t0 - 0.5 * w, t1 + 0.5 * w)

    def _detail_range_changed(self, *_args: object) -> None:
        x0, x1 = self.view_range()
        if not self._syncing:
            self._syncing = True
            try:
                self.region.setRegion((x0, x1))
            finally:
                self._syncing = False
        self.range_changed.emit(x0, x1)
        # every lane on the new range and the plots' new transforms set now, not in the paint:
        # pyqtgraph sets a transform lazily at the start of a paint, and the items that follow
        # it (the cursor lines, the labels) then mark the scene dirty again, which cost a
        # second whole paint of the window right after the first (measured on a pan step)
        for lane in self.lanes.values():
            if lane.plot is not self.master:
                lane.plot.getViewBox().linkedXChanged()
        self._request_view(quick_only=True)
        self.glw.scene().prepareForPaint()

    def _region_moved(self) -> None:
        if self._syncing or self.doc is None:
            return
        a, b = self.region.getRegion()
        self._syncing = True
        try:
            self.set_view(float(a), float(b))
        finally:
            self._syncing = False

    def _overview_clicked(self, t: float) -> None:
        x0, x1 = self.view_range()
        w = x1 - x0
        self.set_view(t - w / 2, t + w / 2)
        self.set_cursor(t)

    def _schedule(self) -> None:
        if self.doc is not None:
            self._load_timer.start()

    # -- loading -------------------------------------------------------------------------------

    def _wanted(self) -> list[tuple[str, str]]:
        doc = self.doc
        assert doc is not None
        cur = doc.current
        out: list[tuple[str, str]] = []
        for lane in self.visible_lanes():
            for spec, tr in lane.specs:
                if spec.before:
                    src = doc.recorded if (doc.reprocessed and self.compare) else None
                else:
                    src = cur if (spec.method == "" or self.methods_on.get(spec.method)) else None
                if src is None or not src.has(spec.series):
                    tr.visible = False
                    continue
                tr.visible = True
                key = (src.key, spec.series)
                if key not in out:
                    out.append(key)
        return out

    def _request_view(self, quick_only: bool = False) -> None:
        """Read the rows in view: at once when :func:`answers_quickly` (then shown in the same
        paint as the new range), else on the worker; ``quick_only``: only the former, the
        latter left to the event loop's next pass (several range changes may come first)."""
        doc = self.doc
        if doc is None or not doc.n_rows:
            return
        x0, x1 = self.view_range()
        start, stop = doc.rows_between(x0, x1)
        width = max(1, self.master.getViewBox().width())
        max_points = int(min(MAX_POINTS, max(MIN_POINTS, 2 * width)))
        cur = doc.current
        req = ViewRequest(
            start, stop, max_points, tuple(self._wanted()),
            self.lanes["fsr"].plot.isVisible() and cur.has("processed/phase")
            and stop - start <= PHASE_MAX_ROWS,
        )  # fmt: skip
        sources = {doc.recorded.key: doc.recorded, cur.key: cur}
        quick = answers_quickly(req, sources)
        if quick_only and not quick:
            self._schedule()
            return
        self._request_id += 1
        rid = self._request_id
        self.request_log.append((rid, time.perf_counter()))
        del self.request_log[:-256]

        if quick:
            # rows of a short range or a built pyramid: read here and drawn in the same paint
            # as the new range. Measured on an 8-hour session: each pan step was painted
            # twice (the new range with the old data, then the new data), and waited for the
            # worker thread; under load that hand-over was most of the step's time
            self._load_timer.stop()
            self.loader.cancel()
            try:
                value = load_view(rid, req, doc, sources, cur, None)
            except Exception as e:  # what the worker would have delivered as an error
                self._apply(Response(rid, None, e))
                return
            self._apply(Response(rid, value, None))
            return
        job = functools.partial(load_view, rid, req, doc, sources, cur)
        self.loader.submit(job, self._apply)

    def _apply(self, response: Response[ViewData]) -> None:
        exc = response.error
        if exc is not None:
            if not isinstance(exc, Cancelled):
                self.failed.emit(f"cannot show this range: {exc}")
            return
        doc = self.doc
        resp = response.value
        if resp is None or doc is None or resp.doc is not doc:
            return
        if resp.request_id < self._applied_id:
            return  # a worker's answer overtaken by one read at once on this thread
        self._applied_id = resp.request_id
        req = resp.request
        cur = doc.current
        if not {key for key, _name in req.series} <= {doc.recorded.key, cur.key}:
            return  # read before the angles or the reprocessing changed: a newer one follows
        self.last_window = resp.windows
        t_s = doc.t_s
        for lane in self.visible_lanes():
            lane.draw(self.last_window, t_s, doc.recorded.key, cur.key, cur.angle_method)
        self._draw_events(cur, req)
        fsr = self.lanes["fsr"]
        phase = resp.phase
        if phase is not None and len(phase):
            x = t_s[req.start : req.stop]
            # a band never spans lost data: an off sample at the last time before each gap
            g = cur.gaps[0]
            g = g[(g > req.start) & (g < req.stop)] - req.start
            x = np.insert(x, g, x[g - 1])
            phase = np.insert(phase.astype(np.int16), g, -1)
        for tr, k in fsr.bands:
            if phase is not None and len(phase):
                tr.set_spans(*step_runs(x, phase == k), FSR_RANGE[0], FSR_RANGE[1])
            else:
                tr.clear()
        for lane in self.lanes.values():
            if lane.markers is not None:
                xs = np.array([m.t_s for m in doc.session.markers], dtype=np.float64)
                lane.markers.set(*_vlines(xs, *lane.yrange), connect="pairs")
            lane.traces.nominal[0] = self.view_range()
            lane.traces.commit()
        if not self._fitted_y:
            self._fitted_y = True
            self.fit_y()
        for lane in self.visible_lanes():
            lane.refresh_legend()
        self.applied_requests += 1
        self.loaded.emit(resp.request_id)

    def _draw_events(self, src: ReviewSource, req: ViewRequest) -> None:
        doc = self.doc
        assert doc is not None
        x0, x1 = self.view_range()
        show = (x1 - x0) <= EVENTS_MAX_S
        for lane in self.lanes.values():
            if show:
                lane.set_events(doc.t_s, src.heel_strike_idx, src.toe_off_idx, req.start,
                                req.stop)  # fmt: skip
            else:
                lane.clear_events()

    def fit_y(self) -> None:
        """Fit each lane's y range to the data in view (Home)."""
        mid_t_s = sum(self.view_range()) / 2
        for lane in self.visible_lanes():
            lane.fit_y(mid_t_s)
        for lane in self.lanes.values():
            lane.centre_missing(mid_t_s)

    # -- cursor and selection ------------------------------------------------------------------

    def set_cursor(self, t_s: float) -> None:
        if self._moving_cursor or self.doc is None or not self.doc.n_rows:
            return
        self._moving_cursor = True
        try:
            self.cursor_t_s = float(t_s)
            for line in [self.overview_cursor, *(ln.cursor for ln in self.lanes.values())]:
                if line is None:
                    continue
                line.setVisible(True)
                if line.value() != t_s:
                    line.setValue(t_s)
        finally:
            self._moving_cursor = False
        self.readout.setText(self.readout_text())
        self.cursor_moved.emit(self.cursor_t_s)

    def readout_text(self) -> str:
        """The time and the values at the cursor, read from the current series (exact row)."""
        if self.doc is None:
            return ""
        return readout_html(self.doc, self.cursor_t_s, self.segment)

    def _selection_dragged(self, t0: float, t1: float, finished: bool) -> None:
        self.set_selection(t0, t1)

    def set_selection(self, t0: float, t1: float) -> None:
        if t1 - t0 <= 0:
            self.selection = None
            self.selection_changed.emit(math.nan, math.nan)
        else:
            self.selection = (float(t0), float(t1))
            self.selection_changed.emit(float(t0), float(t1))
        self.refresh_shading()

    def clear_selection(self) -> None:
        self.set_selection(0.0, 0.0)

    # -- for tests and the benchmark -----------------------------------------------------------

    def trace_points(self, lane: str, series: str, column: int, before: bool = False) -> int:
        n = self.lanes[lane].points(series, column, before)
        if n is not None:
            return n
        raise KeyError(f"no trace {series}[{column}] in lane {lane}")

    def overview_points(self) -> int:
        return self.strip.points()

    def shutdown(self) -> None:
        # no view request after the loader stopped (one may be scheduled for this event loop)
        self._load_timer.stop()
        self.doc = None
        self.loader.stop()


__all__ = ["Timeline"]
