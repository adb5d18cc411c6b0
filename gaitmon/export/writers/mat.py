"""MAT export: one struct ``session`` in a v5 MAT file (MATLAB ``load``, ``scipy.io.loadmat``).

Every ``*_idx`` field is a 1-based MATLAB row index. Layout: docs/file-format.md, "Export
formats".
"""

from __future__ import annotations

import io
import json
import struct
from enum import Enum
from pathlib import Path
from typing import BinaryIO, TypeAlias

import numpy as np

from gaitmon import __version__
from gaitmon.export.writers.errors import Cancel, ExportError, Progress, step
from gaitmon.export.writers.source import (
    Series,
    Source,
    export_header,
    gaps,
    json_default,
    markers,
    metadata,
)
from gaitmon.io.deidentify import Scrubber
from gaitmon.values import JsonValue, scalar

# MATLAB's v5/v7 MAT formats cap one variable at 2 GB (v7.3 lifts it, but scipy cannot read
# v7.3); the whole `session` struct is one variable, so it must fit. Margin for headers/names.
MAT_V5_MAX_BYTES = 2**31 - 2**24

# What a field of a MATLAB struct holds as scipy.io.savemat takes it: plain values, numpy arrays
# and scalars, and nested structs
MatValue: TypeAlias = "JsonValue | np.ndarray | np.generic | dict[str, MatValue]"


class Placeholder(Enum):
    """A per-sample field of the struct being built, streamed into the file by
    :func:`write_struct` (never whole in memory)."""

    STREAMED = "streamed"


# A struct's fields in order, the per-sample arrays as placeholders
MatStruct: TypeAlias = "dict[str, MatValue | Placeholder]"


def planned_outputs(src: Source, scrub: Scrubber, out: Path) -> list[Path]:
    return [out]


def write(src: Source, outputs: list[Path], scrub: Scrubber, deidentify: bool,
          progress: Progress | None, cancel: Cancel | None, chunk_rows: int | None) -> None:
    (out,) = outputs
    _write_mat(src, out, scrub, deidentify, progress, cancel)


def mat_cell(strings: list[str] | tuple[str, ...]) -> np.ndarray:
    """A MATLAB cell array of char (column), as scipy.io.savemat wants it."""
    arr = np.empty((len(strings), 1), dtype=object)
    for i, s in enumerate(strings):
        arr[i, 0] = s
    return arr


def mat_value(v: JsonValue) -> MatValue:
    """Plain metadata -> something savemat stores sensibly (None -> [], lists -> arrays/cells)."""
    if v is None:
        return np.zeros((0, 0))
    if isinstance(v, dict):
        return {_mat_name(k): mat_value(x) for k, x in v.items()}
    if isinstance(v, list):
        if v and all(isinstance(x, dict) for x in v):
            # list of records -> struct of column arrays
            keys = list(v[0].keys())
            return {_mat_name(k): mat_value([x.get(k) for x in v]) for k in keys}
        if all(isinstance(x, str) for x in v):
            return mat_cell(v)
        if all(isinstance(x, bool | int | float) for x in v):
            return np.asarray(v, dtype=np.float64).reshape(-1, 1)
        return mat_cell([json.dumps(x, default=json_default) for x in v])
    if isinstance(v, bool):
        return np.uint8(v)
    return v


def _mat_name(k: str) -> str:
    """MATLAB field names: letters, digits, underscore, starting with a letter, <= 63 chars."""
    s = "".join(c if (c.isascii() and (c.isalnum() or c == "_")) else "_" for c in k)
    if not s or not s[0].isalpha():
        s = "f_" + s
    return s[:63]


def _mat_bytes(src: Source) -> int:
    """Bytes of the per-sample arrays in the MAT `session` variable (timeline as double)."""
    total = 0
    for s in src.series:
        size = 8 if s.path.startswith("timeline/") else _series_dtype(s, src).itemsize
        total += src.n * len(s.columns) * size
    return total

def _one_based(v: JsonValue) -> JsonValue:
    """Metadata with every ``*_idx`` field of its table rows made 1-based, as everywhere in
    the MAT file (tables are lists of row dicts; see source.METADATA_SECTIONS)."""
    if isinstance(v, dict):
        return {k: _one_based(x) for k, x in v.items()}
    if isinstance(v, list) and v and all(isinstance(row, dict) for row in v):
        return [{k: int(scalar(x)) + 1 if k.endswith("_idx") else x for k, x in row.items()}
                for row in v]
    return v


# MAT v5 element types and array classes (MATLAB "MAT-File Format", level 5)
_MI_INT8, _MI_INT32, _MI_UINT32, _MI_MATRIX = 1, 5, 6, 14
_MI_BY_DTYPE = {"i1": 1, "u1": 2, "i2": 3, "u2": 4, "i4": 5, "u4": 6, "f4": 7, "f8": 9,
                "i8": 12, "u8": 13}
_MX_BY_DTYPE = {"f8": 6, "f4": 7, "i1": 8, "u1": 9, "i2": 10, "u2": 11, "i4": 12, "u4": 13,
                "i8": 14, "u8": 15}
STREAM_ROWS = 262_144  # rows per read while streaming a per-sample array


def _pad8(n: int) -> int:
    return -n % 8


def _element(raw: bytes, pos: int) -> tuple[int, int, int]:
    """(type, data start, end incl. padding) of the data element at ``pos``."""
    word, nbytes = struct.unpack_from("<II", raw, pos)
    if word >> 16:  # small data element: type and size in one word, data in the next four
        return word & 0xFFFF, pos + 4, pos + 8
    return word, pos + 8, pos + 8 + nbytes + _pad8(nbytes)


def _series_dtype(s: Series, src: Source) -> np.dtype:
    if s.path.startswith("timeline/"):
        return np.dtype("<f8")  # MATLAB works in double; seq < 2**53 stays exact
    # as the session reader returns it (however the file stores it)
    return np.asarray(src.read(s.path, 0, 1)).dtype.newbyteorder("<")


def _series_shape(s: Series, src: Source) -> tuple[int, ...]:
    shape = tuple(int(d) for d in np.asarray(src.read(s.path, 0, 1)).shape[1:])
    return (src.n, *shape) if shape else (src.n, 1)


def _array_header(dtype: np.dtype, shape: tuple[int, ...]) -> tuple[bytes, int]:
    """An unnamed numeric miMATRIX (a struct field) up to its data, and the data's size."""
    code = dtype.str[1:]
    nbytes = int(np.prod(shape)) * dtype.itemsize
    dims = struct.pack(f"<{len(shape)}i", *shape)
    dims += bytes(_pad8(len(dims)))
    body = (struct.pack("<IIII", _MI_UINT32, 8, _MX_BY_DTYPE[code], 0)
            + struct.pack("<II", _MI_INT32, 4 * len(shape)) + dims
            + struct.pack("<II", _MI_INT8, 0)
            + struct.pack("<II", _MI_BY_DTYPE[code], nbytes))
    total = len(body) + nbytes + _pad8(nbytes)
    return struct.pack("<II", _MI_MATRIX, total) + body, nbytes


MAT_HEADER_TEXT_BYTES = 116  # the header's description; then subsystem offset, version, endian


def undated_header(head: bytes) -> bytes:
    """scipy's 128-byte MAT header with its description ("... Created on: <date and time>")
    replaced by one without a date, space-padded as MATLAB pads it (a de-identified export
    does not say when it was made). The other 12 bytes (version, byte order) are kept."""
    text = f"MATLAB 5.0 MAT-file, written by gaitmon {__version__}".encode("ascii")
    return text.ljust(MAT_HEADER_TEXT_BYTES, b" ") + head[MAT_HEADER_TEXT_BYTES:128]


def _splice(raw: bytes, order: list[str], big: dict[str, Series], src: Source, f: BinaryIO,
            progress: Progress | None, cancel: Cancel | None, header: bool = True,
            dated: bool = True) -> None:
    """Write scipy's MAT file of the small fields with the per-sample arrays added to the
    struct, each streamed column by column from the session (MAT arrays are column-major).
    ``header``: the file's 128-byte header first (False: a further variable of the file);
    ``dated=False``: that header without the date (:func:`undated_header`)."""
    head, pos = raw[:128], 128
    if not dated:
        head = undated_header(head)
    kind, start, _ = _element(raw, pos)
    assert kind == _MI_MATRIX
    subs = []  # flags, dims, name, field name length, field names, then one per field
    p = start
    while p < len(raw):
        _, _, end = _element(raw, p)
        subs.append(raw[p:end])
        p = end
    flags, dims, name, fnl_el, names_el, *fields = subs
    fnl = struct.unpack_from("<i", fnl_el, 4 if struct.unpack_from("<I", fnl_el)[0] >> 16
                             else 8)[0]
    _, nstart, _ = _element(names_el, 0)
    small_names = [names_el[nstart + i * fnl : nstart + (i + 1) * fnl].rstrip(b"\0").decode()
                   for i in range(len(fields))]
    by_name = dict(zip(small_names, fields, strict=True))
    names = b"".join(k.encode("ascii").ljust(fnl, b"\0") for k in order)
    names_el = struct.pack("<II", _MI_INT8, len(names)) + names + bytes(_pad8(len(names)))
    headers = {k: _array_header(_series_dtype(s, src), _series_shape(s, src))
               for k, s in big.items()}
    size = len(flags) + len(dims) + len(name) + len(fnl_el) + len(names_el)
    for k in order:
        if k in headers:
            hdr, nbytes = headers[k]
            size += len(hdr) + nbytes + _pad8(nbytes)
        else:
            size += len(by_name[k])
    if header:
        f.write(head)
    f.write(struct.pack("<II", _MI_MATRIX, size))
    for part in (flags, dims, name, fnl_el, names_el):
        f.write(part)
    done = 0
    for k in order:
        if k not in headers:
            f.write(by_name[k])
            continue
        hdr, nbytes = headers[k]
        f.write(hdr)
        base = f.tell()
        _stream_columns(big[k], src, f, base)
        f.seek(base + nbytes)
        f.write(bytes(_pad8(nbytes)))
        done += 1
        step(progress, cancel, 0.2 + 0.8 * done / len(big))


def _stream_columns(s: Series, src: Source, f: BinaryIO, base: int) -> None:
    """Rows in blocks; each block's columns go to their place in the column-major array."""
    dtype = _series_dtype(s, src)
    n = src.n
    for r0 in range(0, n, STREAM_ROWS):
        r1 = min(n, r0 + STREAM_ROWS)
        block = np.asarray(src.read(s.path, r0, r1))
        # trailing dimensions flattened in MATLAB's (column-major) order
        cols = block.reshape(r1 - r0, -1, order="F").astype(dtype, copy=False)
        for c in range(cols.shape[1]):
            f.seek(base + (c * n + r0) * dtype.itemsize)
            f.write(np.ascontiguousarray(cols[:, c]).data)


def _write_mat(src: Source, out: Path, scrub: Scrubber, deidentify: bool,
               progress: Progress | None, cancel: Cancel | None) -> None:
    session, big = session_struct(src, scrub, deidentify)
    with open(out, "wb") as f:
        write_struct(f, "session", session, big, src, progress, cancel, dated=not deidentify)
    step(progress, cancel, 1.0)


def session_struct(src: Source, scrub: Scrubber,
                   deidentify: bool) -> tuple[MatStruct, dict[str, Series]]:
    """The ``session`` struct's fields in order (the per-sample arrays as placeholders, to be
    streamed by :func:`write_struct`) and those arrays' series."""
    series = src.series
    total = _mat_bytes(src)
    if total > MAT_V5_MAX_BYTES:
        raise ExportError(
            f"{src.path.name} is too long for one MAT v5 variable ({total / 2**30:.1f} GB > "
            "2 GB MATLAB limit); export --format csv, or read the .h5 directly in MATLAB "
            "(h5read)"
        )
    session: MatStruct = {}
    head = export_header(src, "mat", deidentify)
    for k, v in head.items():
        session[k] = mat_value(v)
    session["index_base"] = 1.0
    session["t0_s"] = 0.0
    labels: dict[str, MatValue] = {}
    big: dict[str, Series] = {}  # the per-sample arrays: streamed, never whole in memory
    for s in series:
        session[s.key] = Placeholder.STREAMED
        big[s.key] = s
        labels[s.key] = mat_cell(s.columns) if s.key != "acc_ms2" else mat_cell(s.labels)
    session["labels"] = labels
    session["units"] = {s.key: s.unit for s in series}
    t = src.read("timeline/t_s").astype(np.float64) if src.n else np.zeros(0)
    events: dict[str, MatValue] = {}
    for name in ("heel_strike", "toe_off"):
        idx = src.events(name)
        events[f"{name}_idx"] = (idx + 1).astype(np.float64).reshape(-1, 1)
        events[f"{name}_t_s"] = t[idx].reshape(-1, 1)
    session["events"] = events
    mks = markers(src, scrub)
    mk_struct: dict[str, MatValue] = {
        "sample_idx": np.array([m["sample_idx"] + 1 for m in mks], float).reshape(-1, 1),
        "t_s": np.array([m["t_s"] for m in mks], float).reshape(-1, 1),
        "label": mat_cell([m["label"] for m in mks]),
    }
    session["markers"] = mk_struct
    gps = gaps(src, scrub)
    gap_struct: dict[str, MatValue] = {
        "sample_idx": np.array([g["sample_idx"] + 1 for g in gps], float).reshape(-1, 1),
        "n_lost": np.array([g["n_lost"] for g in gps], float).reshape(-1, 1),
        "duration_s": np.array([g["duration_s"] for g in gps], float).reshape(-1, 1),
        "reason": mat_cell([g["reason"] for g in gps]),
    }
    session["gaps"] = gap_struct
    session["meta"] = mat_value(_one_based(metadata(src, scrub)))
    return session, big


def write_struct(f: BinaryIO, name: str, session: MatStruct, big: dict[str, Series],
                 src: Source, progress: Progress | None, cancel: Cancel | None,
                 header: bool = True, dated: bool = True) -> None:
    """One struct variable ``name`` of a MAT v5 file, to the open binary file ``f``; the
    first variable of a file with ``header``, the file's header before it (``dated=False``:
    without the date, for a de-identified export)."""
    from scipy.io import savemat

    small = {k: v for k, v in session.items() if v is not Placeholder.STREAMED}
    buf = io.BytesIO()
    savemat(buf, {name: small}, format="5", oned_as="column",
            long_field_names=True, do_compression=False)
    _splice(buf.getvalue(), list(session), big, src, f, progress, cancel, header, dated)


