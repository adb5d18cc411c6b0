"""The Both legs tab's gait cycles: each leg's cycle-normalised mean ± SD of the hip, knee and
ankle, left and right overlaid per joint, and each leg's mean toe off.

Overlaid, as in the live two-leg view (:mod:`gaitmon.ui.plots.bilateral`): how the legs differ
(a lower knee peak, an earlier toe off) reads at a glance on one y scale. Left is orange, right
purple (:func:`gaitmon.ui.theme.side_colours`, the report's too); the title is the legend. The
curves are :class:`gaitmon.review.both_legs.SideCycles`: the one-leg review's and the report's
means (``gaitmon.analysis.cycle_stats`` over each leg's included strides), never recomputed here.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QWidget

from gaitmon.io.session.parts import SIDE_NAMES, SIDES
from gaitmon.review.both_legs import N_POINTS, SideCycles
from gaitmon.ui.plots import JOINTS
from gaitmon.ui.review.cycles import add_cycle_plot, fit_y_range
from gaitmon.ui.theme import Colours, side_colours

TITLE = "Gait cycle, both legs: mean ± SD"


class _SideItems:
    """One leg's items in each joint's plot."""

    def __init__(self) -> None:
        self.mean: list[pg.PlotCurveItem] = []
        self.lower: list[pg.PlotCurveItem] = []
        self.upper: list[pg.PlotCurveItem] = []
        self.toe_off: list[pg.InfiniteLine] = []


class BothLegsCycles(pg.GraphicsLayoutWidget):  # type: ignore[misc]  # pyqtgraph is untyped
    """Left and right mean cycles overlaid per joint (module doc); :meth:`set_cycles` draws."""

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.side_colours = side_colours(colours)
        self.ci.setContentsMargins(2, 2, 8, 2)
        self.pct = np.linspace(0.0, 100.0, N_POINTS)
        self.cycles: dict[str, SideCycles] = {}
        self.plots: list[pg.PlotItem] = []
        self.sides = {side: _SideItems() for side in SIDES}
        self.title = self.addLabel(TITLE, row=0, col=0, size="9pt")
        for j, (key, label, yr) in enumerate(JOINTS):
            p = add_cycle_plot(self, j + 1, f"{key} (°)", yr, colours)
            if j == len(JOINTS) - 1:
                p.getAxis("bottom").setLabel("% of each leg's stride")
            p.setToolTip(
                f"{label} over the gait cycle, both legs: each leg's mean (line) ± SD (band) "
                "over its included strides, 0 % and 100 % its own heel strikes; dashed: its "
                "mean toe off. The one-leg review's and the report's curves."
            )
            for side in SIDES:
                c = self.side_colours[side]
                band = QColor(c)
                band.setAlpha(45)
                lower = pg.PlotCurveItem(pen=pg.mkPen(band, width=1))
                upper = pg.PlotCurveItem(pen=pg.mkPen(band, width=1))
                fill = pg.FillBetweenItem(lower, upper, brush=band)
                mean = pg.PlotCurveItem(pen=pg.mkPen(c, width=2))
                toe = pg.InfiniteLine(pos=60, angle=90,
                                      pen=pg.mkPen(c, width=1, style=Qt.PenStyle.DashLine))
                toe.setVisible(False)
                for item in (lower, upper, fill, mean, toe):
                    p.addItem(item)
                items = self.sides[side]
                items.lower.append(lower)
                items.upper.append(upper)
                items.mean.append(mean)
                items.toe_off.append(toe)
            self.plots.append(p)
        self._set_title()

    def legend_entries(self) -> list[tuple[str, str]]:
        """(colour #rrggbb, text) of each leg drawn, as the title's legend shows them."""
        out = []
        for side in SIDES:
            cyc = self.cycles.get(side)
            if cyc is not None and cyc.n_strides:
                out.append((self.side_colours[side].name(),
                            f"{SIDE_NAMES[side]} leg, {cyc.n_strides} strides"))
        return out

    def _set_title(self) -> None:
        legend = " &nbsp; ".join(f"<span style='color:{c}'>━━</span>&nbsp;{html.escape(t)}"
                                 for c, t in self.legend_entries())  # fmt: skip
        self.title.setText(f"<b>{TITLE}</b>" + (f"<br>{legend}" if legend else ""))
        # never narrower than the title and its legend: a layout wider than the view is cut
        self.setMinimumWidth(max(240, math.ceil(self.title.item.boundingRect().width()) + 16))

    def clear_data(self) -> None:
        self.cycles = {}
        for items in self.sides.values():
            for curves in (items.mean, items.lower, items.upper):
                for curve in curves:
                    curve.setData([], [])
            for line in items.toe_off:
                line.setVisible(False)
        self._set_title()

    def set_cycles(self, cycles: Mapping[str, SideCycles]) -> None:
        """Draw each leg's mean ± SD and toe off (a leg without strides draws nothing)."""
        self.clear_data()
        self.cycles = dict(cycles)
        for side, cyc in self.cycles.items():
            if side not in self.sides or not cyc.n_strides:
                continue
            items = self.sides[side]
            band = bool(np.isfinite(cyc.sd_deg).all())
            for j in range(len(JOINTS)):
                mean = cyc.mean_deg[:, j]
                items.mean[j].setData(self.pct, mean)
                if band:
                    items.lower[j].setData(self.pct, mean - cyc.sd_deg[:, j])
                    items.upper[j].setData(self.pct, mean + cyc.sd_deg[:, j])
                toe = items.toe_off[j]
                toe.setVisible(math.isfinite(cyc.toe_off_pct))
                if toe.isVisible():
                    toe.setValue(cyc.toe_off_pct)
                    toe.setToolTip(f"{SIDE_NAMES[side]} leg's mean toe off: "
                                   f"{cyc.toe_off_pct:.1f} % of its stride")  # fmt: skip
        self._set_title()
        self._fit_y()

    def mean_curve(self, side: str, joint: int) -> np.ndarray:
        """The mean curve drawn for ``side`` 's ``joint`` (empty when none): for the tests."""
        y = self.sides[side].mean[joint].getData()[1]
        return np.empty(0) if y is None else np.asarray(y)

    def _fit_y(self) -> None:
        for j, (_key, _label, yr) in enumerate(JOINTS):
            parts = []
            for cyc in self.cycles.values():
                if cyc.n_strides:
                    sd = np.nan_to_num(cyc.sd_deg[:, j])
                    parts += [cyc.mean_deg[:, j] - sd, cyc.mean_deg[:, j] + sd]
            fit_y_range(self.plots[j], parts, yr)
