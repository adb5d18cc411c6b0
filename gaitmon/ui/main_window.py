"""The live monitor window: connection, live plots, gait panel, recording, markers, zeroing.

The window owns no data path. Acquisition, processing and recording run in the engine's
threads; a QTimer (~30 Hz) pulls one `Snapshot` and hands it to the plots and the status
widgets. Blocking calls (connect, zero on the unit) go through `TaskRunner`. Every slot is
wrapped so that an unexpected exception becomes one line in the status bar (and a traceback
in the log file), never a crash.
"""

from __future__ import annotations

import functools
import logging
import math
import time
from pathlib import Path
from typing import Any

from PySide6.QtCore import QEvent, QSettings, QSize, QStandardPaths, Qt, QTimer
from PySide6.QtGui import QAction, QActionGroup, QCloseEvent
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDockWidget,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QMainWindow,
    QMessageBox,
    QSizePolicy,
    QToolBar,
    QToolButton,
    QVBoxLayout,
    QWidget,
)

from gaitmon import __version__
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import EngineError, Mode, Snapshot
from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import (
    SIMULATED_LABEL,
    SIMULATED_PORT,
    Connection,
    available_ports,
    open_connection,
)
from gaitmon.live.health import HealthTracker, link_view
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded, make_action
from gaitmon.ui.dialogs import SETTINGS_FIELDS, SessionDialog, SettingsDialog, shortcuts_dialog
from gaitmon.ui.plots import METHOD_LABELS, CyclePlots, LivePlots, RawPlots
from gaitmon.ui.tasks import TaskRunner
from gaitmon.ui.theme import Colours, configure_pyqtgraph, current_colours

log = logging.getLogger("gaitmon.ui")

REFRESH_HZ = 30.0
GAIT_PANEL_EVERY = 3  # ticks between gait-panel updates
WINDOWS_S = (5.0, 10.0, 30.0)
MODES = (
    (Mode.RAW, "PC computes (raw frames)", "The unit sends raw ADC frames; gaitmon runs the "
     "paper's filters, Kalman filter and gait detection on the PC (all three methods)."),
    (Mode.TILT, "Unit's tilt angles", "The unit sends its own accelerometer and Kalman tilts "
     "(no gyro integration, no foot contacts)."),
    (Mode.JOINT, "Unit's joint angles", "The unit sends its own joint angles, foot contacts and "
     "gait phase."),
)  # fmt: skip
SHORTCUTS = [
    ("Space", "pause / resume the display (acquisition and recording continue)"),
    ("M", "drop a marker (with the label typed in the marker field, if any)"),
    ("Ctrl+R", "start / stop recording"),
    ("Ctrl+K", "connect / disconnect"),
    ("F5", "refresh the list of ports"),
    ("Ctrl+0", "zero: standing pose (the subject stands upright, still, leg straight)"),
    ("1 / 2 / 3", "show the last 5 / 10 / 30 s"),
    ("Home", "reset the y ranges"),
    ("Ctrl+,", "processing settings"),
    ("Ctrl+Shift+X", "simulated unit: cut the link for 3 s"),
    ("F1", "this list"),
    ("Ctrl+Q", "quit"),
]


def _fmt_bytes(n: int) -> str:
    if n < 1_000_000:
        return f"{n / 1000:.0f} kB"
    if n < 1_000_000_000:
        return f"{n / 1e6:.1f} MB"
    return f"{n / 1e9:.2f} GB"


def _fmt_elapsed(s: float) -> str:
    s = max(0, int(s))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m:02d}:{sec:02d}"


class Prefs:
    """Typed access to the QSettings the window remembers."""

    def __init__(self, settings: QSettings) -> None:
        self.s = settings

    def get(self, key: str, default: Any, kind: type = str) -> Any:
        value = self.s.value(key, default)
        if value is None:
            return default
        try:
            if kind is bool:
                return value if isinstance(value, bool) else str(value).lower() in ("1", "true")
            return kind(value)
        except (TypeError, ValueError):
            return default

    def set(self, key: str, value: Any) -> None:
        self.s.setValue(key, value)

    def pipeline_config(self) -> PipelineConfig:
        base = PipelineConfig()
        changes = {}
        for name, _label, _tip in SETTINGS_FIELDS:
            changes[name] = self.get(f"pipeline/{name}", getattr(base, name), float)
        try:
            return base.replace(**changes)
        except (ValueError, TypeError):
            log.warning("stored processing settings are invalid; using the paper's values")
            return base

    def save_pipeline_config(self, cfg: PipelineConfig) -> None:
        for name, _label, _tip in SETTINGS_FIELDS:
            self.set(f"pipeline/{name}", float(getattr(cfg, name)))


def default_session_folder() -> Path:
    docs = QStandardPaths.writableLocation(QStandardPaths.StandardLocation.DocumentsLocation)
    return Path(docs or Path.home()) / "gaitmon"


class MainWindow(QMainWindow):
    """The live monitor. ``settings`` is injected so tests can isolate it."""

    def __init__(
        self,
        settings: QSettings,
        *,
        sim: SimConfig | None = None,
        autoconnect: str | None = None,
        mode: Mode | str | None = None,
        confirm_close: bool = True,
    ) -> None:
        super().__init__()
        self.prefs = Prefs(settings)
        self.sim = sim
        self.confirm_close = confirm_close
        self.conn: Connection | None = None
        self.errors: list[str] = []  # unexpected exceptions caught by `guarded` (tests check)
        self.config = self.prefs.pipeline_config()
        self.health = HealthTracker()
        self.tasks = TaskRunner(self)
        self.last_snapshot: Snapshot | None = None
        self.session_dialog: SessionDialog | None = None
        self.settings_dialog: SettingsDialog | None = None
        self._connecting = False
        self._recording = False
        self._closing = False
        self._shown_strides = -1
        self._ticks = 0
        self._restore_timer: QTimer | None = None
        self.colours: Colours = current_colours()
        configure_pyqtgraph(self.colours)

        self.setWindowTitle("gaitmon — live monitor")
        self.setDockNestingEnabled(True)
        self._build_actions()
        self._build_toolbars()
        self._build_central()
        self._build_docks()
        self._build_menus()
        self._build_statusbar()
        self._restore_prefs(mode)
        self._update_controls()

        self.timer = QTimer(self)
        self.timer.setInterval(round(1000 / REFRESH_HZ))
        self.timer.setTimerType(Qt.TimerType.PreciseTimer)
        self.timer.timeout.connect(self._tick)
        if autoconnect is not None:
            QTimer.singleShot(0, functools.partial(self.connect_device, autoconnect))

    # ------------------------------------------------------------------------------------
    # construction
    # ------------------------------------------------------------------------------------

    _action = make_action  # a method: the window owns its actions

    def _build_actions(self) -> None:
        self.act_connect = self._action(
            "Connect", self.toggle_connect, "Ctrl+K", "Connect to the selected unit (Ctrl+K)"
        )
        self.act_refresh = self._action(
            "Refresh ports", self.refresh_ports, "F5", "Look for serial ports again (F5)"
        )
        self.act_zero = self._action(
            "Zero",
            self.zero,
            "Ctrl+0",
            "Zero the standing pose: the subject stands upright and still, leg straight (Ctrl+0)",
        )
        self.act_record = self._action(
            "Record", self.toggle_recording, "Ctrl+R", "Start / stop recording a session (Ctrl+R)"
        )
        self.act_marker = self._action(
            "Marker", self.add_marker, "M", "Drop a marker now, with the label typed beside (M)"
        )
        self.act_pause = self._action(
            "Pause",
            self.set_paused,
            "Space",
            "Freeze the display; acquisition and recording continue (Space)",
            checkable=True,
        )
        self.act_settings = self._action(
            "Settings…", self.open_settings, "Ctrl+,", "Filter, Kalman and FSR settings"
        )
        self.act_reset_y = self._action(
            "Reset y ranges", self.reset_y_ranges, "Home", "Back to the clinical y ranges"
        )
        self.act_cut = self._action(
            "Cut link for 3 s",
            functools.partial(self.cut_simulated_link, 3.0),
            "Ctrl+Shift+X",
            "Simulate a Bluetooth drop-out: the simulated unit's port vanishes for 3 s",
        )
        self.act_restore = self._action(
            "Restore link now", self.restore_simulated_link, None, "End a simulated drop-out"
        )
        self.act_help = self._action("Keyboard shortcuts", self.show_shortcuts, "F1")
        self.act_about = self._action("About gaitmon", self.show_about)
        self.act_quit = self._action("Quit", self.close, "Ctrl+Q")
        self.window_group = QActionGroup(self)
        self.window_actions: dict[float, QAction] = {}
        for i, w in enumerate(WINDOWS_S, start=1):
            a = self._action(
                f"Last {w:g} s",
                functools.partial(self.set_window, w),
                str(i),
                f"Show the last {w:g} seconds ({i})",
                checkable=True,
            )
            self.window_group.addAction(a)
            self.window_actions[w] = a
        self.method_actions: dict[str, QAction] = {}
        for key, colour_name in (("acc", "red"), ("kalman", "green"), ("gyro", "blue")):
            a = self._action(
                f"{METHOD_LABELS[key]} ({colour_name})",
                functools.partial(self.set_method, key),
                tip=f"Show the {METHOD_LABELS[key].lower()} traces",
                checkable=True,
            )
            self.method_actions[key] = a
        self.act_four_phases = self._action(
            "Four gait sub-phases",
            self.set_four_phases,
            tip="Shade loading / foot flat / push-off (off: stance vs swing)",
            checkable=True,
        )

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
        self.link_banner = QLabel()
        self.link_banner.setWordWrap(True)
        self.link_banner.setVisible(False)
        self.link_banner.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        lay.addWidget(self.link_banner)
        self.record_banner = QLabel()
        self.record_banner.setWordWrap(True)
        self.record_banner.setVisible(False)
        self.record_banner.setStyleSheet(self._banner_style("alert"))
        lay.addWidget(self.record_banner)

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
        self.pause_label = QLabel("  ❚❚ Display paused: acquisition and recording continue  ")
        self.pause_label.setStyleSheet(self._banner_style("warn"))
        self.pause_label.setVisible(False)
        bar.addWidget(self.pause_label)
        lay.addLayout(bar)

        self.live = LivePlots(self.colours)
        self.live.setToolTip("")
        lay.addWidget(self.live, 1)
        self.setCentralWidget(central)
        self._central_layout = lay

    def _build_docks(self) -> None:
        # gait panel
        gait = QWidget()
        g = QVBoxLayout(gait)
        g.setContentsMargins(4, 4, 4, 4)
        grid = QGridLayout()
        grid.setHorizontalSpacing(10)
        self.gait_values: dict[str, QLabel] = {}
        rows = (
            ("cadence", "Cadence (derived)", "steps/min: 120 / mean stride time of the last "
             "strides. Derived: one unit measures one leg."),
            ("stride", "Last stride", "time from one heel strike to the next (s)"),
            ("stance", "Stance", "stance time as % of the last stride (normal ≈ 60 %)"),
            ("strides", "Strides", "strides completed since connecting"),
        )  # fmt: skip
        big = self.font()
        big.setPointSizeF(big.pointSizeF() * 1.5)
        big.setBold(True)
        for r, (key, label, tip) in enumerate(rows):
            name = QLabel(label)
            name.setToolTip(tip)
            value = QLabel("—")
            value.setFont(big)
            value.setToolTip(tip)
            value.setAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
            grid.addWidget(name, r, 0)
            grid.addWidget(value, r, 1)
            self.gait_values[key] = value
        g.addLayout(grid)
        self.cycle_title = QLabel("Gait cycle: mean ± SD of the last strides, current stride")
        self.cycle_title.setWordWrap(True)
        g.addWidget(self.cycle_title)
        self.cycles = CyclePlots(self.colours)
        self.cycles.setMinimumHeight(300)
        g.addWidget(self.cycles, 1)
        self.gait_dock = QDockWidget("Gait", self)
        self.gait_dock.setObjectName("dock-gait")
        self.gait_dock.setWidget(gait)
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
        mb = self.menuBar()
        dev = mb.addMenu("&Device")
        dev.addAction(self.act_connect)
        dev.addAction(self.act_refresh)
        dev.addSeparator()
        dev.addAction(self.act_zero)
        dev.addAction(self.act_settings)
        dev.addSeparator()
        self.sim_menu = dev.addMenu("Simulator")
        self.sim_menu.addAction(self.act_cut)
        self.sim_menu.addAction(self.act_restore)
        dev.addSeparator()
        dev.addAction(self.act_quit)
        ses = mb.addMenu("&Session")
        ses.addAction(self.act_record)
        ses.addAction(self.act_marker)
        view = mb.addMenu("&View")
        view.addAction(self.act_pause)
        view.addSeparator()
        for a in self.window_actions.values():
            view.addAction(a)
        view.addSeparator()
        for a in self.method_actions.values():
            view.addAction(a)
        view.addAction(self.act_four_phases)
        view.addAction(self.act_reset_y)
        view.addSeparator()
        view.addAction(self.gait_dock.toggleViewAction())
        view.addAction(self.raw_dock.toggleViewAction())
        helpm = mb.addMenu("&Help")
        helpm.addAction(self.act_help)
        helpm.addAction(self.act_about)

    def _build_statusbar(self) -> None:
        sb = self.statusBar()
        self.state_label = QLabel()
        self.state_label.setToolTip("Link state")
        self.health_label = QLabel()
        self.rec_label = QLabel()
        self.rec_label.setToolTip("Recording: elapsed time, file size, file name")
        self.cal_label = QLabel()
        self.cal_label.setToolTip("Standing-pose zeroing (Zero, Ctrl+0)")
        self.samples_label = QLabel()
        self.samples_label.setToolTip("Samples received since connecting")
        for w in (self.rec_label, self.cal_label, self.health_label, self.samples_label):
            w.setSizePolicy(QSizePolicy.Policy.Preferred, QSizePolicy.Policy.Preferred)
            sb.addPermanentWidget(w)
        sb.addPermanentWidget(self.state_label)
        self._set_state_pill("Disconnected", "ok")

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
        geo = p.s.value("window/geometry")
        self.geometry_restored = bool(geo is not None and self.restoreGeometry(geo))
        state = p.s.value("window/state")
        self.state_restored = bool(state is not None and self.restoreState(state))

    # ------------------------------------------------------------------------------------
    # small helpers
    # ------------------------------------------------------------------------------------

    def _banner_style(self, grade: str) -> str:
        colour = {"ok": self.colours.ok, "warn": self.colours.warn}.get(grade, self.colours.alert)
        return f"background: {colour}; color: white; padding: 4px 8px; border-radius: 3px;"

    def _set_state_pill(self, text: str, grade: str) -> None:
        colour = {"ok": self.colours.ok, "warn": self.colours.warn}.get(grade, self.colours.alert)
        if text == "Disconnected":
            colour = "gray"
        self.state_label.setText(f"<span style='color:{colour}'>●</span> {text}")
        self.state_label.setProperty("state_text", text)

    def notify(self, text: str, timeout_ms: int = 10_000) -> None:
        """A one-line message in the status bar."""
        self.statusBar().showMessage(text, timeout_ms)
        log.info(text)

    def report_exception(self, where: str, exc: BaseException) -> None:
        log.error("unexpected error in %s", where, exc_info=exc)
        msg = f"Unexpected error ({where}): {one_line(exc)}"
        self.errors.append(msg)
        self.notify(msg)

    @property
    def engine(self):
        return self.conn.engine if self.conn is not None else None

    @property
    def window_s(self) -> float:
        return self.live.window_s

    @property
    def paused(self) -> bool:
        return self.act_pause.isChecked()

    @property
    def state_text(self) -> str:
        return str(self.state_label.property("state_text") or "")

    def _update_controls(self) -> None:
        connected = self.conn is not None
        busy = self._connecting
        self.act_connect.setText(
            "Connecting…" if busy else ("Disconnect" if connected else "Connect")
        )
        self.act_connect.setEnabled(not busy)
        self.port_combo.setEnabled(not connected and not busy)
        self.mode_combo.setEnabled(not connected and not busy)
        self.act_refresh.setEnabled(not connected and not busy)
        for a in (self.act_zero, self.act_record, self.act_marker):
            a.setEnabled(connected)
        self.act_record.setText("Stop" if self._recording else "Record")
        self.act_record.setToolTip(
            "Stop recording (Ctrl+R)" if self._recording else "Record a session (Ctrl+R)"
        )
        sim = connected and self.conn is not None and self.conn.simulated
        self.sim_menu.setEnabled(sim)
        self.act_cut.setEnabled(sim)
        self.act_restore.setEnabled(sim)

    # ------------------------------------------------------------------------------------
    # connection
    # ------------------------------------------------------------------------------------

    @guarded
    def refresh_ports(self) -> None:
        current = self.port_combo.currentData()
        self.port_combo.clear()
        for p in available_ports():
            self.port_combo.addItem(p.friendly(), p.device)
            self.port_combo.setItemData(
                self.port_combo.count() - 1, p.device, Qt.ItemDataRole.ToolTipRole
            )
        self.port_combo.addItem(SIMULATED_LABEL, SIMULATED_PORT)
        self.port_combo.setItemData(
            self.port_combo.count() - 1,
            "A simulated unit on a pseudo-terminal in this program: a subject stands, then "
            "walks. Device ▸ Simulator cuts its link.",
            Qt.ItemDataRole.ToolTipRole,
        )
        idx = self.port_combo.findData(current) if current else -1
        self.port_combo.setCurrentIndex(idx if idx >= 0 else 0)

    @guarded
    def toggle_connect(self) -> None:
        if self.conn is not None:
            self.disconnect_device()
        else:
            self.connect_device()

    @guarded
    def connect_device(self, port: str | None = None) -> None:
        if self.conn is not None or self._connecting:
            return
        if port is not None:
            idx = self.port_combo.findData(port)
            if idx >= 0:
                self.port_combo.setCurrentIndex(idx)
        port = port or self.port_combo.currentData()
        if not port:
            self.notify("No port selected: choose the unit's port or the simulated device.")
            return
        mode = Mode(self.mode_combo.currentData())
        cfg = self.config
        sim = self.sim
        self._connecting = True
        self._set_state_pill("Connecting…", "warn")
        self._update_controls()
        self.notify(f"Connecting to {self.port_combo.currentText()}…", 0)
        self.tasks.submit(
            lambda: open_connection(port, mode, cfg, sim=sim),
            self._connected,
            name="connect",
        )

    @guarded
    def _connected(self, conn: Connection | None, exc: BaseException | None) -> None:
        self._connecting = False
        if exc is not None or conn is None:
            self._set_state_pill("Disconnected", "ok")
            self._update_controls()
            why = one_line(exc) if exc is not None else "unknown reason"
            if exc is not None and not isinstance(exc, EngineError):
                log.error("connect failed", exc_info=exc)
            self.notify(f"Could not connect: {why}", 30_000)
            return
        if self._closing:
            conn.close()
            return
        self.conn = conn
        self.prefs.set("device/last_port", conn.port)
        self.prefs.set("device/mode", conn.engine.mode.value)
        self.health.reset()
        self._shown_strides = -1
        self.live.clear_data()
        self.cycles.clear_data()
        self.raw.clear_data()
        ident = conn.engine.identity
        who = f"{ident.name} {ident.firmware} #{ident.serial} ({ident.side})" if ident else ""
        self.notify(f"Connected to {conn.label} {who}".strip())
        self._update_controls()
        self.timer.start()
        self._tick()

    @guarded
    def disconnect_device(self) -> None:
        conn = self.conn
        if conn is None:
            return
        self.timer.stop()
        self.conn = None
        if self._restore_timer is not None:
            self._restore_timer.stop()
            self._restore_timer = None
        was_recording = self._recording
        self._recording = False
        try:
            status = conn.engine.stop_recording() if was_recording else None
        finally:
            conn.close()
        self.link_banner.setVisible(False)
        self._set_state_pill("Disconnected", "ok")
        self.health_label.setText("")
        self.rec_label.setText("")
        self._update_controls()
        if status is not None:
            self.notify(f"Recording saved: {status.path} ({status.rows} frames). Disconnected.")
        else:
            self.notify("Disconnected.")

    @guarded
    def cut_simulated_link(self, duration_s: float = 3.0) -> None:
        conn = self.conn
        if conn is None or conn.simulator is None:
            self.notify("The link can only be cut on the simulated device.")
            return
        conn.simulator.cut()
        self.notify(f"Simulated link cut for {duration_s:g} s.")
        if self._restore_timer is not None:
            self._restore_timer.stop()
        t = QTimer(self)
        t.setSingleShot(True)
        t.timeout.connect(self.restore_simulated_link)
        t.start(round(duration_s * 1000))
        self._restore_timer = t

    @guarded
    def restore_simulated_link(self) -> None:
        conn = self.conn
        if self._restore_timer is not None:
            self._restore_timer.stop()
            self._restore_timer = None
        if conn is None or conn.simulator is None:
            return
        conn.simulator.restore()
        self.notify("Simulated link restored; the window reconnects by itself.")

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
        conn = self.conn
        if conn is None:
            return
        eng = conn.engine
        paused = self.paused
        snap = eng.snapshot(0.05 if paused else self.window_s)
        self._update_status(snap, conn)
        if paused:
            return
        self.last_snapshot = snap
        self.live.update_from(snap)
        self._ticks += 1
        # the gait panel changes slowly: 10 Hz is plenty to read and saves a third of its cost
        if self.gait_dock.isVisible() and self._ticks % GAIT_PANEL_EVERY == 0:
            self._update_gait(snap)
        if self.raw_dock.isVisible():
            self.raw.update_from(snap)

    def _update_status(self, snap: Snapshot, conn: Connection) -> None:
        port = "the simulated unit" if conn.simulated else conn.port
        view = link_view(
            snap.link_state,
            snap.link_reason,
            snap.seconds_to_reconnect,
            snap.last_data_age_s,
            port,
        )
        if view.banner:
            self.link_banner.setText(view.banner)
            if self.link_banner.property("grade") != view.grade:
                self.link_banner.setStyleSheet(self._banner_style(view.grade))
                self.link_banner.setProperty("grade", view.grade)
            self.link_banner.setVisible(True)
        elif self.link_banner.isVisible():
            self.link_banner.setVisible(False)
        pill = view.pill
        if view.state == "reconnecting" and snap.seconds_to_reconnect is not None:
            pill = f"Reconnecting ({snap.seconds_to_reconnect:.1f} s)"
        self._set_state_pill(pill, view.grade)

        link = snap.link
        if link is not None:
            d = link.decoder
            h = self.health.update(
                time.monotonic(),
                d.frames_ok,
                d.frames_lost,
                d.crc_failures,
                snap.frame_rate_hz,
                snap.last_data_age_s,
                reconnects=link.reconnects,
                link_up=snap.link_state == "connected",
                errors=snap.engine_errors + link.rx_errors,
                last_error=snap.engine_error or link.rx_error,
            )
            colour = {"ok": "palette(window-text)", "lossy": self.colours.warn}.get(
                h.grade, self.colours.alert
            )
            weight = "normal" if h.grade == "ok" else "bold"
            self.health_label.setText(h.text)
            if self.health_label.property("grade") != h.grade:  # re-styling is not free
                self.health_label.setStyleSheet(f"color: {colour}; font-weight: {weight}")
                self.health_label.setProperty("grade", h.grade)
            self.health_label.setToolTip(h.tooltip)
        self.samples_label.setText(f"{snap.samples_total:,} samples")
        self.samples_label.setProperty("samples", snap.samples_total)
        if snap.mode is Mode.RAW:
            cal = "zeroed" if snap.calibrated else "not zeroed"
        else:
            cal = "unit zeroes itself"
        self.cal_label.setText(cal)
        self._update_recording(snap, conn)

    def _update_recording(self, snap: Snapshot, conn: Connection) -> None:
        rec = snap.recording
        if self._recording and not rec.active:
            # the recorder stopped by itself (full disk, ...): finish the file, keep acquiring
            status = conn.engine.stop_recording()
            self._recording = False
            self._update_controls()
            why = rec.error or status.error or "the recorder stopped"
            msg = (
                f"Recording stopped: {why}. Acquisition continues; "
                f"{status.rows} frames were saved in {Path(status.path).name}."
            )
            self.record_banner.setText(msg)
            self.record_banner.setVisible(True)
            self.notify(msg, 0)
            self.rec_label.setText("")
            return
        if self._recording:
            self.rec_label.setText(
                f"<span style='color:{self.colours.alert}'>●</span> REC "
                f"{_fmt_elapsed(rec.elapsed_s)} · {_fmt_bytes(rec.file_bytes)} · "
                f"{Path(rec.path).name}"
            )
            if rec.dropped_blocks:
                self.rec_label.setText(
                    self.rec_label.text() + f" · {rec.dropped_blocks} blocks NOT saved"
                )

    def _update_gait(self, snap: Snapshot) -> None:
        g = snap.gait
        v = self.gait_values

        def fmt(x: float, spec: str, unit: str) -> str:
            return f"{x:{spec}} {unit}" if math.isfinite(x) else "—"

        v["cadence"].setText(fmt(g.cadence_derived_steps_per_min, ".0f", "steps/min"))
        v["stride"].setText(fmt(g.last_stride_time_s, ".2f", "s"))
        v["stance"].setText(fmt(g.last_stance_pct, ".0f", "%"))
        v["strides"].setText(str(g.n_strides))
        if g.n_strides != self._shown_strides:
            self._shown_strides = g.n_strides
            k = len(g.cycles_deg)
            self.cycle_title.setText(
                f"Gait cycle: mean ± SD of the last {k} strides (band), current stride (line)"
                if k
                else "Gait cycle: waiting for complete strides…"
            )
        self.cycles.update_from(snap)

    # ------------------------------------------------------------------------------------
    # recording, markers, zero, settings
    # ------------------------------------------------------------------------------------

    @guarded
    def toggle_recording(self) -> None:
        if self._recording:
            self.stop_recording()
        else:
            self.open_session_dialog()

    @guarded
    def open_session_dialog(self) -> None:
        if self.conn is None:
            self.notify("Connect to a unit before recording.")
            return
        if self.session_dialog is not None and self.session_dialog.isVisible():
            self.session_dialog.raise_()
            return
        p = self.prefs
        folder = Path(p.get("session/folder", str(default_session_folder())))
        ident = self.conn.engine.identity
        side = p.get("session/side", "") or (ident.side if ident else "")
        dlg = SessionDialog(
            self,
            folder=folder,
            patient_id=p.get("session/patient_id", ""),
            side=side,
            operator=p.get("session/operator", ""),
        )
        dlg.accepted.connect(self._session_accepted)
        self.session_dialog = dlg
        dlg.open()

    @guarded
    def _session_accepted(self) -> None:
        dlg = self.session_dialog
        conn = self.conn
        if dlg is None or dlg.result_form is None:
            return
        form = dlg.result_form
        if conn is None:
            self.notify("The unit was disconnected; nothing is recorded.")
            return
        try:
            from gaitmon.io.session import SessionMeta
        except ImportError:
            self.notify("Recording is not available in this installation (no session writer).")
            return
        meta = SessionMeta(
            patient_id=form.patient_id, side=form.side, operator=form.operator, notes=form.notes
        )
        try:
            conn.engine.start_recording(form.path, meta)
        except EngineError as exc:
            self.notify(f"Could not start recording: {one_line(exc)}", 30_000)
            return
        p = self.prefs
        p.set("session/folder", str(form.path.parent))
        p.set("session/operator", form.operator)
        p.set("session/side", form.side)
        p.set("session/patient_id", form.patient_id)
        self._recording = True
        self.record_banner.setVisible(False)
        self._update_controls()
        self.notify(f"Recording to {form.path}")

    @guarded
    def stop_recording(self) -> None:
        conn = self.conn
        if conn is None or not self._recording:
            return
        self._recording = False
        status = conn.engine.stop_recording()
        self._update_controls()
        self.rec_label.setText("")
        if status.error:
            self.notify(f"Recording stopped with an error: {status.error}", 30_000)
        else:
            self.notify(
                f"Recording saved: {status.path} ({status.rows:,} frames, "
                f"{_fmt_bytes(status.file_bytes)}, {_fmt_elapsed(status.elapsed_s)})",
                30_000,
            )

    @property
    def recording(self) -> bool:
        return self._recording

    @guarded
    def add_marker(self) -> None:
        conn = self.conn
        if conn is None:
            self.notify("Connect to a unit before dropping markers.")
            return
        label = self.marker_edit.text().strip()
        conn.engine.add_marker(label)
        self.marker_edit.clear()
        where = " (saved in the recording)" if self._recording else ""
        self.notify(f"Marker {label!r} dropped{where}." if label else f"Marker dropped{where}.")

    @guarded
    def zero(self) -> None:
        conn = self.conn
        if conn is None:
            self.notify("Connect to a unit before zeroing.")
            return
        self.act_zero.setEnabled(False)
        self.notify("Zeroing: the subject stands upright and still…", 0)
        self.tasks.submit(conn.engine.zero, self._zeroed, name="zero")

    @guarded
    def _zeroed(self, _cal: Any, exc: BaseException | None) -> None:
        self._update_controls()
        if exc is None:
            self.notify("Standing pose zeroed: angles now read 0 in this pose.")
        elif isinstance(exc, EngineError):
            self.notify(f"Zero refused: {one_line(exc)}", 30_000)
        else:
            self.report_exception("zero", exc)

    @guarded
    def open_settings(self) -> None:
        note = ""
        if self.conn is not None and self.conn.engine.mode is not Mode.RAW:
            note = (
                "The unit computes the angles in this mode: these settings take effect when "
                "gaitmon computes (mode “PC computes”). They are saved now."
            )
        dlg = SettingsDialog(self, self.config, note=note)
        dlg.accepted.connect(self._settings_accepted)
        self.settings_dialog = dlg
        dlg.open()

    @guarded
    def _settings_accepted(self) -> None:
        dlg = self.settings_dialog
        if dlg is None or dlg.config is None:
            return
        cfg = dlg.config
        if self.conn is not None:
            try:
                self.conn.engine.apply_config(cfg)
            except EngineError as exc:
                self.notify(f"Settings not applied: {one_line(exc)}", 30_000)
                return
        self.config = cfg
        self.prefs.save_pipeline_config(cfg)
        self.live.set_fsr_threshold(cfg.fsr_threshold)
        logged = " and logged in the recording" if self._recording else ""
        self.notify(
            f"Settings applied{logged}: cut-off {cfg.cutoff_hz:g} Hz, Q_angle {cfg.q_angle:g}, "
            f"Q_gyro {cfg.q_gyro:g}, R {cfg.r:g}, FSR threshold {cfg.fsr_threshold:g}."
        )

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
        old_live, old_cycles, old_raw = self.live, self.cycles, self.raw
        self.live = LivePlots(colours)
        self._central_layout.replaceWidget(old_live, self.live)
        self.cycles = CyclePlots(colours)
        self.cycles.setMinimumHeight(300)
        old_cycles.parentWidget().layout().replaceWidget(old_cycles, self.cycles)
        self.raw = RawPlots(colours)
        self.raw_dock.setWidget(self.raw)
        for w in (old_live, old_cycles, old_raw):
            w.deleteLater()
        self.set_window(self.window_s if hasattr(old_live, "window_s") else 10.0)
        for key, on in old_live.methods_on.items():
            self.live.set_method(key, on)
        self.set_four_phases(old_live.four_phases)
        self.live.set_fsr_threshold(self.config.fsr_threshold)
        self._shown_strides = -1

    def shutdown(self) -> None:
        """Stop everything this window started (idempotent); the window stays open."""
        self._closing = True
        self.timer.stop()
        self.tasks.wait_all()
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
