"""The C3D file itself: header block, parameter section and float data, written with numpy.

Why not ezc3d (used before): writing a part through its Python binding cost ~0.1 s of CPU and
kept about the data size of every file it wrote until the process exited, so an 8-hour export
(207 parts) took 26.7 CPU s in recycled child processes. The format is small and documented
(c3d.org, "The C3D File Format User Guide"): 512-byte blocks, Intel byte order, float data
(POINT:SCALE < 0). ezc3d remains the independent reader the tests use.

A part is built (gaitmon.export.writers.c3d) as a :class:`C3dSpec`, plain data.

Layout written: block 1 the header; from block 2 the parameter groups and parameters of the
spec; then per frame the points (X, Y, Z, residual
word as float32: 0 valid, -1 invalid) followed by one sample of every analog channel.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TypeAlias

import numpy as np

# A parameter's value, as ezc3d's add_parameter took it: text, lines of text, or numbers (a
# number, a list of them, or an array that keeps its shape)
C3dValue: TypeAlias = "str | Sequence[str] | float | Sequence[float] | np.ndarray"


@dataclass
class C3dSpec:
    """One C3D file as plain data: the parameters to set and the arrays."""

    values: list[tuple[str, str, C3dValue]] = field(default_factory=list)  # set existing param
    params: list[tuple[str, str, C3dValue, str]] = field(default_factory=list)  # add_parameter
    int_params: list[tuple[str, str, list[int], str]] = field(default_factory=list)
    points: np.ndarray = field(default_factory=lambda: np.zeros((4, 0, 0)))
    residuals: np.ndarray = field(default_factory=lambda: np.zeros((1, 0, 0)))
    analogs: np.ndarray = field(default_factory=lambda: np.zeros((1, 0, 0)))

    def set_value(self, group: str, name: str, value: C3dValue) -> None:
        self.values.append((group, name, value))

    def add_parameter(self, group: str, name: str, value: C3dValue, desc: str = "") -> None:
        self.params.append((group, name, value, desc))

    def add_int_parameter(self, group: str, name: str, values: list[int],
                          desc: str = "") -> None:
        self.int_params.append((group, name, [int(v) for v in values], desc))


BLOCK = 512
_INTEL = 84  # processor type: Intel (little-endian, IEEE floats)
_CHAR, _BYTE, _INT, _FLOAT = -1, 1, 2, 4


class _Param:
    """One parameter: C3D type, dimensions (first varies fastest) and its data bytes."""

    def __init__(self, name: str, kind: int, dims: tuple[int, ...], data: bytes,
                 desc: str = "") -> None:
        if len(dims) > 7 or any(not 0 <= d <= 255 for d in dims):
            raise ValueError(f"C3D parameter {name}: dimensions {dims} do not fit in bytes")
        self.name, self.kind, self.dims, self.data, self.desc = name, kind, dims, data, desc


def _chars(values: str | Sequence[str]) -> tuple[tuple[int, ...], bytes]:
    """A string -> 1-D char array; a list of strings -> (width, n), each padded with spaces."""
    if isinstance(values, str):
        raw = values.encode("utf-8")
        return (len(raw),), raw
    items = [str(v).encode("utf-8") for v in values]
    width = max((len(b) for b in items), default=0)
    return (width, len(items)), b"".join(b.ljust(width, b" ") for b in items)


def _value_param(name: str, value: C3dValue, desc: str = "") -> _Param:
    """A parameter from a value as ezc3d's add_parameter takes it: text, a list of text, or
    numbers (float; a numpy array keeps its shape, Fortran order as C3D wants)."""
    if isinstance(value, str) or (
        isinstance(value, list | tuple) and all(isinstance(v, str) for v in value) and value
    ):
        dims, data = _chars(value)
        return _Param(name, _CHAR, dims, data, desc)
    if isinstance(value, list | tuple) and not value:
        return _Param(name, _CHAR, (0, 0), b"", desc)
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        return _Param(name, _FLOAT, (), arr.astype("<f4").tobytes(), desc)
    return _Param(name, _FLOAT, tuple(int(d) for d in arr.shape),
                  arr.astype("<f4").ravel(order="F").tobytes(), desc)


def _int_param(name: str, ints: Iterable[int], desc: str = "") -> _Param:
    vals = np.asarray(list(ints), dtype=np.int64)
    # 16-bit words; values above 32767 (e.g. a frame count) are stored as their unsigned word
    return _Param(name, _INT, (len(vals),), (vals & 0xFFFF).astype("<u2").tobytes(), desc)


def _encode_parameters(groups: dict[str, dict[str, _Param]], n_blocks: int) -> bytes:
    out = bytearray([1, 0x50, n_blocks, _INTEL])
    records: list[bytes] = []
    for gid, (gname, params) in enumerate(groups.items(), start=1):
        name = gname.upper().encode("ascii")
        desc = b""
        records.append(struct.pack("<bb", len(name), -gid) + name
                       + struct.pack("<hB", 3 + len(desc), len(desc)) + desc)
        for p in params.values():
            pname = p.name.upper().encode("ascii")
            pdesc = p.desc.encode("utf-8")[:255]
            body = (struct.pack("<bB", p.kind, len(p.dims)) + bytes(p.dims) + p.data
                    + struct.pack("<B", len(pdesc)) + pdesc)
            records.append(struct.pack("<bb", len(pname), gid) + pname
                           + struct.pack("<h", 2 + len(body)) + body)
    if records:
        # the last record's offset is 0: the end of the parameter section
        last = bytearray(records[-1])
        nlen = abs(struct.unpack("<b", last[:1])[0])
        last[2 + nlen : 4 + nlen] = b"\x00\x00"
        records[-1] = bytes(last)
    for r in records:
        out += r
    return bytes(out)


def _groups(spec: C3dSpec, n_points: int, n_analogs: int, n_frames: int,
            data_start: int) -> dict[str, dict[str, _Param]]:
    """Every group and parameter: the required POINT / ANALOG ones, then the spec's own."""
    g: dict[str, dict[str, _Param]] = {"POINT": {}, "ANALOG": {}, "FORCE_PLATFORM": {}}

    def put(group: str, p: _Param) -> None:
        g.setdefault(group, {})[p.name.upper()] = p

    put("POINT", _int_param("USED", [n_points]))
    put("POINT", _value_param("LABELS", []))
    put("POINT", _value_param("DESCRIPTIONS", []))
    put("POINT", _value_param("SCALE", np.array([-1.0])))
    put("POINT", _value_param("UNITS", ["mm"]))
    put("POINT", _value_param("RATE", np.array([100.0])))
    put("POINT", _int_param("DATA_START", [data_start]))
    put("POINT", _int_param("FRAMES", [min(n_frames, 0xFFFF)]))
    put("ANALOG", _int_param("USED", [n_analogs]))
    put("ANALOG", _value_param("LABELS", []))
    put("ANALOG", _value_param("DESCRIPTIONS", []))
    put("ANALOG", _value_param("GEN_SCALE", np.array([1.0])))
    put("ANALOG", _value_param("SCALE", np.ones(n_analogs)))
    put("ANALOG", _int_param("OFFSET", [0] * n_analogs))
    put("ANALOG", _value_param("UNITS", []))
    put("ANALOG", _value_param("RATE", np.array([100.0])))
    put("FORCE_PLATFORM", _int_param("USED", [0]))
    for group, name, value in spec.values:
        put(group, _value_param(name, value))
    for group, name, value, desc in spec.params:
        put(group, _value_param(name, value, desc))
    for group, name, ints, desc in spec.int_params:
        put(group, _int_param(name, ints, desc))
    return g


def _header(n_points: int, n_analogs: int, n_frames: int, rate_hz: float,
            data_start: int) -> bytes:
    h = bytearray(BLOCK)
    struct.pack_into("<BBHHHHH", h, 0, 2, 0x50, n_points, n_analogs, 1,
                     min(n_frames, 0xFFFF), 10)
    struct.pack_into("<fHHf", h, 12, -1.0, data_start, 1, rate_hz)
    struct.pack_into("<H", h, 2 * 147, 0x3039)  # word 148: 4-character event labels
    return bytes(h)


def write_c3d(spec: C3dSpec, out: str) -> None:
    """Write one C3D file (float data, Intel order) from the spec's parameters and arrays."""
    pts = np.asarray(spec.points)  # (4, n_points, n_frames), row 3 is 1 (homogeneous)
    res = np.asarray(spec.residuals)  # (1, n_points, n_frames): 0 valid, -1 invalid
    an = np.asarray(spec.analogs)  # (1, n_analogs, n_frames)
    n_points, n_frames = int(pts.shape[1]), int(pts.shape[2])
    n_analogs = int(an.shape[1])
    if n_points == 0:
        n_frames = int(an.shape[2])
    rate = next((float(np.asarray(v).ravel()[0]) for grp, name, v in spec.values
                 if (grp, name) == ("POINT", "RATE")), 100.0)
    # the parameter section's size does not depend on DATA_START's value: encode twice
    groups = _groups(spec, n_points, n_analogs, n_frames, 0)
    size = len(_encode_parameters(groups, 0))
    n_blocks = -(-size // BLOCK)
    data_start = 2 + n_blocks
    params = _encode_parameters(_groups(spec, n_points, n_analogs, n_frames, data_start),
                                n_blocks)
    frame = np.empty((n_frames, 4 * n_points + n_analogs), "<f4")
    if n_points:
        xyz = frame[:, : 4 * n_points].reshape(n_frames, n_points, 4)
        xyz[:, :, :3] = pts[:3].transpose(2, 1, 0)
        xyz[:, :, 3] = res[0].T
    if n_analogs:
        frame[:, 4 * n_points :] = an[0].T
    with open(out, "wb") as f:
        f.write(_header(n_points, n_analogs, n_frames, rate, data_start))
        f.write(params.ljust(n_blocks * BLOCK, b"\x00"))
        data = frame.tobytes()
        f.write(data)
        f.write(bytes(-len(data) % BLOCK))
