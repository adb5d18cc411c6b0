"""A series' values at chosen rows only, read a bounded slice at a time: what the stride
analysis needs of ``/timeline/t_s`` (the true time at each heel strike and toe off) without
the whole series in memory (23 MB of float64 for an 8-hour record, read whole on top of the
joint angles by ``gaitmon info``, the report and a recovery's closing analysis: issue 28)."""

from __future__ import annotations

from typing import Protocol

import numpy as np

SLICE_ROWS = 1 << 18  # rows read at a time (2 MB of float64 times)


class RangeReader(Protocol):
    n_samples: int

    def read_range(
        self, start: int, stop: int, names: list[str] | None = None
    ) -> dict[str, np.ndarray]: ...


class RowValues:
    """The values of a 1-D per-sample series at ``rows`` (of a record of ``n`` rows), with
    the two things the stride analysis asks of a whole array: ``len`` (the record's rows) and
    ``take(rows)`` (the values at rows it holds, as ``ndarray.take`` gives them)."""

    def __init__(self, n: int, rows: np.ndarray, values: np.ndarray) -> None:
        self._n = int(n)
        self.rows = rows
        self.values = values

    def __len__(self) -> int:
        return self._n

    def take(self, rows: object) -> np.ndarray:
        r = np.asarray(rows, dtype=np.int64)
        k = np.searchsorted(self.rows, r)
        if len(r) and (k.max() >= len(self.rows) or np.any(self.rows[k] != r)):
            raise IndexError("a row that was not read")
        return self.values[k]

    @classmethod
    def read(
        cls, session: RangeReader, name: str, rows: np.ndarray, slice_rows: int | None = None
    ) -> RowValues:
        """``name`` at ``rows`` (any order, repeats, rows past the record dropped), read
        from ``session`` a slice of at most ``slice_rows`` (:data:`SLICE_ROWS`) rows at a time."""
        step = slice_rows or SLICE_ROWS
        n = int(session.n_samples)
        r = np.sort(np.asarray(rows, dtype=np.int64).ravel())
        r = r[(r >= 0) & (r < n)]
        if len(r):
            r = r[np.concatenate(([True], r[1:] != r[:-1]))]
        parts: list[np.ndarray] = []
        i = 0
        while i < len(r):
            a = int(r[i])
            j = int(np.searchsorted(r, a + step))  # the rows inside [a, a + step)
            b = int(r[j - 1]) + 1
            block = session.read_range(a, b, [name])[name]
            parts.append(block[r[i:j] - a])
            del block
            i = j
        values = np.concatenate(parts) if parts else np.empty(0)
        return cls(n, r, values)
