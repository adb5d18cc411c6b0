"""Remote start/stop: an LSL marker stream whose "start" and "stop" samples start and stop a
recording (as LabRecorder users drive their other devices). The words are configurable and
matched whole, ignoring case and surrounding spaces; every other sample is ignored, and so are
a "stop" before the "start" and anything after the "stop" (one recording per command)."""

from __future__ import annotations

import threading
from dataclasses import dataclass
from types import ModuleType
from typing import Any

from gaitmon.errors import UserError
from gaitmon.lsl.inlet import MarkerInlet


@dataclass(frozen=True)
class ControlWords:
    start: str = "start"
    stop: str = "stop"

    def __post_init__(self) -> None:
        if not self.start.strip() or not self.stop.strip():
            raise UserError("the LSL start and stop words must not be empty")
        if self.start.strip().casefold() == self.stop.strip().casefold():
            raise UserError(
                f"the LSL start and stop words are the same ({self.start!r}); give two words"
            )


class RemoteControl:
    """Watches one marker stream; ``started`` / ``stopped`` are set on the start / stop words,
    with their instants (``time.monotonic()``'s clock) in ``start_host_time_s`` /
    ``stop_host_time_s``."""

    def __init__(
        self, pylsl: ModuleType, info: Any, words: ControlWords, open_timeout_s: float = 5.0
    ) -> None:
        self.words = words
        self.started = threading.Event()
        self.stopped = threading.Event()
        self.start_host_time_s: float | None = None
        self.stop_host_time_s: float | None = None
        self._start = words.start.strip().casefold()
        self._stop = words.stop.strip().casefold()
        self.inlet = MarkerInlet(
            pylsl, info, open_timeout_s=open_timeout_s, thread_name="gaitmon-lsl-control"
        )
        self.name = self.inlet.name

    def start(self) -> None:
        self.inlet.start(self._on_marker)

    def close(self) -> None:
        self.inlet.close()

    def _on_marker(self, label: str, host_time_s: float) -> None:
        word = label.strip().casefold()
        if word == self._start and not self.started.is_set():
            self.start_host_time_s = host_time_s
            self.started.set()
        elif word == self._stop and self.started.is_set() and not self.stopped.is_set():
            self.stop_host_time_s = host_time_s
            self.stopped.set()
