"""A small XDF writer for the tests, written from the XDF 1.0 specification
(https://github.com/sccn/xdf/wiki/Specifications), not from pyxdf: pyxdf reading what it
writes is the independent check of both.

File: the magic ``XDF:``, then chunks ``[NumLengthBytes][Length][Tag u16][Content]`` (Length
counts the tag and the content). Tags: 1 FileHeader (XML), 2 StreamHeader (stream id u32 +
XML), 3 Samples (stream id u32, varlen sample count, then per sample a timestamp byte 8 + a
float64 timestamp, and the values: little-endian numbers, or per channel a varlen byte
length + UTF-8 bytes for strings), 4 ClockOffset (stream id u32, collection time f64, offset
f64), 5 Boundary (a fixed 16-byte UUID), 6 StreamFooter (stream id u32 + XML). A variable
length integer is one byte giving its width (1, 4 or 8) and the little-endian value.

LabRecorder writes headers first, then samples and clock offsets interleaved, boundaries now and
then, and the footers last; this writer does the same.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

BOUNDARY_UUID = bytes(
    [0x43, 0xA5, 0x46, 0xDC, 0xCB, 0xF5, 0x41, 0x0F, 0xB3, 0x0E, 0xD5, 0x46, 0x73, 0x83, 0xCB, 0xE4]
)
FORMATS = {"float32": "<f4", "double64": "<f8", "int8": "<i1", "int16": "<i2", "int32": "<i4",
           "int64": "<i8", "string": None}  # fmt: skip


def varlen(n: int) -> bytes:
    if n < 256:
        return b"\x01" + struct.pack("<B", n)
    if n < 2**32:
        return b"\x04" + struct.pack("<I", n)
    return b"\x08" + struct.pack("<Q", n)


def chunk(tag: int, content: bytes) -> bytes:
    return varlen(len(content) + 2) + struct.pack("<H", tag) + content


def xml_element(tag: str, inner: str | dict | list | None) -> str:
    """``<tag>inner</tag>``: a dict gives child elements, a list repeats the tag, a string is
    escaped text."""
    if isinstance(inner, list):
        return "".join(xml_element(tag, item) for item in inner)
    if isinstance(inner, dict):
        body = "".join(xml_element(k, v) for k, v in inner.items())
    else:
        body = "" if inner is None else escape(str(inner))
    return f"<{tag}>{body}</{tag}>"


@dataclass
class Stream:
    name: str
    type: str
    channel_format: str  # float32, int32, string, ...
    nominal_srate: float
    time_stamps: np.ndarray  # (N,) seconds, on the sending computer's clock
    time_series: np.ndarray | list[list[str]]  # (N, channels)
    channel_count: int
    desc: dict = field(default_factory=dict)  # the <desc> element's children
    source_id: str = ""
    # (collection time on the recording computer, offset): recording clock = sending + offset
    clock_offsets: list[tuple[float, float]] = field(default_factory=list)

    def header_xml(self) -> bytes:
        info = {
            "name": self.name, "type": self.type, "channel_count": self.channel_count,
            "channel_format": self.channel_format, "source_id": self.source_id,
            "nominal_srate": repr(float(self.nominal_srate)), "version": "1.1",
            "created_at": "100.0", "uid": f"uid-{self.name}", "session_id": "default",
            "hostname": "testhost", "desc": self.desc or None,
        }  # fmt: skip
        return ('<?xml version="1.0"?>' + xml_element("info", info)).encode("utf-8")

    def samples_chunk(self, stream_id: int, a: int, b: int) -> bytes:
        out = [struct.pack("<I", stream_id), varlen(b - a)]
        fmt = FORMATS[self.channel_format]
        for k in range(a, b):
            out.append(b"\x08" + struct.pack("<d", float(self.time_stamps[k])))
            if fmt is None:
                for value in self.time_series[k]:
                    raw = str(value).encode("utf-8")
                    out.append(varlen(len(raw)) + raw)
            else:
                out.append(np.asarray(self.time_series[k], dtype=fmt).tobytes())
        return b"".join(out)

    def footer_xml(self) -> bytes:
        n = len(self.time_stamps)
        offsets = [{"time": repr(t), "value": repr(v)} for t, v in self.clock_offsets]
        info = {
            "first_timestamp": repr(float(self.time_stamps[0])) if n else "0",
            "last_timestamp": repr(float(self.time_stamps[-1])) if n else "0",
            "sample_count": n,
            "clock_offsets": {"offset": offsets} if offsets else None,
        }
        return ('<?xml version="1.0"?>' + xml_element("info", info)).encode("utf-8")


def write_xdf(
    path: Path, streams: list[Stream], *, chunk_s: float = 0.5, footers: bool = True
) -> Path:
    """Write ``streams`` as LabRecorder does: headers, then every ``chunk_s`` seconds of the
    recording clock one Samples chunk per stream with samples in that slot (and the clock
    offsets collected by then), a Boundary chunk every 10 slots, the footers last."""
    out = [b"XDF:", chunk(1, b'<?xml version="1.0"?><info><version>1.0</version></info>')]
    for sid, s in enumerate(streams, start=1):
        out.append(chunk(2, struct.pack("<I", sid) + s.header_xml()))
    starts = [float(s.time_stamps[0]) for s in streams if len(s.time_stamps)]
    ends = [float(s.time_stamps[-1]) for s in streams if len(s.time_stamps)]
    t0, t1 = (min(starts), max(ends)) if starts else (0.0, 0.0)
    pos = [0] * len(streams)
    off_pos = [0] * len(streams)
    slot = 0
    t = t0
    while t <= t1 + chunk_s:
        t += chunk_s
        for sid, s in enumerate(streams, start=1):
            i = sid - 1
            stop = int(np.searchsorted(s.time_stamps, t, side="left"))
            if stop > pos[i]:
                out.append(chunk(3, s.samples_chunk(sid, pos[i], stop)))
                pos[i] = stop
            while off_pos[i] < len(s.clock_offsets) and s.clock_offsets[off_pos[i]][0] <= t:
                ct, ov = s.clock_offsets[off_pos[i]]
                out.append(chunk(4, struct.pack("<Idd", sid, ct, ov)))
                off_pos[i] += 1
        slot += 1
        if slot % 10 == 0:
            out.append(chunk(5, BOUNDARY_UUID))
    for sid, s in enumerate(streams, start=1):
        i = sid - 1
        if pos[i] < len(s.time_stamps):
            out.append(chunk(3, s.samples_chunk(sid, pos[i], len(s.time_stamps))))
        for ct, ov in s.clock_offsets[off_pos[i] :]:
            out.append(chunk(4, struct.pack("<Idd", sid, ct, ov)))
        if footers:
            out.append(chunk(6, struct.pack("<I", sid) + s.footer_xml()))
    path.write_bytes(b"".join(out))
    return path
