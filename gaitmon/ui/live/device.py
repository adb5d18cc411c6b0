"""The live monitor's device slots: ports, connect / disconnect, zero, the simulator's link, its
subject (stand still / walk again) and its foot sensors (dead heel, toe stuck loaded).

Connecting and zeroing block (the unit identifies itself, the engine checks the pose), so they
are requests to :class:`~gaitmon.ui.live.jobs.DeviceJobs` whose typed responses arrive here on
the GUI thread.
"""

from __future__ import annotations

import logging
import math

from PySide6.QtCore import Qt, QTimer

from gaitmon.dsp.calibration import Calibration
from gaitmon.engine import EngineError, Mode
from gaitmon.jobs import Response
from gaitmon.live.connection import (
    SIMULATED_LABEL,
    SIMULATED_PORT,
    Connection,
    available_ports,
)
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.live.base import LiveWindowBase
from gaitmon.ui.live.jobs import ConnectRequest

log = logging.getLogger("gaitmon.ui")


class DeviceSlots(LiveWindowBase):
    """Slots of the Device menu and the connection toolbar."""

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
            "walks. Device ▸ Simulator cuts its link and makes the subject stand still.",
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
        request = ConnectRequest(port, Mode(self.mode_combo.currentData()), self.config, self.sim)
        self._connecting = True
        self.status.set_state_pill("Connecting…", "warn")
        self._update_controls()
        self.notify(f"Connecting to {self.port_combo.currentText()}…", 0)
        self.jobs.connect(request, self._connected)

    @guarded
    def _connected(self, response: Response[Connection]) -> None:
        self._connecting = False
        exc = response.error
        conn = response.value
        if exc is not None or conn is None:
            self.status.set_state_pill("Disconnected", "ok")
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
        self.status.connected()
        for act in self.sim_fsr_actions.values():  # a new simulated unit has working sensors
            act.setChecked(False)
        self.gait_panel.clear()
        self.live.clear_data()
        self.raw.clear_data()
        ident = conn.engine.identity
        who = f"{ident.name} {ident.firmware} #{ident.serial} ({ident.side})" if ident else ""
        self.notify(f"Connected to {conn.label} {who}".strip())
        self._update_controls()
        self.timer.start()
        self._tick()
        self._lsl_connected()

    @guarded
    def disconnect_device(self) -> None:
        conn = self.conn
        if conn is None:
            return
        self._wait_saved()  # a Stop's file is finished before its engine goes
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
            try:
                conn.close()
            finally:
                self._lsl_stop()  # after the engine's end: its last event went out
        self.status.disconnected()
        self._update_controls()
        if status is not None:
            self.notify(f"Recording saved: {status.path} ({status.rows} frames). Disconnected.")
        else:
            self.notify("Disconnected.")

    @guarded
    def zero(self) -> None:
        conn = self.conn
        if conn is None:
            self.notify("Connect to a unit before zeroing.")
            return
        self.act_zero.setEnabled(False)
        self.notify("Zeroing: the subject stands upright and still…", 0)
        self.jobs.zero(conn.engine, self._zeroed)

    @guarded
    def _zeroed(self, response: Response[Calibration]) -> None:
        self._update_controls()
        exc = response.error
        if exc is None:
            self.statusBar().setToolTip("")
            self.notify("Standing pose zeroed: angles now read 0 in this pose.")
        elif isinstance(exc, EngineError):
            # the clinician's sentence in the bar; the figures behind it in the tooltip
            self.statusBar().setToolTip(getattr(exc.__cause__, "detail", "") or one_line(exc))
            self.notify(f"Zero refused. {one_line(exc)}", 30_000)
        else:
            self.report_exception("zero", exc)

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

    @guarded
    def set_simulated_standing(self, standing: bool) -> None:
        """Device ▸ Simulator ▸ Stand still / Walk again (the simulated subject, in process)."""
        conn = self.conn
        unit = conn.unit if conn is not None else None
        if unit is None:
            self.notify("Only the simulated subject can be told to stand still or walk.")
            return
        if standing:
            stands_at_s = unit.stand_still()
            wait_s = max(0.0, stands_at_s - unit.device_time_s) / unit.speed
            self.notify(
                f"The simulated subject stops within {math.ceil(wait_s)} s and stands still "
                "until Device ▸ Simulator ▸ Walk again: zero then."
            )
        else:
            unit.walk()
            self.notify("The simulated subject walks again.")

    @guarded
    def set_simulated_fsr_fault(self, key: str, on: bool) -> None:
        """Device ▸ Simulator ▸ Heel sensor dead / Toe sensor stuck loaded (checkable)."""
        conn = self.conn
        unit = conn.unit if conn is not None else None
        if unit is None:
            self.sim_fsr_actions[key].setChecked(False)
            self.notify("Only the simulated unit's foot sensors can be broken.")
            return
        heel_dead, toe_stuck = unit.foot_sensor_fault
        if key == "heel_dead":
            heel_dead = bool(on)
        else:
            toe_stuck = bool(on)
        unit.set_foot_sensor_fault(heel_dead, toe_stuck)
        faults = (("the heel sensor is dead", heel_dead), ("the toe sensor is stuck", toe_stuck))
        broken = [what for what, bad in faults if bad]
        self.notify(
            f"Simulated foot sensors: {' and '.join(broken)}." if broken
            else "Simulated foot sensors work again."
        )  # fmt: skip
