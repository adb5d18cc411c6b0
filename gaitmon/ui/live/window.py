"""The live monitor's window shell: layout, toolbars, docks, and the wiring between them.

The window owns no data path. Acquisition, processing and recording run in the engine's
threads; a QTimer (~30 Hz) pulls one `Snapshot` and hands it to the plots, the status view and
the gait panel (:mod:`.status`). The actions are rows of a table (:mod:`.actions`); the device,
session and processing slots are :mod:`.device`, :mod:`.recording` and :mod:`.processing`;
blocking calls (connect, zero on the unit) go through :mod:`.jobs`. Every slot is wrapped so
that an unexpected exception becomes one line in the status bar (and a traceback in the log
file), never a crash.
"""

from __future__ import annotations

import functools
import logging

from PySide6.QtCore import QEvent, QSettings, QSize, Qt, QTimer
from PySide6.QtGui import QAction, QActionGroup, QCloseEvent
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDockWidget,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QMessageBox,
    QSizePolicy,
    QToolBar,
    QToolButton,
    QVBoxLayout,
    QWidget,
)

from gaitmon import __version__
from gaitmon.engine import Mode
from gaitmon.io.sim.bilateral import BilateralConfig
from gaitmon.io.sim.config import SimConfig
from gaitmon.live.pair import PairSource
from gaitmon.ui.actions import guarded
from gaitmon.ui.dialogs import SettingsDialog, shortcuts_dialog
from gaitmon.ui.live.actions import (
    METHOD_COLOURS,
    MODES,
    SHORTCUTS,
    SIM_FSR_FAULTS,
    SIMULATOR,
    TILT_METHODS,
    VIEW,
    WINDOWS_S,
    build_actions,
    build_menus,
)
from gaitmon.ui.live.device import DeviceSlots
from gaitmon.ui.live.guide import GuideBar
from gaitmon.ui.live.jobs import DeviceJobs
from gaitmon.ui.live.lsl import LslSlots
from gaitmon.ui.live.pair_slots import PairSlots
from gaitmon.ui.live.prefs import Prefs
from gaitmon.ui.live.processing import ProcessingSlots
from gaitmon.ui.live.recording import RecordingSlots
from gaitmon.ui.live.status import GaitPanel, StatusView, banner_style
from gaitmon.ui.live.views import ViewSlots
from gaitmon.ui.plots import METHOD_LABELS, LivePlots, RawPlots
from gaitmon.ui.theme import configure_pyqtgraph, current_colours

log = logging.getLogger("gaitmon.ui")

REFRESH_HZ = 30.0
GAIT_PANEL_EVERY = 3  # ticks between gait-panel updates


class MainWindow(PairSlots, DeviceSlots, RecordingSlots, ProcessingSlots, ViewSlots, LslSlots):
    """The live monitor. ``settings`` is injected so tests can isolate it; ``sim``: the
    simulated device's settings (default: SimConfig()); ``pair_sim``: the simulated pair's
    (both legs, :mod:`.pair_slots`); ``pair``: connect both legs to it at once."""

    def __init__(
        self,
        settings: QSettings,
        *,
        sim: SimConfig | None = None,
        autoconnect: str | None = None,
        mode: Mode | str | None = None,
        confirm_close: bool = True,
        pair_sim: BilateralConfig | None = None,
        pair: PairSource | None = None,
    ) -> None:
        super().__init__()
        self.prefs = Prefs(settings)
        self.sim = sim
        self._init_pair(pair_sim)
        self.confirm_close = confirm_close
        self.conn = None
        self.errors = []
        self.config = self.prefs.pipeline_config()
        self.jobs = DeviceJobs(self)
        self.last_snapshot = None
        self.session_dialog = None
        self.settings_dialog: SettingsDialog | None = None
        self._connecting = False
        self._recording = False
        self._saving = False
        self._closing = False
        self._ticks = 0
        self._restore_timer = None
        self.lsl_outlets = None
        self.colours = current_colours()
        configure_pyqtgraph(self.colours)

        self.setWindowTitle("gaitmon — live monitor")
        self.setDockNestingEnabled(True)
        self.status = StatusView(self.statusBar(), self.colours)
        self._build_actions()
        self._build_toolbars()
        self._build_central()
        self._build_docks()
        self._build_menus()
        self._restore_prefs(mode)
        self._update_controls()

        self.timer = QTimer(self)
        self.timer.setInterval(round(1000 / REFRESH_HZ))
        self.timer.setTimerType(Qt.TimerType.PreciseTimer)
        self.timer.timeout.connect(self._tick)
        if autoconnect is not None:
            QTimer.singleShot(0, functools.partial(self.connect_device, autoconnect))
        elif pair is not None:
            QTimer.singleShot(0, functools.partial(self.connect_pair, pair))

    # the status view's widgets, by the names the window has always had
    @property
    def link_banner(self) -> QLabel:
        return self.status.link_banner

    @property
    def record_banner(self) -> QLabel:
        return self.status.record_banner

    @property
    def health_label(self) -> QLabel:
        return self.status.health_label

    @property
    def rec_label(self) -> QLabel:
        return self.status.rec_label

    @property
    def cal_label(self) -> QLabel:
        return self.status.cal_label

    @property
    def samples_label(self) -> QLabel:
        return self.status.samples_label

    # ------------------------------------------------------------------------------------
    # construction
    # ------------------------------------------------------------------------------------

    def _build_actions(self) -> None:
        acts = build_actions(self)
        self.window_actions: dict[float, QAction] = {w: acts[f"window_{w:g}"] for w in WINDOWS_S}
        self.window_group = QActionGroup(self)
        for a in self.window_actions.values():
            self.window_group.addAction(a)
        self.method_actions: dict[str, QAction] = {
            key: acts[f"method_{key}"] for key, _ in METHOD_COLOURS
        }
        self.tilt_actions = {key: acts[f"tilt_{key}"] for key, _text, _tip in TILT_METHODS}
        self.tilt_group = QActionGroup(self)  # exclusive: one filter in force
        for a in self.tilt_actions.values():
            self.tilt_group.addAction(a)
        self.sim_fsr_actions = {key: acts[f"sim_{key}"] for key, _text, _tip in SIM_FSR_FAULTS}
        self.act_connect = acts["connect"]
        self.act_refresh = acts["refresh"]
        self.act_zero = acts["zero"]
        self.act_record = acts["record"]
        self.act_marker = acts["marker"]
        self.act_pause = acts["pause"]
        self.act_settings = acts["settings"]
        self.act_reset_y = acts["reset_y"]
        self.act_cut = acts["cut"]
        self.act_restore = acts["restore"]
        self.act_help = acts["help"]
        self.act_about = acts["about"]
        self.act_quit = acts["quit"]
        self.act_four_phases = acts["four_phases"]
        self.act_engineering = acts["engineering"]
        self.act_guide = acts["guide"]
        self.act_lsl = acts["lsl"]
        self.act_lsl_patient = acts["lsl_patient_id"]
        self._actions = acts

    def _build_toolbars(self) -> None:
        tb = QToolBar("Connection", self)
        tb.setObjectName("toolbar-connection")
        tb.setIconSize(QSize(16, 16))
        self.addToolBar(tb)
        self.port_combo = QComboBox()
        self.port_combo.setMinimumContentsLength(28)
        self.port_combo.setSizeAdjustPolicy(
            QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon
        )
        self.port_combo.setToolTip("The unit's serial port (Bluetooth SPP shows up as one)")
        tb.addWidget(QLabel(" Unit "))
        tb.addWidget(self.port_combo)
        refresh = QToolButton()
        refresh.setDefaultAction(self.act_refresh)
        refresh.setText("⟳")
        tb.addWidget(refresh)
        self.mode_combo = QComboBox()
        for mode, text, tip in MODES:
            self.mode_combo.addItem(text, mode.value)
            self.mode_combo.setItemData(
                self.mode_combo.count() - 1, tip, Qt.ItemDataRole.ToolTipRole
            )
        self.mode_combo.setToolTip("What the unit sends (choose before connecting)")
        tb.addWidget(QLabel("  Mode "))
        tb.addWidget(self.mode_combo)
        self.connect_button = QToolButton()
        self.connect_button.setDefaultAction(self.act_connect)
        self.connect_button.setToolButtonStyle(Qt.ToolButtonStyle.ToolButtonTextOnly)
        self.connect_button.setMinimumWidth(90)
        tb.addWidget(self.connect_button)

        tb2 = QToolBar("Session", self)
        tb2.setObjectName("toolbar-session")
        self.addToolBar(tb2)
        tb2.addAction(self.act_zero)
        self.record_button = QToolButton()
        self.record_button.setDefaultAction(self.act_record)
        self.record_button.setMinimumWidth(70)
        tb2.addWidget(self.record_button)
        tb2.addSeparator()
        self.marker_edit = QLineEdit()
        self.marker_edit.setPlaceholderText("marker label (optional)")
        self.marker_edit.setToolTip(
            "Optional label for the next marker; Enter or M (outside this field) drops it"
        )
        self.marker_edit.setMaximumWidth(190)
        self.marker_edit.returnPressed.connect(lambda: self.add_marker())
        tb2.addWidget(self.marker_edit)
        tb2.addAction(self.act_marker)
        tb2.addSeparator()
        tb2.addAction(self.act_pause)
        self.window_combo = QComboBox()
        for w in WINDOWS_S:
            self.window_combo.addItem(f"{w:g} s", w)
        self.window_combo.setToolTip("Time window shown (1 / 2 / 3)")
        self.window_combo.currentIndexChanged.connect(self._window_combo_changed)
        tb2.addWidget(QLabel("  Window "))
        tb2.addWidget(self.window_combo)
        tb2.addSeparator()
        tb2.addAction(self.act_engineering)  # a toggle button: the engineering view

    def _legend_box(self, text: str, colour: str, checkable: bool) -> QWidget:
        if checkable:
            w: QWidget = QCheckBox(text)
        else:
            w = QLabel(f"<span style='color:{colour}'>■</span> {text}")
        if checkable:
            w.setStyleSheet(f"QCheckBox {{ color: {colour}; font-weight: 600; }}")
        return w

    def _build_central(self) -> None:
        c = self.colours
        central = QWidget()
        lay = QVBoxLayout(central)
        lay.setContentsMargins(4, 2, 4, 2)
        lay.setSpacing(2)
        lay.addWidget(self.status.link_banner)
        lay.addWidget(self.status.record_banner)
        lay.addWidget(self.status.fsr_banner)
        self.guide = GuideBar(self.colours, (self.act_connect, self.act_zero, self.act_record))
        lay.addWidget(self.guide)

        bar = QHBoxLayout()
        bar.setSpacing(12)
        self.method_boxes: dict[str, QCheckBox] = {}
        for key, colour in (("acc", c.acc), ("kalman", c.kalman), ("gyro", c.gyro)):
            box = self._legend_box(METHOD_LABELS[key], colour.name(), True)
            assert isinstance(box, QCheckBox)
            box.setToolTip(f"Show or hide the {METHOD_LABELS[key].lower()} traces")
            box.toggled.connect(lambda on, k=key: self.set_method(k, on))
            self.method_boxes[key] = box
            bar.addWidget(box)
        bar.addSpacing(16)
        bar.addWidget(self._legend_box("heel", c.heel.name(), False))
        bar.addWidget(self._legend_box("toe", c.toe.name(), False))
        self.phase_legend = QLabel()
        bar.addWidget(self.phase_legend)
        self.phase_combo = QComboBox()
        self.phase_combo.addItem("stance / swing", False)
        self.phase_combo.addItem("4 sub-phases", True)
        self.phase_combo.setToolTip("How the gait phase is shaded on the FSR plot")
        self.phase_combo.currentIndexChanged.connect(self._phase_combo_changed)
        bar.addWidget(self.phase_combo)
        events = QLabel("┃ heel strike  ┆ toe off")
        events.setToolTip(
            "Gait events from the foot sensors, drawn on the joint and FSR plots: heel strike "
            "solid, toe off dashed"
        )
        bar.addWidget(events)
        for label in (self.phase_legend, events):
            # legends may be clipped on a narrow screen rather than force a wide window
            label.setMinimumWidth(40)  # overrides the text's minimum: shrinks only if needed
        bar.addStretch(1)
        lay.addLayout(bar)
        # a banner row of its own: in the legend's row it took the legend's width (clipping it)
        # and widened the central area, squeezing the gait dock (kept so after a restart)
        self.pause_label = QLabel("  ❚❚ Display paused: acquisition and recording continue  ")
        self.pause_label.setStyleSheet(banner_style(self.colours, "warn"))
        self.pause_label.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.pause_label.setVisible(False)
        lay.insertWidget(2, self.pause_label)

        self.live = LivePlots(self.colours)
        self.live.setToolTip("")
        lay.addWidget(self.live, 1)
        self.setCentralWidget(central)
        self._central_layout = lay

    def _build_docks(self) -> None:
        self.gait_panel = GaitPanel(self.colours)
        self.gait_dock = QDockWidget("Gait", self)
        self.gait_dock.setObjectName("dock-gait")
        self.gait_dock.setWidget(self.gait_panel)
        self.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.gait_dock)
        # raw sensors (hidden by default)
        self.raw = RawPlots(self.colours)
        self.raw.setMinimumHeight(160)
        self.raw_dock = QDockWidget("Raw sensors", self)
        self.raw_dock.setObjectName("dock-raw")
        self.raw_dock.setWidget(self.raw)
        self.addDockWidget(Qt.DockWidgetArea.BottomDockWidgetArea, self.raw_dock)
        self.raw_dock.hide()
        self.resize(1400, 860)
        # the live plots get the room; the gait panel a column (a saved layout overrides this)
        self.resizeDocks([self.gait_dock], [370], Qt.Orientation.Horizontal)
        self.resizeDocks([self.raw_dock], [260], Qt.Orientation.Vertical)

    def _build_menus(self) -> None:
        menus = build_menus(self, self._actions)
        self.sim_menu = menus[SIMULATOR]
        view = menus[VIEW]
        view.addSeparator()
        view.addAction(self.gait_dock.toggleViewAction())
        view.addAction(self.raw_dock.toggleViewAction())

    def _restore_prefs(self, mode: Mode | str | None) -> None:
        p = self.prefs
        self.refresh_ports()
        last = p.get("device/last_port", "")
        idx = self.port_combo.findData(last) if last else -1
        if idx >= 0:
            self.port_combo.setCurrentIndex(idx)
        mode_value = Mode(mode).value if mode is not None else p.get("device/mode", "raw")
        self.mode_combo.setCurrentIndex(max(self.mode_combo.findData(mode_value), 0))
        window = p.get("view/window_s", 10.0, float)
        if window not in WINDOWS_S:
            window = 10.0
        self.set_window(window)
        for key in ("acc", "kalman", "gyro"):
            self.set_method(key, p.get(f"view/method_{key}", True, bool))
        self.set_four_phases(p.get("view/four_phases", True, bool))
        self.live.set_fsr_threshold(self.config.fsr_threshold)
        self.show_tilt_method()
        geo = p.s.value("window/geometry")
        self.geometry_restored = bool(geo is not None and self.restoreGeometry(geo))
        state = p.s.value("window/state")
        self.state_restored = bool(state is not None and self.restoreState(state))
        self._restore_view()  # after the layout: the clinical view hides the raw dock
        self._restore_lsl()

    def _update_controls(self) -> None:
        super()._update_controls()
        if hasattr(self, "guide"):
            self._show_guide_state()

    # ------------------------------------------------------------------------------------
    # view options
    # ------------------------------------------------------------------------------------

    @guarded
    def set_paused(self, paused: bool) -> None:
        if self.act_pause.isChecked() != paused:
            self.act_pause.setChecked(paused)
        self.pause_label.setVisible(paused)
        self.act_pause.setText("Resume" if paused else "Pause")

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
        self.prefs.set("view/window_s", window_s)
        if self.paused and self.last_snapshot is not None:
            self.live.update_from(self.last_snapshot)

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
        self.prefs.set(f"view/method_{method}", on)
        if on and self.last_snapshot is not None and self.paused:
            self.live.update_from(self.last_snapshot)

    @guarded
    def set_four_phases(self, four: bool) -> None:
        four = bool(four)
        self.live.set_four_phases(four)
        if self.act_four_phases.isChecked() != four:
            self.act_four_phases.setChecked(four)
        idx = 1 if four else 0
        if self.phase_combo.currentIndex() != idx:
            self.phase_combo.setCurrentIndex(idx)
        c = self.colours
        if four:
            parts = [
                f"<span style='color:{col.name()}'>█</span> {name}"
                for col, name in zip(c.phases, ("loading", "foot flat", "push-off"), strict=True)
            ]
            text = " ".join(parts)
        else:
            text = f"<span style='color:{c.stance.name()}'>█</span> stance"
        self.phase_legend.setText(text)
        self.prefs.set("view/four_phases", four)

    def _phase_combo_changed(self, index: int) -> None:
        self.set_four_phases(bool(self.phase_combo.itemData(index)))

    @guarded
    def reset_y_ranges(self) -> None:
        self.live.reset_y_ranges()

    # ------------------------------------------------------------------------------------
    # the ~30 Hz update
    # ------------------------------------------------------------------------------------

    @guarded
    def _tick(self) -> None:
        if self.pair is not None:  # both legs: .pair_slots
            self._tick_pair()
            return
        conn = self.conn
        if conn is None:
            return
        eng = conn.engine
        paused = self.paused
        snap = eng.snapshot(0.05 if paused else self.window_s)
        self.status.show_link(snap, "the simulated unit" if conn.simulated else conn.port)
        self.status.show_checks(snap)
        self._show_recording(snap, conn)
        self._show_guide_state(snap.calibrated)
        if paused:
            return
        self.last_snapshot = snap
        self.live.set_angle_method(snap.angle_method)
        self.live.update_from(snap)
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
            self.gait_panel.show_snapshot(snap)
        if self.raw_dock.isVisible():
            self.raw.update_from(snap)

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
        if not getattr(self, "_closing", True) and ev.type() in (
            QEvent.Type.PaletteChange,
            QEvent.Type.ThemeChange,
        ):
            try:
                self._apply_theme()
            except Exception as exc:  # a theme change must never take the window down
                self.report_exception("theme", exc)

    def _apply_theme(self) -> None:
        colours = current_colours()
        if colours.dark == self.colours.dark or not hasattr(self, "live"):
            return
        self.colours = colours
        configure_pyqtgraph(colours)
        # curves are created once per theme: rebuild the plot widgets with the new shades
        self.status.colours = colours
        old_live, old_raw = self.live, self.raw
        self.live = LivePlots(colours)
        self._central_layout.replaceWidget(old_live, self.live)
        self.gait_panel.set_colours(colours)
        self.guide.set_colours(colours)
        self.raw = RawPlots(colours)
        self.raw_dock.setWidget(self.raw)
        for w in (old_live, old_raw):
            w.deleteLater()
        self.set_window(self.window_s if hasattr(old_live, "window_s") else 10.0)
        for key, on in old_live.methods_on.items():
            self.live.set_method(key, on)
        self.set_four_phases(old_live.four_phases)
        self.live.set_fsr_threshold(self.config.fsr_threshold)
        self.live.set_angle_method(old_live.angle_method)
        self.live.set_engineering(old_live.engineering)
        self._restyle_pair_view()

    def shutdown(self) -> None:
        """Stop everything this window started (idempotent); the window stays open."""
        self._closing = True
        self.timer.stop()
        self._wait_saved()  # a recording just stopped: its file is finished first
        # a connect still running is closed when it finishes; a zero's answer is dropped
        self.jobs.stop()
        self.disconnect_device()

    def closeEvent(self, ev: QCloseEvent) -> None:
        try:
            if self._recording and self.confirm_close:
                answer = QMessageBox.question(
                    self,
                    "Quit gaitmon",
                    "A recording is running. Stop it (the file is completed) and quit?",
                )
                if answer != QMessageBox.StandardButton.Yes:
                    ev.ignore()
                    return
            self.prefs.set("window/geometry", self.saveGeometry())
            self.prefs.set("window/state", self.saveState())
            self.shutdown()
            self.prefs.s.sync()
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
