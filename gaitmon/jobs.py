"""Off-thread work as request -> response: the one worker primitive, Qt-free.

A :class:`Worker` owns one thread. ``submit(fn, on_done)`` runs ``fn(ticket)`` there and hands a
typed :class:`Response` to ``on_done`` through ``post``, the consumer's way of running a callable
on its own thread (the GUI's event loop in ``gaitmon.ui.jobs``; calling it directly, headless).
A request captures everything it needs when it is submitted; the worker never reads the
consumer's state.

Two policies:

* ``latest=True``, *newest wins* (a view following the user: a pan overtaken by the next pan is
  never loaded). A new submit replaces a request not yet started and makes the running one stale.
* ``latest=False``, *in order* (connect, then zero): every request runs; none goes stale by a
  later submit.

Either way :meth:`Worker.cancel` makes everything submitted so far stale. A stale response is
never given to ``on_done``; ``on_stale(value)`` disposes of its value instead (closes a file or
a connection nobody wants any more), also when the worker is stopped with work still running.
``fn`` learns it is stale from :meth:`Ticket.progress` (returns False) or :meth:`Ticket.check`
(raises :class:`gaitmon.errors.Cancelled`), so long jobs stop early.
"""

from __future__ import annotations

import collections
import functools
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from gaitmon.errors import Cancelled

T = TypeVar("T")
Post = Callable[[Callable[[], None]], None]

PROGRESS_INTERVAL_S = 0.05  # at most ~20 progress reports a second reach the consumer


def _call(fn: Callable[[], None]) -> None:
    fn()


@dataclass(frozen=True)
class Response(Generic[T]):
    """What came back from one request: its value, or the exception it raised."""

    request_id: int
    value: T | None
    error: BaseException | None

    @property
    def cancelled(self) -> bool:
        return isinstance(self.error, Cancelled)

    def result(self) -> T:
        """The value; re-raises the request's exception."""
        if self.error is not None:
            raise self.error
        return self.value  # type: ignore[return-value]


@dataclass
class _Request(Generic[T]):
    request_id: int
    fn: Callable[[Ticket], T]
    on_done: Callable[[Response[T]], None]
    on_stale: Callable[[T], None] | None


class Ticket:
    """What a running request may ask: is it still wanted, and how far has it got."""

    def __init__(self, worker: Worker, request_id: int) -> None:
        self._worker = worker
        self.request_id = request_id
        self._last_report = 0.0

    @property
    def wanted(self) -> bool:
        return self._worker.wanted(self.request_id)

    def check(self) -> None:
        """Raise :class:`Cancelled` once the request is stale or cancelled."""
        if not self.wanted:
            raise Cancelled("cancelled")

    def progress(self, fraction: float) -> bool:
        """Report how far the request got (0..1, throttled); False once it is no longer wanted."""
        now = time.monotonic()
        if now - self._last_report >= PROGRESS_INTERVAL_S or fraction >= 1.0:
            self._last_report = now
            self._worker._report_progress(self.request_id, float(fraction))
        return self.wanted


class Worker:
    """One worker thread serving requests; see the module docstring."""

    def __init__(
        self,
        name: str,
        *,
        latest: bool = True,
        post: Post = _call,
        on_progress: Callable[[float], None] | None = None,
        on_busy: Callable[[bool], None] | None = None,
    ) -> None:
        self.name = name
        self.latest = latest
        self._post = post
        self._on_progress = on_progress
        self._on_busy = on_busy
        self._cond = threading.Condition()
        self._queue: collections.deque[_Request[Any]] = collections.deque()
        self._last_id = 0  # the newest request id handed out
        self._stale_upto = 0  # requests with an id up to this one are stale
        self._running: int | None = None
        self._handing = False  # the worker thread is handing a response to ``post``
        self._stopping = False
        self._busy_told = False  # consumer thread only
        self._thread = threading.Thread(target=self._loop, name=f"gaitmon-{name}", daemon=True)
        self._thread.start()

    # -- any thread ------------------------------------------------------------------------------

    def wanted(self, request_id: int) -> bool:
        with self._cond:
            return request_id > self._stale_upto and not self._stopping

    @property
    def busy(self) -> bool:
        with self._cond:
            return self._running is not None or bool(self._queue)

    # -- consumer thread -------------------------------------------------------------------------

    def submit(
        self,
        fn: Callable[[Ticket], T],
        on_done: Callable[[Response[T]], None],
        on_stale: Callable[[T], None] | None = None,
    ) -> int:
        """Queue ``fn(ticket)``; ``on_done(response)`` runs through ``post`` unless stale."""
        with self._cond:
            if self._stopping:
                raise RuntimeError(f"worker {self.name} is stopped")
            self._last_id += 1
            rid = self._last_id
            if self.latest:
                self._stale_upto = rid - 1
                self._queue.clear()
            self._queue.append(_Request(rid, fn, on_done, on_stale))
            self._cond.notify_all()
        self._tell_busy()
        return rid

    def cancel(self) -> None:
        """Drop what is queued and make the running request stale."""
        with self._cond:
            self._stale_upto = self._last_id
            self._queue.clear()
        self._tell_busy()

    def wait_idle(self, timeout_s: float = 10.0) -> bool:
        """Block until nothing runs or waits and the last response was handed to ``post`` (it may
        still be in ``post``'s queue)."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while self._running is not None or self._queue or self._handing:
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._cond.wait(left)
        return True

    def stop(self, timeout_s: float = 10.0) -> bool:
        """Cancel everything and end the thread; False if the running request did not end."""
        self.cancel()
        with self._cond:
            self._stopping = True
            self._cond.notify_all()
        self._thread.join(timeout_s)
        return not self._thread.is_alive()

    def _tell_busy(self) -> None:
        busy = self.busy
        if busy != self._busy_told:
            self._busy_told = busy
            if self._on_busy is not None:
                self._on_busy(busy)

    def _deliver(self, request: _Request[Any], response: Response[Any]) -> None:
        self._tell_busy()
        if self.wanted(request.request_id):
            request.on_done(response)
        else:
            self._dispose(request, response)

    # -- worker thread ---------------------------------------------------------------------------

    @staticmethod
    def _dispose(request: _Request[Any], response: Response[Any]) -> None:
        if request.on_stale is not None and response.error is None and response.value is not None:
            request.on_stale(response.value)

    def _report_progress(self, request_id: int, fraction: float) -> None:
        on_progress = self._on_progress
        if on_progress is None:
            return

        def report() -> None:
            if self.wanted(request_id):
                on_progress(fraction)

        self._post(report)

    def _loop(self) -> None:
        while True:
            with self._cond:
                while not self._queue and not self._stopping:
                    self._cond.wait()
                if self._stopping:
                    return
                request = self._queue.popleft()
                self._running = request.request_id
            try:
                value = request.fn(Ticket(self, request.request_id))
                response = Response(request.request_id, value, None)
            except BaseException as exc:  # handed to the consumer, which reports it
                response = Response(request.request_id, None, exc)
            with self._cond:
                self._running = None
                stopping = self._stopping
                self._handing = not stopping
                self._cond.notify_all()
            if stopping:  # nobody will read it: dispose of it here
                self._dispose(request, response)
                return
            try:
                self._post(functools.partial(self._deliver, request, response))
            finally:
                # idle only once ``post`` returned: until then this thread may hold what ``post``
                # reaches (a QtWorker it holds only weakly), and the consumer may be waiting on it
                with self._cond:
                    self._handing = False
                    self._cond.notify_all()
