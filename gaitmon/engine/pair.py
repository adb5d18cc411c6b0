"""Units recorded into one session: two units, one per leg, into one bilateral session.

Each leg has its own :class:`Engine` (its own Device, link health, reconnection, gaps and
recorder thread) writing an ordinary crash-safe recording of its own beside the target,
``FILE.L.partial`` / ``FILE.R.partial`` (``gaitmon.finish.bilateral.part_path``). At the stop
:meth:`EnginePair.finish` combines them into ``FILE`` (``combine_parts``: both layouts under
``/units/<side>`` and the clock fits under ``/sync``). A link lost on one leg is a gap in that
leg's part only; the other leg records on. If the process dies, the parts and their journals
stay, and the next reader of ``FILE`` recovers and combines them.

:class:`EngineGroup` runs its units' engines, keyed by side, through the same steps (start,
record, zero together, the unit's clock since the recording started, stop, finish);
:class:`EnginePair` is the two-leg group. A group of one unit records straight into ``FILE``,
as ``Engine.start_recording`` does: one leg is the one-unit case.
"""

from __future__ import annotations

import contextlib
import dataclasses
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from gaitmon.dsp.calibration import Calibration
from gaitmon.engine.core import Engine, EngineError
from gaitmon.engine.snapshot import Mode, RecordingStatus
from gaitmon.engine.zeroing import ZeroSearch
from gaitmon.finish.combine import combine_parts
from gaitmon.io.journal import journal_path
from gaitmon.io.session.h5file import _being_recorded
from gaitmon.io.session.header import SessionError, SessionMeta
from gaitmon.io.session.parts import SIDE_NAMES, SIDES, part_path, parts_of

if TYPE_CHECKING:
    from gaitmon.engine.stream import UnitClockMark

# closing a part computes its smoothed angles and overview (an hour: tens of seconds on a busy
# machine); both must be closed before they can be combined
STOP_TIMEOUT_S = 300.0
# as `gaitmon record --zero` for one unit: a subject still settling gets this long
ZERO_TIMEOUT_S = 10.0


class EngineGroup:
    """The engines of one recording, by side (module doc); one engine: a one-unit recording."""

    def __init__(self, engines: Mapping[str, Engine]) -> None:
        if not engines:
            raise ValueError("a recording needs at least one unit")
        self.engines: dict[str, Engine] = dict(engines)
        self._start: dict[str, UnitClockMark] = {}  # each unit's clock at the recording's start
        self.path: Path | None = None
        self._meta = SessionMeta()
        self._overwrite = False
        self._created: set[str] = set()  # the units whose recording this group created
        # each unit's engine index where the last :meth:`zero` takes effect (raw mode)
        self.zero_at: dict[str, int] = {}
        self._searches: dict[str, ZeroSearch] = {}  # requested before streaming

    @property
    def sides(self) -> tuple[str, ...]:
        return tuple(self.engines)

    @property
    def in_parts(self) -> bool:
        """Each unit records a part, combined at the end (more than one unit)."""
        return len(self.engines) > 1

    def recording_path(self, side: str) -> Path:
        """Where that unit records: its part, or the file itself for a one-unit group."""
        assert self.path is not None
        return part_path(self.path, side) if self.in_parts else self.path

    def start(
        self,
        path: str | Path,
        meta: SessionMeta | None = None,
        *,
        overwrite: bool = False,
        record: bool = True,
        before_stream: Callable[[str, Engine], None] | None = None,
    ) -> None:
        """Start every unit, each recording from its first frame (``record`` False: streaming
        only, until :meth:`start_recording`, e.g. after :meth:`zero`). ``before_stream(side,
        engine)`` runs for each once it is identified, before its first frame (the LSL outlets
        open there). ``EngineError`` (all stopped, nothing left behind) if any cannot start."""
        self._target(path, meta, overwrite)
        started: list[str] = []
        try:
            for side, eng in self.engines.items():

                def hook(s: str = side, e: Engine = eng) -> None:
                    if record:
                        self._record(s)
                    if before_stream is not None:
                        before_stream(s, e)

                eng.start(before_stream=hook)
                started.append(side)
                if record:
                    self._start[side] = eng.clock_mark()
        except BaseException:
            self._abandon(started)
            raise

    def _target(self, path: str | Path, meta: SessionMeta | None, overwrite: bool) -> None:
        """The file to record to; the parts of an interrupted recording of it are refused
        (``EngineError``) unless ``overwrite``, then deleted."""
        path = Path(path)
        old = parts_of(path) if self.in_parts else {}
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
        self._overwrite = overwrite

    def _record(self, side: str, from_idx: int | None = None) -> None:
        if self.in_parts:  # each part says its leg; an old part was deleted by _target
            meta = dataclasses.replace(self._meta, side=side)
            self.engines[side].start_recording(self.recording_path(side), meta, overwrite=True,
                                               from_idx=from_idx)  # fmt: skip
        else:
            eng = self.engines[side]
            eng.start_recording(self.recording_path(side), self._meta, overwrite=self._overwrite,
                                from_idx=from_idx)  # fmt: skip
        self._created.add(side)

    def _abandon(self, started: list[str], *, streaming: bool = False) -> None:
        """A start that failed: the units stopped (``streaming``: they stream on, only their
        recordings stopped), the files this group created (still empty) deleted."""
        for side in started:
            self.engines[side].stop_recording("error: start-up failed")
            if not streaming:
                self.engines[side].stop()
        if self.path is not None:
            for side in self.engines if self.in_parts else self._created:
                rpath = self.recording_path(side)
                for q in (rpath, journal_path(rpath)):
                    with contextlib.suppress(OSError):
                        q.unlink()

    def start_recording(self, path: str | Path | None = None, meta: SessionMeta | None = None,
                        *, overwrite: bool = False, at_zero: bool = False) -> None:  # fmt: skip
        """Every unit from its next block on (after a ``start(record=False)``); the
        calibration a :meth:`zero` left waiting is each one's header's. ``at_zero``: each
        unit from the sample where its last zero takes effect (``zero_at``; `gaitmon record
        --zero`), so the first row is decided by the data, not by when this ran. With ``path``: the
        engines already stream on their own (the live window's, started with
        ``Engine.start``) and record into ``path``; if any cannot start, none records and all
        stream on (``EngineError``)."""
        if path is not None:
            self._target(path, meta, overwrite)
        started: list[str] = []
        try:
            for side, eng in self.engines.items():
                self._record(side, self.zero_at.get(side) if at_zero else None)
                started.append(side)
                self._start[side] = eng.clock_mark()
        except BaseException:
            if path is None:
                self._abandon(list(self.engines))
            else:
                self._abandon(started, streaming=True)
            raise

    def zero(
        self, stop: threading.Event | None = None, timeout_s: float = ZERO_TIMEOUT_S,
        window_s: float = 1.5, *, from_start: bool = False,
    ) -> dict[str, Calibration]:  # fmt: skip
        """The standing calibration of every unit: each unit's earliest still ``window_s`` of
        data from the request on (the last ``window_s`` before it included), or with
        ``from_start`` from its first sample on (`gaitmon record --zero`: the subject stands
        when the units start). The windows are picked by the units' samples, not by when this
        thread runs: every row since the request is looked at, so a busy machine or a unit
        faster than real time zeroes the same pose. Retried as data comes (the subject
        settling, the first seconds of data) until every unit has one; ``EngineError`` naming
        the leg (or legs) without a still window once its windows ending within ``timeout_s``
        of that unit's samples (its clock) since the request were all looked at (or 3 x
        ``timeout_s`` of wall time with no zero: a unit that sends nothing); an empty dict if
        ``stop`` is set first. A unit that zeroes itself (tilt/joint mode) keeps its
        calibration and is not handed it again, as ``Engine.zero`` does (handed again, a
        running recording logged an unchanged calibration as a zeroing). If not every unit
        can be zeroed, none is (one found meanwhile is withdrawn). Each unit's calibration
        takes effect at its own sample, ``ZERO_MARGIN_S`` after its window, found by its
        engine thread (``engine.zeroing``; kept in :attr:`zero_at`)."""
        deadline = time.monotonic() + 3.0 * timeout_s
        n = int(window_s * next(iter(self.engines.values())).fs_hz)
        asked: dict[str, int] = {}  # where each unit's search began
        searches: dict[str, ZeroSearch] = {}  # the engine threads' (raw mode)
        for side, eng in self.engines.items():
            if eng.mode is Mode.RAW:
                early = self._searches.pop(side, None) if from_start else None
                asked[side] = 0 if from_start else max(0, eng.samples_total - n)
                searches[side] = early or eng.request_zero(window_s, since_idx=asked[side])
        self._searches = {}
        cals: dict[str, Calibration] = {}
        at: dict[str, int] = {}
        last_error: dict[str, str] = {}
        try:
            while stop is None or not stop.is_set():
                timed_out = time.monotonic() > deadline
                for side, eng in self.engines.items():
                    if side in cals:
                        continue
                    if side not in searches:  # tilt/joint mode: the unit zeroes itself
                        try:
                            cals[side] = eng.zero(window_s, apply=False)
                            last_error.pop(side, None)
                        except EngineError as exc:
                            last_error[side] = str(exc)
                        continue
                    found, refused, looked = eng.zero_search(searches[side])
                    if found is not None:
                        cals[side], at[side] = found
                        last_error.pop(side, None)
                        continue
                    last_error[side] = refused or (
                        f"need {window_s:g} s of data from the unit to zero; wait and retry"
                    )
                    # every window ending within timeout_s of its samples was looked at
                    if looked - asked[side] > (timeout_s + window_s) * eng.fs_hz:
                        timed_out = True
                if not last_error:
                    self.zero_at = at
                    searches = {}  # found and applied: nothing to withdraw
                    return cals
                if timed_out:
                    raise EngineError("; ".join(
                        f"could not zero{_unit_name(s)}: {e}" for s, e in last_error.items()
                    ))  # fmt: skip
                time.sleep(0.02)
            return {}
        finally:  # not every unit zeroed: none is (a zero one of them found is withdrawn)
            for side, search in searches.items():
                self.engines[side].cancel_zero(search, withdraw=True)

    def request_zero_from_start(self, side: str, window_s: float = 1.5) -> None:
        """Before ``side``'s unit streams (``start``'s ``before_stream``): its engine thread
        looks for the standing window from the first sample on, so the window, the sample the
        calibration takes effect at and the file's first row (:meth:`zero` with
        ``from_start``, then ``start_recording(at_zero=True)``) are decided by the samples,
        however far the engine thread gets before :meth:`zero` runs."""
        eng = self.engines[side]
        if eng.mode is Mode.RAW:
            self._searches[side] = eng.request_zero(window_s, since_idx=0, hold=True)

    def recorded_s(self, side: str) -> float:
        """Seconds of that unit's clock since the recording started (received + lost)."""
        eng = self.engines[side]
        recorded = eng.recorded_unit_s()  # from its first row, which may be a scheduled sample
        return eng.seconds_since(self._start.get(side)) if recorded is None else recorded

    def stop(self, reason: str = "user", timeout_s: float = STOP_TIMEOUT_S) -> dict[
        str, RecordingStatus
    ]:
        """Finish every recording (at once: closing a long part computes its smoothed angles)
        and stop the engines (idempotent). A recording not finished within ``timeout_s`` says
        so in its status's ``error``; its recorder finishes in the background."""
        out = self.stop_recording(reason, timeout_s)
        for eng in self.engines.values():
            eng.stop()
        return out

    def stop_recording(self, reason: str = "user", timeout_s: float = STOP_TIMEOUT_S) -> dict[
        str, RecordingStatus
    ]:
        """Finish every recording at once, the engines streaming on (the live window); as
        :meth:`stop` otherwise."""
        out: dict[str, RecordingStatus] = {}

        def finish(side: str) -> None:
            out[side] = self.engines[side].stop_recording(reason, timeout_s)

        threads = [threading.Thread(target=finish, args=(s,), name=f"gaitmon-stop-{s}")
                   for s in self.engines]  # fmt: skip
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        return out

    def finish(self, timeout_s: float = STOP_TIMEOUT_S) -> Path:
        """The one session file: the parts combined into it, once every recorder has let go of
        its part (waiting up to ``timeout_s``); ``SessionError`` if that fails (the parts are
        kept then, and combined when the file is next opened). A one-unit group's file is
        finished by its stop already."""
        if self.path is None:
            raise SessionError("the pair was never started")
        if not self.in_parts:
            return self.path
        deadline = time.monotonic() + timeout_s
        for side in self.engines:
            jpath = journal_path(self.recording_path(side))
            while jpath.exists() and _being_recorded(jpath) and time.monotonic() < deadline:
                time.sleep(0.1)
        return combine_parts(self.path)


class EnginePair(EngineGroup):
    """The left and right engines of one bilateral recording (module doc)."""

    def __init__(self, left: Engine, right: Engine) -> None:
        super().__init__(dict(zip(SIDES, (left, right), strict=True)))


def _unit_name(side: str) -> str:
    """How an error names a unit after a verb: " the left leg (L)", or (a unit that is not a
    leg, e.g. a one-unit group's) nothing, as ``gaitmon record`` always said of one unit."""
    return f" the {SIDE_NAMES[side]} leg ({side})" if side in SIDE_NAMES else ""
