"""The journal's name beside its session file and its lock: what a reader needs to know whether
a recording was interrupted (:func:`journal_path`) or is live (:func:`journal_lock`), without
the journal's byte layout (:mod:`gaitmon.io.journal`, which re-exports these), so that
``gaitmon info`` does not load the writer's and recovery's record types."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

try:
    import fcntl
except ImportError:  # Windows: no advisory lock
    fcntl = None  # type: ignore[assignment]

JOURNAL_SUFFIX = ".journal"


def journal_path(session_path: str | os.PathLike[str]) -> Path:
    """``FILE.h5`` -> ``FILE.h5.journal``."""
    p = Path(session_path)
    return p.with_name(p.name + JOURNAL_SUFFIX)


def _lock(fd: int, *, blocking: bool = False) -> bool:
    """An exclusive advisory lock on the open file; False if someone else holds one. Where
    ``fcntl`` is missing (Windows) there is no lock and this says True."""
    if fcntl is None:
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | (0 if blocking else fcntl.LOCK_NB))
    except BlockingIOError:
        return False
    return True


@contextlib.contextmanager
def journal_lock(path: str | os.PathLike[str]) -> Iterator[bool]:
    """Hold the journal's lock while the block runs; yields False if a live recorder (this
    process or another) holds it. The kernel drops the lock when a recorder dies."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    try:
        yield _lock(fd)
    finally:
        os.close(fd)
