"""The one worker primitive (gaitmon.jobs), headless: newest wins, in order, cancel, progress."""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable

import pytest

from gaitmon.errors import Cancelled
from gaitmon.jobs import Response, Ticket, Worker


class Consumer:
    """Stands for the GUI thread: posted callables wait here until drained by the test."""

    def __init__(self) -> None:
        self.q: queue.Queue[Callable[[], None]] = queue.Queue()
        self.progress: list[float] = []
        self.busy: list[bool] = []

    def post(self, fn: Callable[[], None]) -> None:
        self.q.put(fn)

    def drain(self, worker: Worker) -> None:
        assert worker.wait_idle(5.0)
        while not self.q.empty():
            self.q.get()()


def make(latest: bool) -> tuple[Worker, Consumer]:
    c = Consumer()
    w = Worker("test", latest=latest, post=c.post, on_progress=c.progress.append,
               on_busy=c.busy.append)  # fmt: skip
    return w, c


def test_newest_wins_the_overtaken_request_is_disposed_and_the_pending_one_never_runs() -> None:
    w, c = make(latest=True)
    started, release = threading.Event(), threading.Event()
    ran: list[str] = []
    done: list[Response[str]] = []
    stale: list[str] = []

    def slow(t: Ticket) -> str:
        started.set()
        release.wait(5)
        ran.append("a")
        return "a"

    def quick(name: str) -> Callable[[Ticket], str]:
        def fn(t: Ticket) -> str:
            ran.append(name)
            return name
        return fn

    w.submit(slow, done.append, stale.append)
    assert started.wait(5)
    w.submit(quick("b"), done.append, stale.append)
    rc = w.submit(quick("c"), done.append, stale.append)
    release.set()
    c.drain(w)
    w.stop()
    assert ran == ["a", "c"]  # b was replaced before it started
    assert [r.value for r in done] == ["c"] and done[0].request_id == rc
    assert stale == ["a"]
    assert c.busy == [True, False]


def test_in_order_policy_runs_and_delivers_every_request() -> None:
    w, c = make(latest=False)
    done: list[Response[int]] = []
    for k in range(5):
        w.submit(lambda t, k=k: k * k, done.append)
    c.drain(w)
    w.stop()
    assert [r.value for r in done] == [0, 1, 4, 9, 16]
    assert all(r.error is None for r in done)


def test_cancel_makes_the_running_request_stale_and_check_raises() -> None:
    w, c = make(latest=True)
    started, release = threading.Event(), threading.Event()
    seen: list[bool] = []
    done: list[Response[None]] = []

    def job(t: Ticket) -> None:
        started.set()
        release.wait(5)
        seen.append(t.wanted)
        t.check()

    w.submit(job, done.append)
    assert started.wait(5)
    w.cancel()
    release.set()
    c.drain(w)
    w.stop()
    assert seen == [False]
    assert done == []  # a cancelled request reaches nobody


def test_errors_come_back_typed_and_result_reraises() -> None:
    w, c = make(latest=False)
    done: list[Response[int]] = []

    def bad(t: Ticket) -> int:
        raise ValueError("bad block")

    w.submit(bad, done.append)
    w.submit(lambda t: (_ for _ in ()).throw(Cancelled("x")), done.append)
    c.drain(w)
    w.stop()
    assert isinstance(done[0].error, ValueError) and done[0].value is None
    with pytest.raises(ValueError, match="bad block"):
        done[0].result()
    assert done[1].cancelled and not done[0].cancelled


def test_progress_reaches_the_consumer_only_for_the_current_request() -> None:
    w, c = make(latest=True)
    gate = threading.Event()

    def job(t: Ticket) -> int:
        for k in range(1, 5):
            t.progress(k / 4)
        gate.wait(5)
        return 1

    w.submit(job, lambda r: None)
    while w.busy and c.q.qsize() < 2:  # wait until at least the first and last report posted
        threading.Event().wait(0.01)
    w.cancel()  # the reports already posted are now stale
    gate.set()
    c.drain(w)
    assert c.progress == []
    w.submit(job, lambda r: None)
    c.drain(w)
    w.stop()
    assert c.progress[-1] == 1.0 and c.progress == sorted(c.progress)


def test_stop_disposes_of_a_result_that_arrives_afterwards() -> None:
    w, c = make(latest=True)
    started = threading.Event()
    stale: list[str] = []

    def job(t: Ticket) -> str:
        started.set()
        threading.Event().wait(0.2)
        return "connection"

    w.submit(job, lambda r: pytest.fail("delivered after stop"), stale.append)
    assert started.wait(5)
    assert w.stop(5)
    c.drain(w)
    assert stale == ["connection"]
    with pytest.raises(RuntimeError, match="stopped"):
        w.submit(job, lambda r: None)


def test_wait_idle_returns_only_once_the_last_response_was_handed_to_post() -> None:
    """A worker thread still inside ``post`` holds what ``post`` reaches (a QtWorker's strong
    reference): ``wait_idle`` returned before ``post`` did, and a QtWorker dropped just then was
    kept alive by the worker thread (one CI failure)."""
    handed: list[Callable[[], None]] = []

    def slow_post(fn: Callable[[], None]) -> None:
        threading.Event().wait(0.3)
        handed.append(fn)

    w = Worker("handing", post=slow_post)
    try:
        w.submit(lambda t: 7, lambda r: None)
        assert w.wait_idle(5.0)
        assert len(handed) == 1
    finally:
        w.stop(5.0)


def test_a_qt_worker_is_freed_by_its_last_reference_not_by_a_garbage_collection(qapp) -> None:
    """No reference cycle through the core: a QtWorker in a cycle would be freed by whichever
    thread runs the next collection, where PySide's destructor can deadlock with the GUI's."""
    import gc
    import weakref

    from gaitmon.ui.jobs import QtWorker

    w = QtWorker("freed")
    done: list[Response[int]] = []
    w.submit(lambda t: 7, done.append)
    idle = w.wait_idle(5.0)  # (not inside an assert: pytest keeps what an assert touched)
    assert idle and [r.value for r in done] == [7]
    thread = w.core._thread
    qapp.processEvents()  # the queued wake-ups the window's event loop would have run
    ref = weakref.ref(w)
    gc.disable()
    try:
        del w
        assert ref() is None
    finally:
        gc.enable()
    thread.join(5.0)
    assert not thread.is_alive()  # dropped without stop(): its thread ended too


def test_a_qt_worker_whose_qt_side_is_deleted_tells_nobody_and_raises_nothing(qapp) -> None:
    """A parent window deleted the QtWorker's C++ object while its wrapper and thread lived on
    (as at interpreter exit): the thread's last busy/progress/response news is dropped quietly
    ("Signal source has been deleted" was raised on the worker thread)."""
    import shiboken6
    from PySide6.QtCore import QObject

    from gaitmon.ui.jobs import QtWorker

    raised: list[BaseException] = []
    old_hook = threading.excepthook
    threading.excepthook = lambda args: raised.append(args.exc_value)
    parent = QObject()
    w = QtWorker("orphan", parent=parent)
    go = threading.Event()

    def job(t: Ticket) -> int:
        go.wait(5.0)
        t.progress(0.5)
        return 1

    try:
        w.submit(job, lambda r: None)
        shiboken6.delete(parent)
        assert not shiboken6.isValid(w)
        go.set()
        assert w.core.wait_idle(5.0)  # its response and progress were posted to nobody
        assert w.core.stop(5.0)  # and "not busy" is told to nobody
    finally:
        threading.excepthook = old_hook
    assert raised == []
