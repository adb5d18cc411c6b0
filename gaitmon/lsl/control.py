"""Remote start/stop: an LSL marker stream whose "start" and "stop" samples start and stop a
recording (as LabRecorder users drive their other devices). The words are configurable; a
sample is the word when its first channel, with any spaces (U+0020) around it removed, is
the word in ASCII letters of any case ("stop", " STOP "): nothing else, not a tab or a line
break around it, not a letter outside ASCII that case-folds to one ("ſtop"). Every other
sample is ignored, and so are a "stop" before the "start" and anything after the "stop" (one
recording per command). Which stream is the control stream: its name and, with
``--lsl-control-source-id``, its source id (``inlet.resolve_marker_stream``)."""

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
        for w in (self.start, self.stop):
            if not w.strip(" ").isascii() or not w.strip(" ").isprintable():
                raise UserError(
                    f"the LSL start and stop words must be printable ASCII; got {w!r}"
                )
        if self.start.strip(" ").lower() == self.stop.strip(" ").lower():
            raise UserError(
                f"the LSL start and stop words are the same ({self.start!r}); give two words"
            )


def _word(text: str) -> str | None:
    """``text`` as a control word to compare: spaces around it removed, ASCII letters in lower
    case; None when it holds anything outside ASCII (it is then no word)."""
    word = text.strip(" ")
    return word.lower() if word.isascii() else None


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
        self._start = _word(words.start)
        self._stop = _word(words.stop)
        self.inlet = MarkerInlet(
            pylsl, info, open_timeout_s=open_timeout_s, thread_name="gaitmon-lsl-control"
        )
        self.name = self.inlet.name

    def start(self) -> None:
        self.inlet.start(self._on_marker)

    def close(self) -> None:
        self.inlet.close()

    def _on_marker(self, label: str, host_time_s: float) -> None:
        word = _word(label)
        if word is None:
            return
        if word == self._start and not self.started.is_set():
            self.start_host_time_s = host_time_s
            self.started.set()
        elif word == self._stop and self.started.is_set() and not self.stopped.is_set():
            self.stop_host_time_s = host_time_s
            self.stopped.set()
