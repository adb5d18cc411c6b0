"""Blocking calls (connect, zero on the unit) off the GUI thread, as request -> response.

`TaskRunner.submit(fn, on_done)` runs ``fn()`` in a short-lived thread that touches no widget and
delivers ``on_done(result, exception)`` on the GUI thread through a queued signal. At shutdown,
`wait_all()` joins the threads and delivers what finished, so nothing started in the
background (an engine, a simulator) can outlive the window.
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Callable
from typing import Any

from PySide6.QtCore import QObject, Qt, Signal, Slot

Callback = Callable[[Any, BaseException | None], None]


class TaskRunner(QObject):
    _finished = Signal(int)

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._ids = itertools.count(1)
        self._threads: dict[int, threading.Thread] = {}
        self._callbacks: dict[int, Callback] = {}
        self._results: dict[int, tuple[Any, BaseException | None]] = {}
        self._lock = threading.Lock()
        self._finished.connect(self._deliver, Qt.ConnectionType.QueuedConnection)

    def submit(self, fn: Callable[[], Any], on_done: Callback, name: str = "task") -> int:
        tid = next(self._ids)
        th = threading.Thread(
            target=self._run, args=(tid, fn), name=f"gaitmon-ui-{name}-{tid}", daemon=True
        )
        with self._lock:
            self._threads[tid] = th
            self._callbacks[tid] = on_done
        th.start()
        return tid

    @property
    def busy(self) -> bool:
        with self._lock:
            return bool(self._threads)

    def _run(self, tid: int, fn: Callable[[], Any]) -> None:
        try:
            result: tuple[Any, BaseException | None] = (fn(), None)
        except BaseException as exc:  # handed to the GUI thread, which reports it
            result = (None, exc)
        with self._lock:
            self._results[tid] = result
        self._finished.emit(tid)

    @Slot(int)
    def _deliver(self, tid: int) -> None:
        with self._lock:
            th = self._threads.pop(tid, None)
            cb = self._callbacks.pop(tid, None)
            result = self._results.pop(tid, None)
        if th is not None:
            th.join()
        if cb is not None and result is not None:
            cb(*result)

    def wait_all(self, timeout_s: float = 10.0) -> None:
        """Join every running task and deliver its result now (used when closing)."""
        deadline = time.monotonic() + timeout_s
        with self._lock:
            ids = list(self._threads)
        for tid in ids:
            with self._lock:
                th = self._threads.get(tid)
            if th is not None:
                th.join(max(0.0, deadline - time.monotonic()))
            with self._lock:
                done = tid in self._results
            if done:
                self._deliver(tid)
