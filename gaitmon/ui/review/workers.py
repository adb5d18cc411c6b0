"""Background work for the review window as request -> worker -> response on the GUI thread.

A :class:`LatestWorker` owns one thread. ``submit(fn, on_done)`` replaces any request not yet
started (only the newest matters: a pan that was overtaken by the next pan is never loaded),
and a response that arrives after a newer submit (or :meth:`cancel`) is dropped on the GUI
thread, so stale data never reaches a plot. ``fn(ticket)`` gets a :class:`Ticket` whose
``progress(fraction)`` reports to the GUI (throttled) and returns False once the request is
stale or cancelled, which long jobs use to stop early. The worker never touches a widget.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from PySide6.QtCore import QObject, Qt, Signal, Slot

Done = Callable[[Any, BaseException | None], None]


class Ticket:
    """What a running request may ask: is it still wanted, and how far it got."""

    def __init__(self, worker: LatestWorker, gen: int) -> None:
        self._worker = worker
        self.gen = gen
        self._last_emit = 0.0

    @property
    def wanted(self) -> bool:
        return self._worker.generation == self.gen and not self._worker.stopping

    def progress(self, fraction: float) -> bool:
        now = time.monotonic()
        if now - self._last_emit > 0.05 or fraction >= 1.0:
            self._last_emit = now
            self._worker._progressed.emit(self.gen, float(fraction))
        return self.wanted


class LatestWorker(QObject):
    """One worker thread serving the newest request; see the module docstring."""

    progressed = Signal(float)  # fraction of the current request, on the GUI thread
    busy_changed = Signal(bool)
    _finished = Signal(int, object, object, object)
    _progressed = Signal(int, float)

    def __init__(self, name: str, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.name = name
        self.generation = 0
        self.stopping = False
        self._cond = threading.Condition()
        self._pending: tuple[int, Callable[[Ticket], Any], Done, Callable | None] | None = None
        self._running = False
        self._busy = False
        self._finished.connect(self._deliver, Qt.ConnectionType.QueuedConnection)
        self._progressed.connect(self._on_progress, Qt.ConnectionType.QueuedConnection)
        self._thread = threading.Thread(
            target=self._loop, name=f"gaitmon-review-{name}", daemon=True
        )
        self._thread.start()

    # -- GUI thread ----------------------------------------------------------------------------

    def submit(
        self,
        fn: Callable[[Ticket], Any],
        on_done: Done,
        on_stale: Callable[[Any], None] | None = None,
    ) -> int:
        """Run ``fn(ticket)`` after what is running now; ``on_stale(result)`` disposes of a
        result nobody wants any more (e.g. closes a file opened for a superseded request)."""
        with self._cond:
            self.generation += 1
            self._pending = (self.generation, fn, on_done, on_stale)
            self._cond.notify()
        self._set_busy(True)
        return self.generation

    def cancel(self) -> None:
        """Drop the pending request and make the running one stale."""
        with self._cond:
            self.generation += 1
            self._pending = None
        self._set_busy(self._running)

    @property
    def busy(self) -> bool:
        with self._cond:
            return self._running or self._pending is not None

    def wait_idle(self, timeout_s: float = 10.0) -> bool:
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while self._running or self._pending is not None:
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._cond.wait(left)
        return True

    def stop(self, timeout_s: float = 10.0) -> None:
        self.cancel()
        with self._cond:
            self.stopping = True
            self._cond.notify_all()
        self._thread.join(timeout_s)

    def _set_busy(self, busy: bool) -> None:
        if busy != self._busy:
            self._busy = busy
            self.busy_changed.emit(busy)

    @Slot(int, object, object, object)
    def _deliver(self, gen: int, result: Any, exc: Any, callbacks: Any) -> None:
        on_done, on_stale = callbacks
        if gen != self.generation or self.stopping:
            if on_stale is not None and exc is None and result is not None:
                on_stale(result)
            return
        self._set_busy(self.busy)
        on_done(result, exc)

    @Slot(int, float)
    def _on_progress(self, gen: int, fraction: float) -> None:
        if gen == self.generation:
            self.progressed.emit(fraction)

    # -- worker thread -------------------------------------------------------------------------

    def _loop(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self.stopping:
                    self._cond.wait()
                if self.stopping:
                    return
                gen, fn, on_done, on_stale = self._pending  # type: ignore[misc]
                self._pending = None
                self._running = True
            try:
                result, exc = fn(Ticket(self, gen)), None
            except BaseException as e:  # handed to the GUI thread, which reports it
                result, exc = None, e
            with self._cond:
                self._running = False
                self._cond.notify_all()
            if self.stopping:
                if on_stale is not None and exc is None and result is not None:
                    on_stale(result)
                return
            self._finished.emit(gen, result, exc, (on_done, on_stale))
