"""A session file from elsewhere is read only from itself, within a bound on memory
(``docs/trust-model.md``, "A session file from elsewhere").

HDF5 lets a file point outside itself: a dataset's bytes can live in another file (external raw
storage, e.g. ``/etc/passwd``), a link can lead into another file (external links), a dataset can
map other files' datasets (virtual datasets). It also lets a small file declare huge things: a
dataset of 10^12 rows that stores nothing, an attribute of hundreds of MB. :func:`check_file`
walks a file once when it is opened (:func:`gaitmon.io.session.opening.open_h5`, which every
command and window uses) and refuses any of these with one :class:`SessionError` line naming
the object and why, before anything is read. :func:`checked_counts` refuses raw counts the
channel table's ADC cannot make, where counts are read (a whole-file scan at open would cost
an 8-hour file ~1.5 s).

Sizes checked before reading: every dataset's declared size and every attribute's stored size
(HDF5's own figures); a text attribute's length, which HDF5 keeps in the file's global heap and
only gives by reading the whole text, is read from its 16-byte heap reference in the object
header (:func:`_attribute_data_offsets`, a minimal reader of the header layout of the HDF5
file-format specification, section IV.A).
"""

from __future__ import annotations

import contextlib
import math
import os
import struct
from pathlib import Path
from typing import BinaryIO

import h5py
import numpy as np

from gaitmon.dsp.channels import DEFAULT_TABLE, ChannelTable
from gaitmon.io.session.header import SessionError

# One attribute's stored bytes (a number, a short array, a line of text, the notes): gaitmon's
# largest is the clinician's notes, a few KB.
MAX_ATTRIBUTE_BYTES = 1 << 20
# The data a file may declare per byte it holds. gaitmon's files declare up to ~5x their size
# (per-sample data: a long walk ~4.6x, ~49 bytes a row for ~224; a standing session 3.7x;
# whole files measured: a 12-s walk 0.8x, a 200-s standing session 1.9x, format 1 0.2-0.6x;
# tests/test_hostile_files.py, test_the_budget_leaves_room_for_real_files). gzip can reach
# ~1000x on constant data, so a file made to expand is refused long before memory runs out.
EXPANSION = 64
# ... and below this, whatever the ratio (a small file cannot cost much memory).
MIN_BUDGET_BYTES = 64 << 20
# A text attribute whose length cannot be read from its header is read only from files this
# small (any text in them is at most this long).
UNCHECKED_FILE_BYTES = 16 << 20

_CONTINUATION, _ATTRIBUTE = 0x10, 0x0C
_MAX_HEADER_BLOCKS = 256


def _mb(n: float) -> str:
    return f"{n / 1e6:,.1f} MB" if n < 1e12 else f"{n / 1e12:,.0f} TB"


# The files that passed check_file in this process, by the open file's identity and change
# stamps: a command that opens one file twice (gaitmon info: is it bilateral, then the reader)
# walks it once; a file changed since (its size, mtime or ctime) is walked again.
_PASSED: set[tuple[int, ...]] = set()


def _stamp(f: h5py.File) -> tuple[int, ...] | None:
    """The open file's (device, inode, size, mtime ns, ctime ns), None when its driver has no
    file descriptor to ask."""
    with contextlib.suppress(Exception):
        return _stamp_of(os.fstat(int(f.id.get_vfd_handle())))
    return None


def _stamp_of(st: os.stat_result) -> tuple[int, ...]:
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)


def check_file(path: Path, f: h5py.File) -> None:
    """Refuse (one :class:`SessionError` line) a file open in ``f`` that reads from outside
    itself (external storage, external or user-defined links, virtual datasets) or declares
    more data than it can hold (see the module's text). Reads no dataset; cheap (one pass over
    its few dozen objects), and once per unchanged file in a process (``_PASSED``)."""
    stamp = _stamp(f)
    if stamp is not None and stamp in _PASSED:
        return
    _walk(path, f)
    if stamp is not None:
        _PASSED.add(stamp)


def written_here(path: Path) -> None:
    """Take a session file this process has just built and closed as checked (a reprocessed
    copy: what passed :func:`check_file` in its source, and what gaitmon wrote), so that reading
    it back does not walk it again (~12 ms); any later change of the file changes its stamp."""
    with contextlib.suppress(OSError):
        _PASSED.add(_stamp_of(os.stat(path)))


def _walk(path: Path, f: h5py.File) -> None:
    """:func:`check_file`'s walk over every object of ``f``."""
    name = path.name
    file_bytes = int(f.id.get_filesize())
    budget = max(MIN_BUDGET_BYTES, EXPANSION * file_bytes)
    found: list[tuple[int, str]] = []  # (bytes declared, object)
    links: list[tuple[str, int]] = []

    def visit(link: bytes, info: h5py.h5l.LinkInfo) -> None:
        links.append((link.decode("utf-8", "replace"), info.type))

    f.id.links.visit(visit, info=True)
    for obj_name, kind in links:
        if kind == h5py.h5l.TYPE_EXTERNAL:
            raise SessionError(
                f"{name} is refused: /{obj_name} is a link into another file (an HDF5 external "
                "link); gaitmon reads a session only from its own file"
            )
        if kind not in (h5py.h5l.TYPE_HARD, h5py.h5l.TYPE_SOFT):
            raise SessionError(
                f"{name} is refused: /{obj_name} is a user-defined HDF5 link, which can lead "
                "outside the file; gaitmon reads a session only from its own file"
            )
    seen: set[int] = set()
    raw = _RawHeaders(path, f)
    try:
        # low-level handles: the high-level objects cost ~10x more per object (each open)
        for obj_name in ["", *(n for n, k in links if k == h5py.h5l.TYPE_HARD)]:
            oid = h5py.h5o.open(f.id, obj_name.encode("utf-8") or b".")
            info = h5py.h5o.get_info(oid)
            if info.addr in seen:
                continue
            seen.add(info.addr)
            where = "/" + obj_name
            if info.type == h5py.h5o.TYPE_DATASET:
                found.append((_dataset_bytes(name, where, oid), where))
            if info.num_attrs:
                attrs = _attribute_bytes(name, where, oid, info.num_attrs, raw, info.addr)
                found.append((attrs, f"the attributes of {where}"))
    finally:
        raw.close()
    total = sum(b for b, _ in found)
    if total > budget:
        most, where = max(found)
        raise SessionError(
            f"{name} is refused: it declares {_mb(total)} of data ({_mb(most)} in {where}) in a "
            f"file of {_mb(file_bytes)}, more than a session file can hold; it is damaged or "
            "was not written by gaitmon"
        )


def _dataset_bytes(name: str, where: str, dsid: h5py.h5d.DatasetID) -> int:
    """The bytes reading a dataset whole would take; refuses one stored outside the file."""
    dcpl = dsid.get_create_plist()
    if dcpl.get_layout() == h5py.h5d.VIRTUAL:
        raise SessionError(
            f"{name} is refused: {where} is a virtual dataset (it maps data of other files); "
            "gaitmon reads a session only from its own file"
        )
    if dcpl.get_external_count() > 0:
        outside = dcpl.get_external(0)[0].decode("utf-8", "replace")
        raise SessionError(
            f"{name} is refused: {where} keeps its data in another file ({outside!r}, HDF5 "
            "external storage); gaitmon reads a session only from its own file"
        )
    space = dsid.get_space()
    if space.get_simple_extent_type() == h5py.h5s.NULL:
        return 0
    return math.prod(space.shape) * dsid.get_type().get_size()


def _attribute_bytes(
    name: str, where: str, oid: h5py.h5o.ObjectID, n_attrs: int, raw: _RawHeaders, addr: int
) -> int:
    """The bytes reading every attribute of the object ``oid`` would take (text included);
    refuses one above :data:`MAX_ATTRIBUTE_BYTES` before it is read. (Per attribute: its
    name only where a message or the text's length needs it, and a nested variable-length
    member looked for only in a type that can nest one: ~20 % of the walk, issue 28.)"""
    total = 0
    offsets: dict[str, int] | None = None
    for i in range(n_attrs):
        aid = h5py.h5a.open(oid, index=i)
        size = int(aid.get_storage_size())
        tid = aid.get_type()
        variable = isinstance(tid, h5py.h5t.TypeVlenID) or (
            isinstance(tid, h5py.h5t.TypeStringID) and tid.is_variable_str()
        )
        if not variable and isinstance(tid, _NESTING) and _nests_variable(tid):
            raise SessionError(
                f"{name} is refused: attribute {_key(aid)!r} of {where} holds variable-length "
                "data inside a compound or array, which gaitmon never writes"
            )
        if variable:
            key = _key(aid)
            if offsets is None:
                offsets = raw.attribute_data_offsets(addr)
            n = math.prod(aid.shape) if aid.shape is not None else 0
            base = 1 if isinstance(tid, h5py.h5t.TypeStringID) else tid.get_super().get_size()
            length = raw.vlen_bytes(offsets.get(key), n, base)
            if length is None:
                raise SessionError(
                    f"{name} is refused: the length of text attribute {key!r} of {where} cannot "
                    "be checked before reading it (it is stored in a form gaitmon never writes)"
                )
            size += length
        if size > MAX_ATTRIBUTE_BYTES:
            raise SessionError(
                f"{name} is refused: attribute {_key(aid)!r} of {where} holds {_mb(size)}, more "
                f"than an attribute of a session ({_mb(MAX_ATTRIBUTE_BYTES)} at most); it is "
                "damaged or was not written by gaitmon"
            )
        total += size
    return total


# the datatypes that can hold another type (compound and enum: composite; array): the only
# ones where a variable-length member can hide (H5Tdetect_class is False for every other)
_NESTING = (h5py.h5t.TypeCompositeID, h5py.h5t.TypeArrayID)


def _nests_variable(tid: h5py.h5t.TypeID) -> bool:
    """Whether a compound, enum or array type holds variable-length data at any depth.
    HDF5's detect_class does not see variable-length text inside an array (it reports it as
    text), so the members and elements are looked at themselves too."""
    if tid.detect_class(h5py.h5t.VLEN):
        return True
    return _variable_inside(tid)


def _variable_inside(tid: h5py.h5t.TypeID) -> bool:
    if isinstance(tid, h5py.h5t.TypeVlenID) or (
        isinstance(tid, h5py.h5t.TypeStringID) and tid.is_variable_str()
    ):
        return True
    if isinstance(tid, h5py.h5t.TypeArrayID):
        return _variable_inside(tid.get_super())
    if isinstance(tid, h5py.h5t.TypeCompoundID):
        return any(_variable_inside(tid.get_member_type(k)) for k in range(tid.get_nmembers()))
    return False  # numbers, fixed text, enums (of integers), references, opaque data


def _key(aid: h5py.h5a.AttrID) -> str:
    return aid.get_name().decode("utf-8", "replace")


class _RawHeaders:
    """Object headers read from the file's bytes, for what HDF5 gives only by reading the data:
    a variable-length attribute's length (stored on disk as 4 bytes of length + a heap id)."""

    def __init__(self, path: Path, f: h5py.File) -> None:
        self.path = path
        self.file_bytes = int(f.id.get_filesize())
        fcpl = f.id.get_create_plist()
        self.sa, self.ss = fcpl.get_sizes()
        self.base = int(fcpl.get_userblock())
        self._raw: BinaryIO | None = None

    def close(self) -> None:
        if self._raw is not None:
            self._raw.close()

    def _read(self, at: int, n: int) -> bytes:
        if self._raw is None:
            self._raw = open(self.path, "rb")  # noqa: SIM115 (closed by close())
        self._raw.seek(self.base + at)
        return self._raw.read(n)

    def _uint(self, b: bytes, at: int, size: int) -> int:
        return int.from_bytes(b[at : at + size], "little")

    def attribute_data_offsets(self, addr: int) -> dict[str, int]:
        """Attribute name -> the file address of its data, for the attributes stored in the
        object header at ``addr`` (compact storage, header version 1 or 2); {} where the
        header cannot be read."""
        out: dict[str, int] = {}
        try:
            self._walk_header(addr, out)
        except (OSError, ValueError, struct.error, IndexError):
            return {}
        return out

    def _walk_header(self, addr: int, out: dict[str, int]) -> None:
        head = self._read(addr, 32)
        blocks: list[tuple[int, int]] = []  # (first message address, end address)
        if head[:4] == b"OHDR":  # version 2
            flags = head[5]
            p = 6 + (16 if flags & 0x20 else 0) + (4 if flags & 0x10 else 0)
            width = 1 << (flags & 3)
            start = addr + p + width
            blocks.append((start, start + self._uint(head, p, width)))
            v2, corder = True, bool(flags & 0x04)
        elif head[0] == 1:
            blocks.append((addr + 16, addr + 16 + self._uint(head, 8, 4)))
            v2, corder = False, False
        else:
            return
        done = 0
        while blocks and done < _MAX_HEADER_BLOCKS:
            done += 1
            start, end = blocks.pop()
            if end - start > self.file_bytes:
                return
            data = self._read(start, end - start)
            pos = 0
            hsize = (4 + (2 if corder else 0)) if v2 else 8
            while pos + hsize <= len(data):
                if v2:
                    kind, size, mflags = data[pos], self._uint(data, pos + 1, 2), data[pos + 3]
                else:
                    kind, size = self._uint(data, pos, 2), self._uint(data, pos + 2, 2)
                    mflags = data[pos + 4]
                body_at = pos + hsize
                body = data[body_at : body_at + size]
                if kind == _CONTINUATION and len(body) >= self.sa + self.ss:
                    at, length = self._uint(body, 0, self.sa), self._uint(body, self.sa, self.ss)
                    blocks.append((at + 4, at + length - 4) if v2 else (at, at + length))
                elif kind == _ATTRIBUTE and not mflags & 0x02 and len(body) >= 8:
                    self._attribute(body, start + body_at, out)
                pos = body_at + size

    def _attribute(self, body: bytes, body_addr: int, out: dict[str, int]) -> None:
        version = body[0]
        ns, dts, dss = (self._uint(body, k, 2) for k in (2, 4, 6))
        if version == 1:
            name_at, data_at = 8, 8 + _pad8(ns) + _pad8(dts) + _pad8(dss)
        elif version in (2, 3):
            name_at = 8 if version == 2 else 9
            data_at = name_at + ns + dts + dss
        else:
            return
        key = body[name_at : name_at + ns].rstrip(b"\0").decode("utf-8", "replace")
        out[key] = body_addr + data_at

    def vlen_bytes(self, at: int | None, n: int, base: int) -> int | None:
        """The bytes of ``n`` variable-length elements (of ``base``-byte items) whose on-disk
        references start at ``at``; None where they cannot be read (a text this long could
        then only be as long as a small file)."""
        if at is None or n * 16 > MAX_ATTRIBUTE_BYTES:
            return 0 if self.file_bytes <= UNCHECKED_FILE_BYTES else None
        step = 4 + self.sa + 4
        data = self._read(at, n * step)
        if len(data) < n * step:
            return None
        return sum(self._uint(data, k * step, 4) for k in range(n)) * base


def full_scale_of(table: ChannelTable) -> np.ndarray:
    """The largest count each channel's ADC can give: the file's channel table's
    ``2**adc_bits - 1``, and never above the unit's own (:mod:`gaitmon.dsp.channel_table`)."""
    full = table.full_scale_counts
    unit = DEFAULT_TABLE.full_scale_counts
    return np.minimum(full, unit) if len(full) == len(unit) else full


def _pad8(n: int) -> int:
    """``n`` rounded up to a multiple of 8 (version-1 attribute messages pad each part)."""
    return (n + 7) // 8 * 8


def checked_counts(
    name: str, full_scale: np.ndarray, counts: np.ndarray, first_row: int
) -> np.ndarray:
    """``counts`` (rows of ``/raw/adc`` from ``first_row``), refused in one :class:`SessionError`
    line if a count is above its channel's ADC full scale (``full_scale``, see
    :func:`full_scale_of`): a unit cannot make it, so the file is damaged or forged."""
    if counts.size == 0 or counts.ndim != 2 or counts.shape[1] != len(full_scale):
        return counts
    over = counts > full_scale
    if over.any():
        row, ch = np.argwhere(over)[0]
        bits = int(full_scale[ch]).bit_length()
        raise SessionError(
            f"{name} is damaged or forged: /raw/adc row {first_row + int(row)} holds "
            f"{int(counts[row, ch])} counts on channel {int(ch)}, above its {bits}-bit ADC's "
            f"{int(full_scale[ch])}; gaitmon reads no counts its unit cannot make"
        )
    return counts


class CheckedCounts:
    """``/raw/adc`` sliced by rows, each slice checked (:func:`checked_counts`): for code that
    reads the counts of a file open for writing (``gaitmon process`` replays a copy)."""

    def __init__(self, name: str, full_scale: np.ndarray, ds: h5py.Dataset) -> None:
        self.name, self.full_scale, self._ds = name, full_scale, ds
        self.dtype = ds.dtype

    def __len__(self) -> int:
        return len(self._ds)

    def __getitem__(self, key: slice) -> np.ndarray:
        a, _, _ = key.indices(len(self._ds))
        return checked_counts(self.name, self.full_scale, self._ds[key], a)
