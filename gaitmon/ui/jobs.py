"""The Qt delivery layer of :mod:`gaitmon.jobs`: responses and progress arrive on the GUI thread.

:class:`QtWorker` is a :class:`gaitmon.jobs.Worker` whose ``post`` queues the callable and wakes
the GUI thread with a queued signal, so ``on_done``, ``progressed`` and ``busy_changed`` always
run on the GUI thread and the worker thread never touches a widget. :meth:`QtWorker.stop` runs
what is still queued before it returns, so a connection or file opened for a request nobody
wants any more is disposed of (``on_stale``) before the window goes away.
"""

from __future__ import annotations

import collections
import threading
import weakref
from collections.abc import Callable
from typing import TypeVar

import shiboken6
from PySide6.QtCore import QObject, Qt, Signal, Slot

from gaitmon.jobs import Response, Ticket, Worker

T = TypeVar("T")


class QtWorker(QObject):
    """One worker thread whose responses are delivered on the GUI thread."""

    progressed = Signal(float)  # fraction of the current request
    busy_changed = Signal(bool)
    _posted = Signal()

    def __init__(self, name: str, *, latest: bool = True, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._pending: collections.deque[Callable[[], None]] = collections.deque()
        self._lock = threading.Lock()
        self._posted.connect(self._drain, Qt.ConnectionType.QueuedConnection)
        # The core and its thread reach this QObject only through a weak reference: a strong one
        # would make a reference cycle, and a QObject in a cycle is freed by whichever thread
        # runs the next garbage collection (an engine or worker thread), where PySide's
        # destructor can deadlock against the GUI thread's. Without the cycle it is freed here.
        # Its C++ side can also be gone while the wrapper lives (a parent window deleted it, or
        # the interpreter is exiting): then nothing is told.
        ref = weakref.ref(self)

        def me() -> QtWorker | None:
            w = ref()
            return w if w is not None and shiboken6.isValid(w) else None

        def post(fn: Callable[[], None]) -> None:
            if (w := me()) is not None:
                w._post(fn)

        def progressed(fraction: float) -> None:
            if (w := me()) is not None:
                w.progressed.emit(fraction)

        def busy_changed(busy: bool) -> None:
            if (w := me()) is not None:
                w.busy_changed.emit(busy)

        self.core = Worker(
            name, latest=latest, post=post, on_progress=progressed, on_busy=busy_changed
        )
        # dropped without stop(): its thread is told to end (not waited for)
        weakref.finalize(self, self.core.stop, 0.0)

    def submit(
        self,
        fn: Callable[[Ticket], T],
        on_done: Callable[[Response[T]], None],
        on_stale: Callable[[T], None] | None = None,
    ) -> int:
        return self.core.submit(fn, on_done, on_stale)

    def cancel(self) -> None:
        self.core.cancel()

    @property
    def busy(self) -> bool:
        return self.core.busy

    def wait_idle(self, timeout_s: float = 10.0) -> bool:
        """Block until the worker is idle, then deliver what it produced (for closing, tests)."""
        idle = self.core.wait_idle(timeout_s)
        self._drain()
        return idle

    def stop(self, timeout_s: float = 10.0) -> bool:
        stopped = self.core.stop(timeout_s)
        self._drain()
        return stopped

    def _post(self, fn: Callable[[], None]) -> None:
        with self._lock:
            self._pending.append(fn)
        self._posted.emit()

    @Slot()
    def _drain(self) -> None:
        while True:
            with self._lock:
                if not self._pending:
                    return
                fn = self._pending.popleft()
            fn()
