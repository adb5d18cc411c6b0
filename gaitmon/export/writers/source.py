"""The read side of export: a session file seen as the series, tables and metadata to export.

Owns the exported series (HDF5 dataset -> CSV columns, MAT field, units, printf precision),
:class:`Source` (a lazy view over an opened session: datasets stay on disk), and the builders
every format shares: metadata, markers, gaps, the export header, side. De-identification is
applied here through a :class:`~gaitmon.io.deidentify.Scrubber`.

Metadata is assembled from :data:`METADATA_SECTIONS`, one builder per key, so a new piece of
session state (e.g. review exclusions) is one builder function and one entry there; the MAT
writer turns every ``*_idx`` in its tables 1-based on its own.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict, cast

import numpy as np

from gaitmon import __version__
from gaitmon.dsp.channel_table import CHANNEL_NAMES, JOINT_TABLE, SEGMENTS
from gaitmon.export.writers.errors import ExportError
from gaitmon.io.deidentify import Scrubber
from gaitmon.text import clean_label
from gaitmon.values import JsonObject, JsonValue, scalar

if TYPE_CHECKING:
    from gaitmon.finish import Session

EXPORT_VERSION = 1

JOINT_LABELS: tuple[str, ...] = tuple(j.key for j in JOINT_TABLE)  # hip_flexion, ...


@dataclass(frozen=True)
class Series:
    """One per-sample dataset and its exported names.

    ``path`` is the HDF5 dataset; ``key`` the MAT field name; ``columns`` the CSV column names
    (one per flattened column, units in the name); ``fmt`` the CSV printf format of one value;
    ``labels`` what each column of the MAT array is (MAT ``session.labels.<key>``).
    """

    path: str
    key: str
    columns: tuple[str, ...]
    fmt: str
    labels: tuple[str, ...]
    unit: str
    description: str


def _seg_cols(suffix: str) -> tuple[str, ...]:
    return tuple(f"{s}_{suffix}" for s in SEGMENTS)


def _joint_cols(suffix: str) -> tuple[str, ...]:
    return tuple(f"{j}_{suffix}" for j in JOINT_LABELS)


# Fixed decimals per unit: well below the sensor resolution, and float32 (~7 significant
# digits) already limits angles near 180 deg to ~1e-5 deg.
_DEG, _MS2, _RADS, _CNT = "%.4f", "%.5f", "%.6f", "%.3f"

PROCESSED_SERIES: tuple[Series, ...] = (
    Series("processed/joint_deg", "joint_deg", _joint_cols("deg"), _DEG, JOINT_LABELS, "deg",
           "Kalman joint angles (clinical signs)"),
    Series("processed/joint_acc_deg", "joint_acc_deg", _joint_cols("acc_deg"), _DEG,
           JOINT_LABELS, "deg", "joint angles from accelerometer tilts"),
    Series("processed/joint_gyro_deg", "joint_gyro_deg", _joint_cols("gyro_deg"), _DEG,
           JOINT_LABELS, "deg", "joint angles from gyro-integrated tilts"),
    Series("processed/tilt_deg", "tilt_deg", _seg_cols("tilt_deg"), _DEG, SEGMENTS, "deg",
           "Kalman segment tilts"),
    Series("processed/tilt_acc_deg", "tilt_acc_deg", _seg_cols("tilt_acc_deg"), _DEG, SEGMENTS,
           "deg", "accelerometer segment tilts"),
    Series("processed/tilt_gyro_deg", "tilt_gyro_deg", _seg_cols("tilt_gyro_deg"), _DEG,
           SEGMENTS, "deg", "gyro-integrated segment tilts"),
    Series("processed/acc_ms2", "acc_ms2",
           tuple(f"{s}_acc_{a}_ms2" for s in SEGMENTS for a in ("x", "z")), _MS2,
           tuple(f"{s}_{a}" for s in SEGMENTS for a in ("x", "z")), "m/s^2",
           "low-passed accelerometer x, z per segment"),
    Series("processed/gyro_rad_s", "gyro_rad_s", _seg_cols("gyro_rad_s"), _RADS, SEGMENTS,
           "rad/s", "gyro rate, calibrated bias removed"),
    Series("processed/fsr_counts", "fsr_counts", ("heel_fsr_lp_count", "toe_fsr_lp_count"),
           _CNT, ("heel", "toe"), "count", "low-passed heel, toe force sensors"),
    Series("processed/heel_loaded", "heel_loaded", ("heel_loaded",), "%d", ("heel_loaded",),
           "0/1", "heel contact state"),
    Series("processed/toe_loaded", "toe_loaded", ("toe_loaded",), "%d", ("toe_loaded",), "0/1",
           "toe contact state"),
    Series("processed/phase", "phase", ("phase",), "%d", ("phase",), "0-3",
           "0 swing, 1 loading response, 2 foot flat, 3 push-off"),
)


def raw_series(channel_names: tuple[str, ...]) -> Series:
    return Series("raw/adc", "adc_count", tuple(f"{c}_count" for c in channel_names), "%d",
                  channel_names, "count", "raw ADC counts in channel order")


TIMELINE_SERIES: tuple[Series, ...] = (
    Series("timeline/t_s", "t_s", ("t_s",), "%.6f", ("t_s",), "s",
           "true sample time from the session start"),
    Series("timeline/seq", "seq", ("seq",), "%d", ("seq",), "1",
           "the unit's sequence number, unwrapped"),
    Series("timeline/host_time_s", "host_time_s", ("host_time_s",), "%.6f", ("host_time_s",),
           "s", "host monotonic clock at arrival (wall clock = + wall_offset_s)"),
)

# ---- reading: a thin view over the session file ----


def as_text(v: object) -> str:
    if isinstance(v, bytes):
        return v.decode("utf-8", errors="replace")
    return str(v)


def plain(v: object) -> JsonValue:
    """HDF5 attribute value -> JSON-able Python value."""
    if isinstance(v, bytes):
        return as_text(v)
    if isinstance(v, np.ndarray):
        as_list: list[JsonValue] = v.tolist()
        return [plain(x) for x in as_list] if v.dtype.kind in "OSU" else as_list
    if isinstance(v, np.generic):
        item: JsonValue = v.item()
        return item
    if isinstance(v, list | tuple):
        return [plain(x) for x in v]
    return cast("JsonValue", v)  # str, int, float, bool: as h5py gives them


class Source:
    """What the exporters need from a session file, read lazily (datasets stay on disk)."""

    def __init__(self, session: Session) -> None:
        h5 = session.h5
        path = session.path
        self.h5 = h5
        self.path = path
        self._session = session
        self._attrs: dict[str, JsonObject] = {}
        # the ranges excluded in review are the session's analysis state: exported with it, and
        # a side file that could not be used is said, as info and the report say it
        self.exclusions, problem = session.exclusions()
        self.problems = (*session.problems, *([problem] if problem else []))
        self._events = {"heel_strike": session.heel_strike_idx, "toe_off": session.toe_off_idx}
        self.attrs: JsonObject = {k: plain(v) for k, v in h5.attrs.items()}
        self.mode = str(self.attrs.get("mode", ""))
        self.fs_hz = float(scalar(self.attrs.get("sample_rate_hz", 100.0)))
        if not self.fs_hz > 0 or not math.isfinite(self.fs_hz):
            raise ExportError(f"{path.name}: bad sample_rate_hz {self.fs_hz!r}")
        if "timeline/t_s" not in h5:
            raise ExportError(f"{path.name}: not a usable session (no /timeline/t_s)")
        self.channel_names = self._channel_names()
        self.host_time_origin_s = 0.0  # subtracted from the host clock (see shift_host_time)
        # the series the session gives (stored or, in format 2, derived on read)
        self.series: list[Series] = [
            s for s in (*TIMELINE_SERIES, *PROCESSED_SERIES, raw_series(self.channel_names))
            if s.path in session.dataset_names
        ]
        # Rows common to every per-sample dataset (the reader's count; ragged ends cut off).
        self.n = session.n_samples
        for s in self.series:
            shape = session.shape_of(s.path)
            width = int(np.prod(shape[1:], dtype=np.int64)) if len(shape) > 1 else 1
            if width != len(s.columns):
                raise ExportError(
                    f"{path.name}: /{s.path} has shape {shape}, expected {len(s.columns)} "
                    "columns per row"
                )

    def _channel_names(self) -> tuple[str, ...]:
        if "device/channels" in self.h5:
            rows = self.h5["device/channels"][()]
            try:
                names = tuple(as_text(x) for x in rows["name"])
            except (KeyError, ValueError):
                names = ()
            if len(names) == len(CHANNEL_NAMES):
                return names
        return CHANNEL_NAMES

    def shift_host_time(self) -> None:
        """Export the host clock from 0 at the first row (de-identification: the host clock
        plus the wall-clock offset would give the recording's date and time)."""
        if self.n and "timeline/host_time_s" in self.h5:
            # through read(): a damaged (compressed) chunk is a one-line ExportError
            self.host_time_origin_s = float(self.read("timeline/host_time_s", 0, 1)[0])

    def group_attrs(self, name: str) -> JsonObject:
        """A group's attributes as plain values (read once: formats that write many parts
        ask for them per part)."""
        if name not in self._attrs:
            self._attrs[name] = (
                {k: plain(v) for k, v in self.h5[name].attrs.items()} if name in self.h5 else {}
            )
        return dict(self._attrs[name])

    @property
    def session(self) -> Session:
        """The open session (its angles as chosen for this export)."""
        return self._session

    def angles(self) -> dict[str, str]:
        """Which angles the tilt and joint series hold, and the method that made them."""
        s = self._session
        return {"source": s.angle_source, "method": s.angle_method,
                "live_method": s.angle_method_of("live")}  # fmt: skip

    def has(self, path: str) -> bool:
        return path in self._session.dataset_names or path in self.h5

    def read(self, path: str, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Rows start:stop of one per-sample series, through the session reader (which
        decodes however the file stores it), so a streaming writer reads one block at a time."""
        stop = self.n if stop is None else stop
        try:
            if path in self._session.dataset_names:
                data = self._session.read_range(start, stop, [path])[path]
            else:
                data = self.h5[path][start:stop]
        except (OSError, RuntimeError, KeyError, ValueError) as e:
            # a damaged chunk surfaces only when read: say so, not "cannot write"
            from gaitmon.io.session.h5file import _short_error

            raise ExportError(
                f"{self.path.name} is damaged: cannot read /{path} rows {start}-{stop} "
                f"({_short_error(e)})"
            ) from None
        if path == "timeline/host_time_s" and self.host_time_origin_s:
            data = data - self.host_time_origin_s
        return data

    def events(self, name: str) -> np.ndarray:
        """Sample indices (0-based) of one event kind, limited to the rows present."""
        idx = self._events[name]
        return idx[(idx >= 0) & (idx < self.n)]

    def table(self, path: str) -> list[JsonObject]:
        """A compound dataset as a list of plain dicts (markers, gaps, changes)."""
        if path not in self.h5:
            return []
        arr = self.h5[path][()]
        if arr.dtype.names is None:
            return []
        return [{k: plain(row[k]) for k in arr.dtype.names} for row in arr]

    def channel_table(self) -> list[JsonObject]:
        return self.table("device/channels")


@contextlib.contextmanager
def open_source(
    path: Path, angles: str = "smoothed", side: str | None = None
) -> Iterator[Source]:
    """Open through gaitmon.io.session, which validates the file and first recovers an
    interrupted recording from its journal, so bad files are judged in one place. ``angles``:
    the session's smoothed (where it has them; else its only, live, angles) or live angles."""
    from gaitmon.finish import open_session
    from gaitmon.io.session import SessionError

    if path.is_dir():
        raise ExportError(f"{path} is a directory, not a session file")
    if angles not in ("smoothed", "live"):
        raise ExportError(f"unknown angles {angles!r}; use smoothed or live")
    try:
        session = open_session(path, side=side)  # side: one leg of a bilateral file
        if angles in session.angle_sources:
            session.use_angles(angles)
    except SessionError as exc:
        raise ExportError(str(exc)) from None
    try:
        yield Source(session)
    except SessionError as exc:  # the reader's own line (e.g. counts no ADC can make)
        raise ExportError(str(exc)) from None
    except (KeyError, ValueError, TypeError, RuntimeError) as exc:
        # (h5py raises RuntimeError for damaged object headers: "Can't get deprecated info")
        raise ExportError(f"{path.name} is damaged ({exc})") from None
    finally:
        session.close()

# ---- metadata and the tables every format exports ----


def _session_fields(src: Source, scrub: Scrubber) -> JsonObject:
    session: JsonObject = {k: "" for k in ("patient_id", "side", "operator", "notes")}
    session.update(src.group_attrs("session"))
    return scrub.session(session)


def _excluded_ranges(src: Source, scrub: Scrubber) -> list[JsonObject]:
    return [{"start_idx": r.start_idx, "stop_idx": r.stop_idx, "label": scrub.text(r.label)}
            for r in src.exclusions]  # fmt: skip


def _wall_offset_s(src: Source, scrub: Scrubber) -> JsonValue:
    if scrub.enabled or not src.has("timeline/host_time_s"):  # it dates the recording
        return None
    return plain(src.h5["timeline/host_time_s"].attrs.get("wall_offset_s", None))


# Key -> builder of every metadata section, in output order (JSON side file, MAT session.meta).
# A builder returns plain values; tables are lists of row dicts whose ``*_idx`` fields are
# 0-based session rows (the MAT writer makes them 1-based). Scrubbing is applied to the whole:
# to the file names quoted in it; what a person typed (exclusion labels) is scrubbed whole.
METADATA_SECTIONS: tuple[tuple[str, Callable[[Source, Scrubber], JsonValue]], ...] = (
    ("root", lambda src, scrub: scrub.root(src.attrs)),
    ("session", _session_fields),
    ("device", lambda src, scrub: {**scrub.device(src.group_attrs("device")),
                                   "channels": src.channel_table()}),
    ("processed", lambda src, scrub: src.group_attrs("processed")),
    ("angles", lambda src, scrub: src.angles()),
    ("config", lambda src, scrub: src.group_attrs("config")),
    ("config_changes", lambda src, scrub: src.table("config/changes")),
    ("calibration", lambda src, scrub: src.group_attrs("calibration")),
    ("calibration_changes", lambda src, scrub: src.table("calibration/changes")),
    ("link", lambda src, scrub: {**src.group_attrs("link"),
                                 "crc_failures": src.table("link/crc_failures")}),
    ("wall_offset_s", _wall_offset_s),
    ("excluded_ranges", _excluded_ranges),
)


def metadata(src: Source, scrub: Scrubber) -> JsonObject:
    """Everything but the per-sample series, as plain values (the JSON side file / MAT meta)."""
    meta: JsonObject = {key: build(src, scrub) for key, build in METADATA_SECTIONS}
    return scrub.mapping(meta) if scrub.enabled else meta


def session_side(src: Source) -> str:
    """'L', 'R' or '' (nobody entered one) from /session side: the leg measured, as
    :func:`gaitmon.text.side_text` reads it for info, the report and compare. The unit's own
    IDENTITY side (/device side) is the unit's, not the patient's, and is not used."""
    s = as_text(src.group_attrs("session").get("side", "")).strip().upper()
    return s if s in ("L", "R") else ""


class ExportedMarker(TypedDict):
    """One exported marker (``sample_idx`` a 0-based session row)."""

    sample_idx: int
    t_s: float
    label: str


class ExportedGap(TypedDict):
    """One exported gap: ``n_lost`` frames lost before row ``sample_idx`` (0-based)."""

    sample_idx: int
    n_lost: int
    duration_s: float
    reason: str


def markers(src: Source, scrub: Scrubber) -> list[ExportedMarker]:
    out: list[ExportedMarker] = []
    for m in src.table("markers"):
        idx = int(scalar(m.get("sample_idx", -1)))
        if 0 <= idx < src.n:
            out.append({"sample_idx": idx, "t_s": float(scalar(m.get("t_s", math.nan))),
                        # cleaned again: a file written before labels were cleaned at
                        # entry may hold ANSI escapes or a megabyte of text
                        "label": clean_label(scrub.text(as_text(m.get("label", ""))))})
    return out


def gaps(src: Source, scrub: Scrubber) -> list[ExportedGap]:
    out: list[ExportedGap] = []
    for g in src.table("gaps"):
        idx = int(scalar(g.get("sample_idx", -1)))
        if 0 <= idx <= src.n:
            out.append({"sample_idx": idx, "n_lost": int(scalar(g.get("n_lost", 0))),
                        "duration_s": float(scalar(g.get("duration_s", math.nan))),
                        "reason": clean_label(scrub.names(as_text(g.get("reason", ""))))})
    return out


def json_rows(rows: Sequence[ExportedMarker] | Sequence[ExportedGap]) -> list[JsonObject]:
    """Marker or gap rows as JSON objects (their values are text and numbers)."""
    return [cast("JsonObject", dict(r)) for r in rows]


def json_default(o: object) -> JsonValue:
    """``json.dump``'s ``default``: numpy values and bytes as JSON values (anything else is
    not serialisable)."""
    if isinstance(o, np.generic):
        item: JsonValue = o.item()
        return item
    if isinstance(o, np.ndarray):
        as_list: list[JsonValue] = o.tolist()
        return as_list
    if isinstance(o, bytes):
        return as_text(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def json_safe(v: JsonValue) -> JsonValue:
    """NaN/inf are not JSON; write them as null."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, list):
        return [json_safe(x) for x in v]
    if isinstance(v, dict):
        return {k: json_safe(x) for k, x in v.items()}
    return v


def export_header_fields(fmt: str, deidentify: bool) -> JsonObject:
    """What every export says of itself (format, version, by, when, de-identified). A
    de-identified export does not say when it was made (``exported_utc`` left out): the day of
    the export is often the day of the visit."""
    head: JsonObject = {
        "format": f"gaitmon-export-{fmt}",
        "export_version": EXPORT_VERSION,
        "exported_by": f"gaitmon {__version__}",
        "exported_utc": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "deidentified": bool(deidentify),
    }
    if deidentify:
        del head["exported_utc"]
    return head


def export_header(src: Source, fmt: str, deidentify: bool) -> JsonObject:
    head: JsonObject = {
        **export_header_fields(fmt, deidentify),
        "mode": src.mode,
        "sample_rate_hz": src.fs_hz,
        "n_samples": src.n,
    }
    if not deidentify:  # a file name often carries a patient code
        head["source_file"] = src.path.name
    return head


def frame_grid(src: Source, placed: str) -> np.ndarray:
    """The frame of every session row on the uniform 1/fs grid from the first sample:
    round((t_s - t_s[0]) * fs), for the formats that store frames (C3D) or rows (BIDS) rather
    than times. ``placed`` ends the message for times that cannot be placed ("in C3D frames")."""
    if src.n == 0:
        return np.zeros(0, np.int64)
    t = src.read("timeline/t_s").astype(np.float64)
    grid = (t - t[0]) * src.fs_hz
    if not np.all(np.abs(grid) < 2.0**53):  # NaN or absurd times: no frame number to cast to
        raise ExportError(f"{src.path.name} is damaged: some sample times are not valid")
    frame = np.rint(grid).astype(np.int64)
    if np.any(np.diff(frame) <= 0):
        raise ExportError(
            f"{src.path.name}: sample times are not increasing on the {src.fs_hz:g} Hz grid; "
            f"cannot place them {placed}"
        )
    return frame
