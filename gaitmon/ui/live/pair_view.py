"""The live window's both-legs view: the overlaid plots, the two legs' link health, the live
bilateral measures and both gait panels.

It only displays. :class:`PairView` takes both legs' snapshots each tick (the window's
:mod:`.pair_part` pulls them); each leg's link is graded by the one-leg window's own logic
(:class:`gaitmon.live.health.HealthTracker`, :func:`gaitmon.live.health.link_view`), and each
leg's Gait panel is the one-leg window's :class:`~gaitmon.ui.live.status.GaitPanel`, fed that
leg's snapshot: the same stride measures, computed once, by the engine. The measured cadence
and the step times come from :class:`gaitmon.live.pair.LiveBilateral`
(``dsp.bilateral.bilateral_gait``, as ``gaitmon info`` on the recorded file).
"""

from __future__ import annotations

import math
import time

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtWidgets import (
    QGridLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QSizePolicy,
    QSplitter,
    QVBoxLayout,
    QWidget,
)

from gaitmon.dsp.bilateral import BilateralGait
from gaitmon.engine import Snapshot
from gaitmon.live.health import (
    HealthTracker,
    LinkView,
    no_data_text,
    snapshot_health,
    snapshot_link_view,
)
from gaitmon.live.pair import SIDE_NAMES, SIDES
from gaitmon.ui.live.status import GaitPanel, angles_text, show_health, value_rows
from gaitmon.ui.plots.bilateral import BilateralPlots
from gaitmon.ui.theme import Colours, side_colours

MEASURES = (
    ("cadence", "Cadence (measured)", "steps/min: 60 / the mean step time of both legs, over "
     "their last steps (measured: both legs are recorded)"),
    ("step", "Step time L · R", "s: from the other foot's heel strike to this foot's, mean of "
     "the last steps of each leg"),
    ("symmetry", "Step symmetry", "symmetry ratio L / R of the step times (1 = symmetric) and "
     "symmetry index 2|L−R|/(L+R) (docs/bilateral.md)"),
    ("double", "Double support L · R", "initial double support, % of the stride: from the "
     "leg's heel strike to the other foot's toe off"),
)  # fmt: skip


class LegStatus(QWidget):
    """One leg's header: its name in its colour, link state and health. Its link banner's text
    (``link``) goes into the window's banner above the plots, named by leg, so a link down on
    one leg does not shift that leg's column against the other's."""

    def __init__(self, side: str, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.side = side
        self.colours = colours
        self.health = HealthTracker()
        colour = side_colours(colours)[side].name()
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.setSpacing(2)
        self.title = QLabel(
            f"<b><span style='color:{colour}'>■</span> {SIDE_NAMES[side].capitalize()} leg</b>"
        )
        self.state_label = QLabel("—")
        self.health_label = QLabel("")
        self.health_label.setWordWrap(True)
        # what made this leg's angles and where their zero comes from (status bar's wording)
        self.method_label = QLabel("")
        self.method_label.setWordWrap(True)
        self.method_label.setToolTip(
            "What makes this leg's Kalman (green) angles, and where their zero comes from: a "
            "standing calibration (Zero) or estimated (no standing Zero yet)"
        )
        self.link: LinkView | None = None  # the last link view shown
        for w in (self.title, self.state_label, self.health_label, self.method_label):
            lay.addWidget(w)
        self.state_text = ""

    def reset(self) -> None:
        self.health.reset()
        self.link = None
        self.state_text = ""
        self.method_label.setText("")

    def show_link(self, snap: Snapshot, port: str) -> None:
        view = snapshot_link_view(snap, port)
        c = self.colours
        colour = {"ok": c.ok, "warn": c.warn}.get(view.grade, c.alert)
        self.state_text = view.pill
        self.state_label.setText(f"<span style='color:{colour}'>●</span> {view.pill}")
        self.state_label.setToolTip(view.tooltip or "Link state")
        self.link = view
        text = angles_text(snap)
        if self.method_label.text() != text:
            self.method_label.setText(text)
        h = snapshot_health(self.health, snap, time.monotonic())
        if h is not None:
            text = f"{h.text} · {snap.samples_total:,} samples"
            show_health(self.health_label, h, self.colours, text)


class PairView(QWidget):
    """Plots on the left; both legs' measures, link health and gait panels on the right."""

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        lay = QHBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        split = QSplitter(Qt.Orientation.Horizontal)
        lay.addWidget(split)
        self.plots = BilateralPlots(colours)
        split.addWidget(self.plots)

        side = QWidget()
        col = QVBoxLayout(side)
        col.setContentsMargins(4, 0, 0, 0)
        box = QGroupBox("Both legs")
        self.measures_box = box
        grid = QGridLayout(box)
        self.values = value_rows(grid, MEASURES, self, scale=1.3)
        col.addWidget(box)
        legs = QHBoxLayout()
        self.status: dict[str, LegStatus] = {}
        self.panels: dict[str, GaitPanel] = {}
        for s in SIDES:
            leg = QVBoxLayout()
            self.status[s] = LegStatus(s, colours)
            self.panels[s] = GaitPanel(colours)
            self.panels[s].cycles.setMinimumHeight(240)
            leg.addWidget(self.status[s])
            leg.addWidget(self.panels[s], 1)
            legs.addLayout(leg, 1)
        col.addLayout(legs, 1)
        side.setSizePolicy(QSizePolicy.Policy.Preferred, QSizePolicy.Policy.Expanding)
        split.addWidget(side)
        split.setStretchFactor(0, 3)
        split.setStretchFactor(1, 2)
        self.split = split

    def clear(self) -> None:
        self.plots.clear_data()
        for s in SIDES:
            self.status[s].reset()
            self.panels[s].clear()
        for v in self.values.values():
            v.setText("—")

    def show_links(self, snaps: dict[str, Snapshot], ports: dict[str, str]) -> None:
        for side, snap in snaps.items():
            self.status[side].show_link(snap, ports[side])

    def banner(self) -> tuple[str, str, str]:
        """(text, grade, tooltip) of the legs' link banners, one line per leg that has one
        ("" when none): the worst grade colours it."""
        lines, tips, grades = [], [], []
        for side in SIDES:
            view = self.status[side].link
            if view is not None and view.banner:
                lines.append(f"{SIDE_NAMES[side].capitalize()} leg: {view.banner}")
                tips.append(f"{SIDE_NAMES[side].capitalize()} leg: {view.tooltip}")
                grades.append(view.grade)
        grade = "alert" if "alert" in grades else "warn" if grades else "ok"
        return "<br>".join(lines), grade, "\n".join(tips)

    def pill(self) -> tuple[str, str]:
        """(text, grade) of the window's state pill: "Connected: both legs" while both legs'
        links are up and bring data, else each other leg's own state ("Left leg: No data")."""
        views = {s: self.status[s].link for s in SIDES}
        off = {s: v for s, v in views.items() if v is not None and v.state != "connected"}
        if not off:
            return "Connected: both legs", "ok"
        text = " · ".join(f"{SIDE_NAMES[s].capitalize()} leg: {v.pill}" for s, v in off.items())
        grades = {v.grade for v in off.values()}
        return text, "alert" if "alert" in grades else "warn"

    def show_panel(self, side: str, snap: Snapshot) -> None:
        """One leg's Gait panel (the slowly changing part: ~10 Hz)."""
        self.panels[side].show_snapshot(snap)

    def show_measures(self, gait: BilateralGait, stalled_s: dict[str, float] | None = None) -> None:
        """The live bilateral measures (~10 Hz); greyed, the box's title saying why, while a
        leg brings no data (``stalled_s``: each leg's ``Snapshot.stalled_s``): they are the
        figures from before."""
        off = {s: t for s, t in (stalled_s or {}).items() if t > 0}
        title = "Both legs"
        if off:
            title += " — ⚠ stale (" + ", ".join(
                f"{SIDE_NAMES[s]} leg: {no_data_text(t)}" for s, t in off.items()
            ) + ")"
        if self.measures_box.title() != title:
            self.measures_box.setTitle(title)
            for label in self.values.values():
                label.setEnabled(not off)

        def fmt(x: float, spec: str) -> str:
            return f"{x:{spec}}" if math.isfinite(x) else "—"

        v = self.values
        v["cadence"].setText(fmt(gait.cadence_steps_min, ".0f") + " steps/min"
                             if math.isfinite(gait.cadence_steps_min) else "—")  # fmt: skip
        step = gait.symmetry_of("step_s")
        v["step"].setText(f"{fmt(step.left, '.2f')} · {fmt(step.right, '.2f')} s")
        v["symmetry"].setText(
            f"SR {fmt(step.ratio, '.2f')} · SI {fmt(step.index_pct, '.0f')} %"
        )
        ds = []
        for s in SIDES:
            pct = gait.side(s).pct("initial_double_support_s")
            pct = pct[np.isfinite(pct)]
            ds.append(float(pct.mean()) if len(pct) else math.nan)
        v["double"].setText(f"{fmt(ds[0], '.0f')} · {fmt(ds[1], '.0f')} %")
