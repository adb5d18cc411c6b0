"""The live monitor's blocking calls off the GUI thread: connecting to a unit, zeroing it.

One :class:`gaitmon.ui.jobs.QtWorker` in order (``latest=False``: connect, then zero; neither
overtakes the other). A request captures everything it needs when it is made (port, mode,
settings, the engine to zero), so the worker never reads a widget. :meth:`DeviceJobs.stop`
cancels what is pending and ends the thread; a connection that finishes opening after that is
closed (``on_stale``), so nothing started in the background outlives the window.

A connect says what it is doing: the request writes its step (:class:`ConnectSteps`: the
filters, the unit) and :class:`ConnectNotice` shows it in the status bar each quarter second
with the seconds waited (:func:`connect_text`). Preparing the filters compiles nothing (their
loops run interpreted live; numba's cache is filled in the background for long batch work,
gaitmon.engine.warmup), so the first connect after an install is as quick as any other.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from PySide6.QtCore import QObject, QTimer

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine, Mode
from gaitmon.engine.warmup import prepare_filters
from gaitmon.io.sim.config import SimConfig
from gaitmon.jobs import Response, Ticket
from gaitmon.live import connection
from gaitmon.live.connection import Connection
from gaitmon.ui.jobs import QtWorker

# ConnectSteps.step: what a connect is doing
FILTERS, UNIT = "filters", "unit"
SAY_WAIT_AFTER_S = 2.0  # a connect quicker than this is only "Connecting to X…"


@dataclass
class ConnectSteps:
    """What a connect request is doing: written by the worker, read by the GUI's timer (one
    string, replaced whole)."""

    step: str = ""  # "" (not started) | FILTERS | UNIT
    started_s: float = field(default_factory=time.monotonic)

    def prepare(self, config: PipelineConfig) -> None:
        """The filters first (their tables; nothing compiles), then the unit."""
        self.step = FILTERS
        prepare_filters(config)
        self.step = UNIT


def connect_text(label: str, step: str, waited_s: float) -> str:
    """The status bar's line while connecting to ``label``: after :data:`SAY_WAIT_AFTER_S`,
    what it waits for, with the whole seconds waited."""
    n = f" ({math.floor(waited_s)} s)" if waited_s >= SAY_WAIT_AFTER_S else ""
    if not n:
        return f"Connecting to {label}…"
    if step == FILTERS:
        return f"Connecting to {label}: preparing the filters…{n}"
    if step == UNIT:
        return f"Connecting to {label}: waiting for the unit to answer…{n}"
    return f"Connecting to {label}…{n}"


class ConnectNotice:
    """While a connect runs, its line in the status bar (``notify``), kept current; ``over``
    says when the connect has answered (then the line is left to what the answer says)."""

    def __init__(self, notify: Callable[[str, int], None], over: Callable[[], bool]) -> None:
        self._notify, self._over = notify, over
        self._label = ""
        self._steps = ConnectSteps()
        self._timer = QTimer()
        self._timer.setInterval(250)
        self._timer.timeout.connect(self._show)

    def start(self, label: str) -> ConnectSteps:
        """A connect to ``label`` begins: the steps its request writes."""
        self._label, self._steps = label, ConnectSteps()
        self._show()
        self._timer.start()
        return self._steps

    def stop(self) -> None:
        self._timer.stop()

    def _show(self) -> None:
        if self._over():
            self._timer.stop()
            return
        waited = time.monotonic() - self._steps.started_s
        self._notify(connect_text(self._label, self._steps.step, waited), 0)


@dataclass(frozen=True)
class ConnectRequest:
    """What opening a connection needs, captured on the GUI thread."""

    port: str  # a serial port path, or gaitmon.live.connection.SIMULATED_PORT
    mode: Mode
    config: PipelineConfig
    sim: SimConfig | None = None  # the simulated unit's settings (default: SimConfig())
    steps: ConnectSteps = field(default_factory=ConnectSteps)  # what it is doing, for the bar

    def __call__(self, ticket: Ticket) -> Connection:
        self.steps.prepare(self.config)
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
