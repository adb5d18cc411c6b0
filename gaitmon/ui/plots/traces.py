"""Drawing primitives the live and review plots share, and the clinical ranges they show.

Everything here is built once and then fed numpy arrays ~30 times a second. What keeps that
cheap (goal: <= 25 % of one core for the live window's GUI thread, measured per sample from
the port by ``benchmarks/bench_gui.py``):

* each plot's traces drawn by one `TraceSet` item (one paint call per plot, paths built by
  ``pg.arrayToQPath``), pen width 1, no antialiasing, fixed axis ranges (no autorange pass);
* in the live window, layered painting (`CountingPlotWidget`): a frame is the trace sets drawn
  between a cached picture of the rest of the scene and a cached picture of the axes (which
  draw the grid); the scene is not traversed for a frame;
* elsewhere, axes cached as pixmaps by Qt; major grid lines only (:func:`style_plot`);
* the x axis is "seconds before now" with a fixed range, so the axes never re-render while the
  traces scroll;
* series known to be finite skip pyqtgraph's finite check; series with gaps (device modes leave
  some series NaN, the gyro integration off scale) are broken at NaN one polygon per finite
  run (:func:`broken_line_path`) and all-NaN ones are hidden;
* the arrays to draw are prepared by Qt-free code (``gaitmon.engine.display``; in the live
  window on the engine thread): windows longer than ``MAX_POINTS`` min/max decimated once per
  series (all columns in one numpy call), so peaks stay visible (``decimate_peak``); gait
  phases as step polygons through the phase changes only (``step_band``); events / markers
  as one ``connect='pairs'`` path per plot (``vertical_lines``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import (
    QAbstractTextDocumentLayout,
    QBrush,
    QColor,
    QFont,
    QPainter,
    QPainterPath,
    QPaintEvent,
    QPalette,
    QPen,
    QPixmap,
    QResizeEvent,
    QTextDocument,
)
from PySide6.QtWidgets import (
    QGraphicsItem,
    QGraphicsObject,
    QGraphicsView,
    QGraphicsWidget,
    QWidget,
)

from gaitmon.dsp.channel_table import JOINT_TABLE, SEGMENT_TABLE
from gaitmon.ui.theme import Colours

# y ranges cover normal and pathological walking with a calibrated (zeroed) unit
# (from the channel table: gaitmon.dsp.channel_table)
TILT_RANGES_DEG = {s.name: s.tilt_range_deg for s in SEGMENT_TABLE}
JOINTS = tuple((j.name, j.label, j.range_deg) for j in JOINT_TABLE)
FSR_RANGE = (-150.0, 4250.0)  # 12-bit ADC counts
# (key, label, tilt series, joint series); drawn in this order, Kalman on top
METHODS = (
    ("gyro", "Gyro integration", "tilt_gyro_deg", "joint_gyro_deg"),
    ("acc", "Accelerometer", "tilt_acc_deg", "joint_acc_deg"),
    ("kalman", "Kalman filter", "tilt_kalman_deg", "joint_kalman_deg"),
)
METHOD_LABELS = {k: label for k, label, _, _ in METHODS}
AXIS_WIDTH_PX = 58

if TYPE_CHECKING:
    # pyqtgraph has no type information. Its bases are typed here as the Qt classes they
    # derive from; what pyqtgraph adds to a layout widget (addPlot, ci, ...) is Any.
    _GraphicsObject = QGraphicsObject

    class _GraphicsLayoutWidget(QGraphicsView):
        def __getattr__(self, name: str) -> Any: ...

    class _AxisItem(QGraphicsWidget):
        def __init__(self, orientation: str) -> None: ...
        def __getattr__(self, name: str) -> Any: ...

else:
    _GraphicsObject = pg.GraphicsObject
    _GraphicsLayoutWidget = pg.GraphicsLayoutWidget
    _AxisItem = pg.AxisItem


def broken_line_path(x: np.ndarray, y: np.ndarray) -> QPainterPath:
    """The polyline through (x, y), broken where a value is NaN: what pyqtgraph draws with
    ``connect='finite'`` (each run of finite points is a polygon, its last point repeated when
    a NaN follows, as pyqtgraph does; a lone point at the end draws nothing), built with one
    polygon per run. pyqtgraph streams every point through a QDataStream once more than 2 %
    are NaN, which costs ~10x more: the gyro integration off scale is such a series."""
    n = len(x)
    path = QPainterPath()
    if n == 0:
        return path
    fin = np.isfinite(x) & np.isfinite(y)
    step = np.diff(fin.view(np.int8))
    starts = np.flatnonzero(step == 1) + 1
    ends = np.flatnonzero(step == -1) + 1  # the NaN after a run
    if fin[0]:
        starts = np.concatenate([[0], starts])
    if fin[-1]:
        ends = np.concatenate([ends, [n]])
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        m = b - a
        k = m + 1 if b < n else m
        if k < 2:
            continue
        poly = pg.functions.create_qpolygonf(k)
        arr = pg.functions.ndarray_from_qpolygonf(poly)
        arr[:m, 0] = x[a:b]
        arr[:m, 1] = y[a:b]
        if k > m:
            arr[m] = arr[m - 1]
        path.addPolygon(poly)
    return path


class Trace:
    """One line (or filled band) inside a `TraceSet`: its path, style and what it shows."""

    __slots__ = ("brush", "column", "fill_level", "method", "n_points", "path", "pen", "rects",
                 "series", "visible")  # fmt: skip

    def __init__(
        self,
        pen: QPen | None = None,
        brush: QColor | None = None,
        fill_level: float | None = None,
        series: str = "",
        column: int = -1,
        method: str = "",
    ) -> None:
        self.pen = pen
        self.brush = QBrush(brush) if brush is not None else None
        self.fill_level = fill_level
        self.series = series
        self.column = column
        self.method = method
        self.path: QPainterPath | None = None
        self.rects: list[QRectF] | None = None
        self.n_points = 0
        self.visible = True

    def set(self, x: np.ndarray, y: np.ndarray, finite: bool = True, connect: str = "") -> None:
        """New points; ``finite=False`` breaks the line at NaNs (device modes have gaps)."""
        if len(x) == 0:
            self.clear()
            return
        self.rects = None
        if self.fill_level is not None:  # close the outline down to the fill level
            x = np.concatenate([x[:1], x, x[-1:]])
            y = np.concatenate([[self.fill_level], y, [self.fill_level]])
        if not finite and not connect:
            self.path = broken_line_path(x, y)
        else:
            self.path = pg.arrayToQPath(
                np.ascontiguousarray(x, dtype=np.float64),
                np.ascontiguousarray(y, dtype=np.float64),
                connect=connect or "all",
                finiteCheck=not finite,
            )
        self.n_points = len(x)

    def set_spans(self, x0: np.ndarray, x1: np.ndarray, bottom: float, top: float) -> None:
        """Filled rectangles from ``x0[i]`` to ``x1[i]``, ``bottom`` to ``top`` (a band of
        :func:`step_runs`): drawn as rectangles, ~5x cheaper to fill than the same area as a
        step polygon (measured: 0.15 vs 0.73 ms for the ~30 runs of a 30-s phase band)."""
        self.path = None
        self.rects = [QRectF(a, bottom, b - a, top - bottom)
                      for a, b in zip(x0.tolist(), x1.tolist(), strict=True)]  # fmt: skip
        self.n_points = 4 * len(self.rects)

    def clear(self) -> None:
        self.path = None
        self.rects = None
        self.n_points = 0


class Label:
    """A line of text inside a `TraceSet`, its top-left corner at (x, y) in data coordinates,
    drawn after the traces in screen pixels as pyqtgraph's ``TextItem`` (anchor (0, 0)) draws it:
    through a `QTextDocument`, so the same layout (and margin) as a QGraphicsTextItem."""

    def __init__(self, colour: QColor, z: float = 0.0) -> None:
        self.colour = QColor(colour)
        self.z = z  # labels are drawn by increasing z, then in the order added
        self.x = 0.0
        self.y = 0.0
        self.visible = False
        self._doc = QTextDocument()
        self._text = ""
        self.right: float | None = None  # data x the text must end before (None: no limit)
        self.drawn: QRectF | None = None  # where it was last drawn, in the painter's pixels

    @property
    def text(self) -> str:
        return self._text

    def set(self, text: str, x: float, y: float, right: float | None = None) -> None:
        """Show ``text`` from (x, y); ``right``: the plot's right edge in data x: a label that
        would run past it is drawn ending there (so "right leg: no data" over an outage that
        began a moment ago is not cut to "righ" by the plot's edge)."""
        if text != self._text:
            self._text = text
            self._doc.setPlainText(text)
        self.x, self.y = float(x), float(y)
        self.right = right
        self.visible = True

    def hide(self) -> None:
        self.visible = False

    def draw(self, p: QPainter) -> None:
        tf = p.transform()
        at = tf.map(QPointF(self.x, self.y))
        size = self._doc.size()
        if self.right is not None:
            edge = tf.map(QPointF(self.right, self.y)).x()
            if at.x() + size.width() > edge:
                at.setX(edge - size.width())
        self.drawn = QRectF(at, size)
        p.save()
        p.resetTransform()
        p.translate(at)
        ctx = QAbstractTextDocumentLayout.PaintContext()
        ctx.palette.setColor(QPalette.ColorRole.Text, self.colour)
        self._doc.documentLayout().draw(p, ctx)
        p.restore()


class TraceSet(_GraphicsObject):
    """All the traces of one plot, drawn by a single item in list order, then its labels.

    One ``paint`` per plot instead of one per curve: with ~50 PlotCurveItems the per-item
    overhead (Python paint logic, bounds, scene bookkeeping) cost ~130 us each per frame. The
    bounding rect is a constant (the plot clips to its view), so no per-frame bounds pass.
    ``dataBounds`` reports the plot's nominal range, so "View all" in the menu stays sane.

    In a `CountingPlotWidget` (``host``) the set is not repainted through the scene: the widget
    draws it between cached pictures of everything else (see there).
    """

    _BIG = QRectF(-1e5, -1e7, 2e5, 2e7)

    def __init__(self, nominal_x: tuple[float, float], nominal_y: tuple[float, float]) -> None:
        super().__init__()
        self.traces: list[Trace] = []
        self.labels: list[Label] = []
        self.nominal = [nominal_x, nominal_y]
        self.antialias = False  # measured: antialiased live traces redraw far slower
        self.host: CountingPlotWidget | None = None

    def add(self, trace: Trace) -> Trace:
        self.traces.append(trace)
        return trace

    def add_label(self, colour: QColor, z: float = 0.0) -> Label:
        label = Label(colour, z)
        self.labels.append(label)
        self.labels.sort(key=lambda lab: lab.z)  # stable: the order added within one z
        return label

    def commit(self) -> None:
        """Schedule a repaint after the traces changed."""
        if self.host is not None and self.host.layered:
            self.host.viewport().update()  # the scene (and its cached pictures) is unchanged
        else:
            self.update()

    def boundingRect(self) -> QRectF:
        return self._BIG

    def dataBounds(
        self, ax: int, frac: float = 1.0, orthoRange: object = None
    ) -> tuple[float, float]:
        return self.nominal[ax]

    def paint(self, p: QPainter, *args: object) -> None:
        if self.host is not None and self.host.drawing_scene_only:
            return
        self.draw(p)

    def draw(self, p: QPainter) -> None:
        p.setRenderHint(QPainter.RenderHint.Antialiasing, self.antialias)
        for tr in self.traces:
            if not tr.visible:
                continue
            if tr.rects is not None:
                if tr.rects:
                    p.setPen(Qt.PenStyle.NoPen)
                    p.setBrush(tr.brush if tr.brush is not None else QBrush())
                    p.drawRects(tr.rects)
                    p.setBrush(QBrush())
                continue
            if tr.path is None:
                continue
            if tr.brush is not None:
                p.fillPath(tr.path, tr.brush)
            else:
                p.setPen(tr.pen)
                p.drawPath(tr.path)
        for label in self.labels:
            if label.visible:
                label.draw(p)


class LayerAxis(_AxisItem):
    """An axis of a `CountingPlotWidget` plot: in layered painting it is drawn above the traces
    from a cached picture of all such axes (its grid and tick marks reach into the plot and lie
    over the traces, as in the scene), not with the rest of the scene under them."""

    def __init__(self, orientation: str, host: CountingPlotWidget) -> None:
        super().__init__(orientation)
        self.host = host
        host.adopt_axis(self)

    def paint(self, p: QPainter, *args: Any) -> None:
        if self.host.drawing_scene_only:
            return
        super().paint(p, *args)


class CountingPlotWidget(_GraphicsLayoutWidget):
    """A GraphicsLayoutWidget that counts its repaints, knows the newest sample it shows, and
    redraws only its traces when only they changed.

    ``mark_new_data(newest_idx)`` after new data is set: the next paint shows every sample up
    to that engine index (what `benchmarks/bench_gui.py` times, per sample, from the port).

    Layered painting (``layered``, on by default; plots made with ``axes()`` and trace sets
    passed to ``adopt``): a frame is three layers, in the scene's own order. Under the traces,
    a cached picture of the scene without them and without the axes (backgrounds, titles, axis
    labels); then each adopted `TraceSet`, clipped to its plot; over them, a cached picture of
    the axes (tick labels, tick marks, grid). Any change to the scene (a y zoom, a resize, a
    title, a theme) drops both pictures; new traces are not a scene change
    (`TraceSet.commit` updates the viewport only). Measured: a frame of the live plots costs
    ~2.5 ms of the GUI thread instead of ~5.5 ms (the per-item scene traversal, its Python
    bounds calls and the axis pixmaps are gone). ``layered = False`` paints the whole scene
    (the axes then cached per item by Qt), as before; the tests compare the two pixel by pixel.
    """

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.paints = 0
        self._shown_idx: float | None = None
        self.drawing_scene_only = False  # rendering the picture under the traces
        self._layered = True
        self._adopted: list[TraceSet] = []
        self._axes: list[LayerAxis] = []
        self._under: QPixmap | None = None
        self._over: QPixmap | None = None
        self.scene().changed.connect(self._scene_changed)

    @property
    def layered(self) -> bool:
        return self._layered

    @layered.setter
    def layered(self, on: bool) -> None:
        self._layered = bool(on)
        for ax in self._axes:
            self._set_axis_cache(ax)
        self._scene_changed(None)
        for ts in self._adopted:
            ts.update()
        self.viewport().update()

    def axes(self) -> dict[str, LayerAxis]:
        """``axisItems`` for ``addPlot``: a left and a bottom axis drawn in the right layer."""
        return {"left": LayerAxis("left", self), "bottom": LayerAxis("bottom", self)}

    def adopt_axis(self, axis: LayerAxis) -> None:
        self._axes.append(axis)

    def adopt(self, traces: TraceSet) -> TraceSet:
        """Draw ``traces`` in the layer between the two cached pictures."""
        traces.host = self
        self._adopted.append(traces)
        self._scene_changed(None)
        return traces

    def _set_axis_cache(self, ax: LayerAxis) -> None:
        # the axes redraw only when their range or size changes: the scene path caches them
        # per item (measured: the grid replayed every frame was ~80 % of a frame); layered
        # painting caches all of them in one picture instead
        mode = QGraphicsItem.CacheMode
        ax.setCacheMode(mode.NoCache if self._layered else mode.DeviceCoordinateCache)

    def mark_new_data(self, newest_idx: float) -> None:
        self._shown_idx = newest_idx

    def _scene_changed(self, _rects: object) -> None:
        self._under = self._over = None

    def resizeEvent(self, ev: QResizeEvent) -> None:
        self._scene_changed(None)
        super().resizeEvent(ev)

    def paintEvent(self, ev: QPaintEvent) -> None:
        if self._layered and self._adopted:
            self._paint_layered()
        else:
            super().paintEvent(ev)
        self.paints += 1
        self._shown_idx = None

    def _new_pixmap(self, fill: QColor) -> QPixmap:
        vp = self.viewport()
        dpr = vp.devicePixelRatioF()
        pm = QPixmap(vp.size() * dpr)
        pm.setDevicePixelRatio(dpr)
        pm.fill(fill)
        return pm

    def _render_pictures(self) -> None:
        vp = self.viewport()
        under = self._new_pixmap(self.backgroundBrush().color())
        p = QPainter(under)
        self.drawing_scene_only = True
        try:
            self.render(p, QRectF(vp.rect()), vp.rect())
        finally:
            self.drawing_scene_only = False
            p.end()
        over = self._new_pixmap(QColor(0, 0, 0, 0))
        p = QPainter(over)
        to_view = self.viewportTransform()
        for ax in self._axes:
            if ax.isVisible():
                p.save()  # an axis's picture leaves its painter state behind
                p.setTransform(ax.deviceTransform(to_view))
                ax.paint(p, None, None)
                p.restore()
        p.end()
        self._under, self._over = under, over

    def _paint_layered(self) -> None:
        scene: Any = self.scene()  # pyqtgraph's GraphicsScene
        scene.prepareForPaint()  # as pyqtgraph's own paintEvent does
        vp = self.viewport()
        if self._under is None or self._under.deviceIndependentSize().toSize() != vp.size():
            self._render_pictures()
        assert self._under is not None and self._over is not None
        p = QPainter(vp)
        p.drawPixmap(0, 0, self._under)
        to_view = self.viewportTransform()
        for ts in self._adopted:
            if not ts.isVisible():
                continue
            parent = ts.parentItem()
            clip = parent.parentItem() if parent is not None else None  # the ViewBox
            if clip is not None:
                p.setClipPath(to_view.map(clip.mapToScene(clip.shape())))
            p.setTransform(ts.deviceTransform(to_view))
            ts.draw(p)
            p.resetTransform()
            p.setClipping(False)
        p.drawPixmap(0, 0, self._over)
        p.end()


def style_plot(
    plot: pg.PlotItem, colours: Colours, ylabel: str, yrange: tuple[float, float], bottom: bool
) -> None:
    plot.setMenuEnabled(True)
    plot.setMouseEnabled(x=False, y=True)  # y zoom to inspect; x follows the clock
    plot.hideButtons()
    plot.showGrid(x=True, y=True, alpha=colours.grid_alpha)
    vb = plot.getViewBox()
    vb.disableAutoRange()
    vb.setDefaultPadding(0.0)
    plot.setYRange(*yrange, padding=0)
    left = plot.getAxis("left")
    left.setWidth(AXIS_WIDTH_PX)
    left.setLabel(ylabel)
    left.enableAutoSIPrefix(False)
    ax = plot.getAxis("bottom")
    if bottom:
        ax.setLabel("time before now (s)")
    else:
        ax.setStyle(showValues=False)
        ax.setHeight(6)
    font = QFont()
    font.setPointSizeF(8.0)
    for a in (left, ax):
        a.setTickFont(font)
        # The axes draw the grid; replaying it on every frame was ~80 % of the paint time
        # (17 ms -> 3 ms per frame measured): keep major ticks only and cache the axes as
        # pixmaps (they only change when the y range or the window size does).
        a.setStyle(maxTickLevel=0)
        if isinstance(a, LayerAxis):
            a.host._set_axis_cache(a)
        else:
            a.setCacheMode(QGraphicsItem.CacheMode.DeviceCoordinateCache)
