"""Markers stamped with a host time (an external trigger received over Lab Streaming Layer):
which sample was taken at that instant, so which row of a recording the marker belongs on.

A marker usually arrives *after* the samples around its instant (and may arrive before them:
Bluetooth is slower than a local network), so it cannot go on "the next row". The engine thread
knows, for every block it processes, each sample's host receive time and its place on the
unit's sample clock (``k``: sample periods since the first sample, lost frames counted, as the
recording's timeline counts them). From these:

* ``RecentEnvelope`` fits host time against ``k`` over the last ``window_s``: a line through
  the lower envelope of the receive times (``gaitmon.dsp.clock_fit.envelope_line``, the one fit
  the bilateral sessions' offline clock mapping uses too), since a delay on the link only ever
  adds to a receive time and the frames of one read share the time of the last one. A marker
  at host time H is then at ``k = (H - a) / b``: the sample *taken* at H, not the one that
  happened to be read at H.
* ``SampleIndex`` turns ``k`` into the engine's sample index (frames lost have none: the
  nearest sample received stands for them).
* ``TimedMarkers`` holds the markers until the sample at their instant has been processed, and
  hands them out placed (engine index and ``k``), or as outside what the engine received.

Only the engine thread calls ``add_block`` and ``due``; ``add`` is for any thread.
"""

from __future__ import annotations

import bisect
import contextlib
import dataclasses
import itertools
import threading
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from gaitmon.dsp.clock_fit import MIN_FIT_SPAN_S, envelope_line
from gaitmon.engine.rows import RowMap


class RecentEnvelope:
    """Host receive time <-> the unit's sample clock ``k``, from the recent blocks: their lower
    envelope, inverted to place markers (the clock that stamps samples is
    ``gaitmon.dsp.sample_clock.SampleClock``)."""

    def __init__(self, fs_hz: float, window_s: float = 30.0) -> None:
        self.fs_hz = fs_hz
        self._window = max(2, int(window_s * fs_hz))
        self._blocks: deque[tuple[np.ndarray, np.ndarray]] = deque()
        self._n = 0
        self._fit: tuple[int, float, float, float] | None = None  # k_ref, h_ref, a, b

    def add(self, k: np.ndarray, host_time_s: np.ndarray) -> None:
        if not len(k):
            return
        self._blocks.append((np.asarray(k, np.int64), np.asarray(host_time_s, np.float64)))
        self._n += len(k)
        while len(self._blocks) > 1 and self._blocks[-1][0][-1] - self._blocks[1][0][0] >= (
            self._window
        ):
            self._n -= len(self._blocks.popleft()[0])
        self._fit = None

    @property
    def empty(self) -> bool:
        return not self._blocks

    def k_at(self, host_time_s: float) -> float | None:
        """The (fractional) sample clock at host time ``host_time_s``; None before any data."""
        if not self._blocks:
            return None
        if self._fit is None:
            self._fit = self._fitted()
        k_ref, h_ref, a, b = self._fit
        return k_ref + (host_time_s - h_ref - a) / b

    def _fitted(self) -> tuple[int, float, float, float]:
        k = np.concatenate([blk[0] for blk in self._blocks])
        h = np.concatenate([blk[1] for blk in self._blocks])
        k_ref, h_ref = int(k[-1]), float(h[-1])
        x = (k - k_ref).astype(np.float64)  # relative: no precision lost on long sessions
        y = h - h_ref
        a, b = envelope_line(x, y, 1.0 / self.fs_hz, MIN_FIT_SPAN_S * self.fs_hz)
        return k_ref, h_ref, a, b


class SampleIndex:
    """The engine's sample indices against the sample clock ``k``, as runs where both step by
    one (a run ends where frames were lost)."""

    def __init__(self) -> None:
        self._k0: list[int] = []
        self._i0: list[int] = []
        self._n: list[int] = []

    @property
    def k_last(self) -> int | None:
        return self._k0[-1] + self._n[-1] - 1 if self._k0 else None

    def add(self, start_idx: int, k: np.ndarray) -> None:
        """A processed block: engine indices ``start_idx ...`` at sample clock ``k``."""
        if not len(k):
            return
        # indices reused (a block that failed after these were noted): the newer block wins
        while self._i0 and self._i0[-1] >= start_idx:
            self._pop()
        if self._i0 and self._i0[-1] + self._n[-1] > start_idx:
            self._n[-1] = start_idx - self._i0[-1]
        cuts = [0, *(np.flatnonzero(np.diff(k) != 1) + 1).tolist(), len(k)]
        for a, z in itertools.pairwise(cuts):
            i0, k0 = start_idx + a, int(k[a])
            if self._i0 and self._i0[-1] + self._n[-1] == i0 and self.k_last == k0 - 1:
                self._n[-1] += z - a
            else:
                self._k0.append(k0)
                self._i0.append(i0)
                self._n.append(z - a)

    def _pop(self) -> None:
        self._k0.pop()
        self._i0.pop()
        self._n.pop()

    def index_at(self, k: float) -> tuple[int, int] | None:
        """(engine index, its k) of the sample nearest to ``k`` among those received, or None
        if ``k`` is more than half a sample before the first one."""
        if not self._k0 or k < self._k0[0] - 0.5:
            return None
        j = bisect.bisect_right(self._k0, k) - 1
        if j < 0:
            return self._i0[0], self._k0[0]
        end = self._k0[j] + self._n[j] - 1
        if k <= end + 0.5 or j + 1 == len(self._k0):
            kk = min(max(round(k), self._k0[j]), end)
            return self._i0[j] + kk - self._k0[j], kk
        # in frames lost between two runs: the nearer edge (the later one on a tie, the row
        # the file logs the gap at)
        if k - end < self._k0[j + 1] - k:
            return self._i0[j] + self._n[j] - 1, end
        return self._i0[j + 1], self._k0[j + 1]


RECORDED, BEFORE, AFTER = "recorded", "before", "after"  # what became of a marker placed


@dataclass(frozen=True)
class TimedMarkerCounts:
    """What became of the markers given a host time (``Engine.timed_markers``): each one is
    recorded, or not recorded for a reason (before or after the recording), or waiting."""

    recorded: int = 0  # placed on a row of a recording
    # not recorded: stamped before the recording's first row (or while none had started yet)
    before: int = 0
    # not recorded: stamped after the recording's last row, or arrived once it had stopped
    after: int = 0
    waiting: int = 0  # their sample has not been processed yet

    @property
    def outside(self) -> int:
        """Not recorded: stamped outside the recording (before it or after it)."""
        return self.before + self.after

    def plus(self, whens: list[str]) -> TimedMarkerCounts:
        """These counts and ``whens`` (RECORDED, BEFORE or AFTER per marker)."""
        return dataclasses.replace(self, recorded=self.recorded + whens.count(RECORDED),
                                   before=self.before + whens.count(BEFORE),
                                   after=self.after + whens.count(AFTER))  # fmt: skip


@dataclass(frozen=True)
class Placed:
    """A marker at the engine's sample ``idx`` (sample clock ``k``); ``idx`` is None when its
    instant is outside what the engine received (before the first sample, or after the last
    one at a flush)."""

    label: str
    idx: int | None
    k: int | None
    late: bool = False  # idx None because its instant is after the last sample received


class TimedMarkers:
    """Markers stamped with a host time, waiting for the sample taken at that instant; what
    became of them (``counts``); and the hand-shake by which a stopping recording has the
    engine thread place every marker still waiting (``flush``, ``placing``)."""

    def __init__(self, fs_hz: float, window_s: float = 30.0, max_pending: int = 4096) -> None:
        self.clock = RecentEnvelope(fs_hz, window_s)
        self.index = SampleIndex()
        self._lock = threading.Lock()  # guards _pending, _counts, overflow, _ended, _closed
        self._pending: list[tuple[float, str]] = []
        self._counts = TimedMarkerCounts()  # (waiting: len(_pending))
        self._ended = False  # a recording has stopped: a marker placed with none is after it
        self._closed = False  # the engine thread is gone: nothing will place a marker again
        self._max_pending = max_pending
        self.overflow = 0  # markers refused: more than max_pending waiting (never expected)
        self._flush_asked = threading.Event()
        self._flush_done = threading.Event()

    @property
    def counts(self) -> TimedMarkerCounts:
        with self._lock:
            return dataclasses.replace(self._counts, waiting=len(self._pending))

    def rows(self, placed: list[Placed], row_map: RowMap | None) -> list[int | None]:
        """``file_rows``, counted: recorded, or why not (before or after the recording)."""
        rows = file_rows(placed, row_map)
        with self._lock:
            whens = [RECORDED if r is not None else self._when(m, row_map)
                     for m, r in zip(placed, rows, strict=True)]  # fmt: skip
            self._counts = self._counts.plus(whens)
        return rows

    def _when(self, m: Placed, row_map: RowMap | None) -> str:
        """Why a marker is on none of the recording's rows (under the lock)."""
        start = None if row_map is None else row_map.record_offset
        if start is None:  # no recording: before the first, or after the last one stopped
            return AFTER if self._ended else BEFORE
        if m.idx is None:  # before the first sample received, or after the last one
            return AFTER if m.late else BEFORE
        return BEFORE if m.idx < start - 1 else AFTER  # (start - 1 rounds onto row 0)

    def recording_ended(self) -> None:
        """A recording has stopped (its waiting markers placed): what comes next is after it."""
        with self._lock:
            self._ended = True

    def recording_started(self) -> None:
        with self._lock:
            self._ended = False

    def reopen(self) -> None:
        """The engine thread starts (again): markers are placed."""
        with self._lock:
            self._closed = False

    def close(self) -> None:
        """The engine thread has stopped: the markers still waiting, and any given from now
        on, arrived after the recording (none will be placed)."""
        with self._lock:
            self._closed = True
            late = len(self._pending)
            self._pending.clear()
            self._counts = self._counts.plus([AFTER if self._ended else BEFORE] * late)

    def flush(self, engine_thread: threading.Thread | None, timeout_s: float = 1.0) -> None:
        """Any thread but the engine's: wait until the engine thread has placed every marker
        waiting (one stamped after the last sample received is outside)."""
        t = engine_thread
        if not self.pending or t is None or t is threading.current_thread() or not t.is_alive():
            return
        self._flush_done.clear()
        self._flush_asked.set()
        self._flush_done.wait(timeout_s)

    @contextlib.contextmanager
    def placing(self) -> Iterator[list[Placed]]:
        """The engine thread, once per loop: the markers due (all of them if a flush was asked
        for, and the asker is released once the body has handed them on)."""
        final = self._flush_asked.is_set()
        if final:
            self._flush_asked.clear()
        try:
            yield self.due(final)
        finally:
            if final:
                self._flush_done.set()

    def add(self, label: str, host_time_s: float) -> None:
        """Any thread."""
        with self._lock:
            if self._closed:
                self._counts = self._counts.plus([AFTER if self._ended else BEFORE])
                return
            if len(self._pending) >= self._max_pending:
                self.overflow += 1
                return
            bisect.insort(self._pending, (float(host_time_s), str(label)))

    @property
    def pending(self) -> int:
        with self._lock:
            return len(self._pending)

    def add_block(self, start_idx: int, k: np.ndarray, host_time_s: np.ndarray) -> None:
        """The engine thread, for each processed block."""
        self.index.add(start_idx, k)
        self.clock.add(k, host_time_s)

    def due(self, final: bool = False) -> list[Placed]:
        """The markers whose sample has been processed, placed; with ``final`` also the rest
        (a marker less than one sample after the last sample goes on it, a later one is
        outside)."""
        with self._lock:
            if not self._pending:
                return []
            pending = list(self._pending)
        out: list[Placed] = []
        k_last = self.index.k_last
        done = 0
        for host_s, label in pending:  # in time order: stop at the first still to come
            k = self.clock.k_at(host_s)
            if k is None or k_last is None:
                if not final:
                    break
                out.append(Placed(label, None, None))
            elif k <= k_last + 0.5:
                at = self.index.index_at(k)
                out.append(Placed(label, *at) if at else Placed(label, None, None))
            elif not final:
                break
            elif k <= k_last + 1.5:
                at = self.index.index_at(k_last)
                out.append(Placed(label, *at) if at else Placed(label, None, None))
            else:
                out.append(Placed(label, None, None, late=True))
            done += 1
        with self._lock:
            # markers added meanwhile were inserted in time order too: remove exactly the ones
            # handed out
            for item in pending[:done]:
                self._pending.remove(item)
        return out


def file_rows(placed: list[Placed], row_map: RowMap | None) -> list[int | None]:
    """The recording's row of each placed marker (None: not one of its rows, or no
    recording). A marker half a sample before row 0 rounds onto it."""
    if row_map is None or row_map.record_offset is None:
        return [None] * len(placed)
    out: list[int | None] = []
    for m in placed:
        row = None
        if m.idx is not None:
            rows = row_map.event_rows(np.array([m.idx]))
            if len(rows):
                row = int(rows[0])
            elif m.idx == row_map.record_offset - 1:
                row = 0
        out.append(row)
    return out
