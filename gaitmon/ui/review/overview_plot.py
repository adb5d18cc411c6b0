"""The whole-session strip above the timeline's lanes: the knee angle's min/max envelope from
the source's pyramid, gaps and exclusions shaded, markers, and the detail range as a draggable
region (which the timeline keeps in step with its lanes)."""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtGui import QColor

from gaitmon.review.model import OVERVIEW_SERIES, Document
from gaitmon.ui.plots import vertical_lines
from gaitmon.ui.review.lanes import ShadeItem
from gaitmon.ui.theme import Colours, pen

HEIGHT_PX = 92
MIN_POINTS = 400  # the envelope is queried at 2 points per pixel, never fewer than this


class OverviewPlot:
    """Draws into ``plot`` (a row of the timeline's layout); see the module docstring."""

    def __init__(self, plot: pg.PlotItem, colours: Colours) -> None:
        self.plot = plot
        plot.setMouseEnabled(x=False, y=False)
        plot.setMaximumHeight(HEIGHT_PX)
        plot.getAxis("left").setLabel("knee (°)")
        plot.setToolTip(
            "The whole session (knee flexion, min/max envelope). Drag the highlighted region to "
            "move the detail view; shaded: gaps (lost data) and excluded ranges."
        )
        self.shade = ShadeItem()
        plot.addItem(self.shade, ignoreBounds=True)
        self.curve = pg.PlotCurveItem(pen=pen(colours.kalman), skipFiniteCheck=False)
        plot.addItem(self.curve)
        self.markers = pg.PlotCurveItem(pen=pen(colours.marker), connect="pairs")
        plot.addItem(self.markers, ignoreBounds=True)
        brush = QColor(colours.band)
        brush.setAlpha(50)
        self.region = pg.LinearRegionItem(values=(0, 1), brush=brush, movable=True)
        self.region.setZValue(10)
        plot.addItem(self.region, ignoreBounds=True)

    def set_extent(self, t0_s: float, t1_s: float, pad_s: float) -> None:
        self.plot.setXRange(t0_s, t1_s, padding=0.01)
        self.region.setBounds((t0_s - pad_s, t1_s + pad_s))

    def draw(self, doc: Document, width_px: int) -> None:
        """The knee envelope of the current series (the recorded one until a reprocessing has
        built its pyramid)."""
        if not doc.n_rows:
            return
        src = doc.current
        ov = src.overview if src.overview.has_pyramid(OVERVIEW_SERIES) else None
        if ov is None:
            ov = doc.recorded.overview
        if not ov.has_pyramid(OVERVIEW_SERIES):
            return
        # broken at the gaps (NaN rows), so no line is drawn across lost data
        w = ov.envelope(OVERVIEW_SERIES, 2 * max(MIN_POINTS, width_px))
        x = doc.t_s[np.minimum(w.idx, doc.n_rows - 1)]
        y = w.y[:, 1].astype(np.float64)
        self.curve.setData(x, y, connect="finite")
        fin = y[np.isfinite(y)]
        if len(fin):
            lo, hi = float(fin.min()), float(fin.max())
            pad = 0.08 * max(hi - lo, 1.0)
            self.plot.setYRange(lo - pad, hi + pad, padding=0)

    def set_markers(self, t_s: np.ndarray) -> None:
        self.markers.setData(*vertical_lines(t_s, -1e6, 1e6), connect="pairs")

    def clear(self) -> None:
        self.curve.setData([], [])
        self.markers.setData([], [])
        self.shade.layers.clear()

    def points(self) -> int:
        x, _y = self.curve.getData()
        return 0 if x is None else len(x)
