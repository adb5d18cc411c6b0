"""The gait-cycle overlay of the live monitor: hip, knee and ankle over the last strides."""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from PySide6.QtGui import QColor, QFontMetrics
from PySide6.QtWidgets import QWidget

from gaitmon.dsp.gait import cycle_mean_sd
from gaitmon.engine import Snapshot
from gaitmon.engine.display import newest_idx
from gaitmon.ui.plots.traces import JOINTS, CountingPlotWidget, style_plot
from gaitmon.ui.theme import Colours, pen

# no data for longer than this (the link is down): the stride in progress is broken, its line
# goes (the time plots shade the outage after 0.3 s; a loaded machine may pause that long)
CURRENT_STALE_S = 1.0


class CyclePlots(CountingPlotWidget):
    """Hip, knee and ankle over the gait cycle: mean ± SD of the last strides + current stride."""

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.ci.setContentsMargins(2, 2, 8, 2)
        self.pct = np.linspace(0.0, 100.0, 101)
        self.mean_curves: list[pg.PlotCurveItem] = []
        self.upper: list[pg.PlotCurveItem] = []
        # hides QWidget.lower() (window stacking), which nothing calls on a plot widget
        self.lower: list[pg.PlotCurveItem] = []  # type: ignore[assignment]
        self.current: list[pg.PlotCurveItem] = []
        self.toe_off_lines: list[pg.InfiniteLine] = []
        self._shown_strides = -1
        # the cycles are Kalman joint angles: the paper's Kalman green, band translucent
        band_colour = QColor(colours.kalman)
        band_colour.setAlpha(60)
        band_pen = pen(band_colour)
        cur_pen = pg.mkPen(colours.current, width=2)
        self._plots: list[pg.PlotItem] = []
        self._short_labels = False
        for j, (key, label, yr) in enumerate(JOINTS):
            p = self.addPlot(row=j, col=0)
            style_plot(p, colours, f"{label} (deg)", yr, bottom=False)
            self._plots.append(p)
            p.vb.sigResized.connect(self._fit_labels)
            p.setMouseEnabled(x=False, y=False)
            p.setXRange(0, 100, padding=0)
            ax = p.getAxis("bottom")
            if j == len(JOINTS) - 1:
                ax.setStyle(showValues=True)
                ax.setHeight(None)
                ax.setLabel("gait cycle (% of stride, from heel strike)")
            p.setToolTip(
                f"{key.capitalize()} over the gait cycle in degrees ({label} +): band = mean ± SD "
                "of the last "
                "strides, line = the current stride so far, dashed = mean toe off."
            )
            lower = pg.PlotCurveItem(pen=band_pen)
            upper = pg.PlotCurveItem(pen=band_pen)
            fill = pg.FillBetweenItem(lower, upper, brush=band_colour)
            mean = pg.PlotCurveItem(pen=pen(colours.kalman))
            cur = pg.PlotCurveItem(pen=cur_pen)
            toe = pg.InfiniteLine(pos=60, angle=90, pen=pen(colours.event, dashed=True))
            toe.setVisible(False)
            for item in (lower, upper, fill, mean, toe, cur):
                p.addItem(item)
            self.lower.append(lower)
            self.upper.append(upper)
            self.mean_curves.append(mean)
            self.current.append(cur)
            self.toe_off_lines.append(toe)

    def _fit_labels(self, *_: object) -> None:
        """Each y axis says "knee flexion (deg)" where the plot is tall enough for it, else
        "knee (deg)" (the sign is in the tooltip): labels longer than their plot overlap the
        next plot's (three cycle plots in a short panel, as in the both-legs view)."""
        if len(self._plots) < len(JOINTS):  # still being built
            return
        axis = self._plots[0].getAxis("left")
        metrics = QFontMetrics(axis.label.font())
        height = min(p.vb.height() for p in self._plots)
        longest = max(metrics.horizontalAdvance(f"{label} (deg)") for _k, label, _r in JOINTS)
        short = longest > height - 4
        if short == self._short_labels:
            return
        self._short_labels = short
        for p, (key, label, _yr) in zip(self._plots, JOINTS, strict=True):
            p.getAxis("left").setLabel(f"{key if short else label} (deg)")

    def clear_data(self) -> None:
        self._shown_strides = -1
        for items in (self.lower, self.upper, self.mean_curves, self.current):
            for it in items:
                it.setData(np.empty(0), np.empty(0))
        for line in self.toe_off_lines:
            line.setVisible(False)

    def update_from(
        self, snap: Snapshot, mean_sd: tuple[np.ndarray, np.ndarray] | None = None
    ) -> None:
        """Show ``snap``'s cycles; ``mean_sd``: their mean and SD already computed off the GUI
        thread (``DisplayFrame.cycle_mean_sd``), else computed here."""
        g = snap.gait
        if g.n_strides != self._shown_strides:
            self._shown_strides = g.n_strides
            cyc = g.cycles_deg
            if len(cyc):
                # the sample SD, as in the review window and the report; one stride has none
                mean, sd = mean_sd if mean_sd is not None else cycle_mean_sd(cyc)
                band = bool(np.isfinite(sd).all())
                for j in range(len(JOINTS)):
                    self.mean_curves[j].setData(self.pct, mean[:, j])
                    for curve, y in ((self.lower[j], -sd[:, j]), (self.upper[j], sd[:, j])):
                        if band:
                            curve.setData(self.pct, mean[:, j] + y)
                        else:
                            curve.setData(np.empty(0), np.empty(0))
            stance = g.last_stance_pct
            for line in self.toe_off_lines:
                ok = math.isfinite(stance)
                line.setVisible(ok)
                if ok:
                    line.setValue(stance)
        pct = g.current_pct
        if len(pct) and snap.last_data_age_s <= CURRENT_STALE_S:
            keep = pct <= 100.0
            for j in range(len(JOINTS)):
                y = g.current_deg[keep, j]
                if np.isfinite(y).all():
                    self.current[j].setData(pct[keep], y, skipFiniteCheck=True)
                else:
                    self.current[j].setData(pct[keep], y, connect="finite")
        else:  # no stride in progress, or no data coming: no line left from an older one
            self.clear_current()
        self.mark_new_data(newest_idx(snap.series))

    def clear_current(self) -> None:
        """Drop the current stride's line (no stride in progress, link down, disconnected)."""
        for curve in self.current:
            if curve.xData is not None and len(curve.xData):
                curve.setData(np.empty(0), np.empty(0))
