"""The pieces the review timeline is drawn with: the time axis, the shaded spans, the lane's
mouse handling, and what a lane holds.

* :class:`TimeAxis` - seconds from the session start, m:ss once ticks are a minute apart,
  titled with the unit the ticks are in ("time (s)");
* :class:`ShadeItem` - vertical bands in named layers (gaps, exclusions, selection, the picked
  stride), drawing only the spans in view;
* :class:`LaneViewBox` - x pan/zoom, Shift+drag selects a range, a click places the cursor;
* :class:`TraceSpec`, :class:`Lane` - which series a lane draws, the items that draw them, and
  what is done to one lane (draw a view, fit y, events, points drawn); :func:`lane_plot` makes
  its plot;
* :class:`LaneLegend` - the lane's legend: a swatch and a name (with its unit) for each coloured
  trace drawn, in one row at the lane's top right.

A lane's y range is fitted to the angles in force (the selected method's, and the recorded ones
under a reprocessing), never to a *reference* trace: the gyro integration drifts (150° after a
minute of walking is usual) and the accelerometer's tilt spikes at each impact, so fitted to
them the angles that matter were squashed into a few pixels. A reference is drawn over that
range, clipped at the lane's edges, its wraps at ±180° broken instead of drawn as vertical
lines, and its legend entry says that it drifts and is not a measurement, and how far off
scale it is in view.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QRectF, Qt, QTimer, Signal
from PySide6.QtGui import QBrush, QColor, QPainter, QPen
from PySide6.QtWidgets import QGraphicsItem

from gaitmon.dsp.channels import SEGMENTS
from gaitmon.io.overview import PeakWindow
from gaitmon.text import num
from gaitmon.ui.plots import Trace, TraceSet, on_scale, vertical_lines
from gaitmon.ui.theme import Colours, pen

AXIS_WIDTH_PX = 58  # every plot's y axis: the lanes' time axes line up


def line_pen(colour: QColor, *, dashed: bool = False) -> QPen:
    """The theme's cosmetic pen, typed (``gaitmon.ui.theme.pen`` is declared as ``object``)."""
    p = pen(colour, dashed=dashed)
    assert isinstance(p, QPen)
    return p


class TimeAxis(pg.AxisItem):  # type: ignore[misc]  # pyqtgraph is untyped
    """Seconds from the session start, written h:mm:ss once the ticks are a minute apart; the
    axis title (when shown) names the unit the ticks are written in."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.titled = False
        self.unit = "s"

    def set_titled(self, on: bool) -> None:
        """Show the axis title ("time (s)") under the ticks."""
        self.titled = bool(on)
        self.setLabel(self.title() if on else None)

    def title(self) -> str:
        return f"time ({self.unit})"

    def _retitle(self) -> None:
        if self.titled:
            self.setLabel(self.title())

    def tickStrings(self, values: list[float], scale: float, spacing: float) -> list[str]:
        if spacing < 60:
            unit = "s"
        else:
            unit = "h:mm:ss" if max((abs(v) for v in values), default=0.0) >= 3600 else "m:ss"
        if unit != self.unit:
            self.unit = unit
            # not while the axis is being laid out: a new title changes its height
            QTimer.singleShot(0, self._retitle)
        if spacing < 60:
            return super().tickStrings(values, scale, spacing)
        out = []
        for v in values:
            s = round(v)
            h, rem = divmod(abs(s), 3600)
            m, sec = divmod(rem, 60)
            sign = "-" if s < 0 else ""
            out.append(f"{sign}{h}:{m:02d}:{sec:02d}" if h else f"{sign}{m}:{sec:02d}")
        return out


class ShadeItem(pg.GraphicsObject):  # type: ignore[misc]
    """Vertical bands (x spans over the full height) in layers; only spans in view are drawn."""

    _BIG = QRectF(-1e9, -1e9, 2e9, 2e9)

    def __init__(self) -> None:
        super().__init__()
        self.layers: dict[str, tuple[np.ndarray, QBrush]] = {}
        self.setZValue(-10)

    def set_layer(self, name: str, spans: np.ndarray, colour: QColor) -> None:
        spans = np.asarray(spans, dtype=np.float64).reshape(-1, 2)
        order = np.argsort(spans[:, 0], kind="stable")
        self.layers[name] = (spans[order], QBrush(colour))
        self.update()

    def spans(self, name: str) -> np.ndarray:
        return self.layers.get(name, (np.empty((0, 2)), None))[0]

    def boundingRect(self) -> QRectF:
        return self._BIG

    def paint(self, p: QPainter, *args: object) -> None:
        vb = self.getViewBox()
        if vb is None:
            return
        view = vb.viewRect()
        x0, x1 = view.left(), view.right()
        # at least one pixel wide, so a one-frame gap stays visible when zoomed out
        px = view.width() / max(1.0, vb.width())
        p.setPen(Qt.PenStyle.NoPen)
        for spans, brush in self.layers.values():
            if not len(spans):
                continue
            lo = int(np.searchsorted(spans[:, 0], x1, side="right"))
            for a, b in spans[:lo]:
                if b < x0:
                    continue
                w = max(b - a, px)
                p.fillRect(QRectF(a, view.top(), w, view.height()), brush)


class LaneViewBox(pg.ViewBox):  # type: ignore[misc]
    """x pan/zoom with the mouse; Shift+drag selects a time range; a click places the cursor."""

    selection_dragged = Signal(float, float, bool)  # t0, t1, finished
    clicked = Signal(float)

    def mouseDragEvent(self, ev: Any, axis: int | None = None) -> None:
        if ev.button() == Qt.MouseButton.LeftButton and (
            ev.modifiers() & Qt.KeyboardModifier.ShiftModifier
        ):
            ev.accept()
            a = self.mapSceneToView(ev.buttonDownScenePos()).x()
            b = self.mapSceneToView(ev.scenePos()).x()
            self.selection_dragged.emit(min(a, b), max(a, b), ev.isFinish())
            return
        super().mouseDragEvent(ev, axis)

    def mouseClickEvent(self, ev: Any) -> None:
        if ev.button() == Qt.MouseButton.LeftButton:
            ev.accept()
            self.clicked.emit(self.mapSceneToView(ev.scenePos()).x())
            return
        super().mouseClickEvent(ev)


@dataclass
class TraceSpec:
    series: str
    column: int
    colour: QColor
    method: str = ""  # "kalman" / "acc" / "gyro": toggled together; "" always shown
    before: bool = False  # the recorded series under a reprocessed one (comparison)
    # the legend's name, with the unit; "{method}" is the angles' method, "{segment}" the
    # segment of the column drawn
    label: str = ""
    reference: bool = False  # drawn for comparison: never sets the lane's y range
    dashed: bool = False


class LaneLegend(pg.TextItem):  # type: ignore[misc]  # pyqtgraph is untyped
    """A lane's legend: one entry (swatch in the trace's colour, name with its unit) for each
    coloured trace drawn, in one row at the top right of the lane's view box (fixed there while
    the traces pan), over a translucent background so the traces stay visible under it."""

    def __init__(self, vb: pg.ViewBox, colours: Colours) -> None:
        bg = QColor(colours.background)
        bg.setAlpha(190)
        super().__init__("", color=colours.foreground, anchor=(1, 0), fill=bg)
        self.entries: list[tuple[str, str]] = []  # (swatch colour #rrggbb, text)
        self.setParentItem(vb)
        self.setZValue(30)
        self.setVisible(False)
        vb.sigResized.connect(self.place)

    def set_entries(self, entries: list[tuple[QColor, str, str]]) -> None:
        """``(colour, swatch, text)`` per entry, in order; an entry named twice is shown once."""
        seen: list[tuple[str, str]] = []
        cells = []
        for colour, swatch, text in entries:
            key = (colour.name(), text)
            if key in seen or not text:
                continue
            seen.append(key)
            cells.append(f"<span style='color:{colour.name()}'>{swatch}</span>&nbsp;"
                         f"{html.escape(text).replace(' ', '&nbsp;')}")  # fmt: skip
        if seen == self.entries:
            return
        self.entries = seen
        self.setHtml("<span style='font-size:8pt'>" + " &nbsp; ".join(cells) + "</span>")
        self.setVisible(bool(seen))
        self.place()

    def texts(self) -> list[str]:
        return [text for _c, text in self.entries]

    def place(self, *_args: object) -> None:
        """At the top right; wrapped between entries when one row is wider than the lane."""
        vb = self.parentItem()
        if vb is None:
            return
        room = max(40.0, vb.width() - 4)
        self.setTextWidth(-1)
        if self.textItem.boundingRect().width() > room:
            self.setTextWidth(room)
        self.setPos(vb.width() - 2, 1)


@dataclass
class Lane:
    key: str
    title: str
    yrange: tuple[float, float]
    plot: pg.PlotItem
    traces: TraceSet
    specs: list[tuple[TraceSpec, Trace]] = field(default_factory=list)
    shade: ShadeItem = field(default_factory=ShadeItem)
    cursor: pg.InfiniteLine | None = None
    events_hs: Trace | None = None
    events_to: Trace | None = None
    markers: Trace | None = None
    bands: list[tuple[Trace, int]] = field(default_factory=list)
    band_names: tuple[str, ...] = ()  # the legend's name of each band (by phase, from 1)
    missing: pg.TextItem | None = None
    legend: LaneLegend | None = None
    extra_legend: list[tuple[QColor, str, str]] = field(default_factory=list)  # always listed
    method: str = ""  # the angles' method, named in the legend
    off_scale: dict[int, float] = field(default_factory=dict)  # by spec: farthest value, in view

    def draw(self, windows: Mapping[tuple[str, str], PeakWindow], t_s: np.ndarray,
             recorded_key: str, current_key: str, method: str) -> None:  # fmt: skip
        """Set each visible trace from the rows read for the view (``windows`` by (source key,
        series); the recorded source's for a "before" trace), a reference's wraps broken."""
        self.method = method
        for spec, tr in self.specs:
            if not tr.visible:
                continue
            w = windows.get((recorded_key if spec.before else current_key, spec.series))
            if w is None or not len(w.idx):
                tr.clear()
                continue
            y = w.y[:, spec.column]
            if spec.reference:  # a jump of more than 180° is a wrap: not drawn as a line
                y = on_scale(y[:, None], [(-math.inf, math.inf)])[0][:, 0]
            tr.set(t_s[w.idx], y, finite=bool(np.isfinite(y).all()))

    def refresh_legend(self) -> None:
        """The legend lists each coloured trace drawn now (and the lane's fixed entries); a
        reference off the lane's scale says how far (its farthest value in view)."""
        if self.legend is None:
            return
        y0, y1 = self.plot.getViewBox().viewRange()[1]
        self.off_scale = {}
        entries = []
        for i, (spec, tr) in enumerate(self.specs):
            if not (tr.visible and tr.path is not None and spec.label):
                continue
            text = spec.label.format(method=self.method or "angles shown",
                                     segment=SEGMENTS[spec.column % len(SEGMENTS)])  # fmt: skip
            if spec.reference:
                r = tr.path.boundingRect()  # its values in view: lowest (top) to highest
                lo, hi = r.top(), r.bottom()
                if math.isfinite(lo) and math.isfinite(hi) and (lo < y0 or hi > y1):
                    self.off_scale[i] = lo if y0 - lo > hi - y1 else hi
                    text += (f", off scale here ({num(lo, 0, sign=True)} to "
                             f"{num(hi, 0, sign=True)}°)")  # fmt: skip
            colour = QColor(tr.pen.color()) if tr.pen is not None else spec.colour
            entries.append((colour, "╌╌" if spec.dashed else "━━", text))
        for (tr, _k), name in zip(self.bands, self.band_names, strict=False):
            if tr.visible and (tr.path is not None or tr.rects) and tr.brush is not None:
                entries.append((tr.brush.color(), "■", name))
        self.legend.set_entries(entries + self.extra_legend)

    def fit_y(self, mid_t_s: float) -> None:
        """Fit the y range to the traces drawn that are not references (the references' only
        when nothing else is drawn; the nominal range when nothing is)."""
        drawn = [(s, tr.path) for s, tr in self.specs if tr.visible and tr.path is not None]
        ys = [p for s, p in drawn if not s.reference] or [p for _s, p in drawn]
        if not ys:
            self.plot.setYRange(*self.yrange, padding=0)
            return
        rect = ys[0].boundingRect()
        for path in ys[1:]:
            rect = rect.united(path.boundingRect())
        lo, hi = rect.top(), rect.bottom()
        if not (math.isfinite(lo) and math.isfinite(hi)) or hi - lo < 1e-6:
            self.plot.setYRange(*self.yrange, padding=0)
            return
        pad = 0.08 * (hi - lo)
        self.plot.setYRange(lo - pad, hi + pad, padding=0)
        if self.missing is not None:
            self.missing.setPos(mid_t_s, (lo + hi) / 2)
        self.refresh_legend()

    def centre_missing(self, mid_t_s: float) -> None:
        """Keep the "not recorded" note in the middle of the view."""
        if self.missing is not None and self.missing.isVisible():
            (y0, y1) = self.plot.getViewBox().viewRange()[1]
            self.missing.setPos(mid_t_s, (y0 + y1) / 2)

    def set_events(self, t_s: np.ndarray, heel_strike_idx: np.ndarray, toe_off_idx: np.ndarray,
                   start: int, stop: int) -> None:  # fmt: skip
        """Heel strike and toe off lines of rows ``start:stop`` (rows past ``t_s`` dropped)."""
        pairs = ((self.events_hs, heel_strike_idx), (self.events_to, toe_off_idx))
        for tr, idx in pairs:
            if tr is None:
                continue
            a, b = np.searchsorted(idx, [start, stop])
            sel = idx[a:b]
            sel = sel[sel < len(t_s)]
            tr.set(*vertical_lines(t_s[sel], -1e6, 1e6), connect="pairs")

    def clear_events(self) -> None:
        for tr in (self.events_hs, self.events_to):
            if tr is not None:
                tr.clear()

    def points(self, series: str, column: int, before: bool = False) -> int | None:
        """Points drawn of the primary trace of ``series[column]``; None if the lane has none."""
        for spec, tr in self.specs:
            if spec.series == series and spec.column == column and spec.before == before and (
                spec.method in ("", "kalman")
            ):
                return tr.n_points if tr.visible else 0
        return None


def lane_plot(colours: Colours, vb: pg.ViewBox | None = None) -> pg.PlotItem:
    """A plot of the timeline: time axis, grid, no auto range, fixed-width y axis."""
    p = pg.PlotItem(viewBox=vb or LaneViewBox(), axisItems={"bottom": TimeAxis("bottom")})
    p.hideButtons()
    p.showGrid(x=True, y=True, alpha=colours.grid_alpha)
    p.setMenuEnabled(True)
    vb = p.getViewBox()
    vb.disableAutoRange()
    vb.setDefaultPadding(0.0)
    left = p.getAxis("left")
    left.setWidth(AXIS_WIDTH_PX)
    left.enableAutoSIPrefix(False)
    # The axes draw the grid, and replaying their pictures was ~85 % of a pan frame
    # (measured: 3 ms per axis per paint): major ticks only, and the y axes (which do not
    # change while panning) cached as pixmaps, as the live window does.
    for name in ("left", "bottom"):
        p.getAxis(name).setStyle(maxTickLevel=0)
    left.setCacheMode(QGraphicsItem.CacheMode.DeviceCoordinateCache)
    return p
