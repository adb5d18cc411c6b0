"""Cycle-normalised hip, knee and ankle: mean ± SD band, strides faint, toe off at mean stance.

Every curve has 101 points (0..100 % of the stride, heel strike to heel strike). Individual
strides are drawn as one path per joint (NaN-separated), at most ``MAX_STRIDES_DRAWN`` of them
spread evenly over the session, so an 8-hour session stays quick to draw; the mean and SD use
every included stride. After a reprocessing, the recorded mean is drawn dashed for comparison.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pyqtgraph as pg
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QWidget

from gaitmon.analysis import evenly_chosen
from gaitmon.review.model import MAX_STRIDES_DRAWN, Analysis
from gaitmon.ui.plots import JOINTS
from gaitmon.ui.theme import Colours, pen

if TYPE_CHECKING:
    from gaitmon.normative import NormativeBands

N_POINTS = 101
NORMAL_COLOUR = "#d08000"  # the normal band's hue (amber), the report's too
NORMAL_FILL_ALPHA = 90  # of 255


def add_cycle_plot(layout: pg.GraphicsLayoutWidget, row: int, y_label: str,
                   y_range: tuple[float, float], colours: Colours) -> pg.PlotItem:
    """One joint's plot of a column of gait cycles: 0-100 % of the stride, a fixed y range,
    no mouse panning (the review's cycle plots and the Both legs tab's share this)."""
    p = layout.addPlot(row=row, col=0)
    p.hideButtons()
    p.setMenuEnabled(True)
    p.showGrid(x=True, y=True, alpha=colours.grid_alpha)
    p.setMouseEnabled(x=False, y=False)
    p.setXRange(0, 100, padding=0)
    p.setYRange(*y_range, padding=0)
    p.getAxis("left").setLabel(y_label)
    p.getAxis("left").setWidth(50)
    return p


def fit_y_range(plot: pg.PlotItem, parts: list[np.ndarray], default: tuple[float, float]) -> None:
    """The plot's y range around the finite values of ``parts`` (10 % padding, at least 0.5
    degrees), or ``default`` when there are none."""
    vals = np.concatenate(parts) if parts else np.empty(0)
    vals = vals[np.isfinite(vals)]
    if not len(vals):
        plot.setYRange(*default, padding=0)
        return
    lo, hi = float(vals.min()), float(vals.max())
    pad = 0.1 * max(hi - lo, 5.0)
    plot.setYRange(lo - pad, hi + pad, padding=0)


def normal_legend_text(bands: NormativeBands, max_chars: int = 26) -> str:
    """The legend entry of the normal band: "normal mean ± 1 SD (its name)", the name cut to
    ``max_chars`` (the plots are narrow; the tooltips give it in full)."""
    name = bands.label if len(bands.label) <= max_chars else bands.label[: max_chars - 1] + "…"
    return f"normal mean ± 1 SD ({name})"


class ReviewCyclePlots(pg.GraphicsLayoutWidget):  # type: ignore[misc]  # pyqtgraph is untyped
    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.ci.setContentsMargins(2, 2, 8, 2)
        self.pct = np.linspace(0.0, 100.0, N_POINTS)
        self.plots: list[pg.PlotItem] = []
        self.strides: list[pg.PlotCurveItem] = []
        self.mean: list[pg.PlotCurveItem] = []
        self.lower: list[pg.PlotCurveItem] = []
        self.upper: list[pg.PlotCurveItem] = []
        self.before: list[pg.PlotCurveItem] = []
        self.toe_off: list[pg.InfiniteLine] = []
        self.n_strides_drawn = 0
        faint = QColor(colours.foreground)
        faint.setAlpha(38)
        band = QColor(colours.kalman)
        band.setAlpha(60)
        before_c = QColor(colours.foreground)
        before_c.setAlpha(170)
        self.norm_lower: list[pg.PlotCurveItem] = []
        self.norm_upper: list[pg.PlotCurveItem] = []
        self.norm_mean: list[pg.PlotCurveItem] = []
        self._bands: NormativeBands | None = None
        self._analysis: Analysis | None = None
        self._tips: list[str] = []
        # the normal band: a hue of its own (not the session's, not the event lines' grey), its
        # fill opaque enough to show a band 1-2 deg wide, thin solid edges, a solid mean
        norm_c = QColor(NORMAL_COLOUR)
        norm_c.setAlpha(NORMAL_FILL_ALPHA)
        norm_edge = QColor(NORMAL_COLOUR)
        norm_edge.setAlpha(150)
        norm_line = QColor(NORMAL_COLOUR)
        self.legend: pg.LegendItem | None = None
        self.title = self.addLabel(
            "Gait cycle (included strides)", row=0, col=0, size="9pt", bold=True
        )
        for j, (key, label, yr) in enumerate(JOINTS):
            p = add_cycle_plot(self, j + 1, f"{key} (deg)", yr, colours)
            ax = p.getAxis("bottom")
            if j == len(JOINTS) - 1:
                ax.setLabel("% of stride (heel strike to heel strike)")
            tip = (
                f"{label} over the gait cycle: green line and band = mean ± SD of the included "
                "strides, grey = individual strides, dashed = mean toe off (stance %); after a "
                "reprocessing the recorded mean is drawn dashed."
            )
            p.setToolTip(tip)
            self._tips.append(tip)
            n_lo = pg.PlotCurveItem(pen=pg.mkPen(norm_edge, width=1))
            n_hi = pg.PlotCurveItem(pen=pg.mkPen(norm_edge, width=1))
            n_fill = pg.FillBetweenItem(n_lo, n_hi, brush=norm_c)
            n_mean = pg.PlotCurveItem(pen=pg.mkPen(norm_line, width=2))
            for item in (n_lo, n_hi, n_fill, n_mean):
                p.addItem(item)
            self.norm_lower.append(n_lo)
            self.norm_upper.append(n_hi)
            self.norm_mean.append(n_mean)
            strides = pg.PlotCurveItem(pen=pen(faint), connect="finite")
            lower = pg.PlotCurveItem(pen=pen(band))
            upper = pg.PlotCurveItem(pen=pen(band))
            fill = pg.FillBetweenItem(lower, upper, brush=band)
            before = pg.PlotCurveItem(pen=pg.mkPen(before_c, width=1, style=pg.QtCore.Qt.DashLine))
            mean = pg.PlotCurveItem(pen=pg.mkPen(colours.kalman, width=2))
            toe = pg.InfiniteLine(pos=60, angle=90, pen=pen(colours.event, dashed=True),
                                  label="toe off", labelOpts={
                                      "position": 0.93, "color": colours.foreground,
                                      "anchors": [(0, 0.5), (0, 0.5)]})  # fmt: skip
            toe.setVisible(False)
            for item in (strides, lower, upper, fill, before, mean, toe):
                p.addItem(item)
            self.plots.append(p)
            self.strides.append(strides)
            self.lower.append(lower)
            self.upper.append(upper)
            self.before.append(before)
            self.mean.append(mean)
            self.toe_off.append(toe)

    def set_normative(self, bands: NormativeBands | None) -> None:
        """Draw a normative mean ± SD band (``gaitmon.normative.NormativeBands``) behind the
        patient's curves; None removes it. Joints the file does not give stay empty."""
        for j in range(len(JOINTS)):
            for it in (self.norm_lower[j], self.norm_upper[j], self.norm_mean[j]):
                it.setData([], [])
            if bands is None:
                continue
            mean, sd = bands.mean_deg[:, j], bands.sd_deg[:, j]
            if not np.isfinite(mean).all():
                continue
            x = np.asarray(bands.cycle_pct, dtype=np.float64)
            self.norm_mean[j].setData(x, mean)
            if np.isfinite(sd).all():
                self.norm_lower[j].setData(x, mean - sd)
                self.norm_upper[j].setData(x, mean + sd)
        self._bands = bands
        self._fit_y()
        # the legend (top plot): the normal mean ± 1 SD, named after its source
        if self.legend is not None:
            self.legend.clear()
            self.legend.setVisible(bands is not None)
        if bands is not None:
            if self.legend is None:
                bg = QColor(self.colours.background)
                bg.setAlpha(200)  # legible over the curves
                self.legend = self.plots[0].addLegend(offset=(4, 2), labelTextSize="8pt",
                                                      brush=bg, verSpacing=-6)  # fmt: skip
            self.legend.setVisible(True)
            self.legend.addItem(self.norm_mean[0], normal_legend_text(bands))
        # the band's own name can be long: it goes in the tooltip, the title stays short
        self.title.setText("Gait cycle (included strides)" + (" · normal band" if bands
                                                                else ""))  # fmt: skip
        about = "" if bands is None else self.band_note(bands)
        self.title.setToolTip(about)
        for p, tip in zip(self.plots, self._tips, strict=True):
            p.setToolTip(tip if bands is None else f"{tip}\n\n{about}")

    @staticmethod
    def band_note(bands: NormativeBands) -> str:
        """What the normal (amber) band is, and what it cannot tell (the tooltips say both)."""
        from gaitmon.normative import CAVEAT

        return (
            f"Amber band and solid amber line: normal mean ± 1 SD, {bands.label} (source: "
            f"{bands.source or 'not given'}; licence: {bands.licence or 'not given'}).\n"
            f"Caveat: {CAVEAT}."
        )

    def clear_data(self) -> None:
        self._analysis = None
        for items in (self.strides, self.lower, self.upper, self.before, self.mean):
            for it in items:
                it.setData([], [])
        for line in self.toe_off:
            line.setVisible(False)
        self.n_strides_drawn = 0

    def set_analysis(self, a: Analysis | None, before: Analysis | None = None) -> None:
        self.clear_data()
        if a is None:
            return
        cyc = a.cycles_deg
        k = len(cyc)
        if k:
            pick = evenly_chosen(k, MAX_STRIDES_DRAWN)  # (the analysis keeps only these)
            self.n_strides_drawn = len(pick)
            x = np.tile(np.append(self.pct, np.nan), len(pick))
            for j in range(len(JOINTS)):
                y = np.concatenate([np.append(cyc[i, :, j], np.nan) for i in pick])
                self.strides[j].setData(x, y, connect="finite")
                mean, sd = a.mean_deg[:, j], a.sd_deg[:, j]
                self.mean[j].setData(self.pct, mean)
                if np.isfinite(sd).all():
                    self.lower[j].setData(self.pct, mean - sd)
                    self.upper[j].setData(self.pct, mean + sd)
                if before is not None and len(before.cycles_deg):
                    self.before[j].setData(self.pct, before.mean_deg[:, j])
        self._analysis = a
        self._fit_y()
        stance = a.stance_pct_mean
        for line in self.toe_off:
            ok = math.isfinite(stance)
            line.setVisible(ok)
            if ok:
                line.setValue(stance)
                line.setToolTip(f"mean toe off: {stance:.1f} % of the stride")

    def _fit_y(self) -> None:
        """Fit each joint's y range to the strides drawn and the normative band, if any."""
        a, bands = self._analysis, self._bands
        for j, (_key, _label, yr) in enumerate(JOINTS):
            parts = []
            if a is not None and len(a.cycles_deg):
                parts.append(a.cycles_deg[:, :, j].ravel())
            if bands is not None and np.isfinite(bands.mean_deg[:, j]).all():
                sd = np.nan_to_num(bands.sd_deg[:, j])
                parts += [bands.mean_deg[:, j] - sd, bands.mean_deg[:, j] + sd]
            fit_y_range(self.plots[j], parts, yr)
