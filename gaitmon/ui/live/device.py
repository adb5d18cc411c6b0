"""The live window's device part: the Connection toolbar (ports, mode, Connect), connect /
disconnect one unit, zero, the simulator's link, its subject (stand still / walk again) and its
foot sensors (dead heel, toe stuck loaded).

Connecting and zeroing block (the unit identifies itself, the engine checks the pose), so they
are requests to :class:`~gaitmon.ui.live.jobs.DeviceJobs` whose typed responses arrive here on
the GUI thread. What the rest of the window does when a unit comes or goes (the display, LSL)
is the window's: it hands :class:`DevicePart` those steps as callbacks.
"""

from __future__ import annotations

import logging
import math
import os
import re
import sys
from collections.abc import Callable

from PySide6.QtCore import QSize, Qt, QTimer
from PySide6.QtGui import QAction
from PySide6.QtWidgets import QComboBox, QLabel, QMainWindow, QMenu, QToolBar, QToolButton

from gaitmon.dsp.calibration import Calibration
from gaitmon.engine import EngineError, Mode
from gaitmon.io.bluetooth import BT_SCHEME, parse_bt_url
from gaitmon.io.sim.config import SimConfig
from gaitmon.jobs import Response
from gaitmon.live.connection import (
    SIMULATED_LABEL,
    SIMULATED_PORT,
    Connection,
    available_ports,
)
from gaitmon.review.settings import LiveKey
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.live.actions import MODES, SIM_FSR_FAULTS
from gaitmon.ui.live.context import LiveContext
from gaitmon.ui.live.jobs import ConnectRequest

log = logging.getLogger("gaitmon.ui")

# the one-leg simulator's actions (a pair cannot stand on request, nor break a sensor)
MAX_RECENT_PORTS = 8
_WINDOWS_PORT = re.compile(r"^(\\\\\.\\)?COM\d+$", re.IGNORECASE)


def port_problem(port: str) -> str:
    """Why a typed ``port`` cannot be connected to, in one line ("" when it can be tried): a
    ``bt://`` address must parse, a serial port must exist (Windows: COMn)."""
    if port == SIMULATED_PORT:
        return ""
    if port.lower().startswith(BT_SCHEME):
        try:
            parse_bt_url(port)
        except ValueError as exc:
            return str(exc)
        return ""
    if sys.platform == "win32" and _WINDOWS_PORT.match(port):
        return ""
    if not os.path.exists(port):
        return (f"No port {port!r}: type a serial port (such as /dev/ttyUSB0 or a "
                "'gaitmon simulate --pty' path) or bt://AA:BB:CC:DD:EE:FF")  # fmt: skip
    return ""


ONE_LEG_SIM_ACTIONS = ("cut", "restore", "stall", "sim_stand", "sim_walk",
                       *(f"sim_{key}" for key, _text, _tip in SIM_FSR_FAULTS))  # fmt: skip


class DevicePart:
    """Slots of the Device menu and the Connection toolbar, for one unit. ``started``: the
    window's steps once a unit is connected; ``stopping`` / ``stopped``: before and after its
    engine is closed (the display timer, the LSL outlets)."""

    def __init__(
        self,
        ctx: LiveContext,
        window: QMainWindow,
        actions: dict[str, QAction],
        sim_menu: QMenu,
        *,
        sim: SimConfig | None,
        started: Callable[[], None],
        stopping: Callable[[], None],
        stopped: Callable[[], None],
    ) -> None:
        self.ctx = ctx
        self.window = window
        self.actions = actions
        self.sim_menu = sim_menu
        self.sim = sim  # the simulated unit's settings (default: SimConfig())
        self.sim_fsr_actions = {key: actions[f"sim_{key}"] for key, _t, _tip in SIM_FSR_FAULTS}
        self._started, self._stopping, self._stopped = started, stopping, stopped
        self._restore_timer: QTimer | None = None
        self.port_combo = QComboBox()
        self.port_combo.setEditable(True)  # a port not listed: typed (a pty, a bt:// address)
        self.port_combo.setInsertPolicy(QComboBox.InsertPolicy.NoInsert)
        self.port_combo.setMinimumContentsLength(28)
        self.port_combo.setSizeAdjustPolicy(
            QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon
        )
        self.port_combo.setToolTip(
            "The unit's serial port (Bluetooth SPP shows up as one). Not listed? Type its path "
            "(e.g. a 'gaitmon simulate --pty' port) or bt://AA:BB:CC:DD:EE:FF"
        )
        line = self.port_combo.lineEdit()
        if line is not None:
            line.setPlaceholderText("port path or bt://address")
            line.returnPressed.connect(lambda: actions["connect"].trigger())
        self.mode_combo = QComboBox()
        for mode, text, tip in MODES:
            self.mode_combo.addItem(text, mode.value)
            self.mode_combo.setItemData(
                self.mode_combo.count() - 1, tip, Qt.ItemDataRole.ToolTipRole
            )
        self.mode_combo.setToolTip("What the unit sends (choose before connecting)")

    def report_exception(self, where: str, exc: BaseException) -> None:
        self.ctx.report_exception(where, exc)

    def build_toolbar(self) -> QToolBar:
        """The Connection toolbar: Unit (ports, refresh), Mode, Connect."""
        tb = QToolBar("Connection", self.window)
        tb.setObjectName("toolbar-connection")
        tb.setIconSize(QSize(16, 16))
        tb.addWidget(QLabel(" Unit "))
        tb.addWidget(self.port_combo)
        refresh = QToolButton()
        refresh.setDefaultAction(self.actions["refresh"])
        refresh.setText("⟳")
        tb.addWidget(refresh)
        tb.addWidget(QLabel("  Mode "))
        tb.addWidget(self.mode_combo)
        self.connect_button = QToolButton()
        self.connect_button.setDefaultAction(self.actions["connect"])
        self.connect_button.setToolButtonStyle(Qt.ToolButtonStyle.ToolButtonTextOnly)
        self.connect_button.setMinimumWidth(90)
        tb.addWidget(self.connect_button)
        return tb

    def restore(self, mode: Mode | str | None) -> None:
        """The ports, the last port and the mode (``mode`` given: that one)."""
        p = self.ctx.prefs
        self.refresh_ports()
        last = p.get(LiveKey.LAST_PORT)
        self.select_port(last)
        mode_value = Mode(mode).value if mode is not None else p.get(LiveKey.MODE)
        self.mode_combo.setCurrentIndex(max(self.mode_combo.findData(mode_value), 0))

    @property
    def mode(self) -> Mode:
        return Mode(self.mode_combo.currentData())

    def update_controls(self) -> None:
        ctx, acts = self.ctx, self.actions
        connected, busy = ctx.connected, ctx.connecting
        acts["connect"].setText(
            "Connecting…" if busy else ("Disconnect" if connected else "Connect")
        )
        acts["connect"].setEnabled(not busy)
        self.port_combo.setEnabled(not connected and not busy)
        self.mode_combo.setEnabled(not connected and not busy)
        acts["refresh"].setEnabled(not connected and not busy)
        acts["zero"].setEnabled(connected)
        one_sim = ctx.conn is not None and ctx.conn.simulated
        pair_sim = ctx.pair is not None and ctx.pair.simulated
        self.sim_menu.setEnabled(one_sim or pair_sim)
        for name in ONE_LEG_SIM_ACTIONS:
            acts[name].setEnabled(ctx.pair is None)
        for name in ("cut", "restore", "stall"):
            acts[name].setEnabled(one_sim)

    def recent_ports(self) -> list[str]:
        """The typed ports connected to before, newest first."""
        text = str(self.ctx.prefs.get(LiveKey.RECENT_PORTS) or "")
        return [p for p in text.split("\n") if p]

    def _remember_port(self, port: str) -> None:
        if port == SIMULATED_PORT:
            return
        recent = [port, *(p for p in self.recent_ports() if p != port)][:MAX_RECENT_PORTS]
        self.ctx.prefs.set(LiveKey.RECENT_PORTS, "\n".join(recent))
        if self.port_combo.findData(port) < 0:
            self._add_recent_item(port)

    def _add_recent_item(self, port: str) -> None:
        self.port_combo.addItem(f"{port} (recent)", port)
        self.port_combo.setItemData(
            self.port_combo.count() - 1, f"{port}: connected to before (typed)",
            Qt.ItemDataRole.ToolTipRole,
        )  # fmt: skip

    def select_port(self, port: str | None) -> None:
        """Show ``port``: its entry when listed, else typed in the field."""
        if not port:
            return
        idx = self.port_combo.findData(port)
        if idx >= 0:
            self.port_combo.setCurrentIndex(idx)
        else:
            self.port_combo.setEditText(port)

    def current_port(self) -> str:
        """The port to connect to: the entry chosen, or the text typed ("" none)."""
        combo = self.port_combo
        text = combo.currentText().strip()
        idx = combo.currentIndex()
        if idx >= 0 and combo.itemText(idx) == text:
            return str(combo.itemData(idx) or "")
        idx = combo.findText(text)
        if idx >= 0:
            return str(combo.itemData(idx) or "")
        return text

    @guarded
    def refresh_ports(self) -> None:
        current = self.current_port()
        self.port_combo.clear()
        listed = available_ports()
        for p in listed:
            self.port_combo.addItem(p.friendly(), p.device)
            self.port_combo.setItemData(
                self.port_combo.count() - 1, p.device, Qt.ItemDataRole.ToolTipRole
            )
        for port in self.recent_ports():
            if port not in {p.device for p in listed}:
                self._add_recent_item(port)
        self.port_combo.addItem(SIMULATED_LABEL, SIMULATED_PORT)
        self.port_combo.setItemData(
            self.port_combo.count() - 1,
            "A simulated unit on a pseudo-terminal in this program: a subject stands, then "
            "walks. Device ▸ Simulator cuts its link and makes the subject stand still.",
            Qt.ItemDataRole.ToolTipRole,
        )
        idx = self.port_combo.findData(current) if current else -1
        if idx < 0 and current:
            self.port_combo.setEditText(current)  # a typed port stays typed
        else:
            self.port_combo.setCurrentIndex(max(idx, 0))

    @guarded
    def connect_device(self, port: str | None = None) -> None:
        ctx = self.ctx
        if ctx.connected or ctx.connecting:
            return
        if port is not None:
            self.select_port(port)
        port = port or self.current_port()
        if not port:
            ctx.notify("No port selected: choose the unit's port or the simulated device.")
            return
        problem = port_problem(port) if self.port_combo.findData(port) < 0 else ""  # typed
        if problem:
            ctx.notify(problem, 30_000)
            return
        steps = ctx.begin_connect(self.port_combo.currentText(), "Connecting…")
        ctx.jobs.connect(ConnectRequest(port, self.mode, ctx.config, self.sim, steps),
                         self._connected)  # fmt: skip

    @guarded
    def _connected(self, response: Response[Connection]) -> None:
        ctx = self.ctx
        conn = ctx.opened(response, "connect")
        if conn is None:
            return
        ctx.conn = conn
        ctx.prefs.set(LiveKey.LAST_PORT, conn.port)
        self._remember_port(conn.port)
        ctx.prefs.set(LiveKey.MODE, conn.engine.mode.value)
        ctx.status.connected()
        for act in self.sim_fsr_actions.values():  # a new simulated unit has working sensors
            act.setChecked(False)
        ident = conn.engine.identity
        who = f"{ident.name} {ident.firmware} #{ident.serial} ({ident.side})" if ident else ""
        ctx.notify(f"Connected to {conn.label} {who}".strip())
        self._started()

    @guarded
    def disconnect_device(self) -> None:
        ctx = self.ctx
        conn = ctx.conn
        if conn is None:
            return
        ctx.wait_saved()  # a Stop's file is finished before its engine goes
        self._stopping()
        ctx.conn = None
        if self._restore_timer is not None:
            self._restore_timer.stop()
            self._restore_timer = None
        was_recording = ctx.recording
        ctx.recording = False
        try:
            status = conn.engine.stop_recording() if was_recording else None
        finally:
            try:
                conn.close()
            finally:
                self._stopped()  # after the engine's end: its last event went out
        ctx.status.disconnected()
        ctx.controls_changed()
        if status is not None:
            ctx.notify(f"Recording saved: {status.path} ({status.rows} frames). Disconnected.")
        else:
            ctx.notify("Disconnected.")

    @guarded
    def zero(self) -> None:
        ctx = self.ctx
        conn = ctx.conn
        if conn is None:
            ctx.notify("Connect to a unit before zeroing.")
            return
        self.actions["zero"].setEnabled(False)
        ctx.notify("Zeroing: the subject stands upright and still…", 0)
        ctx.jobs.zero(conn.engine, self._zeroed)

    @guarded
    def _zeroed(self, response: Response[Calibration]) -> None:
        ctx = self.ctx
        ctx.controls_changed()
        exc = response.error
        if exc is None:
            ctx.status_bar.setToolTip("")
            ctx.notify("Standing pose zeroed: angles now read 0 in this pose.")
        elif isinstance(exc, EngineError):
            # the clinician's sentence in the bar; the figures behind it in the tooltip
            ctx.status_bar.setToolTip(getattr(exc.__cause__, "detail", "") or one_line(exc))
            ctx.notify(f"Zero refused. {one_line(exc)}", 30_000)
        else:
            ctx.report_exception("zero", exc)

    @guarded
    def cut_simulated_link(self, duration_s: float = 3.0) -> None:
        conn = self.ctx.conn
        if conn is None or conn.simulator is None:
            self.ctx.notify("The link can only be cut on the simulated device.")
            return
        conn.simulator.cut()
        self.ctx.notify(f"Simulated link cut for {duration_s:g} s.")
        if self._restore_timer is not None:
            self._restore_timer.stop()
        t = QTimer(self.window)
        t.setSingleShot(True)
        t.timeout.connect(self.restore_simulated_link)
        t.start(round(duration_s * 1000))
        self._restore_timer = t

    @guarded
    def stall_simulated_link(self, duration_s: float = 5.0) -> None:
        """Device ▸ Simulator ▸ Stall link: the simulated unit holds its frames, then sends
        the backlog (io.sim: ``SimulatedUnit.stall``)."""
        conn = self.ctx.conn
        if conn is None or conn.unit is None:
            self.ctx.notify("Only the simulated device's link can be stalled.")
            return
        conn.unit.stall(duration_s)
        self.ctx.notify(f"Simulated unit holds its data for {duration_s:g} s, then sends it all.")

    @guarded
    def restore_simulated_link(self) -> None:
        conn = self.ctx.conn
        if self._restore_timer is not None:
            self._restore_timer.stop()
            self._restore_timer = None
        if conn is None or conn.simulator is None:
            return
        conn.simulator.restore()
        self.ctx.notify("Simulated link restored; the window reconnects by itself.")

    @guarded
    def set_simulated_standing(self, standing: bool) -> None:
        """Device ▸ Simulator ▸ Stand still / Walk again (the simulated subject, in process)."""
        conn = self.ctx.conn
        unit = conn.unit if conn is not None else None
        if unit is None:
            self.ctx.notify("Only the simulated subject can be told to stand still or walk.")
            return
        if standing:
            stands_at_s = unit.stand_still()
            wait_s = max(0.0, stands_at_s - unit.device_time_s) / unit.speed
            # short: it must fit the status bar beside its labels at 1400 px (the walk-through
            # test); the menu path is in the action's tooltip and the guide's hint
            self.ctx.notify(
                f"The simulated subject stands still within {math.ceil(wait_s)} s: zero then."
            )
        else:
            unit.walk()
            self.ctx.notify("The simulated subject walks again.")

    @guarded
    def set_simulated_fsr_fault(self, key: str, on: bool) -> None:
        """Device ▸ Simulator ▸ Heel sensor dead / Toe sensor stuck loaded (checkable)."""
        conn = self.ctx.conn
        unit = conn.unit if conn is not None else None
        if unit is None:
            self.sim_fsr_actions[key].setChecked(False)
            self.ctx.notify("Only the simulated unit's foot sensors can be broken.")
            return
        heel_dead, toe_stuck = unit.foot_sensor_fault
        if key == "heel_dead":
            heel_dead = bool(on)
        else:
            toe_stuck = bool(on)
        unit.set_foot_sensor_fault(heel_dead, toe_stuck)
        faults = (("the heel sensor is dead", heel_dead), ("the toe sensor is stuck", toe_stuck))
        broken = [what for what, bad in faults if bad]
        self.ctx.notify(
            f"Simulated foot sensors: {' and '.join(broken)}." if broken
            else "Simulated foot sensors work again."
        )  # fmt: skip
