"""Min/max ("peak") decimation of long per-sample series, for drawing hours of data fast.

This module owns how the review window reads a long session: only the rows of the visible
range, and never more points than the screen can show. Qt-free (numpy + the session reader).

* :func:`peak_decimate` - one pass of min/max decimation over an in-memory array;
* :class:`PeakPyramid` - min and max of every bin of ``base_step * factor**level`` rows of one
  (N, k) series, built once in a chunked pass (with progress and cancel) and kept in memory
  (an 8-hour series of 3 float32 columns at base step 16 takes ~2.9 MB for all levels; the
  pyramid is cheap to rebuild, so no side file is ever written next to a recording);
* :class:`SessionOverview` - the cache the window queries: ``window(name, start, stop,
  max_points)`` answers from raw rows when they are few, from a direct read + decimation when
  the range is moderate, and from the series' pyramid (built on first need) when the range is
  long (zoomed out over hours).

Every answer is a :class:`PeakWindow`: ``idx`` (row numbers, to map onto ``/timeline/t_s``) and
``y``; a decimated answer holds two rows per bin (the bin's min then max, both at the bin's
first row), so the drawn envelope keeps every peak that the full-rate data has. NaN values
(device modes leave some series NaN) are ignored by the min/max; an all-NaN bin stays NaN.

Gaps (lost frames) are not rows of the file: the row after a gap simply has a later time. So
that a line is never drawn across lost data, a :class:`SessionOverview` given the gaps' rows
(``breaks``) inserts a NaN row after the last point before each gap (:func:`break_at_gaps`), at
every zoom level, from raw rows, a direct decimation or the pyramid alike; drawn with
``connect='finite'`` the line stops at the gap and starts again after it.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gaitmon.errors import Cancelled

__all__ = ["PeakPyramid", "PeakWindow", "SessionOverview", "break_at_gaps", "peak_decimate"]

Reader = Callable[[str, int, int], np.ndarray]  # (series name, start row, stop row) -> rows
Progress = Callable[[float], bool | None]  # fraction done -> False to cancel

BASE_STEP = 16  # rows per bin of the finest pyramid level (0.16 s at 100 Hz)
FACTOR = 4  # each level's bins hold FACTOR bins of the level below
CHUNK_ROWS = 1 << 16  # rows read per step while building (rounded to whole base bins)
DIRECT_FACTOR = 48  # ranges up to this many rows per point are read and decimated directly


@dataclass(frozen=True, eq=False)
class PeakWindow:
    """Rows ``start:stop`` of one series as drawn: ``y`` (m, k) at row numbers ``idx`` (m,).

    ``step`` is the number of rows per bin (1 = every row, no decimation). For ``step > 1``
    rows ``2j`` and ``2j + 1`` of ``y`` are the min and max of bin ``j``, and ``idx`` holds the
    bin's first row twice. ``start``/``stop`` is the row range covered (whole bins).
    """

    idx: np.ndarray
    y: np.ndarray
    step: int
    start: int
    stop: int

    @property
    def decimated(self) -> bool:
        return self.step > 1


def break_at_gaps(
    w: PeakWindow, breaks: np.ndarray, n_lost: np.ndarray | None = None
) -> PeakWindow:
    """``w`` with a NaN row inserted wherever a gap falls between two of its points.

    ``breaks`` are sorted row numbers ``g``: the first row after a gap (rows ``g - 1`` and
    ``g`` are not consecutive samples); ``n_lost`` the frames each gap lost (default: many).
    The NaN row goes after the last point of the bin that holds row ``g - 1`` (for
    ``step == 1``: between rows ``g - 1`` and ``g``) and takes that point's row number, so the
    x of every point is unchanged. A decimated window breaks only at gaps at least one bin
    long: a shorter one is narrower than half a pixel, and breaking there would hatch the
    envelope of a long session with random single-frame losses. Integer series come back as
    float64 (NaN).
    """
    b = np.asarray(breaks, dtype=np.int64)
    keep = (b > w.start) & (b < w.stop)
    if n_lost is not None:
        keep &= np.asarray(n_lost, dtype=np.int64) >= w.step
    b = b[keep]
    if not len(b) or not len(w.idx):
        return w
    if w.step == 1:
        pos = b - w.start  # insert before the point of row g
    else:
        pos = 2 * ((b - 1 - w.start) // w.step + 1)  # after the max of the bin holding g - 1
    pos = np.unique(pos[(pos > 0) & (pos < len(w.idx))])
    if not len(pos):
        return w
    y = w.y if np.issubdtype(w.y.dtype, np.floating) else w.y.astype(np.float64)
    idx = np.insert(w.idx, pos, w.idx[pos - 1])
    y = np.insert(y, pos, np.nan, axis=0)
    return PeakWindow(idx, y, w.step, w.start, w.stop)


def _minmax_bins(y: np.ndarray, step: int) -> tuple[np.ndarray, np.ndarray]:
    """Min and max of consecutive bins of ``step`` rows (the last bin may be short)."""
    n = len(y)
    m_full = n // step
    rest = n - m_full * step
    shape = y.shape[1:]
    mins = np.empty((m_full + (rest > 0), *shape), dtype=y.dtype)
    maxs = np.empty_like(mins)
    if m_full:
        full = y[: m_full * step].reshape(m_full, step, *shape)
        # fmin/fmax skip NaNs without warnings; an all-NaN bin stays NaN
        np.fmin.reduce(full, axis=1, out=mins[:m_full])
        np.fmax.reduce(full, axis=1, out=maxs[:m_full])
    if rest:
        tail = y[m_full * step :]
        mins[-1] = np.fmin.reduce(tail, axis=0)
        maxs[-1] = np.fmax.reduce(tail, axis=0)
    return mins, maxs


def _interleave(
    start: int, step: int, mins: np.ndarray, maxs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    m = len(mins)
    idx = np.repeat(start + step * np.arange(m, dtype=np.int64), 2)
    y = np.empty((2 * m, *mins.shape[1:]), dtype=mins.dtype)
    y[0::2] = mins
    y[1::2] = maxs
    return idx, y


def peak_decimate(y: np.ndarray, max_points: int, start: int = 0) -> PeakWindow:
    """Min/max decimate (N, ...) rows ``y`` (row 0 = absolute row ``start``) to at most
    ``max_points`` rows; returns every row when they already fit."""
    y = np.asarray(y)
    n = len(y)
    if max_points < 2:
        raise ValueError(f"max_points must be >= 2, got {max_points}")
    if n <= max_points:
        return PeakWindow(np.arange(start, start + n, dtype=np.int64), y, 1, start, start + n)
    step = math.ceil(n / (max_points // 2))
    mins, maxs = _minmax_bins(y, step)
    idx, out = _interleave(start, step, mins, maxs)
    return PeakWindow(idx, out, step, start, start + n)


class PeakPyramid:
    """Min/max bins of one (N, k) series at steps ``base_step * factor**level``.

    Built in one chunked pass (:meth:`build`), then queried for any row range without touching
    the file again.
    """

    def __init__(
        self, levels: list[tuple[np.ndarray, np.ndarray]], n_rows: int, base_step: int, factor: int
    ) -> None:
        self.levels = levels  # level -> (mins, maxs), each (ceil(n / step), k)
        self.n_rows = n_rows
        self.base_step = base_step
        self.factor = factor

    def step(self, level: int) -> int:
        return self.base_step * self.factor**level

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes + b.nbytes for a, b in self.levels)

    @classmethod
    def from_array(
        cls, y: np.ndarray, base_step: int = BASE_STEP, factor: int = FACTOR
    ) -> PeakPyramid:
        y = np.asarray(y)
        return cls.build(lambda a, b: y[a:b], len(y), base_step=base_step, factor=factor)

    @classmethod
    def build(
        cls,
        read: Callable[[int, int], np.ndarray],
        n_rows: int,
        *,
        base_step: int = BASE_STEP,
        factor: int = FACTOR,
        chunk_rows: int = CHUNK_ROWS,
        progress: Progress | None = None,
    ) -> PeakPyramid:
        """Read rows ``[a, b)`` with ``read(a, b)`` chunk by chunk; ``progress(fraction)``
        returning False raises :class:`Cancelled`."""
        if base_step < 2 or factor < 2:
            raise ValueError("base_step and factor must be >= 2")
        chunk_rows = max(base_step, chunk_rows // base_step * base_step)
        mins_parts: list[np.ndarray] = []
        maxs_parts: list[np.ndarray] = []
        for a in range(0, n_rows, chunk_rows):
            b = min(n_rows, a + chunk_rows)
            mi, ma = _minmax_bins(np.asarray(read(a, b)), base_step)
            mins_parts.append(mi)
            maxs_parts.append(ma)
            if progress is not None and progress(b / n_rows) is False:
                raise Cancelled
        if not mins_parts:
            raise ValueError("cannot build a pyramid of an empty series")
        return cls.from_level0(np.concatenate(mins_parts), np.concatenate(maxs_parts), n_rows,
                               base_step, factor)  # fmt: skip

    @classmethod
    def from_level0(
        cls, mins: np.ndarray, maxs: np.ndarray, n_rows: int, base_step: int = BASE_STEP,
        factor: int = FACTOR,
    ) -> PeakPyramid:
        """The pyramid from its finest level (min and max of every ``base_step`` rows, e.g.
        as a session file stores them), the coarser levels computed from it."""
        levels = [(mins, maxs)]
        # coarser levels from the finer bins: min of mins, max of maxs (exact, since the
        # bins nest: a level-l bin is exactly `factor` level-(l-1) bins, the last one short)
        while len(levels[-1][0]) > 64:
            lo, hi = levels[-1]
            levels.append((_minmax_bins(lo, factor)[0], _minmax_bins(hi, factor)[1]))
        return cls(levels, n_rows, base_step, factor)

    def query(self, start: int, stop: int, max_points: int) -> PeakWindow:
        """The bins covering rows ``[start, stop)`` at the finest level with at most
        ``max_points`` rows (two per bin); the coarsest level if none is that coarse."""
        start = max(0, min(int(start), self.n_rows))
        stop = max(start, min(int(stop), self.n_rows))
        max_bins = max(1, max_points // 2)
        level = 0
        while True:
            step = self.step(level)
            first, last = start // step, -(-stop // step)
            if last - first <= max_bins or level == len(self.levels) - 1:
                break
            level += 1
        mins, maxs = self.levels[level]
        idx, y = _interleave(first * step, step, mins[first:last], maxs[first:last])
        return PeakWindow(idx, y, step, first * step, min(self.n_rows, last * step))


class SessionOverview:
    """Visible-range reads of a session's series with min/max decimation and cached pyramids.

    ``read(name, start, stop)`` returns rows of a per-sample series (for a :class:`Session`:
    ``lambda n, a, b: s.read_range(a, b, [n])[n]``); 2-D (N, k) or more (flattened to k).
    Safe to call from worker threads; a pyramid being built by one thread is waited for by
    the others rather than built twice.
    """

    def __init__(
        self,
        read: Reader,
        n_rows: int,
        *,
        base_step: int = BASE_STEP,
        breaks: np.ndarray | None = None,
        break_lost: np.ndarray | None = None,
        stored: Callable[[str], PeakPyramid | None] | None = None,
    ) -> None:
        self._read = read
        # a series' pyramid as the file stores it (Session.stored_pyramid), tried before
        # building one from the rows
        self._stored = stored
        self.n_rows = int(n_rows)
        # first rows after the gaps, and the frames each lost: every answer breaks its line
        # there (see break_at_gaps)
        b = np.asarray([] if breaks is None else breaks, dtype=np.int64)
        lost = np.full(len(b), np.iinfo(np.int64).max) if break_lost is None else break_lost
        order = np.argsort(b, kind="stable")
        self.breaks = b[order]
        self.break_lost = np.asarray(lost, dtype=np.int64)[order]
        self.base_step = base_step
        self._pyramids: dict[str, PeakPyramid] = {}
        self._locks: dict[str, threading.Lock] = {}
        self._lock = threading.Lock()

    def read_rows(self, name: str, start: int, stop: int) -> np.ndarray:
        y = np.asarray(self._read(name, start, stop))
        return y.reshape(len(y), -1)

    def has_pyramid(self, name: str) -> bool:
        return name in self._pyramids

    def pyramid(self, name: str, progress: Progress | None = None) -> PeakPyramid:
        """The series' pyramid, built now if needed (may raise :class:`Cancelled`)."""
        with self._lock:
            got = self._pyramids.get(name)
            if got is not None:
                return got
            lock = self._locks.setdefault(name, threading.Lock())
        with lock:
            got = self._pyramids.get(name)
            if got is not None:
                return got
            if self._stored is not None:
                got = self._stored(name)
                if got is not None and (got.n_rows, got.base_step) != (self.n_rows,
                                                                       self.base_step):
                    got = None
            if got is None:
                got = PeakPyramid.build(
                    lambda a, b: self.read_rows(name, a, b),
                    self.n_rows,
                    base_step=self.base_step,
                    progress=progress,
                )
            with self._lock:
                self._pyramids[name] = got
        return got

    def window(
        self,
        name: str,
        start: int,
        stop: int,
        max_points: int,
        progress: Progress | None = None,
    ) -> PeakWindow:
        """Rows ``[start, stop)`` of ``name`` as at most ~``max_points`` rows."""
        start = max(0, min(int(start), self.n_rows))
        stop = max(start, min(int(stop), self.n_rows))
        n = stop - start
        if n <= max_points:
            w = PeakWindow(
                np.arange(start, stop, dtype=np.int64),
                self.read_rows(name, start, stop),
                1,
                start,
                stop,
            )
        elif math.ceil(n / (max_points // 2)) < self.base_step or (
            not self.has_pyramid(name) and n <= DIRECT_FACTOR * max_points
        ):
            # finer than the pyramid, or a moderate range: one read of the range is cheaper
            # than building the whole series' pyramid
            w = peak_decimate(self.read_rows(name, start, stop), max_points, start)
        else:
            w = self.pyramid(name, progress).query(start, stop, max_points)
        return break_at_gaps(w, self.breaks, self.break_lost)

    def envelope(self, name: str, max_points: int) -> PeakWindow:
        """The whole series from its (already built) pyramid, broken at the gaps; a series
        shorter than ``max_points / 2`` bins of the pyramid's finest level (a few minutes) from
        its rows, as :meth:`window` reads them: drawn from 16-row bins, a 20-s walk's knee
        was a sawtooth of min-max strokes 10 pixels apart, not its curve."""
        if math.ceil(self.n_rows / max(1, max_points // 2)) < self.base_step:
            return self.window(name, 0, self.n_rows, max_points)
        w = self.pyramid(name).query(0, self.n_rows, max_points)
        return break_at_gaps(w, self.breaks, self.break_lost)
