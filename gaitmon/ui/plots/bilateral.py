"""The both-legs live plots: hip, knee and ankle of the left and right legs overlaid per joint,
and a two-row foot-contact strip (left above, right below).

Overlaid rather than side by side: the question after a stroke is how the legs differ, and two
curves on one axis show it at a glance (a lower knee peak, a shorter swing, one leg's stance
overlapping the other's) with one y scale by construction; side by side, the eye has to jump
between two columns and compare heights across them. The legs walk half a cycle apart, so
their curves alternate rather than hide each other. Left is orange, right purple
(:func:`gaitmon.ui.theme.side_colours`); the chosen filter's (Kalman) joint angles only, as in
the one-leg clinical view.

Both legs are drawn against one "seconds before now" on the host's clock
(:class:`gaitmon.live.pair.LiveBilateral`). A leg's lost data breaks its lines and is shaded red
as in the one-leg view, over the joint plots with a label naming the leg, and in that leg's row
of the contact strip only; the other leg draws on. Heel strikes are faint lines in the leg's
colour (toe offs are the ends of the contact rows' stance). Built once, fed numpy arrays (the
primitives of :mod:`.traces`).
"""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from PySide6.QtGui import QColor, QPainterPath
from PySide6.QtWidgets import QWidget

from gaitmon.engine import Snapshot
from gaitmon.engine.display import (
    MAX_POINTS,
    STALE_S,
    decimate_peak,
    lost_shading,
    newest_idx,
    step_band,
    vertical_lines,
)
from gaitmon.live.pair import SIDE_NAMES, SIDES
from gaitmon.ui.plots.live import SHADING_TIP
from gaitmon.ui.plots.traces import (
    JOINTS,
    CountingPlotWidget,
    Label,
    Trace,
    TraceSet,
    style_plot,
)
from gaitmon.ui.theme import Colours, pen, side_colours

CONTACT = "contact"
CONTACT_RANGE = (0.0, 2.0)  # the left leg's row is 1..2, the right's 0..1
CONTACT_STRIP_PX = 110
SERIES = "joint_kalman_deg"


def _contact_row(side: str) -> tuple[float, float]:
    return (1.0, 2.0) if side == "L" else (0.0, 1.0)


class _Leg:
    """One leg's traces in every plot."""

    def __init__(self) -> None:
        self.angles: list[Trace] = []  # per joint
        self.lost: dict[str, Trace] = {}  # per plot
        self.settling: dict[str, Trace] = {}
        self.heel_strikes: dict[str, Trace] = {}
        self.stance: Trace | None = None
        self.lost_label: Label | None = None


class BilateralPlots(CountingPlotWidget):
    """Both legs' joint angles overlaid, above a two-row contact strip (module doc)."""

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.side_colours = side_colours(colours)
        self.window_s = 10.0
        self.sets: dict[str, TraceSet] = {}
        self.yranges: dict[str, tuple[float, float]] = {}
        self.plots: dict[str, pg.PlotItem] = {}
        self.legs = {side: _Leg() for side in SIDES}
        self.markers: dict[str, Trace] = {}
        self.ci.setContentsMargins(2, 2, 8, 2)
        self.ci.layout.setVerticalSpacing(3)
        self._build()
        self.set_window(self.window_s)

    def _build(self) -> None:
        c = self.colours
        sc = self.side_colours
        swatches = "  ".join(
            f"<span style='color:{sc[s].name()}'>■</span> {SIDE_NAMES[s]} leg" for s in SIDES
        )
        self.title = self.addLabel(
            f"Joint angles, both legs · {swatches}", row=0, col=0, size="9pt", bold=True
        )
        lost_colour = QColor(c.alert)
        lost_colour.setAlpha(70)  # the one-leg view's and the review's gap shading
        settle_colour = QColor(c.alert)
        settle_colour.setAlpha(22)
        rows: list[tuple[str, str, tuple[float, float]]] = [
            (key, f"{label} (deg)", (float(yr[0]), float(yr[1]))) for key, label, yr in JOINTS
        ]
        rows.append((CONTACT, "contact", CONTACT_RANGE))
        for r, (name, ylabel, yr) in enumerate(rows, start=1):
            p = self.addPlot(row=r, col=0, axisItems=self.axes())
            style_plot(p, c, ylabel, yr, bottom=name == CONTACT)
            ts = self.adopt(TraceSet((-self.window_s, 0.0), yr))
            p.addItem(ts)
            self.plots[name], self.sets[name], self.yranges[name] = p, ts, yr
            for side in SIDES:
                leg = self.legs[side]
                lo = _contact_row(side)[0] if name == CONTACT else yr[0]
                leg.lost[name] = ts.add(Trace(brush=lost_colour, fill_level=lo))
                leg.settling[name] = ts.add(Trace(brush=settle_colour, fill_level=lo))
            if name == CONTACT:
                for side in SIDES:
                    band = QColor(sc[side])
                    band.setAlpha(90)
                    lo = _contact_row(side)[0]
                    self.legs[side].stance = ts.add(Trace(brush=band, fill_level=lo))
            if name != CONTACT:  # the contact rows' edges are the events already
                for side in SIDES:
                    faint = QColor(sc[side])
                    faint.setAlpha(120)
                    self.legs[side].heel_strikes[name] = ts.add(Trace(pen(faint)))
            if name != CONTACT:
                j = len(self.legs["L"].angles)
                for side in SIDES:
                    tr = Trace(pen(sc[side]), series=SERIES, column=j, method=side)
                    self.legs[side].angles.append(ts.add(tr))
            self.markers[name] = ts.add(Trace(pen(c.foreground, dashed=True)))
        for side in SIDES:
            self.legs[side].lost_label = self.sets[JOINTS[0][0]].add_label(QColor(c.alert), z=5)
        for key, _label, _yr in JOINTS:
            sign = "dorsiflexion" if key == "ankle" else "flexion"
            self.plots[key].setToolTip(
                f"{key.capitalize()} angle of both legs in degrees, {sign} positive, 0 = "
                "standing pose: left orange, right purple. Faint lines in the leg's colour: its "
                f"heel strikes. {SHADING_TIP}"
            )
        self.plots[CONTACT].setToolTip(
            "Foot contact: the left leg's stance (upper row) and the right leg's (lower row), "
            "from heel strike to toe off; where both rows are shaded, both feet are on the "
            "ground (double support). Red in a row: that leg's data lost."
        )
        contact = self.plots[CONTACT]
        contact.setMaximumHeight(CONTACT_STRIP_PX)
        self.ci.layout.setRowMaximumHeight(len(JOINTS) + 1, CONTACT_STRIP_PX)
        left_axis = contact.getAxis("left")
        left_axis.setTicks([[(0.5, "R"), (1.5, "L")]])

    # -- options -----------------------------------------------------------------------------

    def set_window(self, window_s: float) -> None:
        self.window_s = float(window_s)
        for name, p in self.plots.items():
            p.setXRange(-self.window_s, 0.0, padding=0)
            self.sets[name].nominal[0] = (-self.window_s, 0.0)

    def reset_y_ranges(self) -> None:
        for name, p in self.plots.items():
            p.setYRange(*self.yranges[name], padding=0)

    def clear_data(self) -> None:
        for ts in self.sets.values():
            for tr in ts.traces:
                tr.clear()
            for label in ts.labels:
                label.hide()
            ts.commit()

    # -- what the tests look at ----------------------------------------------------------------

    def curve_path(self, side: str, joint: int) -> QPainterPath | None:
        return self.legs[side].angles[joint].path

    def curve_points(self, side: str, joint: int) -> int:
        return self.legs[side].angles[joint].n_points

    def lost_path(self, side: str, plot: str) -> QPainterPath | None:
        return self.legs[side].lost[plot].path

    def stance_path(self, side: str) -> QPainterPath | None:
        stance = self.legs[side].stance
        return None if stance is None else stance.path

    def lost_label(self, side: str) -> str:
        label = self.legs[side].lost_label
        return label.text if label is not None and label.visible else ""

    # -- the per-frame update ------------------------------------------------------------------

    def update_from(self, snaps: dict[str, Snapshot], x_now: dict[str, float]) -> None:
        """Both legs' snapshots; ``x_now[side]``: that leg's unit time at this instant (NaN:
        its newest sample stands for now)."""
        newest = math.nan
        for side, snap in snaps.items():
            self._update_leg(side, snap, x_now.get(side, math.nan))
            if side == "L":
                newest = newest_idx(snap.series)
        marks = snaps.get("L") or snaps.get("R")
        if marks is not None:
            now = x_now.get("L" if "L" in snaps else "R", math.nan)
            if not math.isfinite(now):
                t = marks.series["t_s"]
                now = float(t[-1]) if len(t) else 0.0
            mx = np.array([m[0] - now for m in marks.markers], dtype=float)
            for name, tr in self.markers.items():
                tr.set(*vertical_lines(mx, *self.yranges[name]), connect="pairs")
        for ts in self.sets.values():
            ts.commit()
        self.mark_new_data(newest)

    def _update_leg(self, side: str, snap: Snapshot, now: float) -> None:
        leg = self.legs[side]
        s = snap.series
        t = s["t_s"]
        if len(t) == 0:
            return
        stale = snap.last_data_age_s > STALE_S
        if not math.isfinite(now):
            now = float(t[-1]) + (snap.last_data_age_s if stale else 0.0)
        x_full = t - now
        x, y = decimate_peak(x_full, s[SERIES], MAX_POINTS)
        fin = np.isfinite(y)
        all_finite, any_finite = fin.all(axis=0), fin.any(axis=0)
        for j, tr in enumerate(leg.angles):
            if any_finite[j]:
                tr.set(x, y[:, j], bool(all_finite[j]))
            else:
                tr.clear()
        # while a leg's link is down its time runs on, shaded as lost up to now
        x_lost, lost = lost_shading(x_full, s["lost"], bool(stale))
        settling = s["settling"] > 0
        for name, (lo_full, hi_full) in self.yranges.items():
            lo, hi = _contact_row(side) if name == CONTACT else (lo_full, hi_full)
            for shade, xb, mask in ((leg.lost[name], x_lost, lost),
                                    (leg.settling[name], x_full, settling)):  # fmt: skip
                if mask.any():
                    shade.set(*step_band(xb, mask, hi, lo))
                else:
                    shade.clear()
            if name in leg.heel_strikes:
                hs = snap.heel_strike_t_s - now
                leg.heel_strikes[name].set(*vertical_lines(hs, lo, hi), connect="pairs")
        if leg.stance is not None:
            ph = np.nan_to_num(s["phase"], nan=0.0)
            leg.stance.set(*step_band(x_full, ph > 0, *_contact_row(side)[::-1]))
        self._label_lost(side, x_lost, lost)

    def _label_lost(self, side: str, x: np.ndarray, lost: np.ndarray) -> None:
        """Name the leg over its newest lost stretch in the top plot (the shading is red for
        either leg; the label and the contact row say whose)."""
        label = self.legs[side].lost_label
        if label is None:
            return
        rows = np.flatnonzero(lost)
        if not len(rows):
            label.hide()
            return
        before = np.flatnonzero(~lost[: rows[-1]])
        run_start = int(before[-1]) + 1 if len(before) else 0
        x0 = max(float(x[run_start]), -self.window_s)
        top = self.yranges[JOINTS[0][0]][1]
        offset = 0.0 if side == "L" else 0.12 * (top - self.yranges[JOINTS[0][0]][0])
        label.set(f"{SIDE_NAMES[side]} leg: no data", x0, top - offset, right=0.0)
