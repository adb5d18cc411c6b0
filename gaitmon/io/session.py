"""Session files: crash-safe recording to HDF5, reading back, and recovery from the journal.

This module owns the session file format of ``docs/file-format.md``: :class:`SessionWriter`
(the recorder thread's only tool), :func:`open_session` / :class:`Session` (reading, with
automatic recovery of interrupted recordings) and :func:`recover_session`.

How a recording survives a crash. Every :meth:`SessionWriter.append` first writes the block to
the journal (``FILE.journal``, see :mod:`gaitmon.io.journal`) with one ``write()``, so a killed
process loses nothing it had handed over; the rows are staged in memory and written to the
HDF5 file, which is flushed and the journal synced, every ``flush_interval_s`` (100 ms). A clean
:meth:`SessionWriter.close` marks the file complete and deletes the journal. A journal found
beside a file means the recording was interrupted: :func:`recover_session` rebuilds the whole
file from the journal (the raw counts are the truth; processed series are recomputed from row 0
with the logged settings, as ``gaitmon process`` would) and replaces the file atomically.

Why writes are batched per flush rather than per block: an h5py resize + write costs tens of
microseconds per dataset, and a block touches ~17 datasets, so per-block HDF5 writes at
100 blocks/s would cost a noticeable fraction of a core; journal + staging cost a few
microseconds, and the HDF5 work is done 10 times a second in one go.

Chunking. Per-sample datasets use chunks of :data:`CHUNK_ROWS` = 4096 rows (41 s at 100 Hz):
the widest row (``/raw/adc``, 28 bytes) gives 112 KB chunks, inside HDF5's 1 MB default chunk
cache, an 8-hour session (2.88 M rows) is ~700 chunks per dataset (a small chunk index, fast to
open), and a typical review window of 10-60 s touches one or two chunks per dataset. The
writer opens the file without a chunk cache, so each flush writes only the new rows (an
uncompressed chunk is written in place) instead of every partly filled chunk in full. Data are
not compressed: noisy float32 signals compress poorly, a compressed chunk must be rewritten
and re-allocated on every flush, and uncompressed files open in any HDF5 tool with no filter
plugins. The file uses the default (earliest) HDF5 format version, for the oldest readers.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import math
import os
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, NamedTuple

import h5py
import numpy as np

from gaitmon import __version__
from gaitmon.dsp.angles import joint_angles, wrap_angle
from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import CHANNELS, DEFAULT_TABLE, ChannelSpec, ChannelTable
from gaitmon.dsp.gait import ContactEdges
from gaitmon.dsp.pipeline import Pipeline, PipelineBlock, PipelineConfig
from gaitmon.io.device import LinkStats, SampleBlock
from gaitmon.io.journal import (
    BLOCK_TYPES,
    N_COMMON_FIELDS,
    ROW_DTYPES,
    JournalContents,
    JournalWriter,
    RecordType,
    encode_block,
    encode_json,
    journal_lock,
    journal_path,
    read_journal,
)
from gaitmon.io.protocol import FrameKind, Identity

__all__ = [
    "ANGLE_CONVENTION",
    "CHUNK_ROWS",
    "FORMAT",
    "FORMAT_VERSION",
    "MODES",
    "Gap",
    "Marker",
    "Session",
    "SessionError",
    "SessionHeader",
    "SessionMeta",
    "SessionWriter",
    "device_info",
    "journal_path",
    "open_session",
    "recover_session",
    "replay_pipeline",
    "rows_from_pipeline",
]

FORMAT = "gaitmon-session"
FORMAT_VERSION = 1
MODES = ("raw", "tilt", "joint")
CHUNK_ROWS = 4096
_TABLE_CHUNK_ROWS = 256
_EVENT_CHUNK_ROWS = 1024
_RECOVERY_CHUNK_ROWS = 1 << 16
# HDF5 chunk cache of the writing side; 0 = none (the benchmark compares it with HDF5's 1 MB)
WRITER_CHUNK_CACHE_BYTES = 0

ANGLE_CONVENTION = (
    "Segment tilts are sagittal, positive counter-clockwise seen from the subject's right side, "
    "zero in the upright standing calibration pose. Hip flexion + = thigh - body; knee flexion "
    "+ = thigh - shank; ankle dorsiflexion + = foot - shank; every difference wrapped to "
    "(-180, 180] degrees."
)

_F4 = np.dtype("<f4")
_STR = h5py.string_dtype("utf-8")

# path -> (row shape, dtype, modes it is present in); per the table in docs/file-format.md
_PER_SAMPLE: dict[str, tuple[tuple[int, ...], np.dtype, frozenset[str]]] = {
    "timeline/seq": ((), np.dtype("<i8"), frozenset(MODES)),
    "timeline/host_time_s": ((), np.dtype("<f8"), frozenset(MODES)),
    "timeline/t_s": ((), np.dtype("<f8"), frozenset(MODES)),
    "raw/adc": ((14,), np.dtype("<u2"), frozenset({"raw"})),
    "processed/tilt_deg": ((4,), _F4, frozenset({"raw", "tilt"})),
    "processed/tilt_acc_deg": ((4,), _F4, frozenset({"raw", "tilt"})),
    "processed/tilt_gyro_deg": ((4,), _F4, frozenset({"raw"})),
    "processed/joint_deg": ((3,), _F4, frozenset(MODES)),
    "processed/joint_acc_deg": ((3,), _F4, frozenset(MODES)),
    "processed/joint_gyro_deg": ((3,), _F4, frozenset({"raw"})),
    "processed/acc_ms2": ((4, 2), _F4, frozenset({"raw"})),
    "processed/gyro_rad_s": ((4,), _F4, frozenset({"raw"})),
    "processed/fsr_counts": ((2,), _F4, frozenset({"raw"})),
    "processed/heel_loaded": ((), np.dtype("u1"), frozenset({"raw", "joint"})),
    "processed/toe_loaded": ((), np.dtype("u1"), frozenset({"raw", "joint"})),
    "processed/phase": ((), np.dtype("i1"), frozenset({"raw", "joint"})),
}

_TABLES: dict[str, np.dtype] = {
    "markers": np.dtype([("sample_idx", "<i8"), ("t_s", "<f8"), ("label", _STR)]),
    "gaps": np.dtype(
        [("sample_idx", "<i8"), ("n_lost", "<i8"), ("duration_s", "<f8"), ("reason", _STR)]
    ),
    "link/crc_failures": np.dtype([("sample_idx", "<i8"), ("count", "<i8")]),
    "config/changes": np.dtype([("sample_idx", "<i8"), ("json", _STR)]),
    "calibration/changes": np.dtype([("sample_idx", "<i8"), ("json", _STR)]),
}

LINK_TOTALS = (
    "frames_ok",
    "frames_lost",
    "crc_failures",
    "bytes_received",
    "bytes_skipped",
    "invalid_values",
    "reconnects",
    "queue_overflow_frames",
)

_DEVICE_KEYS = (
    "name",
    "firmware",
    "serial",
    "side",
    "transport",
    "channel_table_id",
    "channel_table_crc",
)


def per_sample_datasets(mode: str) -> tuple[str, ...]:
    """The per-sample dataset paths a session of this mode holds, in a fixed order."""
    return tuple(p for p, (_, _, modes) in _PER_SAMPLE.items() if mode in modes)


class SessionError(Exception):
    """A session file could not be written, read or recovered; one-line, actionable message."""


# --------------------------------------------------------------------------------------------
# Header
# --------------------------------------------------------------------------------------------


def _field_names(dtype: np.dtype) -> tuple[str, ...]:
    """The field names of a structured dtype (numpy's ``.names`` is None for plain ones)."""
    names = dtype.names
    assert names is not None, f"{dtype} is not a structured dtype"
    return names


def _utc_now() -> str:
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


@dataclass(frozen=True)
class SessionMeta:
    """Patient and session metadata (``/session``). ``patient_id`` is an identifier, no name."""

    patient_id: str = ""
    side: str = ""  # "L", "R" or ""
    operator: str = ""
    notes: str = ""

    def __post_init__(self) -> None:
        if self.side not in ("L", "R", ""):
            raise ValueError(f"side must be 'L', 'R' or '', got {self.side!r}")


def device_info(identity: Identity | None, transport: str) -> dict[str, Any]:
    """The ``/device`` attributes from the unit's IDENTITY answer and the transport's name."""
    if identity is None:
        return dict.fromkeys(_DEVICE_KEYS, "") | {"transport": transport}
    return {
        "name": identity.name,
        "firmware": identity.firmware,
        "serial": int(identity.serial),
        "side": identity.side,
        "transport": transport,
        "channel_table_id": int(identity.table_id),
        "channel_table_crc": int(identity.table_crc),
    }


@dataclass(frozen=True)
class SessionHeader:
    """Everything known when a recording starts."""

    mode: str  # "raw" | "tilt" | "joint"
    sample_rate_hz: float = 100.0
    meta: SessionMeta = field(default_factory=SessionMeta)
    device: Mapping[str, Any] = field(default_factory=dict)
    config: PipelineConfig = field(default_factory=PipelineConfig)
    calibration: Calibration = field(default_factory=Calibration.identity)
    created_utc: str = field(default_factory=_utc_now)
    channels: tuple[ChannelSpec, ...] = CHANNELS

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")
        if not (math.isfinite(self.sample_rate_hz) and self.sample_rate_hz > 0):
            raise ValueError(f"sample_rate_hz must be > 0, got {self.sample_rate_hz}")
        device = {str(k): ("" if v is None else v) for k, v in dict(self.device).items()}
        for k, v in device.items():
            if not isinstance(v, str | int | float | bool):
                raise ValueError(f"device[{k!r}] must be a str or a number, got {type(v)}")
        object.__setattr__(self, "device", device)

    def as_dict(self) -> dict[str, Any]:
        """JSON-able form: the journal's header record, and what every file attribute is."""
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "software_version": __version__,
            "mode": self.mode,
            "sample_rate_hz": float(self.sample_rate_hz),
            "created_utc": self.created_utc,
            "session": asdict(self.meta),
            "device": dict(self.device),
            "channels": [c.as_dict() for c in self.channels],
            "config": self.config.as_dict(),
            "event_delay_samples": self.config.event_delay_samples,
            "calibration": self.calibration.as_dict(),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> SessionHeader:
        return cls(
            mode=d["mode"],
            sample_rate_hz=float(d["sample_rate_hz"]),
            meta=SessionMeta(**d.get("session", {})),
            device=d.get("device", {}),
            config=PipelineConfig(**d["config"]),
            calibration=Calibration.from_dict(d["calibration"]),
            created_utc=d.get("created_utc", ""),
            channels=tuple(ChannelSpec(**c) for c in d.get("channels", [])) or CHANNELS,
        )

    @property
    def table(self) -> ChannelTable:
        return DEFAULT_TABLE if self.channels == CHANNELS else ChannelTable(self.channels)


# --------------------------------------------------------------------------------------------
# Blocks -> rows
# --------------------------------------------------------------------------------------------


def _deg32(x_rad: np.ndarray) -> np.ndarray:
    return np.degrees(x_rad).astype(_F4)


def rows_from_pipeline(block: PipelineBlock) -> dict[str, np.ndarray]:
    """The ``/processed`` rows of a raw-mode block (angles in degrees, float32)."""
    return {
        "processed/tilt_deg": _deg32(block.tilt_kalman_rad),
        "processed/tilt_acc_deg": _deg32(block.tilt_acc_rad),
        "processed/tilt_gyro_deg": _deg32(block.tilt_gyro_rad),
        "processed/joint_deg": _deg32(block.joint_kalman_rad),
        "processed/joint_acc_deg": _deg32(block.joint_acc_rad),
        "processed/joint_gyro_deg": _deg32(block.joint_gyro_rad),
        "processed/acc_ms2": block.acc_ms2.astype(_F4),
        "processed/gyro_rad_s": block.gyro_rad_s.astype(_F4),
        "processed/fsr_counts": block.fsr_counts.astype(_F4),
        "processed/heel_loaded": block.heel_loaded.astype(np.uint8),
        "processed/toe_loaded": block.toe_loaded.astype(np.uint8),
        "processed/phase": block.phase.astype(np.int8),
    }


def _joints_deg_from_tilts_deg(tilt_deg: np.ndarray) -> np.ndarray:
    return _deg32(joint_angles(wrap_angle(np.radians(tilt_deg))))


def _device_rows(kind: FrameKind, cols: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    if kind == FrameKind.TILT:
        kal = np.asarray(cols["kalman_tilt_deg"], dtype=np.float64)
        acc = np.asarray(cols["acc_tilt_deg"], dtype=np.float64)
        return {
            "processed/tilt_deg": kal.astype(_F4),
            "processed/tilt_acc_deg": acc.astype(_F4),
            "processed/joint_deg": _joints_deg_from_tilts_deg(kal),
            "processed/joint_acc_deg": _joints_deg_from_tilts_deg(acc),
        }
    if kind == FrameKind.JOINT:
        return {
            "processed/joint_deg": np.asarray(cols["kalman_joint_deg"]).astype(_F4),
            "processed/joint_acc_deg": np.asarray(cols["acc_joint_deg"]).astype(_F4),
            "processed/heel_loaded": np.asarray(cols["heel_loaded"]).astype(np.uint8),
            "processed/toe_loaded": np.asarray(cols["toe_loaded"]).astype(np.uint8),
            "processed/phase": np.asarray(cols["phase"]).astype(np.int8),
        }
    raise ValueError(f"device rows need a TILT or JOINT block, got {kind!r}")


class _Timeline:
    """``/timeline/t_s`` = k / fs + extra. ``k`` counts the unit's samples from row 0: each row
    advances it by 1 + the frames lost just before it (sequence numbers cannot be used
    directly: the unit's control frames share the counter). ``extra`` grows only at a gap row
    whose recorded duration is longer than that step (the unit restarted or stopped counting
    during an outage). Integer ``k`` and one formula make the live writer and the recovery,
    which sees all rows at once, give bit-identical times, with no drift over hours."""

    def __init__(self, fs_hz: float) -> None:
        self.fs_hz = fs_hz
        self.k_last: int | None = None
        self.extra_s = 0.0

    def times(self, lost_before: np.ndarray, gap_duration_s: float | None) -> np.ndarray:
        steps = np.asarray(lost_before, dtype=np.int64) + 1
        k = np.cumsum(steps)
        if self.k_last is None:
            k -= k[0]  # row 0 is time 0, whatever was lost before the recording
        else:
            if gap_duration_s is not None:
                step_s = int(steps[0]) / self.fs_hz
                self.extra_s += max(0.0, gap_duration_s + 1.0 / self.fs_hz - step_s)
            k += self.k_last
        self.k_last = int(k[-1])
        return k / self.fs_hz + self.extra_s


# --------------------------------------------------------------------------------------------
# HDF5 layout (shared by the live writer and the recovery)
# --------------------------------------------------------------------------------------------


class _H5File:
    """Creates the session layout and appends to it; knows nothing about journals."""

    def __init__(
        self, path: Path, header: Mapping[str, Any], *, mode: str, reprocessed: bool
    ) -> None:
        # no chunk cache: writes go straight to the file (see the module doc, "Chunking")
        self.f = h5py.File(path, mode, rdcc_nbytes=WRITER_CHUNK_CACHE_BYTES)
        try:
            self._create(header, reprocessed)
        except BaseException:
            with contextlib.suppress(Exception):
                self.f.close()
            raise
        self._ids: dict[str, h5py.h5d.DatasetID] = {}
        self.rows = 0
        self.n_events = {"heel_strike": 0, "toe_off": 0}
        self.events_sorted = True
        self._last_event = {"heel_strike": -1, "toe_off": -1}

    def _create(self, h: Mapping[str, Any], reprocessed: bool) -> None:
        f = self.f
        mode = h["mode"]
        a = f.attrs
        a["format"] = FORMAT
        a["format_version"] = np.int64(FORMAT_VERSION)
        a["created_utc"] = h["created_utc"]
        a["sample_rate_hz"] = float(h["sample_rate_hz"])
        a["software_version"] = h["software_version"]
        a["mode"] = mode
        a["complete"] = False
        a["recovered"] = False
        a["n_samples"] = np.int64(0)
        a["duration_s"] = 0.0
        a["stop_reason"] = ""
        a["angle_convention"] = ANGLE_CONVENTION

        g = f.create_group("session")
        for k, v in h["session"].items():
            g.attrs[k] = str(v)

        g = f.create_group("device")
        for k in _DEVICE_KEYS:
            g.attrs[k] = h["device"].get(k, "")
        for k, v in h["device"].items():
            if k not in _DEVICE_KEYS:
                g.attrs[k] = v
        ch_dtype = np.dtype(
            [
                ("index", "<i8"),
                ("name", _STR),
                ("segment", _STR),
                ("kind", _STR),
                ("unit", _STR),
                ("adc_bits", "<i8"),
                ("vref_v", "<f8"),
                ("zero_v", "<f8"),
                ("sensitivity_v_per_unit", "<f8"),
            ]
        )
        ch_names = _field_names(ch_dtype)
        channels = np.array(
            [tuple(c[name] for name in ch_names) for c in h["channels"]], dtype=ch_dtype
        )
        g.create_dataset("channels", data=channels)

        for path in per_sample_datasets(mode):
            shape, dtype, _ = _PER_SAMPLE[path]
            f.create_dataset(
                path,
                shape=(0, *shape),
                maxshape=(None, *shape),
                dtype=dtype,
                chunks=(CHUNK_ROWS, *shape),
                fill_time="never",
            )
        f["timeline/host_time_s"].attrs["wall_offset_s"] = 0.0
        p = f["processed"]
        p.attrs["source"] = "pc" if mode == "raw" else "device"
        p.attrs["reprocessed"] = bool(reprocessed)

        ev = f.create_group("events")
        for name in ("heel_strike", "toe_off"):
            ev.create_dataset(
                name, shape=(0,), maxshape=(None,), dtype="<i8", chunks=(_EVENT_CHUNK_ROWS,)
            )
        for name, dtype in _TABLES.items():
            f.create_dataset(
                name, shape=(0,), maxshape=(None,), dtype=dtype, chunks=(_TABLE_CHUNK_ROWS,)
            )
        link = f["link"]
        for k in LINK_TOTALS:
            link.attrs[k] = np.int64(0)

        cfg = f["config"]
        for k, v in h["config"].items():
            cfg.attrs[k] = v
        cfg.attrs["event_delay_samples"] = np.int64(h["event_delay_samples"])
        cal = f["calibration"]
        cal.attrs["tilt_offset_rad"] = np.asarray(h["calibration"]["tilt_offset_rad"], "<f8")
        cal.attrs["gyro_bias_rad_s"] = np.asarray(h["calibration"]["gyro_bias_rad_s"], "<f8")

    def set_wall_offset(self, wall_offset_s: float) -> None:
        self.f["timeline/host_time_s"].attrs["wall_offset_s"] = float(wall_offset_s)

    def append_rows(self, cols: Mapping[str, np.ndarray], n: int) -> None:
        if n == 0:
            return
        a, b = self.rows, self.rows + n
        for path, data in cols.items():
            _append_low_level(self._dsid(path), a, data)
        self.rows = b

    def _dsid(self, path: str) -> h5py.h5d.DatasetID:
        dsid = self._ids.get(path)
        if dsid is None:
            dsid = self._ids[path] = self.f[path].id
        return dsid

    def append_events(self, name: str, rows: np.ndarray) -> None:
        if len(rows) == 0:
            return
        if rows[0] < self._last_event[name] or np.any(np.diff(rows) < 0):
            self.events_sorted = False
        self._last_event[name] = max(self._last_event[name], int(rows.max()))
        ds = self.f["events/" + name]
        a = self.n_events[name]
        ds.resize(a + len(rows), axis=0)
        ds[a:] = rows
        self.n_events[name] = a + len(rows)

    def append_table(self, name: str, records: Sequence[tuple[Any, ...]]) -> None:
        if not records:
            return
        ds = self.f[name]
        a = ds.shape[0]
        ds.resize(a + len(records), axis=0)
        ds[a:] = np.array(list(records), dtype=_TABLES[name])

    def set_link_totals(self, totals: Mapping[str, int]) -> None:
        link = self.f["link"]
        for k in LINK_TOTALS:
            link.attrs[k] = np.int64(totals.get(k, 0))

    def t_s_at(self, idx: int) -> float:
        return float(self.f["timeline/t_s"][idx])

    def finish(self, *, complete: bool, recovered: bool, stop_reason: str, fs_hz: float) -> None:
        if not self.events_sorted:  # several pipelines (settings changes) can interleave events
            for name in ("heel_strike", "toe_off"):
                ds = self.f["events/" + name]
                ds[:] = np.sort(ds[()])
        a = self.f.attrs
        a["n_samples"] = np.int64(self.rows)
        a["duration_s"] = self.t_s_at(self.rows - 1) + 1.0 / fs_hz if self.rows else 0.0
        a["stop_reason"] = stop_reason
        a["recovered"] = bool(recovered)
        a["complete"] = bool(complete)

    def size_bytes(self) -> int:
        return int(self.f.id.get_filesize())

    def close(self) -> None:
        self.f.close()


def _append_low_level(dsid: h5py.h5d.DatasetID, start: int, data: np.ndarray) -> None:
    """Grow a dataset along axis 0 and write ``data`` at ``start``: the same as h5py's
    ``resize`` + slice assignment, at a fraction of its per-call cost (it runs ~17 times per
    flush, 10 flushes a second)."""
    data = np.ascontiguousarray(data, dtype=dsid.dtype)
    count = data.shape
    dsid.set_extent((start + count[0], *count[1:]))
    fspace = dsid.get_space()
    fspace.select_hyperslab((start, *(0,) * (len(count) - 1)), count)
    dsid.write(h5py.h5s.create_simple(count), fspace, data)


def _fsync_path(path: Path, directory: bool = False) -> None:
    flags = os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0)
    try:
        fd = os.open(path, flags)
    except OSError:
        if directory:  # not every platform can open a directory; the data itself is synced
            return
        raise
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _being_recorded(jpath: Path) -> bool:
    """Whether a live writer (another window or process) holds this journal's lock."""
    try:
        with journal_lock(jpath) as free:
            return not free
    except OSError:
        return False  # gone meanwhile, or unreadable: the caller's next step reports it


def _short_error(e: BaseException) -> str:
    """A one-line reason from an OSError or an h5py error (whose text can be very long)."""
    if isinstance(e, OSError) and e.errno:
        return f"{os.strerror(e.errno)} (errno {e.errno})"
    text = " ".join(str(e).split()) or type(e).__name__
    # h5py: "Can't write data (file write failed: time = ..., errno = 27, error message = ...)"
    for marker in ("error message = '", 'error message = "'):
        if marker in text:
            return text.split(marker, 1)[1].split("'", 1)[0].split('"', 1)[0]
    return text[:200]


# --------------------------------------------------------------------------------------------
# Writer
# --------------------------------------------------------------------------------------------


class SessionWriter:
    """Records one session: HDF5 file + journal. Used by one thread (the recorder); not
    thread-safe.

    Call :meth:`append` for every block and :meth:`maybe_flush` also while no data arrive
    (e.g. on a queue timeout), so the 100 ms guarantee holds through link outages.

    Any failure to write (disk full, file size limit, I/O error, a removed drive) raises
    :class:`SessionError` once with the whole story; the writer is then dead (every later call
    raises the same error, :meth:`close` just releases the files), the journal is left in
    place and the next :func:`open_session` recovers every row that was written before.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        header: SessionHeader,
        *,
        flush_interval_s: float = 0.1,
        overwrite: bool = False,
    ) -> None:
        self._path = Path(path)
        self.header = header
        self.flush_interval_s = float(flush_interval_s)
        self._fs = float(header.sample_rate_hz)
        self._kind = {"raw": FrameKind.RAW, "tilt": FrameKind.TILT, "joint": FrameKind.JOINT}[
            header.mode
        ]
        self._rtype = BLOCK_TYPES[header.mode]
        self._row_dtype = ROW_DTYPES[self._rtype]
        self._datasets = per_sample_datasets(header.mode)
        jpath = journal_path(self._path)
        name = self._path.name
        if not overwrite:
            if self._path.exists():
                raise SessionError(f"{name} already exists; choose another file name")
            if jpath.exists():
                raise SessionError(
                    f"{jpath.name} exists: an interrupted recording named {name} waits to be "
                    "recovered; open it first, or choose another file name"
                )
        elif jpath.exists() and _being_recorded(jpath):
            # never overwrite a recording in progress (another window or process): deleting
            # its journal and file would lose the whole session
            raise SessionError(
                f"{name} is being recorded right now; stop that recording first, or "
                "choose another file name"
            )
        self._journal: JournalWriter | None = None
        self._h5: _H5File | None = None
        hdr = header.as_dict()
        try:
            if overwrite:
                with contextlib.suppress(FileNotFoundError):
                    jpath.unlink()
            self._journal = JournalWriter(jpath)
            self._journal.write_raw(encode_json(RecordType.HEADER, hdr))
            self._journal.sync()
            self._h5 = _H5File(self._path, hdr, mode="w" if overwrite else "x", reprocessed=False)
            self._h5.f.flush()
        except (OSError, RuntimeError) as e:
            self._release()
            for p in (jpath, self._path):
                with contextlib.suppress(OSError):
                    p.unlink()
            raise SessionError(f"cannot create {name}: {_short_error(e)}") from e

        self._rows = 0  # rows handed to the journal (the truth)
        self._timeline = _Timeline(self._fs)
        self._pending_gap_s: float | None = None
        self._staged: dict[str, list[np.ndarray]] = {p: [] for p in self._datasets}
        self._staged_rows = 0
        self._staged_events: dict[str, list[np.ndarray]] = {"heel_strike": [], "toe_off": []}
        self._staged_tables: dict[str, list[tuple[Any, ...]]] = {k: [] for k in _TABLES}
        self._pending_markers: list[tuple[int, str]] = []
        self._edges = ContactEdges() if header.mode == "joint" else None
        self._wall_offset_s: float | None = None
        self._link_totals: dict[str, int] = dict.fromkeys(LINK_TOTALS, 0)
        self._link_dirty = False
        self._last_seq: int | None = None
        self._dirty = False
        self._last_flush = time.monotonic()
        self._bytes = self._h5.size_bytes()
        self._error: SessionError | None = None
        self._closed = False

    # -- properties ---------------------------------------------------------------------------

    @property
    def path(self) -> Path:
        return self._path

    @property
    def rows(self) -> int:
        """Rows recorded so far (all of them in the journal, at most 100 ms not yet in HDF5)."""
        return self._rows

    @property
    def bytes_written(self) -> int:
        """Size of the HDF5 file at the last flush (what the UI shows as the file size)."""
        return self._bytes

    @property
    def journal_bytes(self) -> int:
        return 0 if self._journal is None else self._journal.bytes_written

    @property
    def error(self) -> SessionError | None:
        """The write error that stopped this recording, if any."""
        return self._error

    @property
    def closed(self) -> bool:
        return self._closed

    # -- recording ------------------------------------------------------------------------------

    def append(
        self,
        samples: SampleBlock,
        processed: PipelineBlock | None = None,
        *,
        event_offset: int = 0,
    ) -> None:
        """Record one block. Raw mode: ``samples.adc`` plus the pipeline's ``processed`` block
        for the same samples; event indices minus ``event_offset`` are row numbers (events
        before row 0 are dropped). Tilt/joint modes: ``processed`` is None."""
        self._check_usable()
        n = len(samples)
        if n == 0:
            self.maybe_flush()
            return
        if FrameKind(samples.kind) != self._kind:
            raise ValueError(
                f"this is a {self.header.mode} session; got a {FrameKind(samples.kind).name} block"
            )
        seq = np.asarray(samples.seq, dtype=np.int64)
        if (self._last_seq is not None and seq[0] <= self._last_seq) or np.any(np.diff(seq) <= 0):
            raise ValueError("sequence numbers must increase strictly across blocks")
        lost = getattr(samples, "lost_before", None)
        if lost is None:  # a block that does not say: take every sequence step as losses
            prev = seq[0] - 1 if self._last_seq is None else self._last_seq
            lost = np.diff(seq, prepend=prev) - 1
        lost = np.asarray(lost, dtype=np.int64)
        if lost.shape != (n,) or np.any(lost < 0):
            raise ValueError("lost_before must be (N,) counts >= 0")
        rec = np.empty(n, dtype=self._row_dtype)
        rec["seq"] = seq
        rec["host_time_s"] = samples.host_time_s
        rec["lost_before"] = lost
        if self._kind == FrameKind.RAW:
            if processed is None or processed.n != n:
                raise ValueError("raw mode needs the pipeline block of the same samples")
            rec["adc"] = samples.adc
            rows = rows_from_pipeline(processed)
        else:
            if processed is not None:
                raise ValueError(f"{self.header.mode} mode takes no pipeline block")
            kind_fields = _field_names(self._row_dtype)[N_COMMON_FIELDS:]
            for name in kind_fields:
                rec[name] = getattr(samples, name)
            rows = _device_rows(self._kind, {k: rec[k] for k in kind_fields})
        wall = float(samples.wall_offset_s)
        self._write_journal(encode_block(self._rtype, wall, rec))

        start = self._rows
        self._rows += n
        self._last_seq = int(seq[-1])
        if self._wall_offset_s is None:
            self._wall_offset_s = wall
        t_s = self._timeline.times(lost, self._pending_gap_s)
        self._pending_gap_s = None
        st = self._staged
        st["timeline/seq"].append(seq)
        st["timeline/host_time_s"].append(np.asarray(samples.host_time_s, dtype=np.float64))
        st["timeline/t_s"].append(t_s)
        if self._kind == FrameKind.RAW:
            st["raw/adc"].append(rec["adc"])
            ev = self._staged_events
            assert processed is not None
            for name, idx in (
                ("heel_strike", processed.heel_strike_idx),
                ("toe_off", processed.toe_off_idx),
            ):
                if len(idx):
                    r = np.asarray(idx, dtype=np.int64) - event_offset
                    ev[name].append(r[r >= 0])
        elif self._edges is not None:
            hs, to = self._edges.process(rec["heel_loaded"], rec["toe_loaded"], start)
            self._staged_events["heel_strike"].append(hs)
            self._staged_events["toe_off"].append(to)
        for path, data in rows.items():
            st[path].append(data)
        self._staged_rows += n
        self._dirty = True
        self.maybe_flush()

    def add_marker(self, label: str, sample_idx: int | None = None) -> None:
        """A clinician's marker at ``sample_idx`` (default: the next row)."""
        self._check_usable()
        idx = self._rows if sample_idx is None else int(sample_idx)
        if idx < 0:
            raise ValueError(f"marker sample_idx must be >= 0, got {idx}")
        self._write_journal(
            encode_json(RecordType.MARKER, {"sample_idx": idx, "label": str(label)})
        )
        self._pending_markers.append((idx, str(label)))
        self._dirty = True

    def add_gap(self, n_lost: int, duration_s: float, reason: str) -> None:
        """Frames missing before the next row (``reason``: 'frames lost', 'link lost: ...')."""
        self._check_usable()
        rec = {
            "sample_idx": self._rows,
            "n_lost": int(n_lost),
            "duration_s": float(duration_s),
            "reason": str(reason),
        }
        self._write_journal(encode_json(RecordType.GAP, rec))
        self._staged_tables["gaps"].append(
            (self._rows, int(n_lost), float(duration_s), str(reason))
        )
        self._pending_gap_s = (self._pending_gap_s or 0.0) + float(duration_s)
        self._dirty = True

    def log_config(self, config: PipelineConfig) -> None:
        """New pipeline settings, in force from the next row."""
        self._check_usable()
        d = config.as_dict()
        self._write_journal(encode_json(RecordType.CONFIG, {"sample_idx": self._rows, "config": d}))
        self._staged_tables["config/changes"].append((self._rows, json.dumps(d)))
        self._dirty = True

    def log_calibration(self, cal: Calibration) -> None:
        """A new standing calibration (zeroing), in force from the next row."""
        self._check_usable()
        d = cal.as_dict()
        self._write_journal(
            encode_json(RecordType.CALIBRATION, {"sample_idx": self._rows, "calibration": d})
        )
        self._staged_tables["calibration/changes"].append((self._rows, json.dumps(d)))
        self._dirty = True

    def update_link(self, stats: LinkStats) -> None:
        """Link totals; journalled only when they changed (cheap to call on every block)."""
        self._check_usable()
        d = stats.decoder
        totals = {
            "frames_ok": int(d.frames_ok),
            "frames_lost": int(d.frames_lost),
            "crc_failures": int(d.crc_failures),
            "bytes_received": int(d.bytes_received),
            "bytes_skipped": int(d.bytes_skipped),
            "invalid_values": int(d.invalid_values),
            "reconnects": int(stats.reconnects),
            "queue_overflow_frames": int(stats.queue_overflow_frames),
        }
        if totals == self._link_totals:
            return
        self._write_journal(
            encode_json(RecordType.LINK, {"sample_idx": self._rows, "totals": totals})
        )
        if totals["crc_failures"] > self._link_totals["crc_failures"]:
            self._staged_tables["link/crc_failures"].append((self._rows, totals["crc_failures"]))
        self._link_totals = totals
        self._link_dirty = True
        self._dirty = True

    def maybe_flush(self) -> None:
        """Flush HDF5 and sync the journal if ``flush_interval_s`` has passed since the last."""
        if self._error is not None or self._closed:
            return
        now = time.monotonic()
        if now - self._last_flush >= self.flush_interval_s:
            self._last_flush = now
            if self._dirty:
                self.flush()

    def flush(self) -> None:
        """Write everything staged to HDF5, flush it to the OS, sync the journal to disk."""
        self._check_usable()
        assert self._h5 is not None and self._journal is not None
        try:
            self._write_staged()
            self._h5.f.flush()
            self._journal.sync()
            self._bytes = self._h5.size_bytes()
        except (OSError, RuntimeError) as e:
            raise self._fail(e) from e
        self._dirty = False

    def close(self, *, stop_reason: str = "user") -> None:
        """Finish the file (complete, n_samples, duration_s, stop_reason) and delete the journal.

        After a write error this only releases the files (the journal stays for recovery).
        """
        if self._closed:
            return
        if self._error is not None:
            self._closed = True
            self._release()
            return
        assert self._h5 is not None and self._journal is not None
        try:
            self._write_staged()
            self._write_markers(final=True)
            self._h5.finish(complete=True, recovered=False, stop_reason=stop_reason, fs_hz=self._fs)
            self._bytes = self._h5.size_bytes()
            self._h5.close()
            self._h5 = None
            _fsync_path(self._path)  # the complete file is on disk before its journal goes
            self._journal.close()
            self._journal = None
            journal_path(self._path).unlink()
            _fsync_path(self._path.parent, directory=True)
        except (OSError, RuntimeError) as e:
            err = self._fail(e)
            self._closed = True
            raise err from e
        self._closed = True

    def abort(self, exc: BaseException) -> str:
        """Stop after an unexpected error (a bug, not a write failure): release the files
        without finishing the HDF5 file and keep the journal, so the next open recovers every
        row handed over. Returns the one-line message (also :attr:`error` from now on)."""
        if self._error is None:
            what = " ".join(str(exc).split())[:200] or type(exc).__name__
            self._error = SessionError(
                f"recording to {self._path.name} stopped by an internal error "
                f"({type(exc).__name__}: {what}); everything up to row {self._rows} "
                f"({self._rows / self._fs:.1f} s) is saved and is recovered when the file is "
                "next opened"
            )
        self._closed = True
        self._release()
        return str(self._error)

    def __enter__(self) -> SessionWriter:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc is None:
            self.close()
        else:
            with contextlib.suppress(SessionError):
                self.close(stop_reason=f"error: {' '.join(str(exc).split())[:200]}")

    # -- internals -------------------------------------------------------------------------------

    def _check_usable(self) -> None:
        if self._error is not None:
            raise self._error
        if self._closed:
            raise SessionError(f"the recording to {self._path.name} is already stopped")

    def _write_journal(self, record: bytes) -> None:
        assert self._journal is not None
        try:
            self._journal.write_raw(record)
        except OSError as e:
            raise self._fail(e) from e

    def _write_staged(self) -> None:
        h5 = self._h5
        assert h5 is not None
        if self._wall_offset_s is not None and h5.rows == 0 and self._staged_rows:
            h5.set_wall_offset(self._wall_offset_s)
        if self._staged_rows:
            cols = {p: _cat(parts) for p, parts in self._staged.items()}
            h5.append_rows(cols, self._staged_rows)
            for parts in self._staged.values():
                parts.clear()
            self._staged_rows = 0
        for name, parts in self._staged_events.items():
            if parts:
                h5.append_events(name, _cat(parts))
                parts.clear()
        for name, recs in self._staged_tables.items():
            if recs:
                h5.append_table(name, recs)
                recs.clear()
        if self._link_dirty:
            h5.set_link_totals(self._link_totals)
            self._link_dirty = False
        self._write_markers(final=False)

    def _write_markers(self, *, final: bool) -> None:
        """Markers wait until their row exists (their t_s is that row's time); at the end, a
        marker beyond the last row gets a time extrapolated at the nominal rate."""
        h5 = self._h5
        assert h5 is not None
        ready: list[tuple[Any, ...]] = []
        while self._pending_markers:
            idx, label = self._pending_markers[0]
            if idx < h5.rows:
                t = h5.t_s_at(idx)
            elif final:
                t = _extrapolated_t(
                    h5.t_s_at(h5.rows - 1) if h5.rows else None, idx, h5.rows, self._fs
                )
            else:
                break
            ready.append((idx, t, label))
            self._pending_markers.pop(0)
        h5.append_table("markers", ready)

    def _fail(self, e: BaseException) -> SessionError:
        fs = self._fs
        err = SessionError(
            f"disk full or write error while recording {self._path.name}: {_short_error(e)}; "
            f"recording stopped, everything up to row {self._rows} "
            f"({self._rows / fs:.1f} s) is saved and is recovered when the file is next opened"
        )
        self._error = err
        self._release()
        return err

    def _release(self) -> None:
        if self._h5 is not None:
            with contextlib.suppress(Exception):
                self._h5.close()
            self._h5 = None
        if self._journal is not None:
            with contextlib.suppress(OSError):
                self._journal.close()
            self._journal = None


def _cat(parts: list[np.ndarray]) -> np.ndarray:
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


def _extrapolated_t(t_last: float | None, idx: int, rows: int, fs: float) -> float:
    if t_last is None:
        return idx / fs
    return t_last + (idx - (rows - 1)) / fs


# --------------------------------------------------------------------------------------------
# Reprocessing and recovery
# --------------------------------------------------------------------------------------------


def replay_pipeline(
    adc: np.ndarray,
    config: PipelineConfig,
    calibration: Calibration,
    changes: Sequence[tuple[int, PipelineConfig | Calibration]] = (),
    *,
    table: ChannelTable = DEFAULT_TABLE,
    chunk_rows: int = _RECOVERY_CHUNK_ROWS,
) -> Iterator[tuple[int, dict[str, np.ndarray], np.ndarray, np.ndarray]]:
    """Run the pipeline over a whole recording from row 0, applying logged changes at their rows.

    Yields ``(start_row, processed rows, heel_strike rows, toe_off rows)`` per chunk. A new
    calibration is applied with ``Pipeline.set_calibration`` (filter state kept); new settings
    start a fresh ``Pipeline(new_config, calibration in force)`` at that row (the stages are
    rebuilt, as they must be when the filter design changes). Changes at the same row apply in
    the given order. Use it for recovery and for ``gaitmon process``.
    """
    n = len(adc)
    ordered = sorted(
        ((max(0, int(i)), k, c) for k, (i, c) in enumerate(changes)), key=lambda x: x[:2]
    )
    cuts = {0, n}
    cuts.update(range(0, n, chunk_rows))
    cuts.update(i for i, _, _ in ordered if i < n)
    bounds = sorted(cuts)
    pipeline = Pipeline(config, calibration, table)
    base = 0
    k = 0
    for a, b in itertools.pairwise(bounds):
        while k < len(ordered) and ordered[k][0] <= a:
            change = ordered[k][2]
            if isinstance(change, Calibration):
                pipeline.set_calibration(change)
            else:
                pipeline = Pipeline(change, pipeline.calibration, table)
                base = a
            k += 1
        blk = pipeline.process(adc[a:b])
        yield a, rows_from_pipeline(blk), blk.heel_strike_idx + base, blk.toe_off_idx + base


def _journal_changes(
    contents: JournalContents,
) -> list[tuple[int, PipelineConfig | Calibration]]:
    out: list[tuple[int, PipelineConfig | Calibration]] = []
    for rtype, obj in contents.changes:
        idx = int(obj["sample_idx"])
        if rtype == RecordType.CONFIG:
            out.append((idx, PipelineConfig(**obj["config"])))
        else:
            out.append((idx, Calibration.from_dict(obj["calibration"])))
    return out


def _timeline_from_rows(
    lost_before: np.ndarray, gaps: Sequence[Mapping[str, Any]], fs: float
) -> np.ndarray:
    """The live writer's t_s, computed for all rows at once (see :class:`_Timeline`)."""
    n = len(lost_before)
    if n == 0:
        return np.empty(0)
    per_row: dict[int, float] = {}
    for g in gaps:  # gaps at the same row add up, in journal order, as the writer does
        idx = int(g["sample_idx"])
        per_row[idx] = per_row.get(idx, 0.0) + float(g["duration_s"])
    t = np.empty(n)
    tl = _Timeline(fs)
    starts = sorted(i for i in per_row if 0 < i < n)
    bounds = [0, *starts, n]
    for a, b in itertools.pairwise(bounds):
        if a == b:
            continue
        t[a:b] = tl.times(lost_before[a:b], per_row.get(a) if a else None)
    return t


def recover_session(
    path: str | os.PathLike[str],
    progress: Callable[[float], bool | None] | None = None,
) -> Path:
    """Rebuild ``path`` from its journal; returns the path. Raises :class:`SessionError`.

    The new file is written beside the old one and moved over it atomically, so a crash during
    recovery loses nothing (the journal is deleted last). ``progress(fraction)`` is called as
    the work advances; returning ``False`` cancels (the journal is kept).
    """
    path = Path(path)
    jpath = journal_path(path)
    name = path.name
    if not jpath.exists():
        raise SessionError(f"{name} has no journal ({jpath.name}) to recover from")
    try:
        with journal_lock(jpath) as free:
            if not free:
                raise SessionError(
                    f"{name} is being recorded right now; open it after the recording stops"
                )
            return _recover_locked(path, jpath, progress)
    except OSError as e:
        raise SessionError(f"cannot read {jpath.name}: {_short_error(e)}") from e


def _recover_locked(
    path: Path, jpath: Path, progress: Callable[[float], bool | None] | None
) -> Path:
    name = path.name
    try:
        contents = read_journal(jpath)
    except OSError as e:
        raise SessionError(f"cannot read {jpath.name}: {_short_error(e)}") from e
    if contents.header is None or contents.rows is None:
        raise SessionError(
            f"cannot recover {name}: its journal {jpath.name} is unusable ({contents.problem})"
        )
    try:
        header = SessionHeader.from_dict(contents.header)
        changes = _journal_changes(contents)
    except (KeyError, TypeError, ValueError) as e:
        raise SessionError(f"cannot recover {name}: bad settings in its journal ({e})") from e

    tmp = path.with_name(path.name + ".recovering")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()  # left by a recovery that was itself interrupted
    try:
        _build_recovered(tmp, header, contents, changes, progress)
        _fsync_path(tmp)
        os.replace(tmp, path)
        _fsync_path(path.parent, directory=True)
        jpath.unlink()
    except _Cancelled:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise SessionError(
            f"recovery of {name} cancelled; the journal is kept, open the file again to recover"
        ) from None
    except (OSError, RuntimeError) as e:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise SessionError(
            f"cannot recover {name}: {_short_error(e)}; free some disk space and open it again "
            "(the journal is kept)"
        ) from e
    return path


class _Cancelled(Exception):
    pass


def _build_recovered(
    tmp: Path,
    header: SessionHeader,
    contents: JournalContents,
    changes: list[tuple[int, PipelineConfig | Calibration]],
    progress: Callable[[float], bool | None] | None,
) -> None:
    hdr = contents.header
    assert hdr is not None and contents.rows is not None
    rows = contents.rows
    n = len(rows)
    fs = header.sample_rate_hz
    mode = header.mode
    h5 = _H5File(tmp, hdr, mode="w", reprocessed=mode == "raw")
    try:
        if contents.wall_offset_s is not None:
            h5.set_wall_offset(contents.wall_offset_s)
        seq = np.ascontiguousarray(rows["seq"])
        host = np.ascontiguousarray(rows["host_time_s"])
        t_s = _timeline_from_rows(rows["lost_before"], contents.gaps, fs)

        def report(done: int) -> None:
            if progress is not None and progress(done / n if n else 1.0) is False:
                raise _Cancelled

        if mode == "raw":
            adc = np.ascontiguousarray(rows["adc"])
            chunks: Iterator[tuple[int, dict[str, np.ndarray], np.ndarray, np.ndarray]] = (
                replay_pipeline(adc, header.config, header.calibration, changes, table=header.table)
            )
        else:
            chunks = _device_chunks(rows, FrameKind.TILT if mode == "tilt" else FrameKind.JOINT)
        for a, proc, hs, to in chunks:
            b = a + len(proc["processed/joint_deg"])
            cols = {
                "timeline/seq": seq[a:b],
                "timeline/host_time_s": host[a:b],
                "timeline/t_s": t_s[a:b],
                **proc,
            }
            if mode == "raw":
                cols["raw/adc"] = adc[a:b]
            h5.append_rows(cols, b - a)
            h5.append_events("heel_strike", hs)
            h5.append_events("toe_off", to)
            report(b)

        h5.append_table(
            "gaps",
            [
                (int(g["sample_idx"]), int(g["n_lost"]), float(g["duration_s"]), str(g["reason"]))
                for g in contents.gaps
            ],
        )
        markers = []
        for m in contents.markers:
            idx = int(m["sample_idx"])
            t = (
                float(t_s[idx])
                if idx < n
                else _extrapolated_t(float(t_s[-1]) if n else None, idx, n, fs)
            )
            markers.append((idx, t, str(m["label"])))
        h5.append_table("markers", markers)
        cfg_log = [
            (i, json.dumps(c.as_dict())) for i, c in changes if isinstance(c, PipelineConfig)
        ]
        cal_log = [(i, json.dumps(c.as_dict())) for i, c in changes if isinstance(c, Calibration)]
        h5.append_table("config/changes", cfg_log)
        h5.append_table("calibration/changes", cal_log)
        crc_log: list[tuple[Any, ...]] = []
        last_crc = 0
        totals: Mapping[str, Any] = {}
        for rec in contents.links:
            totals = rec["totals"]
            crc = int(totals.get("crc_failures", 0))
            if crc > last_crc:
                crc_log.append((int(rec["sample_idx"]), crc))
                last_crc = crc
        h5.append_table("link/crc_failures", crc_log)
        h5.set_link_totals(totals)
        h5.finish(complete=False, recovered=True, stop_reason="recovered", fs_hz=fs)
        report(n)
    finally:
        h5.close()


def _device_chunks(
    rows: np.ndarray, kind: FrameKind
) -> Iterator[tuple[int, dict[str, np.ndarray], np.ndarray, np.ndarray]]:
    edges = ContactEdges() if kind == FrameKind.JOINT else None
    names = _field_names(rows.dtype)[N_COMMON_FIELDS:]
    empty = np.empty(0, np.int64)
    for a in range(0, len(rows), _RECOVERY_CHUNK_ROWS):
        part = rows[a : a + _RECOVERY_CHUNK_ROWS]
        proc = _device_rows(kind, {k: part[k] for k in names})
        if edges is not None:
            hs, to = edges.process(part["heel_loaded"], part["toe_loaded"], a)
        else:
            hs, to = empty, empty
        yield a, proc, hs, to


# --------------------------------------------------------------------------------------------
# Reader
# --------------------------------------------------------------------------------------------


class Marker(NamedTuple):
    sample_idx: int
    t_s: float
    label: str


class Gap(NamedTuple):
    sample_idx: int
    n_lost: int
    duration_s: float
    reason: str


def _s(x: Any) -> str:
    if isinstance(x, bytes):
        return x.decode("utf-8", errors="replace")
    if isinstance(x, np.ndarray) and x.shape == ():
        return _s(x[()])
    return str(x)


def _py(x: Any) -> Any:
    """An HDF5 attribute value as plain Python."""
    if isinstance(x, bytes):
        return x.decode("utf-8", errors="replace")
    if isinstance(x, np.ndarray):
        return x.tolist() if x.shape else _py(x[()])
    if isinstance(x, np.bool_):
        return bool(x)
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.floating):
        return float(x)
    return x


class Session:
    """A session file opened for reading. Metadata is read at open; per-sample data lazily.

    Use as a context manager, or call :meth:`close`. Every failure to read raises
    :class:`SessionError`.
    """

    def __init__(self, path: Path, f: h5py.File, problems: Sequence[str] = ()) -> None:
        self.path = path
        self._f = f
        self.problems: list[str] = list(problems)
        name = path.name
        a = f.attrs
        if "format" not in a:
            raise SessionError(
                f"{name} is not a gaitmon session (no 'format' attribute); "
                "pick a file recorded by gaitmon"
            )
        if _s(a["format"]) != FORMAT:
            raise SessionError(
                f"{name} is not a gaitmon session (format is {_s(a['format'])!r}); "
                "pick a file recorded by gaitmon"
            )
        version = int(a.get("format_version", 0))
        if version > FORMAT_VERSION:
            raise SessionError(
                f"{name} was written by a newer gaitmon (format version {version}); "
                "update gaitmon to open it"
            )
        self.attrs: dict[str, Any] = {k: _py(v) for k, v in a.items()}
        self.mode: str = str(self.attrs.get("mode", ""))
        if self.mode not in MODES:
            raise SessionError(f"{name} is damaged: unknown mode {self.mode!r}")
        self.sample_rate_hz = float(self.attrs["sample_rate_hz"])
        self.created_utc = str(self.attrs.get("created_utc", ""))
        self.complete = bool(self.attrs.get("complete", False))
        self.recovered = bool(self.attrs.get("recovered", False))
        self.stop_reason = str(self.attrs.get("stop_reason", ""))
        self.software_version = str(self.attrs.get("software_version", ""))

        sess = {k: _s(v) for k, v in f["session"].attrs.items()}
        self.meta = SessionMeta(
            **{k: sess.get(k, "") for k in ("patient_id", "side", "operator", "notes")}
        )
        self.device: dict[str, Any] = {k: _py(v) for k, v in f["device"].attrs.items()}
        ch = f["device/channels"][()]
        self.channels: list[dict[str, Any]] = [
            {k: _py(row[k]) for k in ch.dtype.names} for row in ch
        ]

        cfg_attrs = {k: _py(v) for k, v in f["config"].attrs.items()}
        self.event_delay_samples = int(cfg_attrs.pop("event_delay_samples", 0))
        fields = PipelineConfig.__dataclass_fields__
        self.config = PipelineConfig(**{k: v for k, v in cfg_attrs.items() if k in fields})
        self.config_changes: list[tuple[int, PipelineConfig]] = [
            (int(r["sample_idx"]), PipelineConfig(**json.loads(_s(r["json"]))))
            for r in f["config/changes"][()]
        ]
        cal = f["calibration"].attrs
        self.calibration = Calibration(
            np.asarray(cal["tilt_offset_rad"]), np.asarray(cal["gyro_bias_rad_s"])
        )
        self.calibration_changes: list[tuple[int, Calibration]] = [
            (int(r["sample_idx"]), Calibration.from_dict(json.loads(_s(r["json"]))))
            for r in f["calibration/changes"][()]
        ]
        self.heel_strike_idx: np.ndarray = np.asarray(f["events/heel_strike"][()], np.int64)
        self.toe_off_idx: np.ndarray = np.asarray(f["events/toe_off"][()], np.int64)
        self.markers: list[Marker] = [
            Marker(int(r["sample_idx"]), float(r["t_s"]), _s(r["label"])) for r in f["markers"][()]
        ]
        self.gaps: list[Gap] = [
            Gap(int(r["sample_idx"]), int(r["n_lost"]), float(r["duration_s"]), _s(r["reason"]))
            for r in f["gaps"][()]
        ]
        self.link: dict[str, int] = {k: int(v) for k, v in f["link"].attrs.items()}
        self.crc_failures: list[tuple[int, int]] = [
            (int(r["sample_idx"]), int(r["count"])) for r in f["link/crc_failures"][()]
        ]
        proc = f["processed"].attrs
        self.processed_source = _s(proc.get("source", ""))
        self.reprocessed = bool(proc.get("reprocessed", False))
        self.wall_offset_s = float(f["timeline/host_time_s"].attrs.get("wall_offset_s", 0.0))

        self.dataset_names: tuple[str, ...] = tuple(
            p for p in per_sample_datasets(self.mode) if p in f
        )
        missing = set(per_sample_datasets(self.mode)) - set(self.dataset_names)
        if missing:
            raise SessionError(f"{name} is damaged: missing {sorted(missing)[0]}")
        lengths = {p: f[p].shape[0] for p in self.dataset_names}
        self.n_samples = min(lengths.values())
        if len(set(lengths.values())) > 1:
            self.problems.append(
                f"datasets have different lengths; using the first {self.n_samples} rows"
            )
        if self.complete and int(self.attrs.get("n_samples", -1)) != self.n_samples:
            self.problems.append("n_samples attribute does not match the data")
        self.duration_s = float(self.attrs.get("duration_s", 0.0))
        if not self.complete and not self.recovered:
            self.problems.append("the recording was not stopped cleanly")

    # -- access ----------------------------------------------------------------------------------

    @property
    def header(self) -> SessionHeader:
        known = {c.name for c in CHANNELS}
        channels = (
            tuple(ChannelSpec(**c) for c in self.channels)
            if all(c.get("name") in known for c in self.channels)
            else CHANNELS
        )
        return SessionHeader(
            mode=self.mode,
            sample_rate_hz=self.sample_rate_hz,
            meta=self.meta,
            device=self.device,
            config=self.config,
            calibration=self.calibration,
            created_utc=self.created_utc,
            channels=channels,
        )

    def dataset(self, name: str) -> h5py.Dataset:
        """The h5py dataset, e.g. ``'raw/adc'`` or ``'processed/joint_deg'`` (lazy)."""
        if name not in self.dataset_names:
            raise SessionError(
                f"{self.path.name} has no per-sample dataset {name!r} "
                f"(it has {', '.join(self.dataset_names)})"
            )
        return self._f[name]

    def read(self, name: str) -> np.ndarray:
        """A whole per-sample dataset as a numpy array (its first ``n_samples`` rows)."""
        return self.read_range(0, self.n_samples, [name])[name]

    def read_range(
        self, start: int, stop: int, names: Sequence[str] | None = None
    ) -> dict[str, np.ndarray]:
        """Rows ``start:stop`` (clipped to the data) of the named per-sample datasets (all if
        None): read only what a long file's visible window needs."""
        start = max(0, min(int(start), self.n_samples))
        stop = max(start, min(int(stop), self.n_samples))
        out = {}
        for name in names or self.dataset_names:
            ds = self.dataset(name)
            try:
                out[name] = ds[start:stop]
            except (OSError, RuntimeError, ValueError, KeyError) as e:
                raise SessionError(
                    f"{self.path.name} is damaged: cannot read {name} rows {start}-{stop} "
                    f"({_short_error(e)})"
                ) from e
        return out

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._f.close()

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _open_h5(path: Path) -> h5py.File:
    try:
        return h5py.File(path, "r")
    except (OSError, RuntimeError, ValueError) as e:
        raise SessionError(
            f"{path.name} is not an HDF5 file or is damaged ({_short_error(e)}); "
            "pick a session file recorded by gaitmon"
        ) from e


def _read_session(path: Path, problems: Sequence[str] = ()) -> Session:
    f = _open_h5(path)
    try:
        return Session(path, f, problems)
    except SessionError:
        f.close()
        raise
    except Exception as e:  # damaged metadata can fail in many ways inside h5py/numpy
        with contextlib.suppress(Exception):
            f.close()
        raise SessionError(f"{path.name} is damaged ({_short_error(e)})") from e


def open_session(
    path: str | os.PathLike[str],
    *,
    recover: bool = True,
    progress: Callable[[float], bool | None] | None = None,
) -> Session:
    """Open a session for reading, first recovering it if a journal says it was interrupted.

    If the journal itself is unusable, the HDF5 file is opened as it is (flushed every 100 ms
    while recording) and :attr:`Session.problems` says so.
    """
    path = Path(path)
    jpath = journal_path(path)
    if jpath.exists() and recover:
        if _being_recorded(jpath):
            raise SessionError(
                f"{path.name} is being recorded right now; open it after the recording stops"
            )
        if path.exists():
            # a clean stop or a finished recovery only had the journal's deletion left to do
            done = False
            with contextlib.suppress(SessionError), _read_session(path) as s:
                done = s.complete or s.recovered
            if done:
                jpath.unlink()
        if jpath.exists():
            try:
                recover_session(path, progress)
            except SessionError as e:
                if not path.exists():
                    raise
                return _read_session(path, [f"not recovered: {e}"])
    elif not path.exists():
        raise SessionError(f"{path.name} does not exist; check the file name and folder")
    return _read_session(path)
