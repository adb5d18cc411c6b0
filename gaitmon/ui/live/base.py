"""The state the live monitor's slot groups share, and the small helpers they all call.

:class:`LiveWindowBase` declares the widgets, actions and connection state that
:class:`~gaitmon.ui.live.window.MainWindow` builds, so the slot groups (:mod:`.device`,
:mod:`.recording`) can be separate modules and still be type-checked against them. It builds
nothing itself.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from PySide6.QtCore import QTimer
from PySide6.QtGui import QAction
from PySide6.QtWidgets import QComboBox, QLineEdit, QMainWindow, QMenu

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine, Snapshot
from gaitmon.io.sim.config import SimConfig
from gaitmon.jobs import Response
from gaitmon.live.connection import Connection
from gaitmon.ui import one_line
from gaitmon.ui.dialogs import SessionDialog
from gaitmon.ui.live.jobs import DeviceJobs
from gaitmon.ui.live.prefs import Prefs
from gaitmon.ui.live.status import GaitPanel, StatusView
from gaitmon.ui.plots import LivePlots, RawPlots
from gaitmon.ui.theme import Colours

log = logging.getLogger("gaitmon.ui")


class LiveWindowBase(QMainWindow):
    """Shared state of the live monitor; see the module docstring."""

    # set by MainWindow.__init__ before any slot can run
    prefs: Prefs
    sim: SimConfig | None
    conn: Connection | None
    config: PipelineConfig
    colours: Colours
    jobs: DeviceJobs
    errors: list[str]  # unexpected exceptions caught by `guarded` (tests check)
    last_snapshot: Snapshot | None
    session_dialog: SessionDialog | None
    timer: QTimer
    status: StatusView
    gait_panel: GaitPanel
    live: LivePlots
    raw: RawPlots
    port_combo: QComboBox
    mode_combo: QComboBox
    marker_edit: QLineEdit
    sim_menu: QMenu
    act_connect: QAction
    act_refresh: QAction
    act_zero: QAction
    act_record: QAction
    act_marker: QAction
    act_pause: QAction
    act_cut: QAction
    act_restore: QAction
    sim_fsr_actions: dict[str, QAction]  # Device ▸ Simulator: foot-sensor faults, by key
    _connecting: bool
    _recording: bool
    _saving: bool  # a stopped recording's file is being finished on the device worker
    _closing: bool
    _restore_timer: QTimer | None
    _tick: Callable[[], object]  # MainWindow's ~30 Hz display update
    _lsl_connected: Callable[[], None]  # LslSlots: stream if Device ▸ Stream to LSL is on
    _lsl_stop: Callable[[], None]  # LslSlots: close the LSL outlets, if open

    def notify(self, text: str, timeout_ms: int = 10_000) -> None:
        """A one-line message in the status bar."""
        self.statusBar().showMessage(text, timeout_ms)
        log.info(text)

    def report_exception(self, where: str, exc: BaseException) -> None:
        log.error("unexpected error in %s", where, exc_info=exc)
        msg = f"Unexpected error ({where}): {one_line(exc)}"
        self.errors.append(msg)
        self.notify(msg)

    def _begin_saving(self, save: Callable[[], str]) -> None:
        """Finish a stopped recording's file on the device worker (``save`` returns the line to
        show): on a long session that takes seconds (the smoother, the stride store), and the
        window keeps drawing meanwhile; Record waits until the file is done."""
        self._saving = True
        self._update_controls()
        self.status.rec_label.setText("Saving the recording…")
        self.notify("Recording stopped; saving the file…", 0)  # (not "Recording to …")
        self.jobs.worker.submit(lambda ticket: save(), self._saved)

    def _saved(self, response: Response[str]) -> None:
        self._saving = False
        self.status.rec_label.setText("")
        self._update_controls()
        if response.error is not None:
            self.report_exception("saving the recording", response.error)
        elif response.value:
            self.notify(response.value, 30_000)

    def _wait_saved(self, timeout_s: float = 120.0) -> None:
        """Before disconnecting or closing: let a Stop's file be finished (its line is shown)."""
        if self._saving:
            self.jobs.worker.wait_idle(timeout_s)

    @property
    def engine(self) -> Engine | None:
        return self.conn.engine if self.conn is not None else None

    @property
    def recording(self) -> bool:
        return self._recording

    @property
    def saving(self) -> bool:
        """A stopped recording's file is still being finished."""
        return self._saving

    @property
    def window_s(self) -> float:
        return self.live.window_s

    @property
    def paused(self) -> bool:
        return self.act_pause.isChecked()

    @property
    def state_text(self) -> str:
        return self.status.state_text

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
        self.act_record.setEnabled(connected and not self._saving)
        self.act_record.setText("Stop" if self._recording else "Record")
        self.act_record.setToolTip(
            "Stop recording (Ctrl+R)" if self._recording else "Record a session (Ctrl+R)"
        )
        sim = connected and self.conn is not None and self.conn.simulated
        self.sim_menu.setEnabled(sim)
        self.act_cut.setEnabled(sim)
        self.act_restore.setEnabled(sim)
