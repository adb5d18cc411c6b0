"""Two units, one per leg, recorded into one bilateral session.

Each leg has its own :class:`Engine` (its own Device, link health, reconnection, gaps and
recorder thread) writing an ordinary crash-safe recording of its own beside the target,
``FILE.L.partial`` / ``FILE.R.partial`` (``gaitmon.finish.bilateral.part_path``). At the stop
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
from collections.abc import Callable
from pathlib import Path

from gaitmon.dsp.calibration import Calibration
from gaitmon.engine.core import Engine, EngineError
from gaitmon.engine.snapshot import RecordingStatus
from gaitmon.finish.combine import combine_parts
from gaitmon.io.journal import journal_path
from gaitmon.io.session.h5file import _being_recorded
from gaitmon.io.session.header import SessionError, SessionMeta
from gaitmon.io.session.parts import SIDE_NAMES, SIDES, part_path, parts_of

# closing a part computes its smoothed angles and overview (an hour: tens of seconds on a busy
# machine); both must be closed before they can be combined
STOP_TIMEOUT_S = 300.0
# as `gaitmon record --zero` for one unit: a subject still settling gets this long
ZERO_TIMEOUT_S = 10.0


class EnginePair:
    """The left and right engines of one bilateral recording (module doc)."""

    def __init__(self, left: Engine, right: Engine) -> None:
        self.engines = {"L": left, "R": right}
        self._start: dict[str, tuple[int, int]] = {}  # samples, frames lost at the start
        self.path: Path | None = None
        self._meta = SessionMeta()

    def start(
        self,
        path: str | Path,
        meta: SessionMeta | None = None,
        *,
        overwrite: bool = False,
        record: bool = True,
        before_stream: Callable[[str, Engine], None] | None = None,
    ) -> None:
        """Start both units, each recording into its part from its first frame (``record``
        False: streaming only, until :meth:`start_recording`, e.g. after :meth:`zero`).
        ``before_stream(side, engine)`` runs for each once it is identified, before its first
        frame (the LSL outlets open there). ``EngineError`` (both stopped, nothing left
        behind) if either cannot start."""
        self._target(path, meta, overwrite)
        started: list[str] = []
        try:
            for side in SIDES:
                eng = self.engines[side]

                def hook(s: str = side, e: Engine = eng) -> None:
                    if record:
                        self._record(s)
                    if before_stream is not None:
                        before_stream(s, e)

                eng.start(before_stream=hook)
                started.append(side)
                if record:
                    self._start[side] = (eng.samples_total, eng.device.stats.decoder.frames_lost)
        except BaseException:
            self._abandon(started)
            raise

    def _target(self, path: str | Path, meta: SessionMeta | None, overwrite: bool) -> None:
        """The file to record to; the parts of an interrupted recording of it are refused
        (``EngineError``) unless ``overwrite``, then deleted."""
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
        self.path = path
        self._meta = meta or SessionMeta()

    def _record(self, side: str) -> None:
        assert self.path is not None
        meta = dataclasses.replace(self._meta, side=side)
        self.engines[side].start_recording(part_path(self.path, side), meta, overwrite=True)

    def _abandon(self, started: list[str], *, streaming: bool = False) -> None:
        """A start that failed: the units stopped (``streaming``: they stream on, only their
        recordings stopped), the parts (still empty) deleted."""
        for side in started:
            self.engines[side].stop_recording("error: start-up failed")
            if not streaming:
                self.engines[side].stop()
        if self.path is not None:
            for side in SIDES:
                for q in (part_path(self.path, side), journal_path(part_path(self.path, side))):
                    with contextlib.suppress(OSError):
                        q.unlink()

    def start_recording(self, path: str | Path | None = None, meta: SessionMeta | None = None,
                        *, overwrite: bool = False) -> None:  # fmt: skip
        """Both parts from the next block on (after a ``start(record=False)``); the
        calibration a :meth:`zero` left waiting is each part's header's. With ``path``: both
        engines already stream on their own (the live window's, started with ``Engine.start``)
        and record into ``path``; if either cannot start, neither records and both stream on
        (``EngineError``)."""
        if path is not None:
            self._target(path, meta, overwrite)
        started: list[str] = []
        try:
            for side in SIDES:
                eng = self.engines[side]
                self._record(side)
                started.append(side)
                self._start[side] = (eng.samples_total, eng.device.stats.decoder.frames_lost)
        except BaseException:
            if path is None:
                self._abandon(list(SIDES))
            else:
                self._abandon(started, streaming=True)
            raise

    def zero(
        self, stop: threading.Event | None = None, timeout_s: float = ZERO_TIMEOUT_S,
        window_s: float = 1.5,
    ) -> dict[str, Calibration]:  # fmt: skip
        """The standing calibration of both units from the same moment: each unit's last
        ``window_s`` of data, taken one right after the other, retried (the subject settling,
        the first seconds of data) until both succeed in the same try. ``EngineError`` naming
        the leg (or legs) never still in any try after ``timeout_s``; an empty dict if ``stop``
        is set first."""
        deadline = time.monotonic() + timeout_s
        worked: set[str] = set()  # the legs that were still at some try
        last_error: dict[str, str] = {}
        while stop is None or not stop.is_set():
            cals: dict[str, Calibration] = {}
            errors: dict[str, str] = {}
            for side in SIDES:
                try:  # computed only: a window straddling an applied change would mix biases
                    cals[side] = self.engines[side].zero(window_s, apply=False)
                    worked.add(side)
                except EngineError as exc:
                    errors[side] = last_error[side] = str(exc)
            if not errors:
                return {s: self.engines[s].use_calibration(c) for s, c in cals.items()}
            if time.monotonic() > deadline:
                # the leg that never zeroed, not one that did while it waited for the other
                never = [s for s in SIDES if s not in worked] or list(errors)
                raise EngineError("; ".join(
                    f"could not zero the {SIDE_NAMES[s]} leg ({s}): {last_error[s]}" for s in never
                ))  # fmt: skip
            time.sleep(0.02)  # the simulator may run faster than real time
        return {}

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
        out = self.stop_recording(reason, timeout_s)
        for side in SIDES:
            self.engines[side].stop()
        return out

    def stop_recording(self, reason: str = "user", timeout_s: float = STOP_TIMEOUT_S) -> dict[
        str, RecordingStatus
    ]:
        """Finish both parts at once, the engines streaming on (the live window); as
        :meth:`stop` otherwise."""
        out: dict[str, RecordingStatus] = {}

        def finish(side: str) -> None:
            out[side] = self.engines[side].stop_recording(reason, timeout_s)

        threads = [threading.Thread(target=finish, args=(s,), name=f"gaitmon-stop-{s}")
                   for s in SIDES]  # fmt: skip
        for t in threads:
            t.start()
        for t in threads:
            t.join()
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
