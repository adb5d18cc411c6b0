"""C3D export: angles as POINTs, raw channels as ANALOGs, gait events as EVENTs.

Joint angles (and segment tilts) are POINTs of type angle, the 14 ADC channels in physical
units are ANALOGs, gait events and markers go in the EVENT group. Rows are placed on a uniform
1/fs frame grid (lost frames become invalid points). Sessions longer than one C3D trial, or
with more events than one EVENT group holds, are split into parts (``<stem>_part001.c3d``…).
The files themselves are written by gaitmon.export.writers.c3d_file (numpy, no ezc3d). Layout:
docs/file-format.md, "Export formats".
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np

from gaitmon import __version__
from gaitmon.dsp.channels import DEFAULT_TABLE, JOINTS, SEGMENTS, ChannelSpec, ChannelTable
from gaitmon.export.writers.c3d_file import C3dSpec, write_c3d
from gaitmon.export.writers.errors import Cancel, ExportError, Progress, step
from gaitmon.export.writers.outputs import c3d_part_path
from gaitmon.export.writers.source import (
    JOINT_LABELS,
    Source,
    as_text,
    frame_grid,
    markers,
    session_side,
)
from gaitmon.io.deidentify import ANONYMOUS, IDENTIFYING_FIELDS, Scrubber
from gaitmon.values import JsonValue

# A C3D trial counts frames in 16-bit words (header and POINT:FRAMES); past 65535 frames
# readers disagree (ezc3d 1.7 reads back only the first 65535), so long sessions are split.
C3D_MAX_PART_S = 600.0
# EVENT parameters are arrays whose dimensions are single bytes: at most 255 events per file.
C3D_MAX_EVENTS = 255

# C3D angle points named as in Vicon Plug-in Gait (X = sagittal component).
# HipAngles, ...; BodyTilt, ThighTilt, ...: from the channel table
C3D_JOINT_POINTS: tuple[str, ...] = tuple(f"{j.capitalize()}Angles" for j in JOINTS)
C3D_TILT_POINTS: tuple[str, ...] = tuple(f"{s.capitalize()}Tilt" for s in SEGMENTS)

# (row, context, label, description, icon id) of one C3D event
C3dEvent = tuple[int, str, str, str, int]


def planned_outputs(src: Source, scrub: Scrubber, out: Path) -> list[Path]:
    """One file, or one per part when the session is split (the parts depend on the events)."""
    plan = _c3d_plan(src, _event_rows(_c3d_events(src, scrub, session_side(src))))
    if len(plan.parts) > 1:
        return [c3d_part_path(out, k + 1) for k in range(len(plan.parts))]
    return [out]


def write(src: Source, outputs: list[Path], scrub: Scrubber, deidentify: bool,
          progress: Progress | None, cancel: Cancel | None, chunk_rows: int | None) -> None:
    events = _c3d_events(src, scrub, session_side(src))
    rows = _event_rows(events)
    plan = _c3d_plan(src, rows)
    if len(plan.parts) != len(outputs):
        raise ExportError(f"{src.path.name}: C3D parts changed while exporting")
    ev_frame = plan.frame[rows] if len(rows) else np.zeros(0, np.int64)
    specs = (_c3d_part_spec(src, plan, k, scrub, deidentify, events, ev_frame)
             for k in range(len(outputs)))
    write_c3d_parts(specs, outputs, progress, cancel)


def _event_rows(events: list[C3dEvent]) -> np.ndarray:
    return np.array([e[0] for e in events], np.int64)


@dataclass(frozen=True)
class C3dPlan:
    """How rows map onto C3D frames: a uniform 1/fs grid from the first sample, split in parts."""

    frame: np.ndarray  # (N,) int64 frame of each row on the uniform grid
    n_frames: int
    part_frames: int
    parts: tuple[tuple[int, int], ...] = field(default=())  # [first, stop) frames per part


def _c3d_plan(src: Source, events: np.ndarray | None = None,
              max_part_s: float | None = None) -> C3dPlan:
    """Frames on the uniform grid, cut into parts of at most C3D_MAX_PART_S seconds and at
    most C3D_MAX_EVENTS events (``events``: the sorted row indices of every C3D event)."""
    max_part_s = C3D_MAX_PART_S if max_part_s is None else max_part_s
    if src.n == 0:
        return C3dPlan(np.zeros(0, np.int64), 0, 1, ((0, 0),))
    frame = frame_grid(src, "in C3D frames")
    n_frames = int(frame[-1]) + 1
    part = part_frames(src.fs_hz, max_part_s)
    ev = np.sort(frame[events]) if events is not None and len(events) else np.zeros(0, np.int64)
    return C3dPlan(frame, n_frames, part, split_parts(n_frames, part, ev))


def part_frames(fs_hz: float, max_part_s: float | None = None) -> int:
    """Frames in a part of at most ``max_part_s`` (default C3D_MAX_PART_S) seconds."""
    max_part_s = C3D_MAX_PART_S if max_part_s is None else max_part_s
    return max(1, min(65_535, round(max_part_s * fs_hz)))


def split_parts(n_frames: int, part: int, ev: np.ndarray) -> tuple[tuple[int, int], ...]:
    """[first, stop) frames of each part: at most ``part`` frames and C3D_MAX_EVENTS events
    (``ev``: the sorted frames of every event)."""
    parts = []
    a = 0
    while a < n_frames:
        b = min(n_frames, a + part)
        i0 = int(np.searchsorted(ev, a))
        if int(np.searchsorted(ev, b)) - i0 > C3D_MAX_EVENTS:
            b = max(a + 1, int(ev[i0 + C3D_MAX_EVENTS]))  # the 256th event starts the next part
        parts.append((a, b))
        a = b
    return tuple(parts)


def _c3d_events(src: Source, scrub: Scrubber, side: str) -> list[C3dEvent]:
    """(row, context, label, description, icon id) of every C3D event, in row order."""
    ctx = {"L": "Left", "R": "Right"}.get(side, "General")
    out = []
    for name, label, desc, icon in (("heel_strike", "Foot Strike", "heel strike", 1),
                                    ("toe_off", "Foot Off", "toe off", 2)):
        out += [(int(k), ctx, label, desc, icon) for k in src.events(name)]
    out += [(m["sample_idx"], "General", m["label"][:64] or "Marker", "clinician marker", 0)
            for m in markers(src, scrub)]
    out.sort(key=lambda e: e[0])  # stable: strikes before offs before markers on one row
    return out


def _c3d_part_spec(src: Source, plan: C3dPlan, part_no: int, scrub: Scrubber,
                   deidentify: bool, events: list[C3dEvent], ev_frame: np.ndarray) -> C3dSpec:
    """Everything one C3D part holds, as plain data (written by c3d_file.write_c3d)."""
    f0, f1 = plan.parts[part_no]
    nf = f1 - f0
    fs = src.fs_hz
    r0, r1 = np.searchsorted(plan.frame, [f0, f1])
    local = plan.frame[r0:r1] - f0
    side = session_side(src)

    def on_frames(path: str) -> np.ndarray:
        # Frames with no received sample (lost frames) are NaN: invalid points, NaN analogs
        rows = np.asarray(src.read(path, r0, r1), np.float64).reshape(r1 - r0, -1)
        out = np.full((nf, rows.shape[1]), np.nan)
        out[local] = rows
        return out

    c = C3dSpec()
    put_points(c, fs, nf, leg_points(src, on_frames, side, ""))
    put_analogs(c, fs, nf, leg_analogs(src, on_frames, ""))
    if not c.points.shape[1] and not c.analogs.shape[1]:
        raise ExportError(f"{src.path.name}: nothing to put in a C3D file (no angles, no raw)")
    subject = (ANONYMOUS if deidentify
               else as_text(src.group_attrs("session").get("patient_id", "")) or ANONYMOUS)
    # events are in row order, so in frame order (ev_frame): this part's are one slice
    e0, e1 = (int(i) for i in np.searchsorted(ev_frame, [f0, f1]))
    put_events(c, nf, subject, [((int(fr) - f0) / fs, *events[k][1:]) for k, fr in
                                zip(range(e0, e1), ev_frame[e0:e1].tolist(), strict=True)])
    session = scrub.session({**{k: "" for k in IDENTIFYING_FIELDS},
                             **src.group_attrs("session")})
    device = scrub.device(src.group_attrs("device"))
    put_gaitmon(c, src, scrub, deidentify, side or "unknown", device_text(device), session,
                (part_no, len(plan.parts), f0 / fs))
    return c


@dataclass(frozen=True)
class Channels:
    """Channels of a C3D file on the part's frames: (n channels, frames), NaN where missing."""

    labels: list[str]
    descriptions: list[str]
    units: list[str]
    values: np.ndarray  # (n, frames)


def leg_points(src: Source, read: Callable[[str], np.ndarray], side: str,
               body_prefix: str) -> Channels:
    """One unit's angle points (``read(path)``: the series on the part's frames, NaN where
    missing); joint and segment points take ``side`` before their name, the trunk's
    ``body_prefix`` (one unit: none, as Plug-in Gait names it; both legs: its side's)."""
    labels: list[str] = []
    desc: list[str] = []
    blocks: list[np.ndarray] = []
    if src.has("processed/joint_deg"):
        labels += [side + p for p in C3D_JOINT_POINTS]
        desc += [f"{j} (X sagittal; Y, Z not measured = 0), deg" for j in JOINT_LABELS]
        blocks.append(read("processed/joint_deg"))
    if src.has("processed/tilt_deg"):
        labels += [(body_prefix if p == "BodyTilt" else side) + p for p in C3D_TILT_POINTS]
        desc += [f"{s} tilt from vertical (X sagittal), deg" for s in SEGMENTS]
        blocks.append(read("processed/tilt_deg"))
    return Channels(labels, desc, ["deg"] * len(labels), _stack(blocks))


def leg_analogs(src: Source, read: Callable[[str], np.ndarray], prefix: str) -> Channels:
    """One unit's analogs: the ADC channels in physical units, the low-passed force sensors."""
    labels: list[str] = []
    units: list[str] = []
    desc: list[str] = []
    blocks: list[np.ndarray] = []
    if src.has("raw/adc"):
        table = _physical_table(src)
        blocks.append(table.to_physical(read("raw/adc")))
        labels += [prefix + name for name in src.channel_names]
        units += [c.unit for c in table.channels]
        desc += [f"ADC channel {i} in physical units" for i in range(len(table.channels))]
    if src.has("processed/fsr_counts"):
        blocks.append(read("processed/fsr_counts"))
        labels += [prefix + "heel_fsr_lp", prefix + "toe_fsr_lp"]
        units += ["count", "count"]
        desc += ["low-passed heel FSR", "low-passed toe FSR"]
    return Channels(labels, desc, units, _stack(blocks))


def _stack(blocks: list[np.ndarray]) -> np.ndarray:
    return np.concatenate(blocks, axis=1).T if blocks else np.zeros((0, 0))


def put_points(c: C3dSpec, fs: float, nf: int, *groups: Channels) -> None:
    """The POINT group and data: angles in X; a missing (NaN) value is an invalid point
    (residual -1, as the C3D spec marks them: readers show gaps, ezc3d returns NaN)."""
    labels = [x for g in groups for x in g.labels]
    n_pts = len(labels)
    pts = np.zeros((4, n_pts, nf))
    pts[3] = 1.0
    residuals = np.full((1, n_pts, nf), -1.0)
    if n_pts:
        vals = np.concatenate([g.values for g in groups if g.labels], axis=0)
        ok = np.isfinite(vals)
        pts[0][ok] = vals[ok]
        residuals[0][ok] = 0.0
    c.set_value("POINT", "RATE", np.array([fs]))
    c.set_value("POINT", "LABELS", labels)
    c.set_value("POINT", "DESCRIPTIONS", [x for g in groups for x in g.descriptions])
    c.set_value("POINT", "UNITS", ["mm"])
    c.points, c.residuals = pts, residuals
    if n_pts:
        c.add_parameter("POINT", "ANGLES", labels, "points that are angles")
        c.add_parameter("POINT", "ANGLE_UNITS", "deg", "unit of angle points")
        c.add_parameter("POINT", "TYPE_GROUPS", ["ANGLES"], "point type groups")


def put_analogs(c: C3dSpec, fs: float, nf: int, *groups: Channels) -> None:
    """The ANALOG group and data, one sample per frame, in physical units (NaN: missing)."""
    labels = [x for g in groups for x in g.labels]
    n_an = len(labels)
    an = np.full((1, n_an, nf), np.nan)
    if n_an:
        an[0] = np.concatenate([g.values for g in groups if g.labels], axis=0)
    c.set_value("ANALOG", "RATE", np.array([fs]))
    c.set_value("ANALOG", "LABELS", labels)
    c.set_value("ANALOG", "DESCRIPTIONS", [x for g in groups for x in g.descriptions])
    c.set_value("ANALOG", "UNITS", [x for g in groups for x in g.units])
    c.analogs = an
    if n_an:
        c.add_parameter("ANALOG", "SCALE", np.ones(n_an), "data stored in physical units")
        c.add_int_parameter("ANALOG", "OFFSET", [0] * n_an)


def put_events(c: C3dSpec, nf: int, subject: str,
               evs: list[tuple[float, str, str, str, int]]) -> None:
    """The trial's frames, the EVENT group (``evs``: time from frame 1, context, label,
    description, icon id) and the event contexts Left, Right, General."""
    c.add_int_parameter("TRIAL", "ACTUAL_START_FIELD", [1, 0], "first frame")
    c.add_int_parameter("TRIAL", "ACTUAL_END_FIELD", [nf & 0xFFFF, nf >> 16], "last frame")
    # Events: time from frame 1 (time 0.0) of this part, as (whole minutes, seconds). Built
    # in one go: ezc3d's add_event rewrites the whole group per event (quadratic).
    if evs:
        times = np.array([_c3d_time(e[0]) for e in evs]).T  # (2, n)
        c.add_int_parameter("EVENT", "USED", [len(evs)])
        c.add_parameter("EVENT", "TIMES", times)
        c.add_parameter("EVENT", "CONTEXTS", [e[1] for e in evs])
        c.add_parameter("EVENT", "LABELS", [e[2] for e in evs])
        c.add_parameter("EVENT", "DESCRIPTIONS", [e[3] for e in evs])
        c.add_parameter("EVENT", "SUBJECTS", [subject] * len(evs))
        c.add_int_parameter("EVENT", "ICON_IDS", [e[4] for e in evs])
        c.add_int_parameter("EVENT", "GENERIC_FLAGS", [0] * len(evs))
    c.add_parameter("EVENT_CONTEXT", "LABELS", ["Left", "Right", "General"])
    c.add_parameter("EVENT_CONTEXT", "DESCRIPTIONS", ["Left side", "Right side", "For all"])
    c.add_int_parameter("EVENT_CONTEXT", "USED", [3])
    c.add_int_parameter("EVENT_CONTEXT", "ICON_IDS", [0, 1, 2])
    c.add_int_parameter("SUBJECTS", "USED", [1])
    c.add_parameter("SUBJECTS", "NAMES", [subject])


def device_text(device: Mapping[str, JsonValue]) -> str:
    return " ".join(f"{k}={as_text(device[k])}" for k in ("name", "serial", "firmware")
                    if k in device)  # fmt: skip


def put_gaitmon(c: C3dSpec, src: Source, scrub: Scrubber, deidentify: bool, side: str,
                device: str, session: Mapping[str, JsonValue],
                part: tuple[int, int, float]) -> None:
    """The MANUFACTURER group and gaitmon's own (mode, side, date, device, which part of
    the session: (0-based part, parts, session time of its frame 1), identity)."""
    c.add_parameter("MANUFACTURER", "COMPANY", "gaitmon")
    c.add_parameter("MANUFACTURER", "SOFTWARE", "gaitmon export")
    c.add_parameter("MANUFACTURER", "VERSION_LABEL", str(__version__))
    _c3d_text(c, "GAITMON", "MODE", src.mode or "unknown")
    _c3d_text(c, "GAITMON", "SIDE", side)
    _c3d_text(c, "GAITMON", "CREATED_UTC", as_text(scrub.root(src.attrs).get("created_utc", "")))
    _c3d_text(c, "GAITMON", "DEVICE", device)
    part_no, n_parts, t_part0_s = part
    c.add_parameter("GAITMON", "PART", float(part_no + 1), "1-based part of the session")
    c.add_parameter("GAITMON", "N_PARTS", float(n_parts))
    c.add_parameter("GAITMON", "PART_START_S", float(t_part0_s),
                    "session time of this part's frame 1")
    c.add_parameter("GAITMON", "DEIDENTIFIED", float(bool(deidentify)))
    _c3d_text(c, "GAITMON", "ANGLE_CONVENTION", as_text(src.attrs.get("angle_convention", "")))
    if not deidentify:
        for k in IDENTIFYING_FIELDS:
            _c3d_text(c, "GAITMON", k.upper(), as_text(session.get(k, "")))


def write_c3d_parts(specs: Iterator[C3dSpec], paths: list[Path],
                     progress: Progress | None, cancel: Cancel | None) -> None:
    """Write the parts one at a time (each part's rows are read only when it is built)."""
    for k, (spec, path) in enumerate(zip(specs, paths, strict=True)):
        write_c3d(spec, str(path))
        step(progress, cancel, (k + 1) / len(paths))


def _c3d_text(c: C3dSpec, group: str, name: str, text: str, width: int = 80) -> None:
    """A string parameter; C3D dimensions are single bytes, so long text becomes lines."""
    text = text.replace("\r", " ").replace("\n", " ").strip() or "-"
    lines = [text[i : i + width] for i in range(0, len(text), width)][:255]
    c.add_parameter(group, name, lines if len(lines) > 1 else lines[0])


def _c3d_time(t_s: float) -> list[float]:
    minutes = math.floor(t_s / 60.0)
    return [float(minutes), t_s - 60.0 * minutes]


def _physical_table(src: Source) -> ChannelTable:
    """The file's own counts -> physical conversion (/device/channels), else the default."""
    rows = src.channel_table()
    if len(rows) != len(src.channel_names):
        return DEFAULT_TABLE
    fields = ChannelSpec.__dataclass_fields__
    # the table's columns are ChannelSpec's fields, as the session writer stores them
    return ChannelTable(tuple(ChannelSpec(**cast("dict[str, Any]", {k: r[k] for k in fields}))
                              for r in rows))

