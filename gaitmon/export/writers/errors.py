"""What every export module shares: its errors, and how it reports progress and is cancelled."""

from __future__ import annotations

from collections.abc import Callable

from gaitmon.errors import Cancelled

Progress = Callable[[float], object]  # called with the fraction done, 0..1; its result is ignored
Cancel = Callable[[], bool]  # True once the caller wants the export stopped


class ExportError(Exception):
    """A problem with the input, the output path or the format; the message is one line."""


class ExportCancelled(ExportError, Cancelled):
    """The caller's ``cancel()`` returned True; every temporary output has been removed."""

    def __init__(self, message: str = "export cancelled; no file was written") -> None:
        super().__init__(message)


def step(progress: Progress | None, cancel: Cancel | None, fraction: float) -> None:
    """Report progress; the progress points are also the only points an export stops at."""
    if cancel is not None and cancel():
        raise ExportCancelled
    if progress is not None:
        progress(fraction)
