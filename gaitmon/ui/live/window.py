"""The live monitor's window: it builds its parts, lays them out and wires them together.

The window owns no data path. Acquisition, processing and recording run in the engine's
threads; a QTimer (~30 Hz) pulls one `Snapshot` and hands it to the parts that show it. The
window is composed of parts (has-a), each owning its widgets and slots and receiving the
shared :class:`~gaitmon.ui.live.context.LiveContext` by constructor:

* :class:`~.device.DevicePart`         -- the Connection toolbar, one unit's connect / zero,
  the simulator's menu;
* :class:`~.recording.RecordingPart`   -- Record / Stop, the session dialog, markers (one unit
  or both legs);
* :class:`~.processing.ProcessingPart` -- Settings… and the tilt filter, applied live;
* :class:`~.lsl.LslPart`               -- Stream to LSL;
* :class:`~.views.ViewPart`            -- the one-leg plots, the Gait and Raw docks, the
  display's options and the clinical / engineering views;
* :class:`~.pair_part.PairPart`        -- both legs: connect, their view, zero, link cuts;
* :class:`~.status.StatusView`         -- the status bar and the banners;
* :class:`~.guide.GuideBar`            -- the guided start.

The actions are rows of a table (:mod:`.actions`) whose slots the window finds on itself or a
part. Every slot is wrapped so that an unexpected exception becomes one line in the status bar
(and a traceback in the log file), never a crash.
"""

from __future__ import annotations

import functools
import logging
import time
from collections.abc import Callable
from typing import cast

from PySide6.QtCore import QEvent, QSettings, Qt, QTimer
from PySide6.QtGui import QActionGroup, QCloseEvent
from PySide6.QtWidgets import (
    QComboBox,
    QLabel,
    QLineEdit,
    QMainWindow,
    QMessageBox,
    QToolBar,
    QToolButton,
    QVBoxLayout,
    QWidget,
)

from gaitmon import __version__
from gaitmon.engine import Engine, Mode, Snapshot
from gaitmon.engine.live_gait import RecordingStart
from gaitmon.io.sim.bilateral import BilateralConfig
from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import Connection
from gaitmon.live.pair import LiveBilateral, PairConnection, PairSource
from gaitmon.review.settings import LiveKey
from gaitmon.ui.actions import guarded
from gaitmon.ui.dialogs import shortcuts_dialog
from gaitmon.ui.live.actions import (
    SHORTCUTS,
    SIMULATOR,
    VIEW,
    build_actions,
    build_menus,
    window_actions,
)
from gaitmon.ui.live.bar import MessageBar
from gaitmon.ui.live.context import LiveContext
from gaitmon.ui.live.device import DevicePart
from gaitmon.ui.live.guide import GuideBar, GuideState
from gaitmon.ui.live.jobs import DeviceJobs
from gaitmon.ui.live.lsl import LslPart
from gaitmon.ui.live.pair_part import PairPart
from gaitmon.ui.live.prefs import Prefs
from gaitmon.ui.live.processing import ProcessingPart
from gaitmon.ui.live.recording import RecordingPart
from gaitmon.ui.live.status import GaitPanel, StatusView
from gaitmon.ui.live.views import ViewPart
from gaitmon.ui.plots import LivePlots
from gaitmon.ui.theme import Colours, configure_pyqtgraph, current_colours

log = logging.getLogger("gaitmon.ui")

REFRESH_HZ = 30.0
# no frame from the engine thread for this long: the tick draws (no data comes)
FRAME_LATE_S = 2.5 / REFRESH_HZ
PART_TYPES = (DevicePart, RecordingPart, ProcessingPart, LslPart, ViewPart, PairPart)


class MainWindow(QMainWindow):
    """The live monitor. ``settings`` is injected so tests can isolate it; ``sim``: the
    simulated device's settings (default: SimConfig()); ``pair_sim``: the simulated pair's
    (both legs, :mod:`.pair_part`); ``pair``: connect both legs to it at once.
    ``confirm_close`` asks before closing on a recording; ``confirm_unzeroed`` (None: as
    ``confirm_close``) asks before recording a leg with no standing Zero."""

    def __init__(
        self,
        settings: QSettings,
        *,
        sim: SimConfig | None = None,
        autoconnect: str | None = None,
        mode: Mode | str | None = None,
        confirm_close: bool = True,
        confirm_unzeroed: bool | None = None,
        pair_sim: BilateralConfig | None = None,
        pair: PairSource | None = None,
    ) -> None:
        super().__init__()
        self.confirm_close = confirm_close
        colours = current_colours()
        configure_pyqtgraph(colours)
        self.setWindowTitle("gaitmon — live monitor")
        self.setDockNestingEnabled(True)
        self.setStatusBar(MessageBar())  # a long message: its path elided, not cut
        self.status = StatusView(self.statusBar(), colours)
        self.ctx = ctx = LiveContext(
            Prefs(settings), colours, self.statusBar(), self.status, DeviceJobs(self)
        )
        ctx.controls_changed = self._update_controls
        self.prefs, self.jobs, self.errors = ctx.prefs, ctx.jobs, ctx.errors

        specs = window_actions()  # the tilt filters registered now
        acts = self._actions = build_actions(self, self._slot, specs)
        self.act_connect, self.act_refresh = acts["connect"], acts["refresh"]
        self.act_zero, self.act_record = acts["zero"], acts["record"]
        self.act_marker, self.act_pause = acts["marker"], acts["pause"]
        self.act_settings, self.act_reset_y = acts["settings"], acts["reset_y"]
        self.act_cut, self.act_restore = acts["cut"], acts["restore"]
        self.act_help, self.act_about, self.act_quit = acts["help"], acts["about"], acts["quit"]
        self.act_four_phases, self.act_engineering = acts["four_phases"], acts["engineering"]
        self.act_guide, self.act_lsl = acts["guide"], acts["lsl"]
        self.act_lsl_patient = acts["lsl_patient_id"]
        menus = build_menus(self, acts, specs)
        self.sim_menu = menus[SIMULATOR]

        self.view_part = view = ViewPart(ctx, self, acts)
        self.recording_part = RecordingPart(ctx, self, acts)
        self.recording_part.confirm_unzeroed = (
            confirm_close if confirm_unzeroed is None else confirm_unzeroed
        )
        self.processing_part = ProcessingPart(ctx, self, acts, view)
        self.lsl_part = LslPart(ctx, acts)
        self.device_part = device = DevicePart(
            ctx, self, acts, self.sim_menu, sim=sim,
            started=self._started, stopping=self.timer_stop, stopped=self.lsl_part.stop,
        )  # fmt: skip
        self.pair_part = PairPart(
            ctx, self, acts, pair_sim=pair_sim, mode=lambda: device.mode, view=view,
            recording=self.recording_part, started=self._started, stopping=self.timer_stop,
            show_guide=self._show_guide_state,
        )  # fmt: skip
        for spec in specs:  # every row's slot exists (found now, not when first triggered)
            self._slot(spec.slot)
        self.window_group = QActionGroup(self)
        for a in view.window_actions.values():
            self.window_group.addAction(a)
        self._alias_part_widgets()

        self._build_toolbars()
        self._build_central()
        view.add_docks()
        menus[VIEW].addSeparator()
        menus[VIEW].addAction(view.gait_dock.toggleViewAction())
        menus[VIEW].addAction(view.raw_dock.toggleViewAction())
        self._restore_prefs(mode)
        self._update_controls()

        self.timer = QTimer(self)
        self.timer.setInterval(round(1000 / REFRESH_HZ))
        self.timer.setTimerType(Qt.TimerType.PreciseTimer)
        self.timer.timeout.connect(self._tick)
        view.frame_signal.ready.connect(self._show_frame)
        self._frame_shown_s = 0.0  # when the last frame from the engine thread was shown
        if autoconnect is not None:
            QTimer.singleShot(0, functools.partial(device.connect_device, autoconnect))
        elif pair is not None:
            QTimer.singleShot(0, functools.partial(self.pair_part.connect_pair, pair))

    def _slot(self, name: str) -> Callable[..., object]:
        """The slot an action row names: the window's own, else the first part's that has it."""
        for owner in (self, self.device_part, self.recording_part, self.processing_part,
                      self.lsl_part, self.view_part, self.pair_part):  # fmt: skip
            fn = getattr(owner, name, None)
            if callable(fn):
                return cast("Callable[..., object]", fn)
        raise AttributeError(f"no live window slot {name!r}")

    def _alias_part_widgets(self) -> None:
        """The parts' widgets by the names the window has always had (tests, tools)."""
        d, r, v = self.device_part, self.recording_part, self.view_part
        self.port_combo: QComboBox = d.port_combo
        self.mode_combo: QComboBox = d.mode_combo
        self.sim_fsr_actions = d.sim_fsr_actions
        self.marker_edit: QLineEdit = r.marker_edit
        self.tilt_actions = self.processing_part.tilt_actions
        self.window_actions = v.window_actions
        self.method_actions = v.method_actions
        self.method_boxes = v.method_boxes
        self.window_combo, self.phase_combo = v.window_combo, v.phase_combo
        self.phase_legend, self.pause_label = v.phase_legend, v.pause_label
        self.gait_panel, self.gait_dock, self.raw_dock = v.gait_panel, v.gait_dock, v.raw_dock
        self.pair_model: LiveBilateral = self.pair_part.model

    # -- the shared state, read-only, by the names the window has always had -------------------

    @property
    def conn(self) -> Connection | None:
        return self.ctx.conn

    @property
    def pair(self) -> PairConnection | None:
        return self.ctx.pair

    @property
    def engine(self) -> Engine | None:
        return self.ctx.engine

    @property
    def colours(self) -> Colours:
        return self.ctx.colours

    @property
    def last_snapshot(self) -> Snapshot | None:
        return self.ctx.last_snapshot

    @property
    def recording(self) -> bool:
        return self.ctx.recording

    @property
    def saving(self) -> bool:
        """A stopped recording's file is still being finished."""
        return self.ctx.saving

    @property
    def live(self) -> LivePlots:
        return self.view_part.live  # (a new one after a theme change)

    def report_exception(self, where: str, exc: BaseException) -> None:
        self.ctx.report_exception(where, exc)

    def notify(self, text: str, timeout_ms: int = 10_000) -> None:
        self.ctx.notify(text, timeout_ms)

    # ------------------------------------------------------------------------------------
    # construction
    # ------------------------------------------------------------------------------------

    def _build_toolbars(self) -> None:
        self.addToolBar(self.device_part.build_toolbar())
        tb2 = QToolBar("Session", self)
        tb2.setObjectName("toolbar-session")
        self.addToolBar(tb2)
        tb2.addAction(self._actions["zero"])
        self.record_button = QToolButton()
        self.record_button.setDefaultAction(self._actions["record"])
        self.record_button.setMinimumWidth(70)
        tb2.addWidget(self.record_button)
        tb2.addSeparator()
        tb2.addWidget(self.recording_part.marker_edit)
        tb2.addAction(self._actions["marker"])
        tb2.addSeparator()
        tb2.addAction(self._actions["pause"])
        tb2.addWidget(QLabel("  Window "))
        tb2.addWidget(self.view_part.window_combo)
        tb2.addSeparator()
        tb2.addAction(self._actions["engineering"])  # a toggle button: the engineering view

    def _build_central(self) -> None:
        central = QWidget()
        lay = QVBoxLayout(central)
        lay.setContentsMargins(4, 2, 4, 2)
        lay.setSpacing(2)
        view, acts = self.view_part, self._actions
        lay.addWidget(self.status.link_banner)
        lay.addWidget(self.status.record_banner)
        lay.addWidget(view.pause_label)
        lay.addWidget(self.status.fsr_banner)
        self.guide = GuideBar(self.colours, (acts["connect"], acts["zero"], acts["record"]))
        lay.addWidget(self.guide)
        lay.addLayout(view.legend)
        lay.addWidget(view.live, 1)
        self.setCentralWidget(central)
        self._central_layout = lay

    def _restore_prefs(self, mode: Mode | str | None) -> None:
        p = self.ctx.prefs
        self.device_part.restore(mode)
        self.view_part.restore()
        self.processing_part.show_tilt_method()
        geo = p.get(LiveKey.GEOMETRY)
        self.geometry_restored = bool(geo is not None and self.restoreGeometry(geo))
        state = p.get(LiveKey.STATE)
        self.state_restored = bool(state is not None and self.restoreState(state))
        self.view_part.restore_view()  # after the layout: the clinical view hides the raw dock
        self.lsl_part.restore()

    def _update_controls(self) -> None:
        # a frame whose snapshot was taken before this (recording started, say) shows a state
        # the window has left: its plots are drawn, its status is not (_show_frame)
        self._controls_changed_s = time.monotonic()
        self.device_part.update_controls()
        self.recording_part.update_controls()
        self.pair_part.update_controls()
        if hasattr(self, "guide"):
            self._show_guide_state()

    def _show_guide_state(self, zeroed: bool | None = None, zero_from: str | None = None) -> None:
        """Feed the step bar; ``zeroed`` and ``zero_from`` (where the angles' zero comes from)
        from the snapshots (None: keep the last one seen while connected)."""
        ctx, shown = self.ctx, self.guide.state
        source = shown.zero_source if zero_from is None else zero_from
        if ctx.pair is not None:
            # simulated=False: the pair cannot stand still on request, so no menu hint for it
            state = GuideState(connected=True, connecting=False,
                               zeroed=bool(shown.zeroed if zeroed is None else zeroed),
                               recording=ctx.recording, simulated=False,
                               zero_source=source)  # fmt: skip
        else:
            conn = ctx.conn
            if zeroed is None:
                zeroed = conn is not None and shown.connected and shown.zeroed
            state = GuideState(
                connected=conn is not None,
                connecting=ctx.connecting,
                zeroed=bool(zeroed) and conn is not None,
                recording=ctx.recording,
                simulated=conn is not None and conn.simulated,
                zero_source=source if conn is not None else "",
            )
        self.guide.show_state(state)

    # ------------------------------------------------------------------------------------
    # what the parts hand back: connected, going, one unit or both legs
    # ------------------------------------------------------------------------------------

    def _started(self) -> None:
        """A unit (or both legs) connected: the display starts; LSL streams if it is on."""
        if self.ctx.conn is not None:
            self.view_part.clear_data()
            self.view_part.attach(self.ctx.conn.engine, REFRESH_HZ)
        self._watch_recordings()
        self._update_controls()
        self.timer.start()
        self._tick()
        if self.ctx.conn is not None:
            self.lsl_part.connected()

    def _watch_recordings(self) -> None:
        """Each Gait panel learns where its engine's recordings begin (a listener on the
        engine), to count a recording's strides as its file has them."""
        ctx = self.ctx
        watched: list[tuple[GaitPanel, Engine]] = []
        if ctx.conn is not None:
            watched.append((self.view_part.gait_panel, ctx.conn.engine))
        if ctx.pair is not None and self.pair_part.view is not None:
            panels = self.pair_part.view.panels
            watched += [(panels[side], eng) for side, eng in ctx.pair.engines.items()
                        if side in panels]  # fmt: skip
        for panel, engine in watched:
            start = RecordingStart()
            engine.add_listener(start)
            panel.recording_start = start

    def timer_stop(self) -> None:
        self.timer.stop()
        self.view_part.detach()
        # disconnected: no stride is in progress any more (the plots keep the last strides)
        self.view_part.gait_panel.cycles.clear_current()
        if self.pair_part.view is not None:
            for panel in self.pair_part.view.panels.values():
                panel.cycles.clear_current()

    @guarded
    def toggle_connect(self) -> None:
        if self.ctx.connected:
            self.disconnect_device()
        else:
            self.device_part.connect_device()

    @guarded
    def disconnect_device(self) -> None:
        if self.ctx.pair is not None:
            self.pair_part.disconnect_pair()
        else:
            self.device_part.disconnect_device()

    @guarded
    def zero(self) -> None:
        if self.ctx.pair is not None:
            self.pair_part.zero()
        else:
            self.device_part.zero()

    @guarded
    def show_guide(self) -> None:
        """Help ▸ Guided start: the step bar again (after it was closed or recording began)."""
        self.guide.reopen()

    # ------------------------------------------------------------------------------------
    # the ~30 Hz update
    # ------------------------------------------------------------------------------------

    @guarded
    def _tick(self) -> None:
        ctx = self.ctx
        if ctx.pair is not None:  # both legs: .pair_part
            self.pair_part.tick()
            return
        conn = ctx.conn
        if conn is None:
            return
        paused = self.view_part.paused
        if self.view_part.feed is not None:
            self.view_part.feed.request = self.view_part.request()
            if not paused and time.monotonic() - self._frame_shown_s < FRAME_LATE_S:
                return  # the engine thread's frames show it all (_show_frame)
        # paused, or no frame comes (no data: a cut link; the plots scroll on with the clock)
        snap = conn.engine.snapshot(0.05 if paused else self.view_part.window_s)
        if not paused:
            ctx.last_snapshot = snap
            self.view_part.show(snap)
        self._show_status(snap)

    @guarded
    def _show_frame(self) -> None:
        """A frame the engine thread prepared (``ViewPart.attach``): painted first, then the
        status it carries. The GUI thread only hands arrays to the curves here."""
        feed = self.view_part.feed
        frame = feed.take() if feed is not None else None
        ctx = self.ctx
        if frame is None or ctx.conn is None or ctx.pair is not None or self.view_part.paused:
            return
        self._frame_shown_s = time.monotonic()
        self.view_part.show_frame(frame)
        if frame.taken_s >= self._controls_changed_s:
            ctx.last_snapshot = frame.snap
            self._show_status(frame.snap)

    def _show_status(self, snap: Snapshot) -> None:
        conn = self.ctx.conn
        assert conn is not None
        self.status.show_link(snap, "the simulated unit" if conn.simulated else conn.port)
        self.status.show_checks(snap)
        self.recording_part.show_recording({"": snap})
        self._show_guide_state(snap.calibrated, snap.zero_source)

    # ------------------------------------------------------------------------------------
    # help
    # ------------------------------------------------------------------------------------

    @guarded
    def show_shortcuts(self) -> None:
        shortcuts_dialog(self, SHORTCUTS).open()

    @guarded
    def show_about(self) -> None:
        QMessageBox.about(
            self,
            "About gaitmon",
            f"<b>gaitmon {__version__}</b><br>Live monitor, recorder and reviewer for a wearable "
            "gait-measurement unit (4 IMUs and heel/toe force sensors on one leg).<br><br>"
            "Colours follow the source paper: red = accelerometer, green = Kalman filter, "
            "blue = gyro integration; FSR red = heel, green = toe.",
        )

    # ------------------------------------------------------------------------------------
    # theme and shutdown
    # ------------------------------------------------------------------------------------

    def changeEvent(self, ev: QEvent) -> None:
        super().changeEvent(ev)
        ctx = getattr(self, "ctx", None)
        if ctx is not None and not ctx.closing and ev.type() in (
            QEvent.Type.PaletteChange,
            QEvent.Type.ThemeChange,
        ):
            try:
                self._apply_theme()
            except Exception as exc:  # a theme change must never take the window down
                self.report_exception("theme", exc)

    def _apply_theme(self) -> None:
        colours = current_colours()
        if colours.dark == self.ctx.colours.dark or not hasattr(self, "guide"):
            return
        self.ctx.colours = colours
        configure_pyqtgraph(colours)
        # curves are created once per theme: the parts rebuild their plots in the new shades
        self.status.colours = colours
        old_live = self.view_part.set_colours(colours)
        self._central_layout.replaceWidget(old_live, self.view_part.live)
        old_live.deleteLater()
        self.guide.set_colours(colours)
        self.pair_part.restyle()

    def shutdown(self) -> None:
        """Stop everything this window started (idempotent); the window stays open."""
        self.ctx.closing = True
        self.timer.stop()
        self.ctx.wait_saved()  # a recording just stopped: its file is finished first
        # a connect still running is closed when it finishes; a zero's answer is dropped
        self.ctx.jobs.stop()
        self.disconnect_device()

    def closeEvent(self, ev: QCloseEvent) -> None:
        try:
            if self.ctx.recording and self.confirm_close:
                answer = QMessageBox.question(
                    self,
                    "Quit gaitmon",
                    "A recording is running. Stop it (the file is completed) and quit?",
                )
                if answer != QMessageBox.StandardButton.Yes:
                    ev.ignore()
                    return
            self.ctx.prefs.set(LiveKey.GEOMETRY, self.saveGeometry())
            self.ctx.prefs.set(LiveKey.STATE, self.view_part.layout_state())
            self.shutdown()
            self.ctx.prefs.s.sync()
        except Exception as exc:  # closing must always work
            log.error("error while closing", exc_info=exc)
        ev.accept()


def run(
    sim: SimConfig | None = None,
    *,
    connect_simulated: bool = False,
    pair_sim: BilateralConfig | None = None,
    pair: PairSource | None = None,
) -> int:
    """Open the live monitor (``connect_simulated``: connect straight to the simulated unit;
    ``pair``: to both legs)."""
    from gaitmon.live.connection import SIMULATED_PORT
    from gaitmon.ui.app import exec_until_closed, make_application

    app = make_application("gaitmon")
    win = MainWindow(
        QSettings(),
        sim=sim,
        autoconnect=SIMULATED_PORT if connect_simulated else None,
        pair_sim=pair_sim,
        pair=pair,
    )
    win.show()
    return exec_until_closed(app, win)
