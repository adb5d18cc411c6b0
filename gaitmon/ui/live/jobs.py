"""The live monitor's blocking calls off the GUI thread: connecting to a unit, zeroing it.

One :class:`gaitmon.ui.jobs.QtWorker` in order (``latest=False``: connect, then zero; neither
overtakes the other). A request captures everything it needs when it is made (port, mode,
settings, the engine to zero), so the worker never reads a widget. :meth:`DeviceJobs.stop`
cancels what is pending and ends the thread; a connection that finishes opening after that is
closed (``on_stale``), so nothing started in the background outlives the window.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from PySide6.QtCore import QObject

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine, Mode
from gaitmon.io.sim.config import SimConfig
from gaitmon.jobs import Response, Ticket
from gaitmon.live import connection
from gaitmon.live.connection import Connection
from gaitmon.ui.jobs import QtWorker


@dataclass(frozen=True)
class ConnectRequest:
    """What opening a connection needs, captured on the GUI thread."""

    port: str  # a serial port path, or gaitmon.live.connection.SIMULATED_PORT
    mode: Mode
    config: PipelineConfig
    sim: SimConfig | None = None  # the simulated unit's settings (default: SimConfig())

    def __call__(self, ticket: Ticket) -> Connection:
        return connection.open_connection(self.port, self.mode, self.config, sim=self.sim)


class DeviceJobs:
    """Connect and zero requests, answered on the GUI thread with a typed Response."""

    def __init__(self, parent: QObject | None = None) -> None:
        self.worker = QtWorker("live-device", latest=False, parent=parent)

    @property
    def busy(self) -> bool:
        return self.worker.busy

    def connect(
        self, request: ConnectRequest, on_done: Callable[[Response[Connection]], None]
    ) -> int:
        # a connection nobody wants any more (the window closed meanwhile) is closed at once
        return self.worker.submit(request, on_done, on_stale=Connection.close)

    def zero(self, engine: Engine, on_done: Callable[[Response[Calibration]], None]) -> int:
        def run(ticket: Ticket) -> Calibration:
            return engine.zero()

        return self.worker.submit(run, on_done)

    def stop(self, timeout_s: float = 10.0) -> bool:
        """Cancel and end the thread; what finishes afterwards is disposed of, not delivered."""
        return self.worker.stop(timeout_s)
