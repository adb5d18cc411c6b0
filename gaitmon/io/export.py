"""Export of recorded sessions (HDF5, docs/file-format.md) to CSV, MATLAB .mat and C3D.

This module owns the exported layouts (column names, MAT struct fields, C3D groups), the
precision each format keeps, and de-identification of what is exported. The layouts are
documented in docs/file-format.md, section "Export formats"; keep the two in step.

- CSV: one header row, one row per received sample (row k = session sample index k), streamed
  in chunks so an 8-hour file never sits in memory; metadata, events, markers and gaps also go
  to a JSON side file ``<stem>.meta.json``.
- MAT: one struct ``session`` in a v5 MAT file (MATLAB ``load``, ``scipy.io.loadmat``); every
  ``*_idx`` field is a 1-based MATLAB row index.
- C3D: through ezc3d; joint angles (and segment tilts) as POINTs of type angle, the 14 ADC
  channels in physical units as ANALOGs, gait events in the EVENT group. Sessions longer than
  one C3D trial are split into 10-minute parts.

Every output is written to a temporary name beside it and renamed into place at the end, so an
error or Ctrl-C never leaves a half-written file under the final name.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import math
import os
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gaitmon import __version__
from gaitmon.dsp.channels import (
    CHANNEL_NAMES,
    DEFAULT_TABLE,
    JOINTS,
    SEGMENTS,
    ChannelSpec,
    ChannelTable,
)

if TYPE_CHECKING:
    from gaitmon.io.session import Session

FORMATS: tuple[str, ...] = ("csv", "mat", "c3d")
EXTENSIONS: dict[str, str] = {"csv": ".csv", "mat": ".mat", "c3d": ".c3d"}
EXPORT_VERSION = 1

CSV_CHUNK_ROWS = 16_384  # ~15 MB of Python floats and strings per chunk
# MATLAB's v5/v7 MAT formats cap one variable at 2 GB (v7.3 lifts it, but scipy cannot read
# v7.3); the whole `session` struct is one variable, so it must fit. Margin for headers/names.
MAT_V5_MAX_BYTES = 2**31 - 2**24
# A C3D trial counts frames in 16-bit words (header and POINT:FRAMES); past 65535 frames
# readers disagree (ezc3d 1.7 reads back only the first 65535), so long sessions are split.
C3D_MAX_PART_S = 600.0
# EVENT parameters are arrays whose dimensions are single bytes: at most 255 events per file.
C3D_MAX_EVENTS = 255
# ezc3d 1.7 keeps about the data size of each file it writes: beyond this many parts, parts
# are written by a worker process that is replaced after this many.
C3D_INPROCESS_PARTS = 8
ANONYMOUS = "anonymous"  # C3D subject name when there is none or it is withheld

REDACTED = "[removed]"
PROGRESS = Callable[[float], None]

JOINT_LABELS: tuple[str, ...] = ("hip_flexion", "knee_flexion", "ankle_dorsiflexion")
# C3D angle points named as in Vicon Plug-in Gait (X = sagittal component).
C3D_JOINT_POINTS: tuple[str, ...] = ("HipAngles", "KneeAngles", "AnkleAngles")
C3D_TILT_POINTS: tuple[str, ...] = ("BodyTilt", "ThighTilt", "ShankTilt", "FootTilt")

assert len(JOINTS) == len(JOINT_LABELS) == 3 and len(SEGMENTS) == 4


class ExportError(Exception):
    """A problem with the input, the output path or the format; the message is one line."""


# ------------------------------------------------------------------------------------------
# The series a session can hold, and how each format names them
# ------------------------------------------------------------------------------------------


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
           "0 swing, 1 loading, 2 foot flat, 3 push-off"),
)


def _raw_series(channel_names: tuple[str, ...]) -> Series:
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


# ------------------------------------------------------------------------------------------
# Reading: a thin view over the session file
# ------------------------------------------------------------------------------------------


def _text(v: Any) -> str:
    if isinstance(v, bytes):
        return v.decode("utf-8", errors="replace")
    return str(v)


def _plain(v: Any) -> Any:
    """HDF5 attribute value -> JSON-able Python value."""
    if isinstance(v, bytes):
        return _text(v)
    if isinstance(v, np.ndarray):
        return [_plain(x) for x in v.tolist()] if v.dtype.kind in "OSU" else v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, list | tuple):
        return [_plain(x) for x in v]
    return v


class _Source:
    """What the exporters need from a session file, read lazily (datasets stay on disk)."""

    def __init__(self, session: Session) -> None:
        h5 = session.dataset("timeline/t_s").file
        path = session.path
        self.h5 = h5
        self.path = path
        self.problems = tuple(session.problems)
        self._events = {"heel_strike": session.heel_strike_idx, "toe_off": session.toe_off_idx}
        self.attrs: dict[str, Any] = {k: _plain(v) for k, v in h5.attrs.items()}
        self.mode = str(self.attrs.get("mode", ""))
        self.fs_hz = float(self.attrs.get("sample_rate_hz", 100.0))
        if not self.fs_hz > 0 or not math.isfinite(self.fs_hz):
            raise ExportError(f"{path.name}: bad sample_rate_hz {self.fs_hz!r}")
        if "timeline/t_s" not in h5:
            raise ExportError(f"{path.name}: not a usable session (no /timeline/t_s)")
        self.channel_names = self._channel_names()
        self.series: list[Series] = [
            s for s in (*TIMELINE_SERIES, *PROCESSED_SERIES, _raw_series(self.channel_names))
            if s.path in h5
        ]
        # Rows common to every per-sample dataset (the reader's count; ragged ends cut off).
        self.n = min([session.n_samples, *(int(h5[s.path].shape[0]) for s in self.series)])
        for s in self.series:
            ds = h5[s.path]
            width = int(np.prod(ds.shape[1:], dtype=np.int64)) if ds.ndim > 1 else 1
            if width != len(s.columns):
                raise ExportError(
                    f"{path.name}: /{s.path} has shape {ds.shape}, expected {len(s.columns)} "
                    "columns per row"
                )

    def _channel_names(self) -> tuple[str, ...]:
        if "device/channels" in self.h5:
            rows = self.h5["device/channels"][()]
            try:
                names = tuple(_text(x) for x in rows["name"])
            except (KeyError, ValueError):
                names = ()
            if len(names) == len(CHANNEL_NAMES):
                return names
        return CHANNEL_NAMES

    def group_attrs(self, name: str) -> dict[str, Any]:
        if name not in self.h5:
            return {}
        return {k: _plain(v) for k, v in self.h5[name].attrs.items()}

    def has(self, path: str) -> bool:
        return path in self.h5

    def read(self, path: str, start: int = 0, stop: int | None = None) -> np.ndarray:
        stop = self.n if stop is None else stop
        return self.h5[path][start:stop]

    def events(self, name: str) -> np.ndarray:
        """Sample indices (0-based) of one event kind, limited to the rows present."""
        idx = self._events[name]
        return idx[(idx >= 0) & (idx < self.n)]

    def table(self, path: str) -> list[dict[str, Any]]:
        """A compound dataset as a list of plain dicts (markers, gaps, changes)."""
        if path not in self.h5:
            return []
        arr = self.h5[path][()]
        if arr.dtype.names is None:
            return []
        return [{k: _plain(row[k]) for k in arr.dtype.names} for row in arr]

    def channel_table(self) -> list[dict[str, Any]]:
        return self.table("device/channels")


@contextlib.contextmanager
def _open_source(path: Path) -> Iterator[_Source]:
    """Open through gaitmon.io.session, which validates the file and first recovers an
    interrupted recording from its journal, so bad files are judged in one place."""
    from gaitmon.io.session import SessionError, open_session

    if path.is_dir():
        raise ExportError(f"{path} is a directory, not a session file")
    try:
        session = open_session(path)
    except SessionError as exc:
        raise ExportError(str(exc)) from None
    try:
        yield _Source(session)
    except (KeyError, ValueError, TypeError, SessionError) as exc:
        raise ExportError(f"{path.name} is damaged ({exc})") from None
    finally:
        session.close()


# ------------------------------------------------------------------------------------------
# Metadata and de-identification
# ------------------------------------------------------------------------------------------


class _Scrubber:
    """Blanks the identifying fields and removes their values wherever else they appear."""

    FIELDS = ("patient_id", "operator", "notes")

    def __init__(self, session_attrs: dict[str, Any], enabled: bool) -> None:
        self.enabled = enabled
        values = [_text(session_attrs.get(k, "")).strip() for k in self.FIELDS]
        # Longest first so a value containing another is removed whole.
        self.secrets = sorted({v for v in values if v}, key=len, reverse=True)

    def text(self, s: str) -> str:
        if not self.enabled:
            return s
        for secret in self.secrets:
            s = s.replace(secret, REDACTED)
        return s

    def value(self, v: Any) -> Any:
        if isinstance(v, str):
            return self.text(v)
        if isinstance(v, list):
            return [self.value(x) for x in v]
        if isinstance(v, dict):
            return {k: self.value(x) for k, x in v.items()}
        return v

    def session(self, attrs: dict[str, Any]) -> dict[str, Any]:
        out = dict(attrs)
        if self.enabled:
            for k in self.FIELDS:
                out[k] = ""
        return self.value(out) if self.enabled else out


def _metadata(src: _Source, scrub: _Scrubber) -> dict[str, Any]:
    """Everything but the per-sample series, as plain values (the JSON side file / MAT meta)."""
    from gaitmon.io.session import exclusions

    # the ranges excluded in review are the session's analysis state: exported with it
    ranges, _ = exclusions.load(src.path, str(src.attrs.get("created_utc", "")), src.n)
    session = {k: "" for k in ("patient_id", "side", "operator", "notes")}
    session.update(src.group_attrs("session"))
    meta: dict[str, Any] = {
        "root": src.attrs,
        "session": scrub.session(session),
        "device": {**src.group_attrs("device"), "channels": src.channel_table()},
        "processed": src.group_attrs("processed"),
        "config": src.group_attrs("config"),
        "config_changes": src.table("config/changes"),
        "calibration": src.group_attrs("calibration"),
        "calibration_changes": src.table("calibration/changes"),
        "link": {**src.group_attrs("link"), "crc_failures": src.table("link/crc_failures")},
        "wall_offset_s": _plain(src.h5["timeline/host_time_s"].attrs.get("wall_offset_s", None))
        if src.has("timeline/host_time_s") else None,
        "excluded_ranges": [
            {"start_idx": r.start_idx, "stop_idx": r.stop_idx, "label": r.label} for r in ranges
        ],
    }
    return scrub.value(meta) if scrub.enabled else meta


def _side(src: _Source) -> str:
    """'L', 'R' or '' from /session side, else /device side."""
    for group in ("session", "device"):
        s = _text(src.group_attrs(group).get("side", "")).strip().upper()
        if s in ("L", "R"):
            return s
    return ""


def _markers(src: _Source, scrub: _Scrubber) -> list[dict[str, Any]]:
    out = []
    for m in src.table("markers"):
        idx = int(m.get("sample_idx", -1))
        if 0 <= idx < src.n:
            out.append({"sample_idx": idx, "t_s": float(m.get("t_s", math.nan)),
                        "label": scrub.text(_text(m.get("label", "")))})
    return out


def _gaps(src: _Source, scrub: _Scrubber) -> list[dict[str, Any]]:
    out = []
    for g in src.table("gaps"):
        idx = int(g.get("sample_idx", -1))
        if 0 <= idx <= src.n:
            out.append({"sample_idx": idx, "n_lost": int(g.get("n_lost", 0)),
                        "duration_s": float(g.get("duration_s", math.nan)),
                        "reason": scrub.text(_text(g.get("reason", "")))})
    return out


def _json_default(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, bytes):
        return _text(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _json_safe(v: Any) -> Any:
    """NaN/inf are not JSON; write them as null."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, list):
        return [_json_safe(x) for x in v]
    if isinstance(v, dict):
        return {k: _json_safe(x) for k, x in v.items()}
    return v


def _export_header(src: _Source, fmt: str, deidentify: bool) -> dict[str, Any]:
    head: dict[str, Any] = {
        "format": f"gaitmon-export-{fmt}",
        "export_version": EXPORT_VERSION,
        "exported_by": f"gaitmon {__version__}",
        "exported_utc": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "deidentified": bool(deidentify),
        "mode": src.mode,
        "sample_rate_hz": src.fs_hz,
        "n_samples": src.n,
    }
    if not deidentify:  # a file name often carries a patient code
        head["source_file"] = src.path.name
    return head


# ------------------------------------------------------------------------------------------
# Output paths and atomic writes
# ------------------------------------------------------------------------------------------


def default_output(src_path: str | os.PathLike[str], fmt: str) -> Path:
    """FILE with the format's extension (session.h5 -> session.csv)."""
    return Path(src_path).with_suffix(EXTENSIONS[fmt])


def csv_meta_path(csv_path: Path) -> Path:
    """The JSON side file written beside a CSV export: <stem>.meta.json."""
    return csv_path.with_name(csv_path.stem + ".meta.json")


def c3d_part_path(c3d_path: Path, part: int) -> Path:
    """Part k (1-based) of a split C3D export: <stem>_part001.c3d, ..."""
    return c3d_path.with_name(f"{c3d_path.stem}_part{part:03d}{c3d_path.suffix}")


def _tmp_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.partial")


class _AtomicOutputs:
    """Collects temp files; renames them into place on success, deletes them on failure."""

    def __init__(self) -> None:
        self.pairs: list[tuple[Path, Path]] = []

    def tmp(self, final: Path) -> Path:
        t = _tmp_path(final)
        self.pairs.append((t, final))
        return t

    def commit(self) -> list[Path]:
        for t, final in self.pairs:
            os.replace(t, final)
        return [final for _, final in self.pairs]

    def discard(self) -> None:
        for t, _ in self.pairs:
            with contextlib.suppress(FileNotFoundError):
                t.unlink()


def _check_outputs(paths: list[Path], src_path: Path, force: bool) -> None:
    for p in paths:
        if p.resolve() == src_path.resolve():
            raise ExportError(f"refusing to overwrite the session file itself: {p}")
        if p.is_dir():
            raise ExportError(f"output {p} is a directory")
        if p.exists() and not force:
            raise ExportError(f"{p} already exists (use --force to overwrite)")
        if not p.parent.is_dir():
            raise ExportError(f"output folder does not exist: {p.parent}")


# ------------------------------------------------------------------------------------------
# CSV
# ------------------------------------------------------------------------------------------


def _csv_cell(text: str) -> str:
    """RFC 4180 quoting for the free-text column."""
    if any(c in text for c in ',"\r\n') or text != text.strip():
        return '"' + text.replace('"', '""') + '"'
    return text


def _csv_columns(src: _Source) -> list[Series]:
    order = ["timeline/t_s", "timeline/seq"]
    order += [s.path for s in PROCESSED_SERIES]
    order += ["raw/adc", "timeline/host_time_s"]
    by_path = {s.path: s for s in src.series}
    return [by_path[p] for p in order if p in by_path]


CSV_EXTRA_COLUMNS: tuple[str, ...] = ("heel_strike", "toe_off", "gap_lost_frames", "marker")


def _write_csv(src: _Source, out: Path, scrub: _Scrubber, progress: PROGRESS | None,
               chunk_rows: int) -> None:
    series = _csv_columns(src)
    header = [c for s in series for c in s.columns] + list(CSV_EXTRA_COLUMNS)
    num_fmt = ",".join(s.fmt for s in series for _ in s.columns)
    hs = src.events("heel_strike")
    to = src.events("toe_off")
    gaps = _gaps(src, scrub)
    markers = _markers(src, scrub)
    gap_at: dict[int, int] = {}
    for g in gaps:
        gap_at[g["sample_idx"]] = gap_at.get(g["sample_idx"], 0) + g["n_lost"]
    marker_at: dict[int, list[str]] = {}
    for mk in markers:
        marker_at.setdefault(mk["sample_idx"], []).append(mk["label"])
    n = src.n
    with open(out, "w", encoding="utf-8", newline="") as f:
        f.write(",".join(header) + "\n")
        for start in range(0, n, chunk_rows):
            stop = min(n, start + chunk_rows)
            m = stop - start
            blocks = [np.asarray(src.read(s.path, start, stop)).reshape(m, -1) for s in series]
            extra = np.zeros((m, 3), dtype=np.float64)
            extra[hs[(hs >= start) & (hs < stop)] - start, 0] = 1
            extra[to[(to >= start) & (to < stop)] - start, 1] = 1
            for idx, lost in gap_at.items():
                if start <= idx < stop:
                    extra[idx - start, 2] = lost
            # float64 holds every int column exactly (counts, seq < 2**53), so one tolist()
            # feeds one printf per row; this is the speed-critical loop.
            table = np.concatenate([*[b.astype(np.float64) for b in blocks], extra], axis=1)
            row_fmt = num_fmt + ",%d,%d,%d,"
            lines = [row_fmt % tuple(r) for r in table.tolist()]
            for idx, labels in marker_at.items():
                if start <= idx < stop:
                    lines[idx - start] += _csv_cell(" | ".join(labels))
            f.write("\n".join(lines))
            f.write("\n")
            if progress is not None:
                progress(stop / n)
    if n == 0 and progress is not None:
        progress(1.0)


def _csv_meta(src: _Source, scrub: _Scrubber, deidentify: bool) -> dict[str, Any]:
    cols = []
    for s in _csv_columns(src):
        for c in s.columns:
            cols.append({"name": c, "unit": s.unit, "source": "/" + s.path,
                         "description": s.description,
                         "decimals": _decimals(s.fmt)})
    cols += [
        {"name": "heel_strike", "unit": "0/1", "source": "/events/heel_strike",
         "description": "1 on the row of a heel strike", "decimals": 0},
        {"name": "toe_off", "unit": "0/1", "source": "/events/toe_off",
         "description": "1 on the row of a toe off", "decimals": 0},
        {"name": "gap_lost_frames", "unit": "frames", "source": "/gaps",
         "description": "frames lost just before this row (0 if none)", "decimals": 0},
        {"name": "marker", "unit": "", "source": "/markers",
         "description": "clinician marker label(s) on this row, joined with ' | '",
         "decimals": None},
    ]
    return {
        **_export_header(src, "csv", deidentify),
        "row_index": "data row k (0-based, header excluded) is session sample index k",
        "columns": cols,
        "events": {"index_base": 0,
                   "heel_strike_idx": src.events("heel_strike").tolist(),
                   "toe_off_idx": src.events("toe_off").tolist()},
        "markers": _markers(src, scrub),
        "gaps": _gaps(src, scrub),
        **_metadata(src, scrub),
    }


def _decimals(fmt: str) -> int | None:
    if fmt == "%d":
        return 0
    if fmt.startswith("%.") and fmt.endswith("f"):
        return int(fmt[2:-1])
    return None


# ------------------------------------------------------------------------------------------
# MAT (v5)
# ------------------------------------------------------------------------------------------


def _cell(strings: list[str] | tuple[str, ...]) -> np.ndarray:
    """A MATLAB cell array of char (column), as scipy.io.savemat wants it."""
    arr = np.empty((len(strings), 1), dtype=object)
    for i, s in enumerate(strings):
        arr[i, 0] = s
    return arr


def _mat_value(v: Any) -> Any:
    """Plain metadata -> something savemat stores sensibly (None -> [], lists -> arrays/cells)."""
    if v is None:
        return np.zeros((0, 0))
    if isinstance(v, dict):
        return {_mat_name(k): _mat_value(x) for k, x in v.items()}
    if isinstance(v, list):
        if v and all(isinstance(x, dict) for x in v):
            # list of records -> struct of column arrays
            keys = list(v[0].keys())
            return {_mat_name(k): _mat_value([x.get(k) for x in v]) for k in keys}
        if all(isinstance(x, str) for x in v):
            return _cell(v)
        if all(isinstance(x, bool | int | float) for x in v):
            return np.asarray(v, dtype=np.float64).reshape(-1, 1)
        return _cell([json.dumps(x, default=_json_default) for x in v])
    if isinstance(v, bool):
        return np.uint8(v)
    return v


def _mat_name(k: str) -> str:
    """MATLAB field names: letters, digits, underscore, starting with a letter, <= 63 chars."""
    s = "".join(c if (c.isascii() and (c.isalnum() or c == "_")) else "_" for c in k)
    if not s or not s[0].isalpha():
        s = "f_" + s
    return s[:63]


def _mat_bytes(src: _Source) -> int:
    """Bytes of the per-sample arrays in the MAT `session` variable (timeline as double)."""
    total = 0
    for s in src.series:
        size = 8 if s.path.startswith("timeline/") else int(src.h5[s.path].dtype.itemsize)
        total += src.n * len(s.columns) * size
    return total


def _write_mat(src: _Source, out: Path, scrub: _Scrubber, deidentify: bool,
               progress: PROGRESS | None) -> None:
    from scipy.io import savemat

    series = src.series
    total = _mat_bytes(src)
    if total > MAT_V5_MAX_BYTES:
        raise ExportError(
            f"{src.path.name} is too long for one MAT v5 variable ({total / 2**30:.1f} GB > "
            "2 GB MATLAB limit); export --format csv, or read the .h5 directly in MATLAB "
            "(h5read)"
        )
    session: dict[str, Any] = {}
    head = _export_header(src, "mat", deidentify)
    for k, v in head.items():
        session[k] = _mat_value(v)
    session["index_base"] = 1.0
    session["t0_s"] = 0.0
    labels: dict[str, Any] = {}
    for n_done, s in enumerate(series, start=1):
        arr = np.asarray(src.read(s.path))
        if s.path.startswith("timeline/"):
            arr = arr.astype(np.float64)  # MATLAB works in double; seq < 2**53 stays exact
        session[s.key] = arr.reshape(src.n, 1) if arr.ndim == 1 else arr
        labels[s.key] = _cell(s.columns) if s.key != "acc_ms2" else _cell(s.labels)
        if progress is not None:
            progress(0.8 * n_done / len(series))
    session["labels"] = labels
    session["units"] = {s.key: s.unit for s in series}
    t = src.read("timeline/t_s").astype(np.float64) if src.n else np.zeros(0)
    events: dict[str, Any] = {}
    for name in ("heel_strike", "toe_off"):
        idx = src.events(name)
        events[f"{name}_idx"] = (idx + 1).astype(np.float64).reshape(-1, 1)
        events[f"{name}_t_s"] = t[idx].reshape(-1, 1)
    session["events"] = events
    markers = _markers(src, scrub)
    session["markers"] = {
        "sample_idx": np.array([m["sample_idx"] + 1 for m in markers], float).reshape(-1, 1),
        "t_s": np.array([m["t_s"] for m in markers], float).reshape(-1, 1),
        "label": _cell([m["label"] for m in markers]),
    }
    gaps = _gaps(src, scrub)
    session["gaps"] = {
        "sample_idx": np.array([g["sample_idx"] + 1 for g in gaps], float).reshape(-1, 1),
        "n_lost": np.array([g["n_lost"] for g in gaps], float).reshape(-1, 1),
        "duration_s": np.array([g["duration_s"] for g in gaps], float).reshape(-1, 1),
        "reason": _cell([g["reason"] for g in gaps]),
    }
    meta = _metadata(src, scrub)
    # sample indices inside metadata tables are 1-based too, like everywhere in the MAT file
    for table in ("config_changes", "calibration_changes"):
        for row in meta[table]:
            if "sample_idx" in row:
                row["sample_idx"] = int(row["sample_idx"]) + 1
    for row in meta["link"].get("crc_failures", []):
        if "sample_idx" in row:
            row["sample_idx"] = int(row["sample_idx"]) + 1
    session["meta"] = _mat_value(meta)
    with open(out, "wb") as f:
        savemat(f, {"session": session}, format="5", oned_as="column",
                long_field_names=True, do_compression=False)
    if progress is not None:
        progress(1.0)


# ------------------------------------------------------------------------------------------
# C3D
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class C3dPlan:
    """How rows map onto C3D frames: a uniform 1/fs grid from the first sample, split in parts."""

    frame: np.ndarray  # (N,) int64 frame of each row on the uniform grid
    n_frames: int
    part_frames: int
    parts: tuple[tuple[int, int], ...] = field(default=())  # [first, stop) frames per part


def _c3d_plan(src: _Source, events: np.ndarray | None = None,
              max_part_s: float | None = None) -> C3dPlan:
    """Frames on the uniform grid, cut into parts of at most C3D_MAX_PART_S seconds and at
    most C3D_MAX_EVENTS events (``events``: the sorted row indices of every C3D event)."""
    max_part_s = C3D_MAX_PART_S if max_part_s is None else max_part_s
    t = src.read("timeline/t_s").astype(np.float64) if src.n else np.zeros(0)
    if src.n == 0:
        return C3dPlan(np.zeros(0, np.int64), 0, 1, ((0, 0),))
    frame = np.rint((t - t[0]) * src.fs_hz).astype(np.int64)
    if np.any(np.diff(frame) <= 0):
        raise ExportError(
            f"{src.path.name}: sample times are not increasing on the {src.fs_hz:g} Hz grid; "
            "cannot place them in C3D frames"
        )
    n_frames = int(frame[-1]) + 1
    part = max(1, min(65_535, round(max_part_s * src.fs_hz)))
    ev = np.sort(frame[events]) if events is not None and len(events) else np.zeros(0, np.int64)
    parts = []
    a = 0
    while a < n_frames:
        b = min(n_frames, a + part)
        i0 = int(np.searchsorted(ev, a))
        if int(np.searchsorted(ev, b)) - i0 > C3D_MAX_EVENTS:
            b = max(a + 1, int(ev[i0 + C3D_MAX_EVENTS]))  # the 256th event starts the next part
        parts.append((a, b))
        a = b
    return C3dPlan(frame, n_frames, part, tuple(parts))


def _c3d_events(src: _Source, scrub: _Scrubber, side: str) -> list[tuple[int, str, str, str, int]]:
    """(row, context, label, description, icon id) of every C3D event, in row order."""
    ctx = {"L": "Left", "R": "Right"}.get(side, "General")
    out = []
    for name, label, desc, icon in (("heel_strike", "Foot Strike", "heel strike", 1),
                                    ("toe_off", "Foot Off", "toe off", 2)):
        out += [(int(k), ctx, label, desc, icon) for k in src.events(name)]
    out += [(m["sample_idx"], "General", m["label"][:64] or "Marker", "clinician marker", 0)
            for m in _markers(src, scrub)]
    out.sort(key=lambda e: e[0])  # stable: strikes before offs before markers on one row
    return out


@dataclass
class _C3dSpec:
    """One C3D file as plain, picklable data: the parameters to set and the arrays."""

    values: list[tuple[str, str, Any]] = field(default_factory=list)  # set existing param
    params: list[tuple[str, str, Any, str]] = field(default_factory=list)  # add_parameter
    int_params: list[tuple[str, str, list[int], str]] = field(default_factory=list)
    points: np.ndarray = field(default_factory=lambda: np.zeros((4, 0, 0)))
    residuals: np.ndarray = field(default_factory=lambda: np.zeros((1, 0, 0)))
    analogs: np.ndarray = field(default_factory=lambda: np.zeros((1, 0, 0)))

    def set_value(self, group: str, name: str, value: Any) -> None:
        self.values.append((group, name, value))

    def add_parameter(self, group: str, name: str, value: Any, desc: str = "") -> None:
        self.params.append((group, name, value, desc))


def _c3d_write_spec(spec: _C3dSpec, out: str) -> None:
    """Write one C3D file with ezc3d (in a worker process for long exports: ezc3d 1.7 keeps
    about the data size of every c3d it writes, so the worker is replaced every few parts)."""
    import ezc3d

    c = ezc3d.c3d()
    for group, name, value in spec.values:
        c["parameters"][group][name]["value"] = value
    c["data"]["points"] = spec.points
    c["data"]["meta_points"] = {"residuals": spec.residuals}
    c["data"]["analogs"] = spec.analogs
    for group, name, value, desc in spec.params:
        c.add_parameter(group, name, value, desc)
    for group, name, ints, desc in spec.int_params:
        # ezc3d's add_parameter turns Python int lists into FLOAT parameters; the C3D spec
        # wants INTEGER for TRIAL fields, counts and ids, so build the parameter directly.
        p = ezc3d.ezc3d.Parameter(name, desc)
        p.set(ezc3d.ezc3d.VecInt([int(v) for v in ints]), [len(ints)])
        c._storage["parameters"].add_parameter(group, p)
    c.write(out)


def _c3d_param_int(c: _C3dSpec, group: str, name: str, values: list[int],
                   desc: str = "") -> None:
    c.int_params.append((group, name, [int(v) for v in values], desc))


def _c3d_part_spec(src: _Source, plan: C3dPlan, part_no: int, scrub: _Scrubber,
                   deidentify: bool, events: list[tuple[int, str, str, str, int]]) -> _C3dSpec:
    """Everything one C3D part holds, as plain data (written by _c3d_write_spec)."""
    f0, f1 = plan.parts[part_no]
    nf = f1 - f0
    fs = src.fs_hz
    r0, r1 = np.searchsorted(plan.frame, [f0, f1])
    local = plan.frame[r0:r1] - f0
    side = _side(src)

    c = _C3dSpec()
    point_labels: list[str] = []
    point_desc: list[str] = []
    point_blocks: list[np.ndarray] = []
    if src.has("processed/joint_deg"):
        point_labels += [side + p for p in C3D_JOINT_POINTS]
        point_desc += [f"{j} (X sagittal; Y, Z not measured = 0), deg" for j in JOINT_LABELS]
        point_blocks.append(np.asarray(src.read("processed/joint_deg", r0, r1), np.float64))
    if src.has("processed/tilt_deg"):
        point_labels += [
            ("" if p == "BodyTilt" else side) + p for p in C3D_TILT_POINTS
        ]
        point_desc += [f"{s} tilt from vertical (X sagittal), deg" for s in SEGMENTS]
        point_blocks.append(np.asarray(src.read("processed/tilt_deg", r0, r1), np.float64))
    n_pts = len(point_labels)
    # Frames with no received sample (lost frames) are invalid points: residual -1, as the
    # C3D spec marks them (readers then show gaps; ezc3d returns NaN).
    pts = np.zeros((4, n_pts, nf))
    pts[3] = 1.0
    residuals = np.full((1, n_pts, nf), -1.0)
    if n_pts:
        vals = np.concatenate(point_blocks, axis=1)  # (rows, n_pts)
        pts[0][:, local] = vals.T
        residuals[0][:, local] = 0.0
        # a NaN angle (e.g. the unit's invalid value) is missing too
        residuals[0][np.isnan(pts[0])] = -1.0
        pts[0][np.isnan(pts[0])] = 0.0
    c.set_value("POINT", "RATE", np.array([fs]))
    c.set_value("POINT", "LABELS", point_labels)
    c.set_value("POINT", "DESCRIPTIONS", point_desc)
    c.set_value("POINT", "UNITS", ["mm"])
    c.points, c.residuals = pts, residuals
    if n_pts:
        c.add_parameter("POINT", "ANGLES", point_labels, "points that are angles")
        c.add_parameter("POINT", "ANGLE_UNITS", "deg", "unit of angle points")
        c.add_parameter("POINT", "TYPE_GROUPS", ["ANGLES"], "point type groups")

    analog_labels: list[str] = []
    analog_units: list[str] = []
    analog_desc: list[str] = []
    analog_blocks: list[np.ndarray] = []
    if src.has("raw/adc"):
        table = _channel_table(src)
        analog_blocks.append(table.to_physical(src.read("raw/adc", r0, r1)))
        analog_labels += list(src.channel_names)
        analog_units += [c.unit for c in table.channels]
        analog_desc += [f"ADC channel {i} in physical units" for i in range(len(table.channels))]
    if src.has("processed/fsr_counts"):
        analog_blocks.append(np.asarray(src.read("processed/fsr_counts", r0, r1), np.float64))
        analog_labels += ["heel_fsr_lp", "toe_fsr_lp"]
        analog_units += ["count", "count"]
        analog_desc += ["low-passed heel FSR", "low-passed toe FSR"]
    n_an = len(analog_labels)
    an = np.full((1, n_an, nf), np.nan)
    if n_an:
        an[0][:, local] = np.concatenate(analog_blocks, axis=1).T
    c.set_value("ANALOG", "RATE", np.array([fs]))
    c.set_value("ANALOG", "LABELS", analog_labels)
    c.set_value("ANALOG", "DESCRIPTIONS", analog_desc)
    c.set_value("ANALOG", "UNITS", analog_units)
    c.analogs = an
    if n_an:
        c.add_parameter("ANALOG", "SCALE", np.ones(n_an), "data stored in physical units")
        _c3d_param_int(c, "ANALOG", "OFFSET", [0] * n_an)
    if n_pts == 0 and n_an == 0:
        raise ExportError(f"{src.path.name}: nothing to put in a C3D file (no angles, no raw)")

    _c3d_param_int(c, "TRIAL", "ACTUAL_START_FIELD", [1, 0], "first frame")
    _c3d_param_int(c, "TRIAL", "ACTUAL_END_FIELD", [nf & 0xFFFF, nf >> 16], "last frame")
    t_part0 = f0 / fs

    # Events: time from frame 1 (time 0.0) of this part, as (whole minutes, seconds). Built
    # in one go: ezc3d's add_event rewrites the whole group per event (quadratic).
    subject = (ANONYMOUS if deidentify
               else _text(src.group_attrs("session").get("patient_id", "")) or ANONYMOUS)
    evs = [(int(plan.frame[row]) - f0, ctx, label, desc, icon)
           for row, ctx, label, desc, icon in events]
    evs = [e for e in evs if 0 <= e[0] < nf]
    if evs:
        times = np.array([_c3d_time(e[0] / fs) for e in evs]).T  # (2, n)
        _c3d_param_int(c, "EVENT", "USED", [len(evs)])
        c.add_parameter("EVENT", "TIMES", times)
        c.add_parameter("EVENT", "CONTEXTS", [e[1] for e in evs])
        c.add_parameter("EVENT", "LABELS", [e[2] for e in evs])
        c.add_parameter("EVENT", "DESCRIPTIONS", [e[3] for e in evs])
        c.add_parameter("EVENT", "SUBJECTS", [subject] * len(evs))
        _c3d_param_int(c, "EVENT", "ICON_IDS", [e[4] for e in evs])
        _c3d_param_int(c, "EVENT", "GENERIC_FLAGS", [0] * len(evs))
    c.add_parameter("EVENT_CONTEXT", "LABELS", ["Left", "Right", "General"])
    c.add_parameter("EVENT_CONTEXT", "DESCRIPTIONS", ["Left side", "Right side", "For all"])
    _c3d_param_int(c, "EVENT_CONTEXT", "USED", [3])
    _c3d_param_int(c, "EVENT_CONTEXT", "ICON_IDS", [0, 1, 2])

    _c3d_param_int(c, "SUBJECTS", "USED", [1])
    c.add_parameter("SUBJECTS", "NAMES", [subject])
    c.add_parameter("MANUFACTURER", "COMPANY", "gaitmon")
    c.add_parameter("MANUFACTURER", "SOFTWARE", "gaitmon export")
    c.add_parameter("MANUFACTURER", "VERSION_LABEL", str(__version__))

    session = scrub.session({**{k: "" for k in _Scrubber.FIELDS},
                             **src.group_attrs("session")})
    device = scrub.value(src.group_attrs("device")) if deidentify else src.group_attrs("device")
    _c3d_text(c, "GAITMON", "MODE", src.mode or "unknown")
    _c3d_text(c, "GAITMON", "SIDE", side or "unknown")
    _c3d_text(c, "GAITMON", "CREATED_UTC", _text(src.attrs.get("created_utc", "")))
    _c3d_text(c, "GAITMON", "DEVICE", " ".join(
        f"{k}={_text(device.get(k, ''))}" for k in ("name", "serial", "firmware")))
    c.add_parameter("GAITMON", "PART", float(part_no + 1), "1-based part of the session")
    c.add_parameter("GAITMON", "N_PARTS", float(len(plan.parts)))
    c.add_parameter("GAITMON", "PART_START_S", float(t_part0),
                    "session time of this part's frame 1")
    c.add_parameter("GAITMON", "DEIDENTIFIED", float(bool(deidentify)))
    _c3d_text(c, "GAITMON", "ANGLE_CONVENTION", _text(src.attrs.get("angle_convention", "")))
    if not deidentify:
        for k in _Scrubber.FIELDS:
            _c3d_text(c, "GAITMON", k.upper(), _text(session.get(k, "")))
    return c


def _write_c3d_parts(specs: Iterator[_C3dSpec], paths: list[Path],
                     progress: PROGRESS | None) -> None:
    """Write the parts; beyond a few, in a child process replaced every few files, because
    ezc3d 1.7 keeps about the data size of every file it writes until the process exits."""
    worker = _C3dWorker() if len(paths) > C3D_INPROCESS_PARTS else None
    try:
        for k, (spec, path) in enumerate(zip(specs, paths, strict=True)):
            if worker is None:
                _c3d_write_spec(spec, str(path))
            else:
                worker.write(spec, path)
            if progress is not None:
                progress((k + 1) / len(paths))
    finally:
        if worker is not None:
            worker.close()


class _C3dWorker:
    """`python -m gaitmon.io.export --c3d-worker`: pickled (spec, path) in, error text out.

    A plain child process (not multiprocessing): nothing of the caller (its __main__, its
    threads, an open HDF5 file) is re-run or inherited beyond the pipes."""

    def __init__(self) -> None:
        self.proc: Any = None
        self.done = 0

    def _start(self) -> None:
        import subprocess

        env = dict(os.environ)
        root = str(Path(__file__).resolve().parents[2])  # so the child imports this gaitmon
        env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH")) if p)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "gaitmon.io.export", "--c3d-worker"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env,
        )
        self.done = 0

    def write(self, spec: _C3dSpec, path: Path) -> None:
        import pickle

        if self.proc is None or self.done >= C3D_INPROCESS_PARTS:
            self.close()
            self._start()
        _send(self.proc.stdin, pickle.dumps((spec, str(path)), protocol=5))
        reply = _recv(self.proc.stdout)
        if reply is None:
            raise ExportError(f"the C3D writer process stopped while writing {path.name}")
        error = pickle.loads(reply)
        if error:
            raise ExportError(f"cannot write {path.name}: {error}")
        self.done += 1

    def close(self) -> None:
        if self.proc is None:
            return
        with contextlib.suppress(OSError):
            self.proc.stdin.close()  # EOF: the worker's loop ends
        try:
            self.proc.wait(timeout=30)
        except Exception:
            self.proc.kill()
            self.proc.wait()
        finally:
            self.proc.stdout.close()
            self.proc = None


def _send(f: Any, payload: bytes) -> None:
    f.write(len(payload).to_bytes(8, "little"))
    f.write(payload)
    f.flush()


def _recv(f: Any) -> bytes | None:
    head = f.read(8)
    if len(head) < 8:
        return None
    n = int.from_bytes(head, "little")
    data = f.read(n)
    return data if len(data) == n else None


def _c3d_worker_main() -> None:
    import pickle

    inp, out = sys.stdin.buffer, sys.stdout.buffer
    while (msg := _recv(inp)) is not None:
        spec, path = pickle.loads(msg)
        try:
            _c3d_write_spec(spec, path)
            error = ""
        except Exception as exc:  # reported to the parent as one line
            error = f"{type(exc).__name__}: {exc}".splitlines()[0]
        _send(out, pickle.dumps(error))


def _c3d_text(c: _C3dSpec, group: str, name: str, text: str, width: int = 80) -> None:
    """A string parameter; C3D dimensions are single bytes, so long text becomes lines."""
    text = text.replace("\r", " ").replace("\n", " ").strip() or "-"
    lines = [text[i : i + width] for i in range(0, len(text), width)][:255]
    c.add_parameter(group, name, lines if len(lines) > 1 else lines[0])


def _c3d_time(t_s: float) -> list[float]:
    minutes = math.floor(t_s / 60.0)
    return [float(minutes), t_s - 60.0 * minutes]


def _channel_table(src: _Source) -> ChannelTable:
    """The file's own counts -> physical conversion (/device/channels), else the default."""
    rows = src.channel_table()
    if len(rows) != len(src.channel_names):
        return DEFAULT_TABLE
    fields = ChannelSpec.__dataclass_fields__
    return ChannelTable(tuple(ChannelSpec(**{k: r[k] for k in fields}) for r in rows))


# ------------------------------------------------------------------------------------------
# Entry point
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ExportResult:
    paths: tuple[Path, ...]
    n_samples: int
    mode: str
    problems: tuple[str, ...] = ()  # what the session reader noticed (e.g. not stopped cleanly)


def session_length(src_path: str | os.PathLike[str]) -> int:
    """Rows in a session file (raises ExportError for a bad file)."""
    with _open_source(Path(src_path)) as src:
        return src.n


def _planned(out: Path, fmt: str, plan: C3dPlan | None) -> list[Path]:
    if fmt == "csv":
        return [out, csv_meta_path(out)]
    if plan is not None and len(plan.parts) > 1:
        return [c3d_part_path(out, k + 1) for k in range(len(plan.parts))]
    return [out]


def export_session(
    src_path: str | os.PathLike[str],
    fmt: str,
    out: str | os.PathLike[str] | None = None,
    *,
    deidentify: bool = False,
    force: bool = False,
    progress: PROGRESS | None = None,
    chunk_rows: int = CSV_CHUNK_ROWS,
) -> ExportResult:
    """Export one session file; returns the files written. Raises ExportError (one line)."""
    if fmt not in FORMATS:
        raise ExportError(f"unknown format {fmt!r} (choose from {', '.join(FORMATS)})")
    src_path = Path(src_path)
    out_path = Path(out) if out is not None else default_output(src_path, fmt)
    if fmt == "c3d":
        try:
            import ezc3d  # noqa: F401
        except ImportError:
            raise ExportError(
                "C3D export needs the ezc3d package (pip install ezc3d)"
            ) from None
    with _open_source(src_path) as src:
        scrub = _Scrubber(src.group_attrs("session"), deidentify)
        events: list[tuple[int, str, str, str, int]] = []
        plan = None
        if fmt == "c3d":  # the parts (so the output names) depend on the events
            events = _c3d_events(src, scrub, _side(src))
            plan = _c3d_plan(src, np.array([e[0] for e in events], np.int64))
        outputs = _planned(out_path, fmt, plan)
        _check_outputs(outputs, src_path, force)
        atomic = _AtomicOutputs()
        try:
            if fmt == "csv":
                tmp_csv = atomic.tmp(out_path)
                tmp_meta = atomic.tmp(csv_meta_path(out_path))
                _write_csv(src, tmp_csv, scrub, progress, chunk_rows)
                meta = _json_safe(_csv_meta(src, scrub, deidentify))
                with open(tmp_meta, "w", encoding="utf-8") as f:
                    json.dump(meta, f, indent=1, ensure_ascii=False, default=_json_default)
                    f.write("\n")
            elif fmt == "mat":
                _write_mat(src, atomic.tmp(out_path), scrub, deidentify, progress)
            else:
                assert plan is not None
                tmps = []
                for final in outputs:
                    # ezc3d appends ".c3d" to names not ending in it; temp names must end in it
                    tmp = atomic.tmp(final)
                    tmps.append(tmp.with_name(tmp.name + ".c3d"))
                    atomic.pairs[-1] = (tmps[-1], final)
                specs = (_c3d_part_spec(src, plan, k, scrub, deidentify, events)
                         for k in range(len(outputs)))
                _write_c3d_parts(specs, tmps, progress)
            written = atomic.commit()
        except OSError as exc:
            atomic.discard()
            where = exc.filename or out_path
            raise ExportError(f"cannot write {where}: {exc.strerror or exc}") from None
        except BaseException:
            atomic.discard()
            raise
        return ExportResult(tuple(written), src.n, src.mode, src.problems)


if __name__ == "__main__" and sys.argv[1:] == ["--c3d-worker"]:
    _c3d_worker_main()
