"""Two units, one per leg, recorded into one bilateral session.

Each leg has its own :class:`Engine` (its own Device, link health, reconnection, gaps and
recorder thread) writing an ordinary crash-safe recording of its own beside the target,
``FILE.L.partial`` / ``FILE.R.partial`` (``gaitmon.io.session.bilateral.part_path``). At the stop
:meth:`EnginePair.finish` combines them into ``FILE`` (``combine_parts``: both layouts under
``/units/<side>`` and the clock fits under ``/sync``). A link lost on one leg is a gap in that
leg's part only; the other leg records on. If the process dies, the parts and their journals
stay, and the next reader of ``FILE`` recovers and combines them.
"""

from __future__ import annotations

import contextlib
import dataclasses
import threading
import time
from pathlib import Path

from gaitmon.engine.core import Engine, EngineError
from gaitmon.engine.snapshot import RecordingStatus
from gaitmon.io.journal import journal_path
from gaitmon.io.session.combine import combine_parts
from gaitmon.io.session.h5file import _being_recorded
from gaitmon.io.session.header import SessionError, SessionMeta
from gaitmon.io.session.parts import SIDES, part_path, parts_of

# closing a part computes its smoothed angles and overview (an hour: tens of seconds on a busy
# machine); both must be closed before they can be combined
STOP_TIMEOUT_S = 300.0


class EnginePair:
    """The left and right engines of one bilateral recording (module doc)."""

    def __init__(self, left: Engine, right: Engine) -> None:
        self.engines = {"L": left, "R": right}
        self._start: dict[str, tuple[int, int]] = {}  # samples, frames lost at the start
        self.path: Path | None = None

    def start(self, path: str | Path, meta: SessionMeta | None = None, *,
              overwrite: bool = False) -> None:  # fmt: skip
        """Start both units, each recording into its part from its first frame.
        ``EngineError`` (both stopped, nothing left behind) if either cannot start."""
        path = Path(path)
        old = parts_of(path)
        if old and not overwrite:
            raise EngineError(
                f"the parts of an interrupted recording of {path.name} are beside it; "
                f"`gaitmon info {path.name}` recovers them, or overwrite them"
            )
        for p in old.values():
            for q in (p, journal_path(p)):
                with contextlib.suppress(FileNotFoundError):
                    q.unlink()
        meta = meta or SessionMeta()
        started: list[str] = []
        try:
            for side in SIDES:
                eng = self.engines[side]
                part = part_path(path, side)
                side_meta = dataclasses.replace(meta, side=side)

                def record(e: Engine = eng, p: Path = part, m: SessionMeta = side_meta) -> None:
                    e.start_recording(p, m, overwrite=True)

                eng.start(before_stream=record)
                started.append(side)
                self._start[side] = (eng.samples_total, eng.device.stats.decoder.frames_lost)
        except BaseException:
            for side in started:
                self.engines[side].stop()
            for side in SIDES:
                for q in (part_path(path, side), journal_path(part_path(path, side))):
                    with contextlib.suppress(OSError):
                        q.unlink()
            raise
        self.path = path

    def recorded_s(self, side: str) -> float:
        """Seconds of that unit's clock since the recording started (received + lost)."""
        eng = self.engines[side]
        n0, lost0 = self._start.get(side, (0, 0))
        lost = eng.device.stats.decoder.frames_lost - lost0
        return (eng.samples_total - n0 + lost) / eng.fs_hz

    def stop(self, reason: str = "user", timeout_s: float = STOP_TIMEOUT_S) -> dict[
        str, RecordingStatus
    ]:
        """Finish both parts (at once: closing a long part computes its smoothed angles) and
        stop both engines (idempotent). A part not finished within ``timeout_s`` says so in
        its status's ``error``; its recorder finishes in the background."""
        out: dict[str, RecordingStatus] = {}

        def finish(side: str) -> None:
            out[side] = self.engines[side].stop_recording(reason, timeout_s)

        threads = [threading.Thread(target=finish, args=(s,), name=f"gaitmon-stop-{s}")
                   for s in SIDES]  # fmt: skip
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        for side in SIDES:
            self.engines[side].stop()
        return out

    def finish(self, timeout_s: float = STOP_TIMEOUT_S) -> Path:
        """Combine the parts into the one session file, once both recorders have let go of
        them (waiting up to ``timeout_s``); ``SessionError`` if that fails (the parts are kept
        then, and combined when the file is next opened)."""
        if self.path is None:
            raise SessionError("the pair was never started")
        deadline = time.monotonic() + timeout_s
        for side in SIDES:
            jpath = journal_path(part_path(self.path, side))
            while jpath.exists() and _being_recorded(jpath) and time.monotonic() < deadline:
                time.sleep(0.1)
        return combine_parts(self.path)
