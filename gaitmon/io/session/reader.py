"""Reading a session: :func:`open_session` (recovering an interrupted recording first) and
:class:`Session` (metadata at open, per-sample data lazily)."""

from __future__ import annotations

import contextlib
import copy
import json
import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import h5py
import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import CHANNELS, GYRO_IDX, ChannelSpec
from gaitmon.dsp.fsr_check import FsrFault
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.io.journal import journal_path
from gaitmon.io.session.codec import GYRO, JOINT_OF, decode, derived, gyro_from_counts
from gaitmon.io.session.codec import joints_from_stored_tilts as _joints_of
from gaitmon.io.session.exclusions import Exclusion
from gaitmon.io.session.exclusions import read as read_exclusions
from gaitmon.io.session.h5file import _being_recorded, _short_error
from gaitmon.io.session.header import SessionError, SessionHeader, SessionMeta
from gaitmon.io.session.layout import (
    _PER_SAMPLE,
    FORMAT,
    FORMAT_VERSION,
    MODES,
    READER_CHUNK_CACHE_BYTES,
    per_sample_datasets,
    stored_datasets,
)
from gaitmon.io.session.parts import BOTH_LEGS, SIDE_NAMES, parts_of
from gaitmon.io.session.smoothed import (
    ANGLE_SOURCES,
    SMOOTHED,
    smoothed_from_file,
    smoothed_method_label,
    stored_smoothed,
)
from gaitmon.io.session.truth import Truth, truth_from_file

# per-sample series a format-2 file stores encoded (read through SeriesView, not h5py)
_CODED = frozenset(("processed/tilt_deg", "processed/tilt_acc_deg", "processed/tilt_gyro_deg",
                    "processed/joint_deg", "processed/joint_acc_deg", "processed/acc_ms2",
                    "processed/fsr_counts", "smoothed/tilt_deg", "smoothed/joint_deg"))


_DECODE_ROWS = 1 << 18  # rows decoded at a time (64 chunks; ~4 MB of int16 tilts)


class SeriesView:
    """A per-sample series read by slicing (``view[a:b]``), decoded by the session reader."""

    def __init__(self, session: Session, name: str) -> None:
        self._s = session
        self.name = name
        self.shape = session.shape_of(name)
        self.dtype = np.dtype(_PER_SAMPLE[name][1])
        self.ndim = len(self.shape)
        self.file = session.h5

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key: Any) -> np.ndarray:
        if isinstance(key, slice) and key.step in (None, 1):
            a, b, _ = key.indices(self.shape[0])
            return self._s.read_range(a, b, [self.name])[self.name]
        return self._s.read(self.name)[key]

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        a = self._s.read(self.name)
        return a if dtype is None else a.astype(dtype)


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

    def __init__(
        self, path: Path, f: h5py.File | h5py.Group, problems: Sequence[str] = (), *,
        side: str = "",
    ) -> None:  # fmt: skip
        self.path = path
        # one unit of a bilateral file: f is its group /units/<side> (the whole single-unit
        # layout), and closing the session closes the file
        self.unit_side = side
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
        if bool(a.get("bilateral", False)) and not side:
            raise SessionError(BOTH_LEGS.format(name=name))
        version = int(a.get("format_version", 0))
        if version > FORMAT_VERSION:
            raise SessionError(
                f"{name} was written by a newer gaitmon (format version {version}); "
                "update gaitmon to open it"
            )
        self.format_version = max(1, version)
        self.attrs: dict[str, Any] = {k: _py(v) for k, v in a.items()}
        self.mode: str = str(self.attrs.get("mode", ""))
        if self.mode not in MODES:
            raise SessionError(f"{name} is damaged: unknown mode {self.mode!r}")
        # series this file computes on read (format 2: joints from tilts, gyro from counts)
        self._derived = derived(self.mode, self.format_version)
        self.sample_rate_hz = _sample_rate(name, self.attrs.get("sample_rate_hz"))
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
        self.config = PipelineConfig.from_stored(cfg_attrs)
        self.config_changes: list[tuple[int, PipelineConfig]] = [
            (int(r["sample_idx"]), PipelineConfig.from_stored(json.loads(_s(r["json"]))))
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
        self.heel_strike_idx: np.ndarray = _event_rows(name, f, "heel_strike")
        self.toe_off_idx: np.ndarray = _event_rows(name, f, "toe_off")
        self.markers: list[Marker] = [
            Marker(int(r["sample_idx"]), float(r["t_s"]), _s(r["label"])) for r in f["markers"][()]
        ]
        faults = f["events/fsr_faults"][()] if "events/fsr_faults" in f else []
        # force sensors the foot-gyro cross-check flagged, in rows (decided_idx: from there
        # on the events come from the foot gyro)
        self.fsr_faults: list[FsrFault] = [
            FsrFault(_s(r["sensor"]), _s(r["reason"]), int(r["stride_start_idx"]),
                     int(r["sample_idx"]))
            for r in faults
        ]  # fmt: skip
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

        stored = stored_datasets(self.mode, self.format_version)
        missing = sorted(p for p in stored if p not in f)
        if missing:
            raise SessionError(f"{name} is damaged: missing {missing[0]}")
        for p in stored:
            _check_per_sample(name, p, f[p])
        # every series readers get, stored or derived (see gaitmon.io.session.codec)
        self.dataset_names: tuple[str, ...] = per_sample_datasets(self.mode)
        lengths = {p: f[p].shape[0] for p in stored}
        self.n_samples = min(lengths.values())
        if len(set(lengths.values())) > 1:
            self.problems.append(
                f"datasets have different lengths; using the first {self.n_samples} rows"
            )
        if self.complete and int(self.attrs.get("n_samples", -1)) != self.n_samples:
            self.problems.append("n_samples attribute does not match the data")
        self.duration_s = float(self.attrs.get("duration_s", 0.0))
        if not (self.complete or self.recovered) and self.n_samples:
            # an unfinished file's attribute still says 0: its last row's time says how long
            with contextlib.suppress(OSError, RuntimeError, ValueError, TypeError):
                t_last = float(f["timeline/t_s"][self.n_samples - 1])
                if math.isfinite(t_last):
                    self.duration_s = t_last + 1.0 / self.sample_rate_hz
        if not self.complete and not self.recovered:
            self.problems.append("the recording was not stopped cleanly")
        # the angles every reader gets: the zero-lag smoother's (raw mode; stored in /smoothed,
        # or computed on first read), or the live filter's (see gaitmon.io.session.smoothed)
        self.live_angle_method = _s(proc.get("tilt_method", "")) or (
            self.config.tilt_method_label if self.mode == "raw" else "the unit's own"
        )
        self.angle_sources: tuple[str, ...] = (
            ANGLE_SOURCES if self.mode == "raw" and self.n_samples else ("live",)
        )
        self.angle_source = self.angle_sources[0]
        self._bias_rows: list[tuple[int, np.ndarray]] | None = None
        self.smoothed_stored = stored_smoothed(f, self.n_samples)
        self._smoothed: dict[str, np.ndarray] | None = None
        self._stride_cache: dict[bytes, Any] = {}  # heel strikes -> their stride measures
        sm = f.get("smoothed")
        self._smoothed_method = (
            _s(sm.attrs.get("method", "")) if self.smoothed_stored and sm is not None else ""
        ) or smoothed_method_label()

    # -- access ----------------------------------------------------------------------------------

    @property
    def header(self) -> SessionHeader:
        known = {c.name for c in CHANNELS}
        try:
            channels = (
                tuple(ChannelSpec(**c) for c in self.channels)
                if all(c.get("name") in known for c in self.channels)
                else CHANNELS
            )
        except (TypeError, ValueError) as e:
            raise SessionError(
                f"{self.path.name} is damaged: its channel table /device/channels cannot be "
                f"read ({_short_error(e)})"
            ) from e
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

    @property
    def event_source(self) -> str:
        """Where the heel strikes and toe offs come from, for people: the force sensors, the
        foot gyro from the row a sensor was flagged, or the unit (tilt/joint modes)."""
        if self.mode == "tilt":
            return "none (tilt mode)"
        if self.mode == "joint":
            return "the unit's force sensors"
        if not self.config.fsr_check:
            return "the force sensors (not cross-checked with the foot gyro)"
        if not self.fsr_faults:
            return "the force sensors (cross-checked with the foot gyro: no fault)"
        first = min(self.fsr_faults, key=lambda x: x.decided_idx)
        why = "; ".join(f"{x.sensor} force sensor {x.reason}" for x in self.fsr_faults)
        return (f"the force sensors, then the foot gyro from "
                f"{first.decided_idx / self.sample_rate_hz:.1f} s ({why})")  # fmt: skip

    def use_angles(self, source: str) -> None:
        """Which angles ``processed/tilt_deg`` and ``processed/joint_deg`` give from now on:
        "smoothed" (the zero-lag offline estimate, the default where there is one) or "live"
        (the causal filter's, as shown while recording)."""
        if source not in self.angle_sources:
            raise SessionError(
                f"{self.path.name} has no {source!r} angles "
                f"(it has {' and '.join(self.angle_sources)})"
            )
        self.angle_source = source

    def with_angles(self, source: str) -> Session:
        """This session reading the angles of ``source`` (see :meth:`use_angles`): a second
        view of the same open file, so readers on other threads can read one source while
        this session reads the other. Close this session, not the view."""
        view = copy.copy(self)
        view.use_angles(source)
        return view

    def angle_method_of(self, source: str) -> str:
        """The name of the method that made the angles of ``source`` (smoothed | live)."""
        return self._smoothed_method if source == "smoothed" else self.live_angle_method

    @property
    def angle_method(self) -> str:
        """The name of the method behind the angles read now (see :meth:`use_angles`)."""
        return self.angle_method_of(self.angle_source)

    def _smoothed_series(self) -> dict[str, np.ndarray]:
        """The whole smoothed series of a file that does not store them, computed once."""
        if self._smoothed is None:
            try:
                self._smoothed = smoothed_from_file(
                    self._f, self.header.table, self.calibration, self.sample_rate_hz
                )
            except (OSError, RuntimeError, ValueError, KeyError) as e:
                raise SessionError(
                    f"{self.path.name} is damaged: cannot compute the smoothed angles "
                    f"({_short_error(e)}); read the live ones (review: Angles > live)"
                ) from e
        return self._smoothed

    @property
    def h5(self) -> h5py.File | h5py.Group:
        """The open HDF5 file, or a bilateral file's unit group (metadata and tables; per-sample
        series through :meth:`read_range`, which decodes whatever the file stores)."""
        return self._f

    def _check_name(self, name: str) -> None:
        if name not in self.dataset_names:
            raise SessionError(
                f"{self.path.name} has no per-sample dataset {name!r} "
                f"(it has {', '.join(self.dataset_names)})"
            )

    def dataset(self, name: str) -> h5py.Dataset | np.ndarray | SeriesView:
        """A lazily read per-sample series, e.g. ``'raw/adc'`` or ``'processed/joint_deg'``:
        the h5py dataset where the file stores it as readers get it, else a view that decodes
        on slicing; the angle series are those of :attr:`angle_source` (an array if computed
        in memory)."""
        self._check_name(name)
        path = self._path_of(name)
        if path.startswith("smoothed/") and not self.smoothed_stored:
            return self._smoothed_series()[path]
        if path in self._f and path not in self._derived and (
            self.format_version < 2 or path not in _CODED
        ):
            return self._f[path]
        return SeriesView(self, name)

    def _path_of(self, name: str) -> str:
        """The file path of a series under the current angle source."""
        if self.angle_source == "smoothed" and name in SMOOTHED:
            return SMOOTHED[name]
        return name

    def shape_of(self, name: str) -> tuple[int, ...]:
        """(n_samples, *row shape) of a per-sample series, however the file stores it."""
        self._check_name(name)
        return (self.n_samples, *_PER_SAMPLE[name][0])

    def read(self, name: str) -> np.ndarray:
        """A whole per-sample dataset as a numpy array (its first ``n_samples`` rows)."""
        return self.read_range(0, self.n_samples, [name])[name]

    def read_range(
        self, start: int, stop: int, names: Sequence[str] | None = None
    ) -> dict[str, np.ndarray]:
        """Rows ``start:stop`` (clipped to the data) of the named per-sample series (all if
        None), decoded from whatever the file stores (format 1: as they are; format 2:
        quantised series decoded, joint angles and gyro rates derived): read only what a long
        file's visible window needs."""
        start = max(0, min(int(start), self.n_samples))
        stop = max(start, min(int(stop), self.n_samples))
        out = {}
        for name in names or self.dataset_names:
            self._check_name(name)
            try:
                out[name] = self._read_path(self._path_of(name), start, stop)
            except (OSError, RuntimeError, ValueError, KeyError) as e:
                raise SessionError(
                    f"{self.path.name} is damaged: cannot read {name} rows {start}-{stop} "
                    f"({_short_error(e)})"
                ) from e
        return out

    def _read_path(self, path: str, a: int, b: int) -> np.ndarray:
        """Rows a:b of a per-sample series as readers get it. A long range of a series this
        file encodes is decoded a block at a time into the result, so reading a whole 8-hour
        series costs its result, not several times it in temporaries."""
        if b - a > _DECODE_ROWS and (path in self._derived or path in _CODED):
            first = self._read_one(path, a, a + _DECODE_ROWS)
            out = np.empty((b - a, *first.shape[1:]), dtype=first.dtype)
            out[:_DECODE_ROWS] = first
            for k in range(a + _DECODE_ROWS, b, _DECODE_ROWS):
                e = min(b, k + _DECODE_ROWS)
                out[k - a : e - a] = self._read_one(path, k, e)
            return out
        return self._read_one(path, a, b)

    def _read_one(self, path: str, a: int, b: int) -> np.ndarray:
        f = self._f
        if path.startswith("smoothed/") and not self.smoothed_stored:
            return self._smoothed_series()[path][a:b]
        if path in self._derived or (path == "smoothed/joint_deg" and path not in f):
            if path == GYRO:
                return gyro_from_counts(
                    f["raw/adc"][a:b], a, self.header.table.to_physical, GYRO_IDX,
                    self._gyro_bias_rows(),
                )  # fmt: skip
            tilt = JOINT_OF[path]
            return _joints_of(f[tilt][a:b], tilt)
        return decode(path, f[path][a:b])

    def _gyro_bias_rows(self) -> list[tuple[int, np.ndarray]]:
        """(first row, gyro bias) of every calibration in force, in row order (the order
        logged at the same row: the last one wins, as the pipeline applies them)."""
        if self._bias_rows is None:
            rows = [(0, np.asarray(self.calibration.gyro_bias_rad_s, np.float64))]
            changes = sorted(
                ((max(0, r), k, c) for k, (r, c) in enumerate(self.calibration_changes)),
                key=lambda x: x[:2],
            )
            rows += [(r, np.asarray(c.gyro_bias_rad_s, np.float64)) for r, _, c in changes]
            self._bias_rows = rows
        return self._bias_rows

    def stored_pyramid(self, name: str) -> Any:
        """The min/max pyramid of a joint series (under the current angle source) from the
        file's ``/overview`` (:mod:`gaitmon.io.session.stored_overview`), or None where the
        file has none: then build it from the rows."""
        from gaitmon.io.overview import PeakPyramid
        from gaitmon.io.session.stored_overview import read_overview

        if name not in self.dataset_names or not self.n_samples:
            return None
        path = self._path_of(name)
        if path.startswith("smoothed/") and not self.smoothed_stored:
            return None
        try:
            got = read_overview(self._f, path, self.n_samples)
        except (OSError, RuntimeError, ValueError, KeyError):
            return None  # a damaged overview: the rows are read instead
        if got is None:
            return None
        from gaitmon.io.session.stored_overview import BASE_STEP

        return PeakPyramid.from_level0(got[0], got[1], self.n_samples, BASE_STEP)

    def foot_stride_measures(self, heel_strike_idx: np.ndarray | None = None) -> Any:
        """Stride length and foot clearance (:class:`gaitmon.dsp.stride_length.StrideMeasures`)
        of the strides between ``heel_strike_idx`` (default: the recorded heel strikes), from
        the foot IMU: stored in ``/strides`` when computed from exactly these inputs, else
        computed (:mod:`gaitmon.io.session.stored_strides`); None without raw counts. The
        last two results are kept (review compares the recorded events with a reprocessing's),
        so analysing again with other exclusions costs nothing."""
        from gaitmon.io.session.stored_strides import StrideInputs, stride_measures_of

        if self.mode != "raw" or not self.n_samples:
            return None
        hs = np.asarray(self.heel_strike_idx if heel_strike_idx is None else heel_strike_idx,
                        dtype=np.int64)  # fmt: skip
        key = hs.tobytes()
        if key in self._stride_cache:
            return self._stride_cache[key]
        inputs = StrideInputs(self.n_samples, self.sample_rate_hz, self.header.table,
                              self.calibration, self.calibration_changes)  # fmt: skip
        try:
            m = stride_measures_of(
                self._f, lambda a, b: self.read_range(a, b, ["raw/adc"])["raw/adc"], inputs, hs
            )
        except (OSError, RuntimeError, KeyError) as e:
            raise SessionError(
                f"{self.path.name} is damaged: cannot read the foot sensor's raw counts "
                f"({_short_error(e)})"
            ) from e
        # the newest before and this one (the recorded events and a reprocessing's), swapped
        # in whole, so that a reader on another thread never sees it change size
        self._stride_cache = {**dict(list(self._stride_cache.items())[-1:]), key: m}
        return m

    def exclusions(self) -> tuple[list[Exclusion], str]:
        """(ranges, problem): the row ranges the user excluded in review (stored beside the
        recording, see :mod:`gaitmon.io.session.exclusions`), merged and clipped to the data.
        ``problem`` is a one-line reason when the side file could not be used, else ""."""
        return read_exclusions(self)

    @property
    def exclusions_key(self) -> Path:
        """The path the exclusions are kept for (``FILE.review.json`` beside it): the file, or
        for one leg of a bilateral file ``FILE.L`` / ``FILE.R`` (rows are per unit, so each
        leg keeps its own)."""
        if self.unit_side:
            return self.path.with_name(f"{self.path.name}.{self.unit_side}")
        return self.path

    def truth(self, start: int, stop: int) -> Truth:
        """The simulator's ground truth of rows ``start:stop`` (see
        :mod:`gaitmon.io.session.truth`): (true tilts in rad, mounting offsets in rad), or
        (None, None) for a session recorded from a real unit."""
        try:
            return truth_from_file(self._f, start, stop)
        except (OSError, KeyError, ValueError) as e:
            raise SessionError(f"{self.path.name}: cannot read /truth ({e})") from e

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._f.file.close()

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# No unit samples faster; a larger recorded rate is a damaged attribute (1e300 Hz overflows
# the time grids of the exports).
MAX_SAMPLE_RATE_HZ = 100_000.0


def _sample_rate(name: str, value: Any) -> float:
    """The recorded sample rate; a damaged one (0, NaN, negative, not a number) is said here,
    at the file's edge, rather than as a ValueError deep inside the analysis."""
    if value is None:
        raise SessionError(f"{name} is damaged: it has no sample rate")
    try:
        fs = float(value)
    except (TypeError, ValueError):
        fs = float("nan")
    if not (math.isfinite(fs) and 0 < fs <= MAX_SAMPLE_RATE_HZ):
        raise SessionError(f"{name} is damaged: its sample rate is {value!r} Hz")
    return fs


def _event_rows(name: str, f: h5py.File, kind: str) -> np.ndarray:
    """One event kind's rows: whole numbers from 0 on, strictly increasing (as every writer
    stores them); anything else means the file was damaged after it was written."""
    raw = f[f"events/{kind}"][()]
    arr = np.asarray(raw)
    label = kind.replace("_", " ") + "s"
    if arr.ndim != 1 or arr.dtype.kind not in "iu":
        raise SessionError(
            f"{name} is damaged: /events/{kind} holds {arr.dtype} of shape {arr.shape}, "
            "not row numbers"
        )
    rows = arr.astype(np.int64)
    if len(rows) and (rows[0] < 0 or np.any(np.diff(rows) <= 0)):
        raise SessionError(f"{name} is damaged: its {label} are out of order")
    return rows


def _check_per_sample(name: str, path: str, ds: h5py.Dataset) -> None:
    """A per-sample dataset has the row shape and a numeric kind of the layout's table."""
    spec = _PER_SAMPLE.get(path)
    if spec is None:
        return
    row_shape, dtype, _ = spec
    if ds.ndim == 0 or tuple(ds.shape[1:]) != row_shape or ds.dtype.kind not in "iuf":
        raise SessionError(
            f"{name} is damaged: /{path} holds {ds.dtype} rows of shape {tuple(ds.shape[1:])} "
            f"instead of {dtype} rows of shape {row_shape}"
        )


def _open_h5(path: Path) -> h5py.File:
    try:
        return h5py.File(path, "r", rdcc_nbytes=READER_CHUNK_CACHE_BYTES, rdcc_nslots=1021)
    except (OSError, RuntimeError, ValueError) as e:
        why = _short_error(e)
        if path.is_dir():
            why = "a folder"
        elif path.exists() and path.stat().st_size == 0:
            why = "an empty file"
        elif why == "not an HDF5 file":
            pass
        else:
            raise SessionError(
                f"{path.name} is damaged and cannot be opened ({why}); "
                "pick another session file recorded by gaitmon"
            ) from e
        raise SessionError(
            f"{path.name} is not a gaitmon session ({why}); pick a session file recorded by "
            "gaitmon"
        ) from e


def _read_session(path: Path, problems: Sequence[str] = ()) -> Session:
    return _session_of(path, _open_h5(path), problems)


def _session_of(path: Path, f: h5py.File, problems: Sequence[str] = ()) -> Session:
    return _built(path, f, lambda: Session(path, f, problems))


def _built(path: Path, f: h5py.File, make: Callable[[], Session]) -> Session:
    """``make()``, a Session over the open ``f``; on failure ``f`` is closed and the failure is
    one SessionError line."""
    try:
        return make()
    except SessionError:
        f.close()
        raise
    except Exception as e:  # damaged metadata can fail in many ways inside h5py/numpy
        with contextlib.suppress(Exception):
            f.close()
        raise SessionError(f"{path.name} is damaged ({_short_error(e)})") from e


def open_combined_h5(
    path: Path, progress: Callable[[float], bool | None] | None = None
) -> h5py.File:
    """A bilateral session's file, open for reading, after its parts (an interrupted
    recording's) are recovered and combined. Whether it is bilateral is the caller's check."""
    from gaitmon.io.session.combine import finish_parts

    finish_parts(path, progress)
    if not path.exists():
        raise SessionError(f"{path.name} does not exist; check the file name and folder")
    return _open_h5(path)


def open_session(
    path: str | os.PathLike[str],
    *,
    recover: bool = True,
    progress: Callable[[float], bool | None] | None = None,
    side: str | None = None,
) -> Session:
    """Open a session for reading, first recovering it if a journal says it was interrupted.

    If the journal itself is unusable, the HDF5 file is opened as it is (flushed every 100 ms
    while recording) and :attr:`Session.problems` says so.

    A bilateral file (both legs, ``gaitmon.io.session.bilateral``) is opened one unit at a
    time: ``side="L"`` or ``"R"`` gives that leg's session; without a side it is refused with
    a one-line message rather than silently giving one leg.
    """
    path = Path(path)
    if side is not None:
        return _open_unit(path, side, progress)
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
            from gaitmon.io.session.recovery import (  # only when needed
                recover_in_memory,
                recover_session,
            )

            try:
                recover_session(path, progress)
            except SessionError as e:
                # e.g. a full disk: read what the journal holds from memory, so a reader gets
                # every row the recorder said was saved, right away (the file's own rows can
                # stop short of them, in datasets of different lengths)
                with contextlib.suppress(SessionError):
                    f = recover_in_memory(path)
                    return _session_of(path, f, [f"recovered in memory only: {e}"])
                if not path.exists():
                    raise
                return _read_session(path, [f"not recovered: {e}"])
    elif not path.exists():
        if parts_of(path):  # an interrupted bilateral recording
            raise SessionError(BOTH_LEGS.format(name=path.name))
        raise SessionError(f"{path.name} does not exist; check the file name and folder")
    return _read_session(path)


def _open_unit(
    path: Path, side: str, progress: Callable[[float], bool | None] | None
) -> Session:
    """One leg of a bilateral session (its parts recovered and combined first if the recording
    was interrupted)."""
    if side not in SIDE_NAMES:
        raise SessionError(f"side must be L or R, got {side!r}")
    f = open_combined_h5(path, progress)

    def make() -> Session:
        if not bool(f.attrs.get("bilateral", False)):
            raise SessionError(
                f"{path.name} holds one unit, not both legs; open it without a side"
            )
        if f"units/{side}" not in f:
            sides = [s for s in str(_s(f.attrs.get("sides", ""))).split() if s in SIDE_NAMES]
            raise SessionError(
                f"{path.name} has no {SIDE_NAMES[side]} leg (it has "
                f"{' and '.join(SIDE_NAMES[s] for s in sides) or 'none'})"
            )
        return Session(path, f[f"units/{side}"], side=side)

    return _built(path, f, make)
