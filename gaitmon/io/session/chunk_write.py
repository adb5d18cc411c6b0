"""Rows written as whole compressed chunks: libdeflate compresses, HDF5 stores the bytes.

A format-2 per-sample series is stored shuffle + gzip (``codec.COMPRESSION``). Written through
HDF5, each chunk is compressed by the zlib HDF5 was built with: at level 6, ~0.3 CPU s for the
~20 MB of series a 1-h ``gaitmon process`` writes, a third of the command. libdeflate writes
the same format (a zlib stream, which HDF5's built-in deflate filter reads: any HDF5 tool reads
the file as before) at the same level in ~2/3 of the CPU, to within ~1 % of the size.

:class:`RowWriter` writes rows that start on a chunk boundary and fill whole chunks (or end at
the dataset's last row: that chunk is padded, as HDF5 stores an edge chunk whole) by shuffling
and compressing each chunk here and handing HDF5 the bytes (``H5Dwrite_chunk``, which replaces
a cached copy of the chunk). Any other write, a dataset with other filters, or a machine
without the ``deflate`` package goes through HDF5 as before: the values in the file are the same
either way (``tests/test_chunk_write.py``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import h5py
import numpy as np

_compress: Callable[[np.ndarray, int], bytes | bytearray] | None
try:  # libdeflate (a dependency; the HDF5 path serves where it cannot be installed)
    from deflate import zlib_compress as _compress
except ImportError:  # pragma: no cover - the tests set _compress to None instead
    _compress = None


@dataclass(frozen=True)
class _Chunked:
    """What compressing a dataset's chunks here needs to know."""

    rows: int  # rows per chunk (a chunk spans the whole width)
    shape: tuple[int, ...]  # of a chunk
    level: int  # deflate level of the dataset's filter
    shuffle: bool


def _chunked(dsid: h5py.h5d.DatasetID) -> _Chunked | None:
    """The chunking of ``dsid`` if its chunks can be compressed here: chunked by rows, a plain
    number type, and filters exactly deflate or shuffle + deflate; else None."""
    dcpl = dsid.get_create_plist()
    if dcpl.get_layout() != h5py.h5d.CHUNKED or dsid.dtype.kind not in "iuf":
        return None
    chunk = tuple(int(c) for c in dcpl.get_chunk())
    if chunk[1:] != tuple(int(s) for s in dsid.shape[1:]):
        return None
    filters = [dcpl.get_filter(i) for i in range(dcpl.get_nfilters())]
    codes = [int(f[0]) for f in filters]
    if codes == [h5py.h5z.FILTER_DEFLATE]:
        shuffle = False
    elif codes == [h5py.h5z.FILTER_SHUFFLE, h5py.h5z.FILTER_DEFLATE]:
        shuffle = True
    else:
        return None
    values = filters[-1][2]
    level = int(values[0]) if len(values) else 6  # (HDF5's default when none is stored)
    return _Chunked(chunk[0], chunk, level, shuffle)


class RowWriter:
    """Writes rows of one dataset (module doc); its chunking is looked up once."""

    def __init__(self, dsid: h5py.h5d.DatasetID) -> None:
        self.dsid = dsid
        self._compress = _compress
        self._chunked = _chunked(dsid) if self._compress is not None else None

    def write(self, start: int, data: np.ndarray) -> None:
        """``dataset[start : start + len(data)] = data`` (within the dataset's current
        extent), whole chunks compressed by libdeflate where they can be."""
        dsid = self.dsid
        data = np.ascontiguousarray(data, dtype=dsid.dtype)
        n = len(data)
        if n == 0:
            return
        stop = start + n
        c, compress = self._chunked, self._compress
        if (compress is None or c is None or start % c.rows
                or (stop % c.rows and stop != int(dsid.shape[0]))
                or data.shape[1:] != c.shape[1:]):  # fmt: skip
            _write_through_hdf5(dsid, start, data)
            return
        zero = (0,) * (len(c.shape) - 1)
        size = data.dtype.itemsize
        for a in range(0, n, c.rows):
            block = data[a : a + c.rows]
            if len(block) < c.rows:  # the dataset's last chunk: stored whole, padded
                padded = np.zeros(c.shape, dtype=data.dtype)
                padded[: len(block)] = block
                block = padded
            raw = block.reshape(-1).view(np.uint8)
            if c.shuffle and size > 1:
                raw = _shuffled(raw, size)
            dsid.write_direct_chunk((start + a, *zero), compress(raw, c.level))


def _shuffled(raw: np.ndarray, size: int) -> np.ndarray:
    """HDF5's shuffle of values of ``size`` bytes: byte k of every value, k = 0, 1, ... (the
    2-byte values, most of a file, by arithmetic: 3x a strided copy's speed)."""
    if size == 2:
        v = raw.view("<u2")  # (each value's first byte is its low byte in this view)
        out = np.empty(raw.size, np.uint8)
        out[: v.size] = v.astype(np.uint8)
        out[v.size :] = (v >> 8).astype(np.uint8)
        return out
    return np.ascontiguousarray(raw.reshape(-1, size).T).reshape(-1)


def _write_through_hdf5(dsid: h5py.h5d.DatasetID, start: int, data: np.ndarray) -> None:
    count = data.shape
    fspace = dsid.get_space()
    fspace.select_hyperslab((start, *(0,) * (len(count) - 1)), count)
    dsid.write(h5py.h5s.create_simple(count), fspace, data)
