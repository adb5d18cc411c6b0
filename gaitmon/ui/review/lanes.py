"""The pieces the review timeline is drawn with: the time axis, the shaded spans, the lane's
mouse handling, and what a lane holds.

* :class:`TimeAxis` - seconds from the session start, h:mm:ss once ticks are a minute apart;
* :class:`ShadeItem` - vertical bands in named layers (gaps, exclusions, selection, the picked
  stride), drawing only the spans in view;
* :class:`LaneViewBox` - x pan/zoom, Shift+drag selects a range, a click places the cursor;
* :class:`TraceSpec`, :class:`Lane` - which series a lane draws and the items that draw them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QRectF, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QPainter, QPen

from gaitmon.ui.plots import Trace, TraceSet
from gaitmon.ui.theme import pen


def line_pen(colour: QColor, *, dashed: bool = False) -> QPen:
    """The theme's cosmetic pen, typed (``gaitmon.ui.theme.pen`` is declared as ``object``)."""
    p = pen(colour, dashed=dashed)
    assert isinstance(p, QPen)
    return p


class TimeAxis(pg.AxisItem):  # type: ignore[misc]  # pyqtgraph is untyped
    """Seconds from the session start, written h:mm:ss once the ticks are a minute apart."""

    def tickStrings(self, values: list[float], scale: float, spacing: float) -> list[str]:
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
    missing: pg.TextItem | None = None
