"""``gaitmon import FILE.xdf``: a LabRecorder recording of gaitmon's own streams as a session.

The ``raw`` stream (``gaitmon.lsl.layout``) holds the unit's frame counter and its 14 ADC
counts, and its description the session header (settings, calibration, device, side); with
the ``events`` stream's markers, gap reasons and later ``config``/``calibration`` changes,
that is everything a raw-mode recording holds. The rows are laid out as a recording's journal
would hold them (frame counter jumps are frames lost: gaps) and the file is written by
:func:`gaitmon.finish.build_session`, the recovery's own path: the pipeline replayed from
row 0 with the settings changes at their rows, the events, ``/smoothed`` and ``/overview``,
exactly as a recording of the same counts.

Times: pyxdf's clock-synchronised timestamps (:mod:`gaitmon.lsl.xdf_read`). An event (marker,
settings change) goes on the raw sample nearest to its timestamp.

A file with gaitmon's angles but no raw stream (the unit computed its own angles) becomes a
tilt-mode session when the unit was in tilt mode: its tilts, one row per sample, frames lost
where the timestamps skip a period; the unit's accelerometer tilts, which a tilt-mode session
also holds, are not streamed and stay empty (NaN). Joint mode cannot be rebuilt (a joint-mode
session holds the force sensors' contacts, which no stream carries): that is said in one line.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import CHANNEL_NAMES
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.errors import Cancelled, UserError
from gaitmon.lsl.layout import ANGLE_CHANNELS, RAW_CHANNELS, EventWord, parse_event
from gaitmon.lsl.xdf_read import (
    GaitmonUnit,
    XdfContents,
    XdfStream,
    choose_unit,
    describe_streams,
    find_stream,
    gaitmon_units,
    read_xdf,
    text,
)
from gaitmon.text import clean_label

if TYPE_CHECKING:
    from gaitmon.io.session import SessionHeader

ADC_MAX = 0xFFFF  # the unit's counts are 16-bit
FRAMES_LOST = "frames lost"
COUNTER_RESTARTED = "frames lost: the unit's frame counter restarted"


@dataclass(frozen=True)
class ImportOptions:
    """What the command line (or a window) asks of an import."""

    unit: str | None = None  # the unit's serial number, when the file holds several
    markers_from: str | None = None  # a foreign marker stream's name: its samples as markers
    partial: bool = False  # import what a cut-short file holds
    overwrite: bool = False


@dataclass(frozen=True)
class ImportResult:
    path: Path
    unit: str
    n_rows: int
    duration_s: float
    n_gaps: int
    n_lost: int
    n_markers: int
    n_changes: int  # settings and calibration changes applied during the recording
    notes: tuple[str, ...] = field(default_factory=tuple)  # what the user should know


def default_output(src: str | os.PathLike[str]) -> Path:
    """``walk.xdf`` -> ``walk.h5`` beside it (``.xdfz``, ``.xdf.gz`` too)."""
    p = Path(src)
    name = p.name
    for suffix in (".xdf.gz", ".xdfz", ".xdf"):
        if name.lower().endswith(suffix):
            return p.with_name(name[: -len(suffix)] + ".h5")
    return p.with_name(name + ".h5")


def import_xdf(
    src: str | os.PathLike[str],
    dst: str | os.PathLike[str] | None = None,
    options: ImportOptions = ImportOptions(),
    *,
    progress: Callable[[float], bool | None] | None = None,
) -> ImportResult:
    """Write the session held in the XDF file ``src`` to ``dst`` (default: beside it, .h5).

    Raises :class:`UserError` with a one-line message for every problem of the input or the
    output."""
    from gaitmon.finish import build_session
    from gaitmon.io.session import SessionError

    src = Path(src)
    out = default_output(src) if dst is None else Path(dst)
    name = src.name
    if out.exists() and src.exists() and out.resolve() == src.resolve():
        raise UserError(f"OUT is {name} itself: write the session to another file (.h5)")
    if out.exists() and not options.overwrite:
        raise UserError(f"{out} already exists; choose another name with -o, or pass --force")
    if not out.parent.is_dir():
        raise UserError(f"folder {out.parent} does not exist")
    contents = read_xdf(src, also=options.markers_from)
    foreign = None
    if options.markers_from is not None:
        foreign = _marker_stream(name, contents, options.markers_from)
    unit = choose_unit(name, gaitmon_units(contents.streams), options.unit, contents)
    notes: list[str] = []
    if unit.raw is not None:
        raw = _raw_stream(name, unit.raw, unit.serial)
        header: dict[str, Any] = _header_of(raw, "raw", notes).as_dict()
        session = _rows(raw, float(header["sample_rate_hz"]))
    else:
        session, header = _tilt_session(name, unit, notes)
    samples = unit.raw or unit.angles
    unfinished = [s for s in (samples, unit.events) if s is not None and not s.has_footer]
    if contents.problems or unfinished:
        if not options.partial:
            raise UserError(
                f"{name} is cut short (LabRecorder did not finish writing it, or the copy is "
                "incomplete); pass --partial to import the part it holds"
            )
        notes.append(f"{name} is cut short: imported the part it holds")
    fs = float(header["sample_rate_hz"])
    events = unit.events
    gaps = _gaps(session, events, fs)
    markers, changes, header = _events(session, events, header, notes)
    if header["mode"] != "raw":
        changes = []  # the unit computed the angles: the PC's settings changed nothing
    if foreign is not None:
        markers += _foreign_markers(session, foreign, notes)
    markers.sort(key=lambda m: int(m["sample_idx"]))

    from gaitmon.io.journal import JournalContents

    n = len(session.rows)
    lost_total = int(session.rows["lost_before"].sum())
    journal = JournalContents(
        header=header,
        rows=session.rows,
        gaps=gaps,
        markers=markers,
        links=[{"sample_idx": n, "totals": {"frames_ok": n, "frames_lost": lost_total}}],
    )
    try:
        build_session(out, journal, changes, imported_from=name,
                      overwrite=options.overwrite, progress=progress)  # fmt: skip
    except SessionError as e:
        raise UserError(str(e)) from None
    except Cancelled:
        raise UserError("import cancelled; nothing was written") from None
    duration_s = (n + lost_total) / fs
    return ImportResult(out, unit.serial, n, duration_s, len(gaps), lost_total, len(markers),
                        len(changes), tuple(notes))  # fmt: skip


# -- the raw stream -> rows ---------------------------------------------------------------------


@dataclass(frozen=True)
class _Rows:
    rows: np.ndarray  # the journal's RAW row dtype: seq, host_time_s, lost_before, adc
    t_s: np.ndarray  # each row's timestamp (recording clock)
    restarts: frozenset[int]  # rows after which the frame counter restarted


def _raw_stream(name: str, raw: XdfStream, serial: str) -> XdfStream:
    if raw.n == 0:
        raise UserError(f"{name}: the raw stream of unit {serial} holds no samples")
    series = np.asarray(raw.time_series)
    if series.ndim != 2 or series.shape[1] != len(RAW_CHANNELS):
        raise UserError(
            f"{name}: the raw stream of unit {serial} has {series.shape[-1]} channels, "
            f"not {len(RAW_CHANNELS)} (frame counter + {len(CHANNEL_NAMES)} ADC counts)"
        )
    labels = raw.labels()
    expected = [c.label for c in RAW_CHANNELS]
    if labels and labels != expected:
        raise UserError(
            f"{name}: the raw stream's channels are {', '.join(labels)}; expected "
            f"{', '.join(expected)} (a stream of another gaitmon version?)"
        )
    return raw


def _tilt_session(name: str, unit: GaitmonUnit, notes: list[str]) -> tuple[_Rows, dict[str, Any]]:
    """A tilt-mode session from the angles stream alone: the unit's own (Kalman) tilts, one row
    per sample, frames lost where the timestamps skip a sample period. The unit's
    accelerometer tilts are not streamed: their series is left empty (NaN)."""
    from gaitmon.io.journal import ROW_DTYPES, RecordType

    angles = unit.angles
    if angles is None:
        raise UserError(
            f"{name} holds only gaitmon's events of unit {unit.serial}, no samples; nothing "
            "to import"
        )
    mode = text(angles.desc, "gaitmon", "mode") or _angles_mode(angles)
    if mode == "raw":
        raise UserError(
            f"{name} holds the angles gaitmon computed from unit {unit.serial}'s raw counts, "
            f"but not its raw stream ('{_raw_name(angles)}'): a session is rebuilt from the "
            "raw counts; tick that stream too in LabRecorder when recording (gaitmon publishes "
            "it in raw mode with --lsl), or read the angles with any XDF reader"
        )
    if mode != "tilt":
        raise UserError(
            f"{name} holds the unit's own {mode} angles of unit {unit.serial} but no raw "
            "stream: a joint-mode session cannot be rebuilt from them (the streams carry no "
            "force-sensor contacts); record in raw mode (or tilt mode) to import into gaitmon, "
            "or read the angles with any XDF reader"
        )
    series = np.asarray(angles.time_series, dtype=np.float64)
    if angles.n == 0 or series.ndim != 2 or series.shape[1] != len(ANGLE_CHANNELS):
        raise UserError(
            f"{name}: the angles stream of unit {unit.serial} holds no samples of its "
            f"{len(ANGLE_CHANNELS)} channels"
        )
    header = _header_of(angles, "tilt", notes)
    fs = header.sample_rate_hz
    order = np.argsort(angles.time_stamps, kind="stable")
    ts, series = angles.time_stamps[order], series[order]
    k = np.rint((ts - ts[0]) * fs).astype(np.int64)
    step = np.maximum(np.diff(k, prepend=-1), 1)
    rows = np.empty(len(ts), dtype=ROW_DTYPES[RecordType.TILT])
    rows["seq"] = np.cumsum(step) - 1
    rows["host_time_s"] = ts
    rows["lost_before"] = step - 1
    rows["acc_tilt_deg"] = np.nan
    rows["kalman_tilt_deg"] = series[:, len(ANGLE_CHANNELS) - 4 :]
    notes.append(
        "no raw stream: imported the unit's own tilts as a tilt-mode session (the unit's "
        "accelerometer tilts are not streamed, so that series is empty)"
    )
    return _Rows(rows, ts, frozenset()), header.as_dict()


def _raw_name(angles: XdfStream) -> str:
    """The name of the raw stream published beside this angles stream."""
    if angles.name.endswith(" angles"):
        return angles.name[: -len("angles")] + "raw"
    return f"gaitmon {angles.unit} raw"


def _marker_stream(name: str, contents: XdfContents, wanted: str) -> XdfStream:
    """The stream ``--markers-from`` names, refused (as live ``--lsl-markers`` refuses it)
    when it is a regular-rate stream: its samples are data, not events."""
    stream = find_stream(contents, wanted)
    if stream.nominal_srate_hz > 0:
        irregular = [s for s in contents.summaries if s.rate_hz <= 0]
        hint = f" (its irregular-rate streams: {describe_streams(irregular)})" if irregular else ""
        raise UserError(
            f"{name}: stream {clean_label(stream.name)!r} (--markers-from) is a regular "
            f"{stream.nominal_srate_hz:g} Hz stream, not a marker stream; give the name of an "
            f"irregular-rate (marker) stream{hint}"
        )
    return stream


def _angles_mode(angles: XdfStream) -> str:
    """tilt or joint: in joint mode the unit sends no tilts (NaN in the stream)."""
    series = np.asarray(angles.time_series, dtype=np.float64)
    if series.ndim == 2 and series.shape[1] >= 7 and series.size:
        return "joint" if np.isnan(series[:, 3:7]).all() else "tilt"
    return "tilt or joint"


def _rows(raw: XdfStream, fs: float) -> _Rows:
    """One row per raw sample. Frames lost before a row: the counter's step, unless the
    timestamps (the unit's sample clock, which counts data frames only) say fewer frames were
    due: the unit's control frames (a command's answer) share the counter without being
    data lost. A counter that goes back (the unit restarted) is taken up from the time."""
    from gaitmon.io.journal import ROW_DTYPES, RecordType

    series = np.asarray(raw.time_series)
    ts = raw.time_stamps
    order = np.argsort(ts, kind="stable")  # LabRecorder keeps them in order; be sure
    series, ts = series[order], ts[order]
    counter = series[:, 0].astype(np.int64)
    adc = series[:, 1:].astype(np.int64)
    if adc.size and (adc.min() < 0 or adc.max() > ADC_MAX):
        raise UserError(
            f"the raw stream holds counts outside 0..{ADC_MAX} (e.g. {int(adc.min())}, "
            f"{int(adc.max())}): not the unit's ADC counts"
        )
    counter_step = np.diff(counter, prepend=counter[0] - 1)
    time_step = np.maximum(1, np.rint(np.diff(ts, prepend=ts[0] - 1.0 / fs) * fs)).astype(np.int64)
    restarted = counter_step <= 0
    step = np.where(restarted, time_step, np.minimum(counter_step, time_step))
    # the file's sequence numbers: the unit's, carried on across a restart so they increase
    seq = counter.copy()
    for i in np.flatnonzero(restarted):
        seq[i:] += seq[i - 1] + step[i] - seq[i]
    rows = np.empty(len(ts), dtype=ROW_DTYPES[RecordType.RAW])
    rows["seq"] = seq
    rows["host_time_s"] = ts
    rows["lost_before"] = step - 1
    rows["adc"] = adc.astype(np.uint16)
    return _Rows(rows, ts, frozenset(int(i) for i in np.flatnonzero(restarted)))


def _header_of(stream: XdfStream, mode: str, notes: list[str]) -> SessionHeader:
    """The session header carried in the stream's description (``gaitmon/header``), checked by
    :class:`SessionHeader`; without one, what the description says, default settings."""
    from gaitmon.io.session import SessionHeader, SessionMeta

    kind = stream.gaitmon_kind
    blob = text(stream.desc, "gaitmon", "header")
    if blob:
        try:
            d = json.loads(blob)
            header = SessionHeader.from_dict(d | {"mode": mode} if mode != "raw" else d)
        except (ValueError, KeyError, TypeError, AttributeError) as e:
            raise UserError(
                f"the {kind} stream's gaitmon/header is not a session header ({e})"
            ) from None
    else:
        fs = _float(text(stream.desc, "gaitmon", "fs_hz")) or stream.nominal_srate_hz
        if not fs or not math.isfinite(fs) or fs <= 0:
            raise UserError(
                f"the {kind} stream gives no sampling rate (gaitmon/fs_hz, nominal_srate)"
            )
        side = text(stream.desc, "gaitmon", "side") or ""
        device = {
            "name": text(stream.desc, "acquisition", "model") or "",
            "firmware": text(stream.desc, "acquisition", "firmware") or "",
            "serial": stream.unit,
            "transport": "lsl",
        }
        meta = SessionMeta(side=side if side in ("L", "R") else "")
        header = SessionHeader(mode, fs, meta=meta, device=device)
        if mode == "raw":
            notes.append(
                "the raw stream carries no gaitmon header: the default settings and no "
                "calibration were used"
            )
    if header.mode != mode:
        raise UserError(f"the {kind} stream's header says mode {header.mode!r}, not {mode!r}")
    if stream.nominal_srate_hz and abs(stream.nominal_srate_hz - header.sample_rate_hz) > 1e-6:
        raise UserError(
            f"the {kind} stream's rate ({stream.nominal_srate_hz:g} Hz) and its header's "
            f"({header.sample_rate_hz:g} Hz) differ"
        )
    return header


def _float(value: str | None) -> float | None:
    try:
        return float(value) if value else None
    except ValueError:
        return None


# -- events -> gaps, markers, settings changes -------------------------------------------------


def nearest_rows(t_rows: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The row whose timestamp is nearest to each time (ties: the earlier row)."""
    t = np.asarray(t, dtype=np.float64)
    i = np.clip(np.searchsorted(t_rows, t), 1, max(1, len(t_rows) - 1))
    if len(t_rows) < 2:
        return np.zeros(len(t), np.int64)
    before = t - t_rows[i - 1] <= t_rows[i] - t
    return np.where(before, i - 1, i).astype(np.int64)


def _gaps(session: _Rows, events: XdfStream | None, fs: float) -> list[dict[str, Any]]:
    """A gap before each row with frames lost before it; its reason from the ``gap_start``
    event stamped at the gap's first lost frame, "frames lost" without one."""
    lost = session.rows["lost_before"].astype(np.int64)
    at = np.flatnonzero(lost)
    at = at[at > 0]  # frames lost before the first row are not in the session
    reasons: dict[int, str] = {int(i): FRAMES_LOST for i in at}
    for i in session.restarts:
        reasons[i] = COUNTER_RESTARTED
    if events is not None and len(at):
        t = session.t_s
        first_lost_t = t[at - 1] + 1.0 / fs  # when each gap's first lost frame was due
        for te, sample in zip(events.time_stamps, events.time_series, strict=True):
            word, rest = parse_event(str(sample[0]))
            if word != EventWord.GAP_START:
                continue
            k = int(np.argmin(np.abs(first_lost_t - te)))
            # the event belongs to that gap if it was stamped inside it (half a frame's slack)
            if t[at[k] - 1] < te + 0.5 / fs and te < t[at[k]] + 0.5 / fs:
                reasons[int(at[k])] = clean_label(rest) or FRAMES_LOST
    return [
        {"sample_idx": int(i), "n_lost": int(lost[i]), "duration_s": float(lost[i]) / fs,
         "reason": reasons[int(i)]}
        for i in at
    ]  # fmt: skip


def _events(
    session: _Rows, events: XdfStream | None, header: dict[str, Any], notes: list[str]
) -> tuple[list[dict[str, Any]], list[tuple[int, PipelineConfig | Calibration]],
           dict[str, Any]]:  # fmt: skip
    """Markers, and settings/calibration changes from their row on (one at or before row 0
    goes into the header; one that changes nothing is left out, as it would rebuild the
    filters for nothing)."""
    markers: list[dict[str, Any]] = []
    changes: list[tuple[int, PipelineConfig | Calibration]] = []
    if events is None or events.n == 0:
        return markers, changes, header
    t = session.t_s
    half = 0.5 * float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    rows = nearest_rows(t, events.time_stamps)
    config = PipelineConfig.from_stored(header["config"])
    calibration = Calibration.from_dict(header["calibration"])
    outside = 0
    for te, row, sample in zip(events.time_stamps, rows, events.time_series, strict=True):
        word, rest = parse_event(str(sample[0]))
        idx = int(row)
        if word == EventWord.MARKER:
            if te < t[0] - half or te > t[-1] + half:
                outside += 1
                continue
            markers.append({"sample_idx": idx, "label": clean_label(rest)})
        elif word in (EventWord.CONFIG, EventWord.CALIBRATION):
            try:
                obj = json.loads(rest)
                change: PipelineConfig | Calibration = (
                    PipelineConfig.from_stored(obj) if word == EventWord.CONFIG
                    else Calibration.from_dict(obj)
                )  # fmt: skip
            except (ValueError, KeyError, TypeError) as e:
                notes.append(f"a {word.value} event could not be read ({e}); left out")
                continue
            if te > t[-1] + half:
                continue
            if isinstance(change, PipelineConfig):
                if change == config:
                    continue
                config = change
            else:
                if change.as_dict() == calibration.as_dict():
                    continue
                calibration = change
            if idx == 0:
                key = "config" if isinstance(change, PipelineConfig) else "calibration"
                header = header | {key: change.as_dict()}
                if key == "config":
                    header["event_delay_samples"] = config.event_delay_samples
            else:
                changes.append((idx, change))
    if outside:
        notes.append(f"{outside} marker{'s' if outside > 1 else ''} outside the recorded "
                     "samples left out")  # fmt: skip
    return markers, changes, header


def _foreign_markers(session: _Rows, stream: XdfStream, notes: list[str]) -> list[dict[str, Any]]:
    """Each sample of another stream (a stimulator's triggers) as a marker labelled with its
    first channel, on the row nearest to it on the synchronised clock."""
    t = session.t_s
    half = 0.5 * float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    rows = nearest_rows(t, stream.time_stamps)
    out = []
    outside = 0
    for te, row, sample in zip(stream.time_stamps, rows, _labels(stream), strict=True):
        if te < t[0] - half or te > t[-1] + half:
            outside += 1
            continue
        out.append({"sample_idx": int(row), "label": clean_label(sample)})
    if outside:
        notes.append(f"{outside} sample{'s' if outside > 1 else ''} of {stream.name!r} outside "
                     "the recorded samples left out")  # fmt: skip
    return out


def _labels(stream: XdfStream) -> Sequence[str]:
    if stream.channel_format == "string":
        return [str(s[0]) if len(s) else "" for s in stream.time_series]
    values = np.asarray(stream.time_series)
    with contextlib.suppress(IndexError):
        return [f"{float(v):g}" for v in values.reshape(len(values), -1)[:, 0]]
    return [""] * stream.n


__all__ = ["ImportOptions", "ImportResult", "default_output", "import_xdf", "nearest_rows"]
