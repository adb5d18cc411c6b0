"""What the live window's parts share: the preferences, the theme, the processing settings in
force, what is connected (one unit or both legs), the session's state flags, the device worker
and the one-line messages.

:class:`LiveContext` is handed to every part (:mod:`.device`, :mod:`.recording`,
:mod:`.processing`, :mod:`.lsl`, :mod:`.views`, :mod:`.pair_part`) by the window, which owns
it. It holds state, not widgets: each part owns its own widgets and slots, and reaches another
part only through the window's wiring. ``controls_changed`` is the window's callback that
brings every part's actions up to date after a change of state (connected, recording, ...).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Protocol, TypeVar

from PySide6.QtWidgets import QStatusBar

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine, EngineError, Snapshot
from gaitmon.jobs import Response
from gaitmon.live.connection import Connection
from gaitmon.live.pair import PairConnection
from gaitmon.ui import one_line
from gaitmon.ui.live.jobs import ConnectNotice, ConnectSteps, DeviceJobs
from gaitmon.ui.live.prefs import Prefs
from gaitmon.ui.live.status import StatusView
from gaitmon.ui.theme import Colours

log = logging.getLogger("gaitmon.ui")


class _Closable(Protocol):
    def close(self) -> None: ...


C = TypeVar("C", bound=_Closable)  # what a connect opens: a Connection, a PairConnection


class LiveContext:
    """The live window's shared state (module doc)."""

    def __init__(
        self,
        prefs: Prefs,
        colours: Colours,
        status_bar: QStatusBar,
        status: StatusView,
        jobs: DeviceJobs,
    ) -> None:
        self.prefs = prefs
        self.colours = colours
        self.status_bar = status_bar
        self.status = status
        self.jobs = jobs
        self.config: PipelineConfig = prefs.pipeline_config()
        self.errors: list[str] = []  # unexpected exceptions caught by `guarded` (tests check)
        self.conn: Connection | None = None  # one unit
        self.pair: PairConnection | None = None  # both legs (one unit each)
        self.last_snapshot: Snapshot | None = None  # one unit's, as last drawn
        self.connecting = False
        self.recording = False
        self.saving = False  # a stopped recording's file is being finished on the device worker
        self.closing = False
        self.controls_changed: Callable[[], None] = lambda: None  # set by the window
        # the status bar's line while a connect runs (what it waits for, and how long)
        self.connect_notice = ConnectNotice(
            self.notify, lambda: self.closing or not self.connecting
        )

    @property
    def engine(self) -> Engine | None:
        return self.conn.engine if self.conn is not None else None

    @property
    def engines(self) -> dict[str, Engine]:
        """The connected units' engines by side ("" for one unit of either leg)."""
        if self.pair is not None:
            return self.pair.engines
        return {"": self.conn.engine} if self.conn is not None else {}

    @property
    def connected(self) -> bool:
        """One unit or both legs."""
        return self.conn is not None or self.pair is not None

    def notify(self, text: str, timeout_ms: int = 10_000) -> None:
        """A one-line message in the status bar."""
        self.status_bar.showMessage(text, timeout_ms)
        log.info(text)

    def report_exception(self, where: str, exc: BaseException) -> None:
        log.error("unexpected error in %s", where, exc_info=exc)
        msg = f"Unexpected error ({where}): {one_line(exc)}"
        self.errors.append(msg)
        self.notify(msg)

    def begin_connect(self, label: str, pill: str) -> ConnectSteps:
        """A connect to ``label`` (one unit or both legs) is under way: the controls and the
        state ``pill`` say so, the status bar says what it waits for; the steps its request
        writes."""
        self.connecting = True
        self.status.set_state_pill(pill, "warn")
        self.controls_changed()
        return self.connect_notice.start(label)

    def opened(self, response: Response[C], what: str) -> C | None:
        """A connect's answer (one unit or both legs): what opened, or None when it failed
        (said in one line: ``what`` is "connect", "connect both legs") or nobody wants it any
        more (the window is closing: closed at once)."""
        self.connecting = False
        self.connect_notice.stop()
        opened = response.value
        if response.error is not None or opened is None:
            self._connect_failed(response.error, what)
            return None
        if self.closing:
            opened.close()
            return None
        return opened

    def _connect_failed(self, exc: BaseException | None, what: str) -> None:
        self.status.set_state_pill("Disconnected", "ok")
        self.controls_changed()
        if exc is not None and not isinstance(exc, EngineError):
            log.error("%s failed", what, exc_info=exc)
        why = one_line(exc) if exc is not None else "unknown reason"
        self.notify(f"Could not {what}: {why}", 30_000)

    def wait_saved(self, timeout_s: float = 120.0) -> None:
        """Before disconnecting or closing: let a Stop's file be finished (its line is shown)."""
        if self.saving:
            self.jobs.worker.wait_idle(timeout_s)
