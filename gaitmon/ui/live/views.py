"""The live window's view part: the one-leg plots, the Gait and Raw sensors docks, the legend
row, the display's options (pause, time window, traces, gait phases, y ranges) and the two
views.

The **clinical** view (the default) shows the chosen filter's joint angles (hip, knee, ankle;
the green trace only) large, above a compact foot-contact strip (the gait phase and the heel
and toe sensors), with the Gait panel. The **engineering** view adds the accelerometer and
gyro-integration traces, the segment tilts and the raw-sensor dock. View ▸ Engineering view
(Ctrl+E, also on the toolbar) switches; the choice is remembered, as are the window, the traces
and the phases.
"""

from __future__ import annotations

import dataclasses

from PySide6.QtCore import QByteArray, QObject, Qt, Signal
from PySide6.QtGui import QAction
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDockWidget,
    QHBoxLayout,
    QLabel,
    QMainWindow,
    QSizePolicy,
    QWidget,
)

from gaitmon.dsp.gait import PHASE_NAMES
from gaitmon.engine import Engine, Snapshot
from gaitmon.engine.display import DisplayFeed, DisplayFrame, DisplayRequest, prepare_display
from gaitmon.review.settings import LiveKey
from gaitmon.ui.actions import guarded
from gaitmon.ui.live.actions import METHOD_COLOURS, WINDOWS_S
from gaitmon.ui.live.bar import FittingLabel
from gaitmon.ui.live.context import LiveContext
from gaitmon.ui.live.status import GaitPanel, banner_style
from gaitmon.ui.plots import METHOD_LABELS, LivePlots, RawPlots
from gaitmon.ui.theme import Colours

GAIT_PANEL_EVERY = 3  # ticks between gait-panel updates


class FrameSignal(QObject):
    """Posts "a frame is ready" from the engine thread to the GUI thread (queued)."""

    ready = Signal()


def _legend_box(text: str, colour: str, checkable: bool) -> QWidget:
    if checkable:
        w: QWidget = QCheckBox(text)
        w.setStyleSheet(f"QCheckBox {{ color: {colour}; font-weight: 600; }}")
    else:
        w = QLabel(f"<span style='color:{colour}'>■</span> {text}")
    return w


class ViewPart:
    """Owns the one-leg plots (``live``, ``raw``), the gait panel, both docks, the legend row,
    the pause banner and the window combo; slots of the View menu."""

    def __init__(self, ctx: LiveContext, window: QMainWindow, actions: dict[str, QAction]) -> None:
        self.ctx = ctx
        self.window = window
        self.actions = actions
        self.window_actions = {w: actions[f"window_{w:g}"] for w in WINDOWS_S}
        self.method_actions = {key: actions[f"method_{key}"] for key, _ in METHOD_COLOURS}
        self._ticks = 0
        # frames prepared on the engine thread (attach); None: none come, the tick prepares
        self.feed: DisplayFeed | None = None
        self._feed_engine: Engine | None = None
        self.frame_signal = FrameSignal()
        self.last_frame: DisplayFrame | None = None  # the frame drawn last (tests look at it)
        self._docks_shown = (True, False)  # (gait, raw) while both legs hide them
        self._legend_shown: list[QWidget] = []
        # the one-leg layout (QMainWindow.saveState) as it was when both legs took its place:
        # what the window remembers, not the both-legs view's hidden docks (issue 25)
        self._one_leg_state: QByteArray | None = None
        c = ctx.colours
        self.window_combo = QComboBox()
        for w in WINDOWS_S:
            self.window_combo.addItem(f"{w:g} s", w)
        self.window_combo.setToolTip("Time window shown (1 / 2 / 3)")
        self.window_combo.currentIndexChanged.connect(self._window_combo_changed)

        self.legend = QHBoxLayout()
        bar = self.legend
        bar.setSpacing(12)
        self.method_boxes: dict[str, QCheckBox] = {}
        for key, colour in (("acc", c.acc), ("kalman", c.kalman), ("gyro", c.gyro)):
            box = _legend_box(METHOD_LABELS[key], colour.name(), True)
            assert isinstance(box, QCheckBox)
            box.setToolTip(f"Show or hide the {METHOD_LABELS[key].lower()} traces")
            box.toggled.connect(lambda on, k=key: self.set_method(k, on))
            self.method_boxes[key] = box
            bar.addWidget(box)
        bar.addSpacing(16)
        bar.addWidget(_legend_box("heel", c.heel.name(), False))
        bar.addWidget(_legend_box("toe", c.toe.name(), False))
        self.phase_legend = FittingLabel()  # narrow: shorter names, never a cut one
        bar.addWidget(self.phase_legend)
        self.phase_combo = QComboBox()
        self.phase_combo.addItem("stance / swing", False)
        self.phase_combo.addItem("4 sub-phases", True)
        self.phase_combo.setToolTip("How the gait phase is shaded on the FSR plot")
        self.phase_combo.currentIndexChanged.connect(self._phase_combo_changed)
        bar.addWidget(self.phase_combo)
        events = FittingLabel(
            "Gait events from the foot sensors, drawn on the joint and FSR plots: heel strike "
            "solid, toe off dashed"
        )
        events.set_texts("┃ heel strike  ┆ toe off", "┃ HS ┆ TO")
        bar.addWidget(events)
        bar.addStretch(1)
        # a banner row of its own: in the legend's row it took the legend's width (clipping it)
        # and widened the central area, squeezing the gait dock (kept so after a restart)
        self.pause_label = QLabel("  ❚❚ Display paused: acquisition and recording continue  ")
        self.pause_label.setStyleSheet(banner_style(c, "warn"))
        self.pause_label.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.pause_label.setVisible(False)

        self.live = LivePlots(c)
        self.live.setToolTip("")
        self.gait_panel = GaitPanel(c)
        self.gait_dock = QDockWidget("Gait", window)
        self.gait_dock.setObjectName("dock-gait")
        self.gait_dock.setWidget(self.gait_panel)
        self.raw = RawPlots(c)  # raw sensors (hidden by default)
        self.raw.setMinimumHeight(160)
        self.raw_dock = QDockWidget("Raw sensors", window)
        self.raw_dock.setObjectName("dock-raw")
        self.raw_dock.setWidget(self.raw)

    def report_exception(self, where: str, exc: BaseException) -> None:
        self.ctx.report_exception(where, exc)

    def add_docks(self) -> None:
        win = self.window
        win.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.gait_dock)
        win.addDockWidget(Qt.DockWidgetArea.BottomDockWidgetArea, self.raw_dock)
        self.raw_dock.hide()
        win.resize(1400, 860)
        # the live plots get the room; the gait panel a column (a saved layout overrides this)
        win.resizeDocks([self.gait_dock], [370], Qt.Orientation.Horizontal)
        win.resizeDocks([self.raw_dock], [260], Qt.Orientation.Vertical)

    def restore(self) -> None:
        """The window, traces and phases remembered (before the layout is restored)."""
        p = self.ctx.prefs
        window = p.get(LiveKey.WINDOW_S)
        if window not in WINDOWS_S:
            window = 10.0
        self.set_window(window)
        for key in ("acc", "kalman", "gyro"):
            self.set_method(key, p.get(LiveKey.shown(key)))
        self.set_four_phases(p.get(LiveKey.FOUR_PHASES))
        self.live.set_fsr_threshold(self.ctx.config.fsr_threshold)

    def restore_view(self) -> None:
        """The view remembered (after the layout: the clinical view hides the raw dock)."""
        self._apply_view(self.ctx.prefs.get(LiveKey.ENGINEERING))

    @property
    def paused(self) -> bool:
        return self.actions["pause"].isChecked()

    @property
    def window_s(self) -> float:
        return self.live.window_s

    @property
    def engineering(self) -> bool:
        return self.live.engineering

    def _redraw_paused(self) -> None:
        if self.paused and self.ctx.last_snapshot is not None:
            self.live.update_from(self.ctx.last_snapshot)

    @guarded
    def set_paused(self, paused: bool) -> None:
        act = self.actions["pause"]
        if act.isChecked() != paused:
            act.setChecked(paused)
        self.pause_label.setVisible(paused)
        act.setText("Resume" if paused else "Pause")

    @guarded
    def set_window(self, window_s: float) -> None:
        window_s = float(window_s)
        self.live.set_window(window_s)
        self.raw.set_window(window_s)
        a = self.window_actions.get(window_s)
        if a is not None and not a.isChecked():
            a.setChecked(True)
        idx = self.window_combo.findData(window_s)
        if idx >= 0 and self.window_combo.currentIndex() != idx:
            self.window_combo.setCurrentIndex(idx)
        self.ctx.prefs.set(LiveKey.WINDOW_S, window_s)
        self._redraw_paused()

    def _window_combo_changed(self, index: int) -> None:
        w = self.window_combo.itemData(index)
        if w is not None and float(w) != self.window_s:
            self.set_window(float(w))

    @guarded
    def set_method(self, method: str, on: bool) -> None:
        on = bool(on)
        self.live.set_method(method, on)
        box = self.method_boxes[method]
        if box.isChecked() != on:
            box.setChecked(on)
        a = self.method_actions[method]
        if a.isChecked() != on:
            a.setChecked(on)
        self.ctx.prefs.set(LiveKey.shown(method), on)
        if on:
            self._redraw_paused()

    @guarded
    def set_four_phases(self, four: bool) -> None:
        four = bool(four)
        self.live.set_four_phases(four)
        act = self.actions["four_phases"]
        if act.isChecked() != four:
            act.setChecked(four)
        idx = 1 if four else 0
        if self.phase_combo.currentIndex() != idx:
            self.phase_combo.setCurrentIndex(idx)
        c = self.ctx.colours
        if four:
            cols = [col.name() for col in c.phases]
            texts = [" ".join(f"<span style='color:{col}'>█</span> {name}"
                              for col, name in zip(cols, names, strict=True))
                     for names in (PHASE_NAMES[1:], ("loading", "flat", "push"))]  # fmt: skip
            texts.append(" ".join(f"<span style='color:{col}'>█</span>" for col in cols))
        else:
            texts = [f"<span style='color:{c.stance.name()}'>█</span> stance"]
        self.phase_legend.set_texts(*texts)
        self.ctx.prefs.set(LiveKey.FOUR_PHASES, four)

    def _phase_combo_changed(self, index: int) -> None:
        self.set_four_phases(bool(self.phase_combo.itemData(index)))

    @guarded
    def reset_y_ranges(self) -> None:
        self.live.reset_y_ranges()

    @guarded
    def set_engineering_view(self, on: bool) -> None:
        """View ▸ Engineering view: also the raw-sensor dock comes and goes with it."""
        self._apply_view(bool(on))
        self.raw_dock.setVisible(bool(on))

    def _apply_view(self, on: bool) -> None:
        """The view without touching the raw dock (a restored layout decides it)."""
        self.live.set_engineering(on)
        act = self.actions["engineering"]
        if act.isChecked() != on:
            act.setChecked(on)
        # which traces to draw is an engineering choice: the clinical view draws the filter's
        for box in self.method_boxes.values():
            box.setVisible(on)
        for a in self.method_actions.values():
            a.setEnabled(on)
        if not on:
            self.raw_dock.setVisible(False)
        self.ctx.prefs.set(LiveKey.ENGINEERING, on)
        self._redraw_paused()

    def set_shown(self, on: bool) -> None:
        """The one-leg plots, docks and legend row hidden while both legs are shown (the legend
        says nothing about that view), and back as they were."""
        if not on:
            if self._one_leg_state is None:
                self._one_leg_state = self.window.saveState()
            self._docks_shown = (self.gait_dock.isVisible(), self.raw_dock.isVisible())
            self.gait_dock.setVisible(False)
            self.raw_dock.setVisible(False)
        else:
            self._one_leg_state = None
            gait, raw = self._docks_shown
            self.gait_dock.setVisible(gait)
            self.raw_dock.setVisible(raw)
        items = (self.legend.itemAt(k) for k in range(self.legend.count()))
        widgets = [w for it in items if it is not None and (w := it.widget()) is not None]
        if not on:
            self._legend_shown = [w for w in widgets if w.isVisibleTo(self.window)]
            for w in widgets:
                w.setVisible(False)
        else:
            for w in self._legend_shown:
                w.setVisible(True)
            self._legend_shown = []
        self.live.setVisible(on)

    def layout_state(self) -> QByteArray:
        """The window layout to remember (LiveKey.STATE): the one-leg window's docks and
        toolbars, as left before both legs were shown if they are shown now. The both-legs
        view hides the one-leg docks; remembering that hid the Gait panel of the next one-leg
        window (View ▸ Gait unticked)."""
        if self._one_leg_state is not None:
            return self._one_leg_state
        return self.window.saveState()

    def clear_data(self) -> None:
        """A new unit: the gait panel and the plots start empty."""
        self.gait_panel.clear()
        self.live.clear_data()
        self.raw.clear_data()

    def request(self) -> DisplayRequest | None:
        """What the engine thread prepares for this view (None while paused: nothing)."""
        if self.paused:
            return None
        req = self.live.request()
        if self.raw_dock.isVisible():
            req = dataclasses.replace(req, raw=True)
        return req

    def attach(self, engine: Engine, refresh_hz: float) -> None:
        """Have ``engine``'s thread prepare this view's frames right after its blocks (a
        ``DisplayFeed``); ``frame_signal.ready`` says one is ready."""
        self.detach()
        feed = DisplayFeed(engine.snapshot, self.frame_signal.ready.emit, refresh_hz)
        feed.request = self.request()
        engine.add_listener(feed)
        self.feed, self._feed_engine = feed, engine

    def detach(self) -> None:
        if self.feed is not None and self._feed_engine is not None:
            self.feed.request = None
            self._feed_engine.remove_listener(self.feed)
        self.feed = self._feed_engine = None

    def show(self, snap: Snapshot) -> None:
        """One leg's snapshot prepared here and drawn (when no frame comes from the engine)."""
        req = self.request() or self.live.request()
        self.show_frame(prepare_display(snap, req))

    def show_frame(self, frame: DisplayFrame) -> None:
        """One leg's prepared frame drawn (each frame the display is not paused)."""
        snap = frame.snap
        self.last_frame = frame
        if self.feed is not None:  # the view as it is now, for the next frame
            self.feed.request = self.request()
        self.live.set_angle_method(snap.angle_method)
        self.live.show_frame(frame)
        # paint now, not after the rest of this tick and whatever else the event loop holds:
        # the newest samples reach the screen a few ms sooner (the gait panel and the raw
        # plots below do not hold them up). Painting the whole scene instead (not layered),
        # the scene schedules its own repaint of the changed items: a second one would be
        # redundant.
        if self.live.layered:
            self.live.viewport().repaint()
        self._ticks += 1
        # the gait panel changes slowly: 10 Hz is plenty to read and saves a third of its cost
        if self.gait_dock.isVisible() and self._ticks % GAIT_PANEL_EVERY == 0:
            self.gait_panel.show_snapshot(snap, frame.cycle_mean_sd)
        if self.raw_dock.isVisible():
            self.raw.show_frame(frame)

    def set_colours(self, colours: Colours) -> LivePlots:
        """A theme change: curves are created once per theme, so new plot widgets in the new
        shades, set up as the old ones were; returns the old live plots (the window swaps them
        in its layout)."""
        old_live, old_raw = self.live, self.raw
        self.live = LivePlots(colours)
        self.gait_panel.set_colours(colours)
        self.raw = RawPlots(colours)
        self.raw_dock.setWidget(self.raw)
        old_raw.deleteLater()
        self.set_window(old_live.window_s)
        for key, on in old_live.methods_on.items():
            self.live.set_method(key, on)
        self.set_four_phases(old_live.four_phases)
        self.live.set_fsr_threshold(self.ctx.config.fsr_threshold)
        self.live.set_angle_method(old_live.angle_method)
        self.live.set_engineering(old_live.engineering)
        return old_live
