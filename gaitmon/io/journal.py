"""The append-only crash journal that sits beside a session file while it is being recorded.

This module owns the journal's byte layout (see ``docs/file-format.md``, "Crash safety"),
writing records (:class:`JournalWriter`) and reading them back (:func:`read_journal`).

Why a journal next to the HDF5 file: an HDF5 file is a tree of metadata that is only
consistent after a flush, and a ``kill -9`` or a power cut in the middle of one can leave it
unreadable. The journal is a flat sequence of self-checking records, each handed to the
operating system with one ``write()`` as soon as the recorder has it, so whatever was handed
over survives a killed process, and whatever was synced survives a power cut. A torn or
damaged tail costs only the records from the first bad one on.

Layout: the 8-byte magic ``GMJRNL01``, then records
``[u8 type][u32 length LE][payload][u32 CRC-32 (zlib) of type+length+payload, LE]``.
Sample blocks are packed row by row (one fixed-size row per sample, see :data:`ROW_DTYPES`),
so the reader gathers millions of rows with a few vectorised numpy operations instead of
a Python loop per row. Every other record is UTF-8 JSON.

The reader never raises on bad bytes: it stops at the first short or bad record and says why
in :attr:`JournalContents.problem`.
"""

from __future__ import annotations

import contextlib
import enum
import json
import mmap
import os
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gaitmon.dsp.channel_table import N_CHANNELS, N_JOINTS, N_SEGMENTS
from gaitmon.io.journal_files import JOURNAL_SUFFIX as JOURNAL_SUFFIX
from gaitmon.io.journal_files import _lock
from gaitmon.io.journal_files import journal_lock as journal_lock
from gaitmon.io.journal_files import journal_path as journal_path

MAGIC = b"GMJRNL01"

# Who the session is about stays out of the journal: a crash leaves the journal beside the file
# (possibly for long, on a shared drive), and it is plain bytes. The header record carries these
# /session fields blank and IDENTITY_IN_FILE = true; the HDF5 file, created and flushed before
# the first row, holds them, and recovery takes them from there.
IDENTITY_FIELDS: tuple[str, ...] = ("patient_id", "operator", "notes")
IDENTITY_IN_FILE = "identity_in_file"


class RecordType(enum.IntEnum):
    HEADER = 1
    RAW = 2
    TILT = 3
    JOINT = 4
    MARKER = 5
    GAP = 6
    CONFIG = 7
    CALIBRATION = 8
    LINK = 9
    FSR_FAULT = 10


BLOCK_TYPES: dict[str, RecordType] = {
    "raw": RecordType.RAW,
    "tilt": RecordType.TILT,
    "joint": RecordType.JOINT,
}

# One row per sample, little-endian and packed: the block payload after its 12-byte head.
# lost_before: frames the unit sent just before this sample that never arrived.
_COMMON = [("seq", "<i8"), ("host_time_s", "<f8"), ("lost_before", "<u4")]
N_COMMON_FIELDS = len(_COMMON)
ROW_DTYPES: dict[RecordType, np.dtype] = {
    RecordType.RAW: np.dtype([*_COMMON, ("adc", "<u2", (N_CHANNELS,))]),
    RecordType.TILT: np.dtype(
        [
            *_COMMON,
            ("acc_tilt_deg", "<f8", (N_SEGMENTS,)),
            ("kalman_tilt_deg", "<f8", (N_SEGMENTS,)),
        ]
    ),
    RecordType.JOINT: np.dtype(
        [
            *_COMMON,
            ("acc_joint_deg", "<f8", (N_JOINTS,)),
            ("kalman_joint_deg", "<f8", (N_JOINTS,)),
            ("heel_loaded", "u1"),
            ("toe_loaded", "u1"),
            ("phase", "u1"),
        ]
    ),
}

_HEAD = struct.Struct("<BI")  # type, payload length
_TAIL = struct.Struct("<I")  # CRC-32
_BLOCK_HEAD = struct.Struct("<Id")  # n rows, wall_offset_s
_MAX_PAYLOAD = 1 << 30  # a longer length field can only be garbage
_GATHER_ROWS = 1 << 16  # rows gathered per numpy step (bounds the index array's memory)


def without_identity(header: dict[str, Any]) -> dict[str, Any]:
    """The session header as the journal keeps it: the identity fields blank (see
    :data:`IDENTITY_FIELDS`)."""
    session = dict(header.get("session", {}))
    for k in IDENTITY_FIELDS:
        if k in session:
            session[k] = ""
    return {**header, "session": session, IDENTITY_IN_FILE: True}


def encode_record(rtype: int, payload: bytes) -> bytes:
    head = _HEAD.pack(rtype, len(payload))
    return head + payload + _TAIL.pack(zlib.crc32(payload, zlib.crc32(head)))


def encode_json(rtype: RecordType, obj: Any) -> bytes:
    return encode_record(rtype, json.dumps(obj, separators=(",", ":")).encode("utf-8"))


def encode_block(rtype: RecordType, wall_offset_s: float, rows: np.ndarray) -> bytes:
    """A block record from a structured array of :data:`ROW_DTYPES` ``[rtype]``."""
    return encode_record(rtype, _BLOCK_HEAD.pack(len(rows), wall_offset_s) + rows.tobytes())


class JournalWriter:
    """Appends records to a new journal file; every record is one ``write()`` to the OS.

    Not thread-safe (one recorder thread owns it). Raises ``OSError`` on any failure; a record
    cut short by a failed write is ignored by the reader.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND | getattr(os, "O_CLOEXEC", 0)
        self._fd: int | None = os.open(self.path, flags, 0o644)
        _lock(self._fd)  # tells other processes the recording is live (see journal_lock)
        self.bytes_written = 0
        self.write_raw(MAGIC)

    def write_raw(self, data: bytes) -> None:
        if self._fd is None:
            raise OSError(f"journal {self.path.name} is closed")
        view = memoryview(data)
        while view:  # a regular file may take fewer bytes than asked (e.g. at a size limit)
            n = os.write(self._fd, view)
            self.bytes_written += n
            view = view[n:]

    def sync(self) -> None:
        """To the disk (survives a power cut), not just to the OS."""
        if self._fd is not None:
            os.fdatasync(self._fd)

    def close(self) -> None:
        if self._fd is not None:
            fd, self._fd = self._fd, None
            os.close(fd)


@dataclass
class JournalContents:
    """Everything that could be read back from a journal, in journal order.

    ``rows`` is a structured array of the session's block kind (``None`` without a header).
    Logs are lists of ``(sample_idx, obj)``; ``obj`` is the record's JSON object.
    ``problem`` is empty when the journal ended cleanly on a record boundary.
    """

    header: dict[str, Any] | None = None
    rows: np.ndarray | JournalRows | None = None
    wall_offset_s: float | None = None
    n_blocks: int = 0
    markers: list[dict[str, Any]] = field(default_factory=list)
    gaps: list[dict[str, Any]] = field(default_factory=list)
    changes: list[tuple[RecordType, dict[str, Any]]] = field(default_factory=list)
    links: list[dict[str, Any]] = field(default_factory=list)
    fsr_faults: list[dict[str, Any]] = field(default_factory=list)
    valid_bytes: int = 0
    total_bytes: int = 0
    problem: str = ""

    @property
    def n_rows(self) -> int:
        return 0 if self.rows is None else len(self.rows)


_JSON_KEYS: dict[RecordType, tuple[str, ...]] = {
    RecordType.MARKER: ("sample_idx", "label"),
    RecordType.GAP: ("sample_idx", "n_lost", "duration_s", "reason"),
    RecordType.CONFIG: ("sample_idx", "config"),
    RecordType.CALIBRATION: ("sample_idx", "calibration"),
    RecordType.LINK: ("sample_idx", "totals"),
    RecordType.FSR_FAULT: ("sample_idx", "stride_start_idx", "sensor", "reason"),
}


def read_journal(path: str | os.PathLike[str]) -> JournalContents:
    """Read every valid record. Raises ``OSError`` only if the file cannot be opened or read."""
    with open(path, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        if size == 0:
            return JournalContents(problem="the journal is empty")
        mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
    try:
        return _parse(mm, size)
    finally:
        with contextlib.suppress(BufferError):  # only if an error left a view alive
            mm.close()


def _parse(mm: mmap.mmap, size: int) -> JournalContents:
    out = JournalContents(total_bytes=size)
    if size < len(MAGIC) or mm[: len(MAGIC)] != MAGIC:
        out.problem = "not a gaitmon journal (bad magic bytes)"
        return out
    unpack_head = _HEAD.unpack_from
    unpack_tail = _TAIL.unpack_from
    unpack_block = _BLOCK_HEAD.unpack_from
    crc32 = zlib.crc32
    block_type: RecordType | None = None
    row_size = 0
    singles: list[tuple[int, int]] = []  # (offset of the rows, n) of blocks read one by one
    offset_parts: list[np.ndarray] = []  # in journal order, singles flushed between runs
    n_parts: list[np.ndarray] = []

    def flush_singles() -> None:
        if singles:
            offset_parts.append(np.array([a for a, _ in singles], dtype=np.int64))
            n_parts.append(np.array([n for _, n in singles], dtype=np.int64))
            singles.clear()

    n_rows = 0
    o = len(MAGIC)
    buf = np.frombuffer(mm, dtype=np.uint8)
    with memoryview(mm) as mv:
        while True:
            if o + _HEAD.size > size:
                if o < size:
                    out.problem = f"a record cut short at byte {o} (ignored)"
                break
            rtype, length = unpack_head(mm, o)
            end = o + _HEAD.size + length
            if length > _MAX_PAYLOAD or end + _TAIL.size > size:
                out.problem = f"a record cut short at byte {o} (ignored)"
                break
            if crc32(mv[o:end]) != unpack_tail(mm, end)[0]:
                out.problem = f"a damaged record at byte {o} (CRC mismatch); later records ignored"
                break
            body = o + _HEAD.size
            if out.header is None and rtype != RecordType.HEADER:
                out.problem = "the journal does not start with a header record"
                break
            if rtype == RecordType.HEADER:
                if out.header is not None:
                    out.problem = f"a second header at byte {o}; later records ignored"
                    break
                header = _json_or_none(mv[body:end])
                mode = header.get("mode") if isinstance(header, dict) else None
                if mode not in BLOCK_TYPES:
                    out.problem = "the journal header is not a gaitmon session header"
                    break
                out.header = header
                block_type = BLOCK_TYPES[mode]
                row_size = ROW_DTYPES[block_type].itemsize
            elif rtype in (RecordType.RAW, RecordType.TILT, RecordType.JOINT):
                if length < _BLOCK_HEAD.size:
                    out.problem = f"a malformed block at byte {o}; later records ignored"
                    break
                n, wall = unpack_block(mm, body)
                if rtype != block_type or length != _BLOCK_HEAD.size + n * row_size:
                    out.problem = f"a malformed block at byte {o}; later records ignored"
                    break
                if out.wall_offset_s is None and n:
                    out.wall_offset_s = wall
                singles.append((body + _BLOCK_HEAD.size, n))
                n_rows += n
                # Fast path: a recording is mostly a long run of blocks of the same size;
                # check their headers with numpy and only their CRCs one by one.
                rec_len = end + _TAIL.size - o
                run = _same_block_run(buf, mv, end + _TAIL.size, rec_len, buf[o : o + 9], size)
                if run:
                    flush_singles()
                    first = end + _TAIL.size
                    starts = first + rec_len * np.arange(run, dtype=np.int64)
                    offset_parts.append(starts + _HEAD.size + _BLOCK_HEAD.size)
                    n_parts.append(np.full(run, n, dtype=np.int64))
                    n_rows += run * n
                    end = first + rec_len * run - _TAIL.size
            elif rtype in _JSON_KEYS:
                obj = _json_or_none(mv[body:end])
                if not (isinstance(obj, dict) and all(k in obj for k in _JSON_KEYS[rtype])):
                    out.problem = f"a malformed {rtype.name.lower()} record at byte {o}"
                    break
                if rtype == RecordType.MARKER:
                    out.markers.append(obj)
                elif rtype == RecordType.GAP:
                    out.gaps.append(obj)
                elif rtype == RecordType.LINK:
                    out.links.append(obj)
                elif rtype == RecordType.FSR_FAULT:
                    out.fsr_faults.append(obj)
                else:
                    out.changes.append((RecordType(rtype), obj))
            # else: a record type from a later version, CRC-valid: skip it
            o = end + _TAIL.size
        out.valid_bytes = o
    flush_singles()
    if out.header is None and not out.problem:
        out.problem = "the journal has no header record"
    if out.header is not None and block_type is not None:
        offsets = np.concatenate(offset_parts) if offset_parts else np.empty(0, np.int64)
        ns = np.concatenate(n_parts) if n_parts else np.empty(0, np.int64)
        out.rows = JournalRows(mm, buf, ROW_DTYPES[block_type], offsets, ns, n_rows)
        out.n_blocks = len(ns)
        _release(mm, size)  # the parse read every page: they are read again when sliced
    del buf  # (the rows keep their own export of the map, and the map with it)
    return out


_RUN_STEP = 1 << 15  # records examined per numpy step of the fast path


def _same_block_run(
    buf: np.ndarray, mv: memoryview, start: int, rec_len: int, head: np.ndarray, size: int
) -> int:
    """How many records from ``start`` on are complete, CRC-valid and have exactly the 9 head
    bytes (type, length, n) of the block before them."""
    crc32 = zlib.crc32
    body_len = rec_len - _TAIL.size
    cols = np.arange(9, dtype=np.int64)
    tail_cols = np.arange(_TAIL.size, dtype=np.int64) + body_len
    count = 0
    while True:
        avail = (size - start) // rec_len
        k = min(avail, _RUN_STEP)
        if k <= 0:
            return count
        starts = start + rec_len * np.arange(k, dtype=np.int64)
        same = np.all(buf[starts[:, None] + cols] == head, axis=1)
        m = k if same.all() else int(np.argmin(same))
        if m:
            stored = buf[starts[:m, None] + tail_cols].copy().view("<u4").ravel()
            computed = np.fromiter(
                (crc32(mv[p : p + body_len]) for p in starts[:m].tolist()), np.uint32, m
            )
            bad = np.flatnonzero(stored != computed)
            if len(bad):
                m = int(bad[0])
        count += m
        if m < k:
            return count
        start += rec_len * k


def _json_or_none(data: memoryview) -> Any:
    try:
        return json.loads(bytes(data).decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        return None


def _release(mm: mmap.mmap, upto: int) -> None:
    """Let the mapped journal's pages before byte ``upto`` go (they stay in the page cache and
    are read again if touched): the rows gathered out of a long journal do not sit in memory
    beside the mapped file (an 8-hour journal: 138 MB twice)."""
    upto -= upto % mmap.PAGESIZE
    if upto > 0 and hasattr(mm, "madvise") and hasattr(mmap, "MADV_DONTNEED"):
        with contextlib.suppress(OSError, ValueError):
            mm.madvise(mmap.MADV_DONTNEED, 0, upto)


class JournalRows:
    """A journal's sample rows, read out of the mapped file when sliced: ``rows[a:b]`` is a
    structured array of :data:`ROW_DTYPES` (a copy), ``rows["seq"]`` a column sliced the same
    way (``rows["seq"][a:b]``), and ``np.asarray(rows)`` all of them. So a long journal's rows
    (~50 bytes each: 138 MB for 8 hours) are not copied into memory beside the map; the map's
    pages already read can be let go (:meth:`release_before`: they are read from the file
    again if touched). The map stays open while the rows are referenced: drop them before the
    journal is deleted (Windows cannot delete a mapped file)."""

    def __init__(
        self, mm: mmap.mmap, buf: np.ndarray, dtype: np.dtype, offsets: np.ndarray,
        ns: np.ndarray, n_rows: int,
    ) -> None:  # fmt: skip
        self._mm = mm
        self._buf = buf
        self.dtype = dtype
        self._offsets = offsets  # byte offset of each block's first row
        self._first = np.cumsum(ns) - ns  # each block's first row
        self._n = int(n_rows)
        self._last: tuple[int, int, np.ndarray] | None = None  # the last rows read

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, key: str | slice) -> Any:
        if isinstance(key, str):
            return _JournalColumn(self, key)
        if isinstance(key, slice) and key.step in (None, 1):
            a, b, _ = key.indices(self._n)
            return self._read(a, max(a, b))
        raise TypeError("journal rows take row slices a:b or a field name")

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        out = self._read(0, self._n)
        return out if dtype is None else out.astype(dtype)

    def _read(self, a: int, b: int) -> np.ndarray:
        if self._last is not None and self._last[:2] == (a, b):
            return self._last[2]  # (the columns of one chunk are asked one after the other)
        out = np.empty(b - a, dtype=self.dtype)
        flat = out.view(np.uint8).reshape(b - a, self.dtype.itemsize)
        cols = np.arange(self.dtype.itemsize, dtype=np.int64)
        for c in range(a, b, _GATHER_ROWS):
            d = min(b, c + _GATHER_ROWS)
            flat[c - a : d - a] = self._buf[self._row_offsets(c, d)[:, None] + cols]
        self._last = (a, b, out)
        return out

    def _row_offsets(self, a: int, b: int) -> np.ndarray:
        """The byte offset of rows a:b in the map."""
        rows = np.arange(a, b, dtype=np.int64)
        block = np.searchsorted(self._first, rows, side="right") - 1
        return np.asarray(self._offsets[block] + self.dtype.itemsize * (rows - self._first[block]))

    def release_before(self, row: int) -> None:
        """Let the map's pages before row ``row``'s go (rows are in journal order)."""
        if 0 < row <= self._n:
            _release(self._mm, int(self._row_offsets(row - 1, row)[0]))


class _JournalColumn:
    """One field of :class:`JournalRows`, read when sliced."""

    def __init__(self, rows: JournalRows, name: str) -> None:
        self._rows = rows
        self._name = name
        self.dtype = rows.dtype[name]

    def __len__(self) -> int:
        return len(self._rows)

    def __getitem__(self, key: slice) -> np.ndarray:
        return np.asarray(self._rows[key][self._name])

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        out = np.asarray(self._rows)[self._name]
        return out if dtype is None else out.astype(dtype)
