"""Reading a LabRecorder file (XDF) with pyxdf and finding gaitmon's streams in it.

pyxdf does the reading and the clock synchronisation (every stream's timestamps mapped onto the
recording computer's clock with the ClockOffset chunks LabRecorder collected). Its dejittering
is left off: it refits a regular stream's timestamps as ``first + index / rate`` between
breaks, which squeezes out the frames lost on the unit's link (a gap of a few frames is no
break to it) and would move every later sample; gaitmon's outlets already stamp each sample
from the unit's sample clock (``gaitmon.lsl.layout``).

A damaged or cut-short file is reported in one line (:class:`gaitmon.errors.UserError`);
pyxdf's own log lines and tracebacks are kept off the terminal.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gaitmon.errors import UserError
from gaitmon.lsl.layout import ANGLES_TYPE, EVENTS_TYPE, MANUFACTURER, RAW_TYPE, STREAM_KINDS
from gaitmon.text import clean_label

_NAME = re.compile(r"^gaitmon (?P<unit>.+) (?P<stream>raw|angles|events)$")
_SOURCE_ID = re.compile(r"^gaitmon-(?P<unit>.+)-(?P<stream>raw|angles|events)$")
KINDS = {RAW_TYPE: "raw", ANGLES_TYPE: "angles", EVENTS_TYPE: "events"}
# a stream this small is read whole to look at its description (is it gaitmon's, renamed?)
_SMALL_CHANNELS = 16


def text(node: Any, *path: str) -> str | None:
    """The text of ``node/path[0]/path[1]...`` in pyxdf's XML dicts (each child a list),
    or None where an element is missing or empty."""
    for key in path:
        if not isinstance(node, Mapping):
            return None
        items = node.get(key)
        if not items:
            return None
        node = items[0]
    return node.strip() if isinstance(node, str) else None


def children(node: Any, *path: str) -> list[Any]:
    """Every element at ``path`` (the last key may repeat: ``channels/channel``)."""
    for key in path[:-1]:
        if not isinstance(node, Mapping) or not node.get(key):
            return []
        node = node[key][0]
    if not isinstance(node, Mapping):
        return []
    return [c for c in node.get(path[-1], []) if c is not None]


@dataclass(frozen=True)
class XdfStream:
    """One stream of the file, its timestamps on the recording computer's clock."""

    name: str
    type: str
    source_id: str
    channel_format: str
    nominal_srate_hz: float
    desc: Mapping[str, Any]  # the <desc> element, {} if empty
    time_stamps: np.ndarray  # (N,) s
    time_series: Any  # (N, channels) array, or a list of lists of str
    has_footer: bool

    @property
    def n(self) -> int:
        return len(self.time_stamps)

    @property
    def manufacturer(self) -> str:
        return text(self.desc, "acquisition", "manufacturer") or ""

    @property
    def gaitmon_kind(self) -> str | None:
        """The kind of one of gaitmon's streams ("raw", "angles", "events"), else None.

        A stream whose manufacturer is gaitmon says its kind in ``gaitmon/stream`` (streams
        since the XDF MoCap convention was followed), else by its type (gaitmon's types,
        either convention), else by its source id or name (a recorder that renamed the
        types). A description-less stream counts only with gaitmon's type and source id."""
        if self.manufacturer == MANUFACTURER:
            declared = text(self.desc, "gaitmon", "stream")
            if declared in STREAM_KINDS:
                return declared
            if self.type in KINDS:
                return KINDS[self.type]
            for pattern, value in ((_SOURCE_ID, self.source_id), (_NAME, self.name)):
                m = pattern.match(value)
                if m:
                    return m["stream"]
            return None
        kind = KINDS.get(self.type)
        # a description-less events stream still names itself by its source id
        m = _SOURCE_ID.match(self.source_id)
        return kind if kind and m and m["stream"] == kind and not self.manufacturer else None

    @property
    def unit(self) -> str:
        """The unit's serial number (``acquisition/serial_number``, else from the name)."""
        serial = text(self.desc, "acquisition", "serial_number")
        if serial:
            return serial
        for pattern, value in ((_NAME, self.name), (_SOURCE_ID, self.source_id)):
            m = pattern.match(value)
            if m:
                return m["unit"]
        return "?"

    def labels(self) -> list[str]:
        return [text(c, "label") or "" for c in children(self.desc, "channels", "channel")]


@dataclass(frozen=True)
class GaitmonUnit:
    """One unit's streams in the file."""

    serial: str
    raw: XdfStream | None = None
    angles: XdfStream | None = None
    events: XdfStream | None = None

    def describe(self) -> str:
        kinds = [k for k in ("raw", "angles", "events") if getattr(self, k) is not None]
        return f"unit {self.serial} ({', '.join(kinds)})"


class _Collect(logging.Handler):
    """pyxdf's log records while it reads: what it found damaged, kept off the terminal."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.problems: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.levelno >= logging.ERROR:
            self.problems.append(record.getMessage())


@contextlib.contextmanager
def _quiet_pyxdf() -> Iterator[_Collect]:
    log = logging.getLogger("pyxdf")
    handler = _Collect()
    old = log.propagate
    log.addHandler(handler)
    log.propagate = False
    try:
        yield handler
    finally:
        log.removeHandler(handler)
        log.propagate = old


@dataclass(frozen=True)
class StreamSummary:
    """What a message says of one stream of the file (read from its header only)."""

    name: str
    type: str
    channels: int
    rate_hz: float

    def describe(self) -> str:
        rate = f"{self.rate_hz:g} Hz" if self.rate_hz > 0 else "irregular rate"
        kind = clean_label(self.type) or "no type"
        n = f"{self.channels} channel{'s' if self.channels != 1 else ''}"
        return f"{clean_label(self.name)!r} ({kind}, {n}, {rate})"


def describe_streams(summaries: Sequence[StreamSummary], limit: int = 6) -> str:
    """"'EEG' (EEG, 8 channels, 250 Hz), ..." for a one-line message."""
    if not summaries:
        return "no stream at all"
    more = f", and {len(summaries) - limit} more" if len(summaries) > limit else ""
    return ", ".join(s.describe() for s in summaries[:limit]) + more


@dataclass(frozen=True)
class XdfContents:
    streams: list[XdfStream]  # the streams read (gaitmon's kinds, and the one asked for)
    problems: list[str]  # pyxdf's complaints about damage (empty for a good file)
    names: list[str]  # the names of every stream of the file
    summaries: list[StreamSummary] = field(default_factory=list)  # every stream of the file


def read_xdf(path: str | os.PathLike[str], also: str | None = None) -> XdfContents:
    """The streams of the file that can be gaitmon's (by type) and the stream named ``also``.

    Only those are read: a lab's 64-channel EEG beside gaitmon's streams would cost most of the
    time and memory (pyxdf's headers-only pass finds them; a file too damaged for it is read
    whole). Raises :class:`UserError` for a missing file, a file that is not XDF, or one too
    damaged for pyxdf to read."""
    path = Path(path)
    name = path.name
    if not path.is_file():
        raise UserError(f"{path} does not exist; give a LabRecorder recording (.xdf)")
    try:
        import pyxdf
    except ImportError:
        raise UserError("importing .xdf needs pyxdf: pip install 'gaitmon[lsl]'") from None
    try:
        with open(path, "rb") as f:
            magic = f.read(4)
    except OSError as e:
        raise UserError(f"cannot read {name}: {e.strerror or e}") from None
    gzipped = path.name.lower().endswith((".xdfz", ".xdf.gz"))  # pyxdf opens them with gzip
    if magic != b"XDF:" and not gzipped:
        raise UserError(
            f"{name} is not an XDF file (it does not start with 'XDF:'); give a LabRecorder "
            "recording (.xdf)"
        )
    with _quiet_pyxdf() as log:
        try:
            infos: list[dict[str, Any]] | None = pyxdf.resolve_streams(str(path))
        except Exception:  # damaged: the full read below takes what it can
            infos = None
        select: list[int] | None = None
        names: list[str] = []
        summaries: list[StreamSummary] = []
        small: list[int] = []
        if infos is not None:
            names = [str(i.get("name") or "") for i in infos]
            summaries = [_summary(i) for i in infos]
            wanted = (also or "").lower()
            select = [
                int(i["stream_id"])
                for i, summary in zip(infos, summaries, strict=True)
                if _maybe_gaitmon(i, summary)
                or (also and str(i.get("name") or "").lower() == wanted)
            ]
            # a gaitmon stream whose type and name were changed is known only by its
            # description: with none found, the small streams are read to look at theirs
            small = [int(i["stream_id"]) for i, summary in zip(infos, summaries, strict=True)
                     if 0 < summary.channels <= _SMALL_CHANNELS]  # fmt: skip
        loaded = _load(pyxdf, path, select) if select is None or select else []
        streams = [_stream(s) for s in loaded]
        if infos is not None and not any(s.gaitmon_kind for s in streams):
            rest = [k for k in small if select is None or k not in select]
            streams += [_stream(s) for s in (_load(pyxdf, path, rest) if rest else [])]
    if not summaries:
        summaries = [StreamSummary(s.name, s.type, _width(s), s.nominal_srate_hz)
                     for s in streams]  # fmt: skip
    return XdfContents(streams, log.problems, names or [s.name for s in streams], summaries)


def _load(pyxdf: Any, path: Path, select: list[int] | None) -> list[Any]:
    try:
        loaded, _ = pyxdf.load_xdf(
            str(path), select_streams=select, synchronize_clocks=True,
            dejitter_timestamps=False,
        )  # fmt: skip
    except Exception as e:  # pyxdf raises whatever the bytes lead it to (struct, XML, ...)
        what = " ".join(str(e).split())[:120] or type(e).__name__
        raise UserError(
            f"{path.name} is damaged or cut short and cannot be read as XDF ({what})"
        ) from None
    return list(loaded)


def _summary(info: Mapping[str, Any]) -> StreamSummary:
    def number(key: str) -> float:
        try:
            return float(info.get(key) or 0)
        except (TypeError, ValueError):
            return 0.0

    return StreamSummary(str(info.get("name") or ""), str(info.get("type") or ""),
                         int(number("channel_count")), number("nominal_srate"))  # fmt: skip


def _maybe_gaitmon(info: Mapping[str, Any], summary: StreamSummary) -> bool:
    """Read this stream: gaitmon's type (either convention), name or source id."""
    return (summary.type in KINDS or bool(_NAME.match(summary.name))
            or bool(_SOURCE_ID.match(str(info.get("source_id") or ""))))  # fmt: skip


def _width(s: XdfStream) -> int:
    if isinstance(s.time_series, np.ndarray) and s.time_series.ndim == 2:
        return int(s.time_series.shape[1])
    return 1


def _stream(s: Mapping[str, Any]) -> XdfStream:
    info = s["info"]
    desc = (info.get("desc") or [None])[0]
    try:
        srate = float(text(info, "nominal_srate") or 0.0)
    except ValueError:
        srate = 0.0
    return XdfStream(
        name=text(info, "name") or "",
        type=text(info, "type") or "",
        source_id=text(info, "source_id") or "",
        channel_format=text(info, "channel_format") or "",
        nominal_srate_hz=srate,
        desc=desc if isinstance(desc, Mapping) else {},
        time_stamps=np.asarray(s["time_stamps"], dtype=np.float64),
        time_series=s["time_series"],
        has_footer="footer" in s,
    )


def gaitmon_units(streams: Sequence[XdfStream]) -> dict[str, GaitmonUnit]:
    """gaitmon's streams grouped by unit (serial number), in file order."""
    found: dict[str, dict[str, XdfStream]] = {}
    for s in streams:
        kind = s.gaitmon_kind
        if kind is not None:
            found.setdefault(s.unit, {}).setdefault(kind, s)
    return {serial: GaitmonUnit(serial, **kinds) for serial, kinds in found.items()}


def choose_unit(name: str, units: Mapping[str, GaitmonUnit], serial: str | None,
                contents: XdfContents | None = None) -> GaitmonUnit:
    if not units:
        raise UserError(no_gaitmon_stream(name, contents))
    if serial is not None:
        if serial not in units:
            raise UserError(f"{name} has no gaitmon unit {serial}; it has {_list(units)}")
        return units[serial]
    if len(units) > 1:
        raise UserError(
            f"{name} holds the streams of {len(units)} gaitmon units: {_list(units)}; choose "
            "one with --unit SERIAL"
        )
    return next(iter(units.values()))


def no_gaitmon_stream(name: str, contents: XdfContents | None) -> str:
    """Why no gaitmon unit was found, naming what the file holds."""
    streams = contents.streams if contents else []
    summaries = contents.summaries if contents else []
    ours = [s for s in streams if s.manufacturer == MANUFACTURER and s.gaitmon_kind is None]
    if ours:
        found = describe_streams([StreamSummary(s.name, s.type, _width(s), s.nominal_srate_hz)
                                  for s in ours])  # fmt: skip
        return (
            f"{name} holds {len(ours)} stream{'s' if len(ours) > 1 else ''} made by gaitmon "
            f"(acquisition/manufacturer '{MANUFACTURER}'): {found}; but none says which of "
            "gaitmon's streams it is: their types and names were changed (gaitmon reads a "
            f"stream by gaitmon/stream, type {ANGLES_TYPE}, {EVENTS_TYPE} or {RAW_TYPE}, or "
            "name 'gaitmon <unit> angles|events|raw'), so it cannot tell the angles, events "
            "and raw streams apart"
        )
    return (
        f"{name} holds no gaitmon stream; its streams: {describe_streams(summaries)}; record "
        "gaitmon's LSL streams with LabRecorder (gaitmon record --lsl)"
    )


def _list(units: Mapping[str, GaitmonUnit]) -> str:
    return ", ".join(u.describe() for u in units.values())


def find_stream(contents: XdfContents, name: str) -> XdfStream:
    """The stream named ``name`` (``--markers-from``)."""
    streams = contents.streams
    hits = [s for s in streams if s.name == name] or [
        s for s in streams if s.name.lower() == name.lower()
    ]
    if not hits:
        names = ", ".join(repr(n) for n in contents.names) or "none"
        raise UserError(f"no stream named {name!r} in the file; its streams: {names}")
    if len(hits) > 1:
        raise UserError(f"{len(hits)} streams are named {name!r}; rename one in LabRecorder")
    return hits[0]
