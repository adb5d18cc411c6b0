"""Where ``gaitmon batch`` runs its sessions: in this process, in a pool of local worker
processes (``--jobs``), or on a Dask distributed cluster (``--dask``). Generic in the work:
``work(task)`` is called once per task, its result handed to ``done`` as it arrives."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import sys
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from typing import Any, TypeVar

from gaitmon.errors import UserError

T = TypeVar("T")
R = TypeVar("R")

DASK_CONNECT_TIMEOUT_S = 20


def die_with_parent(parent_pid: int) -> None:
    """A pool worker's first act: on Linux, ask the kernel to kill it when the batch process
    dies (``prctl(PR_SET_PDEATHSIG, SIGKILL)``), so a ``kill -9`` of ``gaitmon batch`` leaves
    no worker reprocessing on for nobody (and with them gone, multiprocessing's resource
    tracker reads the end of its pipe and exits too). Elsewhere a no-op: a worker then ends
    at its next task, when it finds the pool's pipe closed."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    pr_set_pdeathsig = 1
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, int(signal.SIGKILL), 0, 0, 0)
    if os.getppid() != parent_pid:  # it died before the request was made: go now
        os._exit(1)


def _init_worker(parent_pid: int) -> None:
    """A pool worker's set-up: it dies with the batch process (:func:`die_with_parent`) and
    leaves Ctrl-C to it (a terminal sends SIGINT to the whole group; the parent decides, and
    stops its workers itself)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent(parent_pid)


def run_local(work: Callable[[T], R], tasks: Sequence[T], jobs: int,
              done: Callable[[R], None]) -> None:  # fmt: skip
    """Run the tasks here (``jobs`` <= 1) or on a pool of ``jobs`` local processes, calling
    ``done`` here, in this thread, with each result as it arrives. When this raises (Ctrl-C, an
    error in ``done``), every worker has been stopped and reaped first: no task of this call
    runs, or writes, after it returns (a worker's half-written file stays as it was)."""
    if jobs <= 1 or len(tasks) <= 1:
        for t in tasks:
            done(work(t))
        return
    # spawn: a fresh interpreter per worker, no fork of a parent holding h5py state or threads
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(jobs, len(tasks)), mp_context=ctx,
                             initializer=_init_worker, initargs=(os.getpid(),)) as pool:
        futures = [pool.submit(work, t) for t in tasks]
        try:
            for f in as_completed(futures):
                done(f.result())
        except BaseException:
            _stop(pool, futures)
            raise


def _stop(pool: ProcessPoolExecutor, futures: Sequence[Future[Any]]) -> None:
    """Cancel what has not started and end the workers now, without waiting for the tasks
    they run (shutdown alone waits for every task already handed to a worker, and they
    finish and write on, seconds after a Ctrl-C). The executor has no public terminate: its
    processes are ``_processes`` (a missing attribute only loses the promptness)."""
    for f in futures:
        f.cancel()
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for p in procs:
        p.terminate()
    # the pool sees its workers die, fails what they held, and ends its own thread
    pool.shutdown(wait=True, cancel_futures=True)
    for p in procs:
        p.join()


def dask_client(address: Any) -> Any:
    """A client of the Dask distributed cluster at ``address`` (the scheduler's address, or a
    cluster object such as a ``LocalCluster``); :class:`UserError` when there is none."""
    try:
        from distributed import Client
    except ImportError:
        raise UserError("--dask needs Dask distributed: pip install 'gaitmon[dask]'") from None
    try:
        # (typed only when installed: the ignore covers both cases)
        return Client(address, timeout=f"{DASK_CONNECT_TIMEOUT_S}s")  # type: ignore[no-untyped-call, unused-ignore]
    except (OSError, TimeoutError, ValueError) as exc:
        why = " ".join(str(exc).split()) or type(exc).__name__
        raise UserError(
            f"cannot reach the Dask scheduler at {address} ({why}); start it with "
            "'dask scheduler' and check the address"
        ) from None


def run_dask(work: Callable[[T], R], tasks: Sequence[T], client: Any,
             done: Callable[[R], None]) -> None:  # fmt: skip
    """The same tasks on the cluster: each worker imports gaitmon and opens its own files
    (the paths must be the same there: a shared file system)."""
    from distributed import as_completed as dask_completed

    futures = client.map(work, list(tasks), pure=False)
    for f in dask_completed(futures):  # type: ignore[no-untyped-call, unused-ignore]
        done(f.result())
