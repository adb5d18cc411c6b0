"""The log of the command line and the windows: one rotating file in the user's log folder.

:func:`setup` is called by ``gaitmon`` (every subcommand and the windows) before anything else
runs. The file (:func:`gaitmon.paths.log_file`, ``~/.local/state/gaitmon/log/gaitmon.log`` on
Linux) keeps INFO and up with times and, for an internal error, its traceback; it rotates at
1 MB keeping 3 old files. The terminal gets warnings as their one-line message (as Python's
own last-resort handler printed them before), INFO too with ``--verbose``, and never a
traceback: a record that carries one, or that its caller has shown in its own line already
(``extra={"shown": True}``), stays in the file.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
from pathlib import Path

from gaitmon import paths

ROOT = "gaitmon"
MAX_BYTES = 1_000_000
BACKUPS = 3
_OURS = "_gaitmon_handler"  # marks the handlers setup() added, so a second call replaces them


class _TerminalFilter(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return not record.exc_info and not getattr(record, "shown", False)


class _Terminal(logging.StreamHandler):  # type: ignore[type-arg]
    """The terminal as it is when a record comes, not when :func:`setup` ran (a test's captured
    stderr, replaced and closed since, must not be written to)."""

    def emit(self, record: logging.LogRecord) -> None:
        self.stream = sys.stderr  # under the handler's lock (Handler.handle)
        super().emit(record)


class _RotatingFile(logging.FileHandler):
    """``logging.handlers.RotatingFileHandler``'s rotation (before a record that would take the
    file to ``max_bytes``: FILE -> FILE.1 -> ... -> FILE.``backups``, the oldest dropped),
    without importing ``logging.handlers``, whose sockets, queues and pickling cost every
    command ~4 ms at start-up. Opened on the first record."""

    def __init__(self, path: Path, max_bytes: int, backups: int) -> None:
        super().__init__(path, encoding="utf-8", delay=True)
        self.max_bytes, self.backups = max_bytes, backups
        self.write_failed = False  # said once on the terminal

    def handleError(self, record: logging.LogRecord) -> None:
        """A write that fails (a full disk, a file no longer writable) is said once, as one
        line on the terminal, and the command carries on (logging's own handler printed
        "--- Logging error ---" and a traceback for every record)."""
        err = sys.exc_info()[1]
        if not isinstance(err, OSError):
            super().handleError(record)  # a record that cannot be formatted: a program error
            return
        if self.write_failed:
            return
        self.write_failed = True
        why = err.strerror or str(err) or type(err).__name__
        with contextlib.suppress(OSError, ValueError):  # no terminal either
            sys.stderr.write(f"gaitmon: cannot write the log file {self.baseFilename} (disk "
                             f"full or not writable: {why}); carrying on\n")  # fmt: skip

    def flush(self) -> None:
        try:
            super().flush()
        except OSError:  # at shutdown, after the last record
            self.handleError(logging.makeLogRecord({}))

    def close(self) -> None:
        try:
            super().close()  # the file's close writes what it still holds, and fails again
        except OSError:
            self.handleError(logging.makeLogRecord({}))

    def emit(self, record: logging.LogRecord) -> None:
        try:
            if self._full(record):
                self._rotate()
        except Exception:  # as logging's own handlers do: report, never raise
            self.handleError(record)
            return
        super().emit(record)

    def _full(self, record: logging.LogRecord) -> bool:
        if not os.path.isfile(self.baseFilename) and os.path.exists(self.baseFilename):
            return False  # not a regular file (a device, a pipe): never rotated
        if self.stream is None:
            self.stream = self._open()
        self.stream.seek(0, 2)
        return self.stream.tell() + len(f"{self.format(record)}\n") >= self.max_bytes

    def _rotate(self) -> None:
        if self.stream:
            self.stream.close()
            self.stream = None  # reopened by emit (delay)
        base = self.baseFilename
        for i in range(self.backups - 1, 0, -1):
            if os.path.exists(f"{base}.{i}"):
                os.replace(f"{base}.{i}", f"{base}.{i + 1}")
        if os.path.exists(base):
            os.replace(base, f"{base}.1")


class _MessageOnly(logging.Formatter):
    def format(self, record: logging.LogRecord) -> str:
        return " ".join(record.getMessage().split())  # one line, no traceback


def setup(verbose: bool = False) -> Path | None:
    """Log ``gaitmon.*`` to the file (INFO) and the terminal (WARNING, INFO with ``verbose``);
    the file's path, or None when it cannot be written (a read-only home: the terminal only).
    Calling again (a second command in one process, a window after the command line) replaces
    what the last call set up."""
    root = logging.getLogger(ROOT)
    for h in [h for h in root.handlers if getattr(h, _OURS, False)]:
        root.removeHandler(h)
        h.close()
    root.setLevel(logging.INFO)
    root.propagate = False  # ours alone: no traceback through the root logger's handlers
    terminal = _Terminal(sys.stderr)
    terminal.setLevel(logging.INFO if verbose else logging.WARNING)
    terminal.addFilter(_TerminalFilter())
    terminal.setFormatter(_MessageOnly())
    _add(root, terminal)
    try:
        path = paths.log_file()
        path.parent.mkdir(parents=True, exist_ok=True)
        handler = _RotatingFile(path, MAX_BYTES, BACKUPS)
    except (OSError, ModuleNotFoundError):
        return None
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    handler.setLevel(logging.INFO)
    _add(root, handler)
    return path


def current_file() -> Path | None:
    """The file :func:`setup` logs to, if it did."""
    for h in logging.getLogger(ROOT).handlers:
        if getattr(h, _OURS, False) and isinstance(h, logging.FileHandler):
            return Path(h.baseFilename)
    return None


def _add(root: logging.Logger, handler: logging.Handler) -> None:
    setattr(handler, _OURS, True)
    root.addHandler(handler)
