"""Reading what a session file stores: :class:`StoredSession` (metadata at open, per-sample
data lazily, decoded from whatever the format stores).

Opening by path (recovering an interrupted recording first, computing what a file does not
store) is the finishing layer's :func:`gaitmon.finish.open_session`; :mod:`.opening` opens a
file as it is.
"""

from __future__ import annotations

import contextlib
import copy
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Self, cast

import h5py
import numpy as np

from gaitmon.dsp.calibration import Calibration, zero_source
from gaitmon.dsp.channels import CHANNELS, GYRO_IDX, ChannelSpec
from gaitmon.dsp.events import FALLBACK, PRIMARY, event_source_label
from gaitmon.dsp.fsr_check import FsrFault
from gaitmon.dsp.pipeline_config import PipelineConfig
from gaitmon.io.session.codec import GYRO, JOINT_OF, decode, derived, gyro_from_counts
from gaitmon.io.session.codec import joints_from_stored_tilts as _joints_of
from gaitmon.io.session.exclusions import Exclusion
from gaitmon.io.session.exclusions import read as read_exclusions
from gaitmon.io.session.h5file import _short_error
from gaitmon.io.session.header import SessionError, SessionHeader, SessionMeta
from gaitmon.io.session.layout import (
    _PER_SAMPLE,
    ANGLE_SOURCES,
    FORMAT,
    FORMAT_VERSION,
    MODES,
    SMOOTHED,
    per_sample_datasets,
    stored_datasets,
    stored_smoothed,
)
from gaitmon.io.session.parts import BOTH_LEGS
from gaitmon.io.session.series import (
    AttrValue,
    Gap,
    Marker,
    SeriesView,
    _check_per_sample,
    _event_rows,
    _py,
    _sample_rate,
    attr_text,
)
from gaitmon.io.session.trust import checked_counts, full_scale_of
from gaitmon.text import clean_label
from gaitmon.values import scalar

if TYPE_CHECKING:
    from gaitmon.io.overview import PeakPyramid
    from gaitmon.io.session.truth import Truth

__all__ = ["Gap", "Marker", "SeriesView", "StoredSession"]

# per-sample series a format-2 file stores encoded (read through SeriesView, not h5py)
_CODED = frozenset(("processed/tilt_deg", "processed/tilt_acc_deg", "processed/tilt_gyro_deg",
                    "processed/joint_deg", "processed/joint_acc_deg", "processed/acc_ms2",
                    "processed/fsr_counts", "smoothed/tilt_deg", "smoothed/joint_deg"))


def _json(value: object) -> Any:
    """A change's settings, stored as JSON text (json imported only for a file with changes)."""
    import json

    return json.loads(attr_text(value))


_DECODE_ROWS = 1 << 18  # rows decoded at a time (64 chunks; ~4 MB of int16 tilts)


class StoredSession:
    """A session file opened for reading what it stores. Metadata is read at open; per-sample
    data lazily.

    It computes nothing the pipeline makes: a raw session's smoothed angles that the file
    does not store come from :meth:`_computed_smoothed`, which the finishing layer's session
    (:class:`gaitmon.finish.Session`, what :func:`gaitmon.finish.open_session` gives) supplies.
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
        if attr_text(a["format"]) != FORMAT:
            raise SessionError(
                f"{name} is not a gaitmon session (format is {attr_text(a['format'])!r}); "
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
        self.attrs: dict[str, AttrValue] = {k: _py(v) for k, v in a.items()}
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

        sess = {k: attr_text(v) for k, v in f["session"].attrs.items()}
        self.meta = SessionMeta(
            **{k: sess.get(k, "") for k in ("patient_id", "side", "operator", "notes")}
        )
        self.device: dict[str, AttrValue] = {k: _py(v) for k, v in f["device"].attrs.items()}
        ch = f["device/channels"][()]
        self.channels: list[dict[str, AttrValue]] = [
            {k: _py(row[k]) for k in ch.dtype.names} for row in ch
        ]

        cfg_attrs = {k: _py(v) for k, v in f["config"].attrs.items()}
        self.event_delay_samples = int(scalar(cfg_attrs.pop("event_delay_samples", 0)))
        self.config = PipelineConfig.from_stored(cfg_attrs)
        self.config_changes: list[tuple[int, PipelineConfig]] = [
            (int(r["sample_idx"]), PipelineConfig.from_stored(_json(r["json"])))
            for r in f["config/changes"][()]
        ]
        cal = f["calibration"].attrs
        self.calibration = Calibration(
            np.asarray(cal["tilt_offset_rad"]), np.asarray(cal["gyro_bias_rad_s"])
        )
        self.calibration_changes: list[tuple[int, Calibration]] = [
            (int(r["sample_idx"]), Calibration.from_dict(_json(r["json"])))
            for r in f["calibration/changes"][()]
        ]
        self.heel_strike_idx: np.ndarray = _event_rows(name, f, "heel_strike")
        self.toe_off_idx: np.ndarray = _event_rows(name, f, "toe_off")
        self.markers: list[Marker] = [
            # a label cleaned again: a file written before labels were cleaned at entry may
            # hold ANSI escapes or a megabyte of text
            Marker(int(r["sample_idx"]), float(r["t_s"]), clean_label(attr_text(r["label"])))
            for r in f["markers"][()]
        ]
        faults = f["events/fsr_faults"][()] if "events/fsr_faults" in f else []
        # force sensors the foot-gyro cross-check flagged, in rows (decided_idx: from there
        # on the events come from the foot gyro)
        self.fsr_faults: list[FsrFault] = [
            FsrFault(attr_text(r["sensor"]), attr_text(r["reason"]), int(r["stride_start_idx"]),
                     int(r["sample_idx"]))
            for r in faults
        ]  # fmt: skip
        self.gaps: list[Gap] = [
            Gap(int(r["sample_idx"]), int(r["n_lost"]), float(r["duration_s"]),
                clean_label(attr_text(r["reason"])))
            for r in f["gaps"][()]
        ]
        self.link: dict[str, int] = {k: int(v) for k, v in f["link"].attrs.items()}
        self.crc_failures: list[tuple[int, int]] = [
            (int(r["sample_idx"]), int(r["count"])) for r in f["link/crc_failures"][()]
        ]
        proc = f["processed"].attrs
        self.processed_source = attr_text(proc.get("source", ""))
        self.reprocessed = bool(proc.get("reprocessed", False))
        self.wall_offset_s = float(f["timeline/host_time_s"].attrs.get("wall_offset_s", 0.0))

        stored = stored_datasets(self.mode, self.format_version)
        missing = sorted(p for p in stored if p not in f)
        if missing:
            raise SessionError(f"{name} is damaged: missing {missing[0]}")
        opened = {p: f[p] for p in stored}  # each opened once (~60 us an object)
        for p, ds in opened.items():
            _check_per_sample(name, p, ds)
        # every series readers get, stored or derived (see gaitmon.io.session.codec)
        self.dataset_names: tuple[str, ...] = per_sample_datasets(self.mode)
        lengths = {p: ds.shape[0] for p, ds in opened.items()}
        self.n_samples = min(lengths.values())
        if len(set(lengths.values())) > 1:
            self.problems.append(
                f"datasets have different lengths; using the first {self.n_samples} rows"
            )
        if self.complete and int(scalar(self.attrs.get("n_samples", -1))) != self.n_samples:
            self.problems.append("n_samples attribute does not match the data")
        self.duration_s = float(scalar(self.attrs.get("duration_s", 0.0)))
        if not (self.complete or self.recovered) and self.n_samples:
            # an unfinished file's attribute still says 0: its last row's time says how long
            with contextlib.suppress(OSError, RuntimeError, ValueError, TypeError):
                t_last = float(f["timeline/t_s"][self.n_samples - 1])
                if math.isfinite(t_last):
                    self.duration_s = t_last + 1.0 / self.sample_rate_hz
        if not self.complete and not self.recovered:
            self.problems.append("the recording was not stopped cleanly")
        # the angles every reader gets: the zero-lag smoother's (raw mode; stored in /smoothed,
        # or computed on first read), or the live filter's (see gaitmon.finish.smoothed)
        self.live_angle_method = attr_text(proc.get("tilt_method", "")) or (
            self.config.tilt_method_label if self.mode == "raw" else "the unit's own"
        )
        self.angle_sources: tuple[str, ...] = (
            ANGLE_SOURCES if self.mode == "raw" and self.n_samples else ("live",)
        )
        self.angle_source = self.angle_sources[0]
        self._bias_rows: list[tuple[int, np.ndarray]] | None = None
        self._full_scale: np.ndarray | None = None  # each channel's largest count (raw_counts)
        self.smoothed_stored = stored_smoothed(f, self.n_samples)
        self._smoothed: dict[str, np.ndarray] | None = None
        sm = f.get("smoothed")
        # the stored method's name; a file without /smoothed: the finishing layer's
        self._smoothed_method = (
            attr_text(sm.attrs.get("method", "")) if self.smoothed_stored and sm is not None else ""
        )

    # -- access ----------------------------------------------------------------------------------

    @property
    def header(self) -> SessionHeader:
        known = {c.name for c in CHANNELS}
        try:
            channels = (
                tuple(ChannelSpec(**cast("dict[str, Any]", c)) for c in self.channels)
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
        # the pipeline's event sources, as the registry names them (gaitmon.dsp.events)
        primary, fallback = event_source_label(PRIMARY), event_source_label(FALLBACK)
        if not self.config.fsr_check:
            return f"{primary} (not cross-checked with {fallback})"
        if not self.fsr_faults:
            return f"{primary} (cross-checked with {fallback}: no fault)"
        first = min(self.fsr_faults, key=lambda x: x.decided_idx)
        why = "; ".join(f"{x.sensor} force sensor {x.reason}" for x in self.fsr_faults)
        return (f"{primary}, then {fallback} from "
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

    def with_angles(self, source: str) -> Self:
        """This session reading the angles of ``source`` (see :meth:`use_angles`): a second
        view of the same open file, so readers on other threads can read one source while
        this session reads the other. Close this session, not the view."""
        view = copy.copy(self)
        view.use_angles(source)
        return view

    @property
    def zero_source(self) -> str:
        """Where the angles' zero comes from (gaitmon.dsp.calibration.zero_source)."""
        return zero_source(self.calibration, self.calibration_changes, self.sample_rate_hz,
                           self.mode)  # fmt: skip

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
            self._smoothed = self._computed_smoothed()
        return self._smoothed

    def _computed_smoothed(self) -> dict[str, np.ndarray]:
        """``{"smoothed/tilt_deg": ..., "smoothed/joint_deg": ...}`` of a raw session that does
        not store them: the format stores and reads, it does not run the smoother (the
        finishing layer's session computes them)."""
        raise SessionError(
            f"{self.path.name} does not store its smoothed angles; open it with "
            "gaitmon.finish.open_session, which computes them, or read the live ones"
        )

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
        on slicing (the raw counts: always a view, which checks them, see :meth:`raw_counts`);
        the angle series are those of :attr:`angle_source` (an array if computed in memory)."""
        self._check_name(name)
        path = self._path_of(name)
        if path.startswith("smoothed/") and not self.smoothed_stored:
            return self._smoothed_series()[path]
        if path in self._f and path not in self._derived and path != "raw/adc" and (
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
                    self.raw_counts(a, b), a, self.header.table.to_physical, GYRO_IDX,
                    self._gyro_bias_rows(),
                )  # fmt: skip
            tilt = JOINT_OF[path]
            return _joints_of(f[tilt][a:b], tilt)
        if path == "raw/adc":
            return self.raw_counts(a, b)
        return decode(path, f[path][a:b])

    def raw_counts(self, a: int, b: int) -> np.ndarray:
        """Rows a:b of ``/raw/adc`` as stored, refused (:class:`SessionError`) if a count is
        above what its channel's ADC can give (:func:`gaitmon.io.session.trust.checked_counts`:
        every read of the counts goes through here)."""
        if self._full_scale is None:
            self._full_scale = full_scale_of(self.header.table)
        return checked_counts(self.path.name, self._full_scale, self._f["raw/adc"][a:b], a)

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

    def stored_pyramid(self, name: str) -> PeakPyramid | None:
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
        from gaitmon.io.session.truth import truth_from_file  # simulated sessions only

        try:
            return truth_from_file(self._f, start, stop)
        except (OSError, KeyError, ValueError) as e:
            raise SessionError(f"{self.path.name}: cannot read /truth ({e})") from e

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._f.file.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
