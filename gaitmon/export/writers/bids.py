"""BIDS export: a session as one recording of a Motion-BIDS dataset (BIDS 1.9, ``motion``).

``OUT`` is the dataset folder; one export adds one recording to it::

    OUT/dataset_description.json, README, participants.tsv
    OUT/sub-<label>/[ses-<label>/]motion/
        sub-<label>[_ses-<label>]_task-<label>_tracksys-imuR_motion.tsv  (no header)
        ..._channels.tsv, ..._channels.json, ..._motion.json, ..._gaitmon.json
        sub-<label>[_ses-<label>]_task-<label>_events.tsv, ..._events.json
    OUT/sub-<label>/[ses-<label>/]sub-<label>[_ses-<label>]_scans.tsv    (not de-identified)

Rows of ``_motion.tsv`` are on the regular 1/fs grid that BIDS motion assumes: row k is time
k / fs from the first sample, and every lost frame is a row of ``n/a`` (placed from
``/timeline/t_s``, which counts the lost frames, as the C3D export's frames are). Events
(heel strike, toe off, markers, gaps) are dated on the same grid. A second export into the same
folder adds its participant to ``participants.tsv`` (and its scan to ``scans.tsv``) and
rewrites gaitmon's ``README`` from every recording present; ``dataset_description.json`` and a
study's own README are never replaced (:mod:`.bids_dataset`). The tracking system is the
unit, labelled by its leg (``imuL``/``imuR``, ``imu`` without a side), as in a both-legs
export, so a dataset mixing the two names one unit alike.
Layout: docs/file-format.md, "Export formats" / "BIDS".
"""

from __future__ import annotations

import csv
import io
import json
import re
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gaitmon import __version__
from gaitmon.dsp.channels import SEGMENTS
from gaitmon.export.writers.bids_dataset import (
    GAITMON_SUFFIX,
    bidsignore_text,
    dataset_description,
    is_gaitmon_readme,
    readme_text,
)
from gaitmon.export.writers.bids_labels import BidsOptions
from gaitmon.export.writers.csv_text import CsvColumn, format_block
from gaitmon.export.writers.errors import Cancel, ExportError, Progress, step
from gaitmon.export.writers.source import (
    JOINT_LABELS,
    ExportedGap,
    Source,
    as_text,
    frame_grid,
    gaps,
    json_default,
    json_safe,
    markers,
    session_side,
)
from gaitmon.io.deidentify import Scrubber
from gaitmon.text import spreadsheet_cell
from gaitmon.values import JsonObject, JsonValue, scalar

NA = "n/a"
# the motion channel types with a <TYPE>ChannelCount (every one RECOMMENDED, 0 included)
MOTION_TYPES = ("ACCEL", "ANGACCEL", "GYRO", "JNTANG", "LATENCY", "MAGN", "ORNT", "POS", "VEL")
MANUFACTURER = "gaitmon"  # the unit's design, as the C3D export's COMPANY and LSL's streams say
TSV_CHUNK_FRAMES = 32_768  # rows of _motion.tsv formatted at a time
_ISO_UTC = re.compile(r"\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d{1,6})?Z?")
_SIDE = {"L": "Left", "R": "Right"}
_JOINT_POINT = ("Hip", "Knee", "Ankle")
_PLACE = {"body": "pelvis (hip)", "thigh": "thigh", "shank": "shank (calf)", "foot": "foot"}


def tracksys(side: str) -> str:
    """The tracking system of one unit, by its leg: ``imuL``, ``imuR`` (one leg or both: one
    scheme), ``imu`` when no side was entered. The entity and TrackingSystemName agree."""
    return f"imu{side}" if side in ("L", "R") else "imu"


@dataclass(frozen=True)
class Channel:
    """One column of ``_motion.tsv``: a row of ``_channels.tsv`` and where its values are."""

    name: str
    component: str
    type: str
    tracked_point: str
    units: str
    description: str
    path: str  # the session's per-sample dataset
    column: int  # column of the dataset's rows, flattened
    decimals: int
    status: str = NA
    status_description: str = NA
    placement: str = NA  # where on the body (channels.tsv "placement")
    reference_frame: str = NA  # a level of CHANNELS_JSON["reference_frame"]


def channels(src: Source) -> list[Channel]:
    """The exported channels, in column order: per segment accelerometer x, z and gyro y; the
    heel and toe force sensors; segment tilts; joint angles (those the session's mode has)."""
    side = _SIDE.get(session_side(src), "")
    seg_point = {s: ("Body" if s == "body" else side + s.capitalize()) for s in SEGMENTS}
    leg = f"{side.lower()} " if side else ""
    place = {s: (_PLACE[s] if s == "body" else leg + _PLACE[s]) for s in SEGMENTS}
    angles = src.angles()
    how = f"{angles['source']} angles: {angles['method']}"
    out: list[Channel] = []
    for i, seg in enumerate(SEGMENTS):
        if src.has("processed/acc_ms2"):
            for j, axis in enumerate(("x", "z")):
                out.append(Channel(
                    f"{seg}_acc_{axis}", axis, "ACCEL", seg_point[seg], "m/s^2",
                    f"{seg} accelerometer {axis} (sensor axis, low-passed, calibrated)",
                    "processed/acc_ms2", 2 * i + j, 5, placement=place[seg],
                    reference_frame="sensor"))
        if src.has("processed/gyro_rad_s"):
            out.append(Channel(
                f"{seg}_gyro_y", "y", "GYRO", seg_point[seg], "rad/s",
                f"{seg} gyro rate about the mediolateral axis (calibrated bias removed)",
                "processed/gyro_rad_s", i, 6, placement=place[seg],
                reference_frame="sensor"))
    if src.has("processed/fsr_counts"):
        faults = _fsr_faults(src)
        # "good" only where the foot-gyro cross-check watched the sensor and did not flag it
        checked = bool(src.group_attrs("config").get("fsr_check", False))
        for i, sensor in enumerate(("heel", "toe")):
            status, why = ("good", NA) if checked else (NA, NA)
            if sensor in faults:
                status, why = "bad", faults[sensor]
            # the force on the sole along its normal: component z of the "sole" frame
            out.append(Channel(
                f"{sensor}_fsr", "z", "MISC", side + sensor.capitalize(), "arbitrary",
                f"{sensor} force sensor, low-passed ADC counts (not calibrated to newtons)",
                "processed/fsr_counts", i, 3, status, why,
                placement=f"under the {leg}{'heel' if sensor == 'heel' else 'big toe'}",
                reference_frame="sole"))
    if src.has("processed/tilt_deg"):
        for i, seg in enumerate(SEGMENTS):
            out.append(Channel(
                f"{seg}_tilt", "y", "ORNT", seg_point[seg], "deg",
                f"{seg} sagittal tilt, + counter-clockwise seen from the right, 0 standing "
                f"({how})", "processed/tilt_deg", i, 4, placement=place[seg],
                reference_frame="standing"))
    if src.has("processed/joint_deg"):
        for i, joint in enumerate(JOINT_LABELS):
            out.append(Channel(
                joint, "y", "JNTANG", side + _JOINT_POINT[i], "deg",
                f"{joint.replace('_', ' ')} (+), proximal to distal segment ({how})",
                "processed/joint_deg", i, 4,
                placement=f"{leg}{_JOINT_POINT[i].lower()} joint",
                reference_frame="anatomical"))
    return out


def _fsr_faults(src: Source) -> dict[str, str]:
    """Force sensors the foot-gyro cross-check flagged: sensor -> why, and from when."""
    out: dict[str, str] = {}
    for row in src.table("events/fsr_faults"):
        sensor = as_text(row.get("sensor", ""))
        idx = int(scalar(row.get("sample_idx", 0)))
        out.setdefault(sensor, f"{as_text(row.get('reason', ''))} (flagged from row {idx}; "
                               "events from the foot gyro from there)")
    return out


@dataclass(frozen=True)
class Names:
    """Where one recording goes in the dataset folder."""

    root: Path
    subject: str
    session: str | None
    task: str

    @property
    def folder(self) -> Path:
        sub = self.root / f"sub-{self.subject}"
        return sub if self.session is None else sub / f"ses-{self.session}"

    @property
    def prefix(self) -> str:
        ses = "" if self.session is None else f"_ses-{self.session}"
        return f"sub-{self.subject}{ses}"

    def motion(self, suffix: str, tracksys: str | None) -> Path:
        """``motion/<prefix>_task-<t>_tracksys-<label>_<suffix>``: entities in the BIDS order
        (``tracksys`` None: a file of the recording's every tracking system, no entity)."""
        system = "" if tracksys is None else f"_tracksys-{tracksys}"
        name = f"{self.prefix}_task-{self.task}{system}_{suffix}"
        return self.folder / "motion" / name

    @property
    def scans(self) -> Path:
        return self.folder / f"{self.prefix}_scans.tsv"


class BidsWriter:
    """One BIDS export (a fresh writer per export: it keeps the plan between the calls)."""

    def __init__(self, options: BidsOptions) -> None:
        self.options = options
        self.names: Names | None = None
        self.system = "imu"
        self.finals: list[Path] = []
        self.patient_id = ""

    # -- the FormatWriter contract ----------------------------------------------------------

    def planned_outputs(self, src: Source, scrub: Scrubber, out: Path) -> list[Path]:
        pid = as_text(src.group_attrs("session").get("patient_id", ""))
        names = Names(out, self.options.subject_label(pid), self.options.session_label,
                      self.options.task_label)
        self.options.check_subject_free(out / "participants.tsv", pid)
        self.names = names
        self.patient_id = pid
        self.system = tracksys(session_side(src))
        files = [names.motion(s, self.system) for s in UNIT_FILES]
        files += [names.motion(s, None) for s in ("events.tsv", "events.json")]
        if not scrub.enabled and acq_time(src):
            files.append(names.scans)
        files += dataset_files(out)
        self.finals = files
        return list(files)

    def merges_existing(self, path: Path) -> bool:
        """Files that one export adds to (several recordings share them)."""
        return path.name in ("participants.tsv", "README", ".bidsignore") or path.name.endswith(
            "_scans.tsv")

    def write(self, src: Source, outputs: list[Path], scrub: Scrubber, deidentify: bool,
              progress: Progress | None, cancel: Cancel | None, chunk_rows: int | None) -> None:
        names = self.names
        if names is None or len(outputs) != len(self.finals):
            raise ExportError("BIDS export: planned_outputs must be called first")
        tmp = dict(zip(self.finals, outputs, strict=True))
        chans = channels(src)
        if not chans:
            raise ExportError(f"{src.path.name} has no series to export as BIDS motion channels")
        frame = frame_grid(src, "on BIDS rows")
        n_rows = int(frame[-1]) + 1 if len(frame) else 0
        unit = {s: tmp[names.motion(s, self.system)] for s in UNIT_FILES}
        write_motion_tsv(src, chans, frame, unit["motion.tsv"], progress, cancel,
                         TSV_CHUNK_FRAMES if chunk_rows is None else chunk_rows)
        write_text(unit["channels.tsv"], channels_tsv(src, chans))
        write_json(unit["channels.json"], channels_json(chans))
        sidecar = motion_sidecar(src, chans, n_rows, frame, scrub, names.task, self.system,
                                 effective_rate_hz(src, frame))
        write_json(unit["motion.json"], sidecar)
        write_json(unit[GAITMON_SUFFIX], gaitmon_sidecar(src, scrub, GAITMON_ROWS))
        write_text(tmp[names.motion("events.tsv", None)], events_tsv(events(src, scrub, frame)))
        write_json(tmp[names.motion("events.json", None)], EVENTS_JSON)
        if names.scans in tmp:
            row = {"filename": names.motion("motion.tsv", self.system).relative_to(
                names.folder).as_posix(), "acq_time": acq_time(src)}
            write_text(tmp[names.scans], merge_tsv(names.scans, row))
        write_dataset_files(names, tmp, self.options, [names.motion("motion.json", self.system)],
                            self.patient_id)


UNIT_FILES = ("motion.tsv", "channels.tsv", "channels.json", "motion.json", GAITMON_SUFFIX)
GAITMON_ROWS = ("row k of _motion.tsv is the time k / SamplingFrequency from the first sample; "
                "a lost frame is a row of n/a")


def dataset_files(root: Path) -> list[Path]:
    """The dataset-level files one export writes: participants.tsv and .bidsignore (merged),
    the README (gaitmon's, regenerated; a study's own is kept), dataset_description.json (only
    when absent: a dataset's own description is never replaced)."""
    files = [root / "participants.tsv", root / ".bidsignore"]
    readme = root / "README"
    if not readme.exists() or is_gaitmon_readme(readme):
        files.append(readme)
    if not (root / "dataset_description.json").exists():
        files.append(root / "dataset_description.json")
    return files


def write_dataset_files(names: Names, tmp: dict[Path, Path], options: BidsOptions,
                        planned_motion: list[Path], patient_id: str) -> None:
    root = names.root
    # the session's row (with its patient id's hash when the label is made from it, so a
    # later export can refuse another patient's id that gives the same label)
    write_text(tmp[root / "participants.tsv"],
               merge_tsv(root / "participants.tsv", options.participant_row(patient_id)))
    write_text(tmp[root / ".bidsignore"], bidsignore_text(root / ".bidsignore"))
    if root / "README" in tmp:
        write_text(tmp[root / "README"], readme_text(root, planned_motion))
    if root / "dataset_description.json" in tmp:
        write_json(tmp[root / "dataset_description.json"], dataset_description(options))


def configure(options: Mapping[str, object] | None) -> BidsWriter:
    """The writer of one export (the BIDS plugin, :mod:`gaitmon.export.bids`, asks for it)."""
    return BidsWriter(BidsOptions.from_mapping(options))


# ---- _motion.tsv ----------------------------------------------------------------------------


# reader(f0, f1) -> read(path): a series on grid rows [f0, f1), (f1 - f0, columns), NaN missing
GridReader = Callable[[int, int], Callable[[str], np.ndarray]]


def write_motion_tsv(src: Source, chans: list[Channel], frame: np.ndarray, out: Path,
                     progress: Progress | None, cancel: Cancel | None, chunk: int) -> None:
    """Rows on the 1/fs grid, ``chunk`` grid rows at a time (memory does not grow with the
    session); a lost frame, or a value that is not finite, is ``n/a``."""

    def placed(f0: int, f1: int) -> Callable[[str], np.ndarray]:
        r0, r1 = (int(i) for i in np.searchsorted(frame, [f0, f1]))

        def read(path: str) -> np.ndarray:
            rows = np.asarray(src.read(path, r0, r1)).reshape(r1 - r0, -1)
            v = np.full((f1 - f0, rows.shape[1]), np.nan)
            v[frame[r0:r1] - f0] = rows.astype(np.float64)
            return v

        return read

    n_rows = int(frame[-1]) + 1 if len(frame) else 0
    write_grid_tsv(chans, n_rows, placed, out, progress, cancel, chunk)


def write_grid_tsv(chans: list[Channel], n_rows: int, reader: GridReader, out: Path,
                   progress: Progress | None, cancel: Cancel | None, chunk: int) -> None:
    """``n_rows`` rows of ``chans``, read by ``reader`` ``chunk`` rows at a time; a value that
    is not finite is ``n/a``."""
    paths = list(dict.fromkeys(c.path for c in chans))
    with open(out, "wb") as f:
        for f0 in range(0, n_rows, max(1, chunk)):
            f1 = min(n_rows, f0 + max(1, chunk))
            read = reader(f0, f1)
            blocks = {p: read(p) for p in paths}
            cols = []
            for c in chans:
                x = blocks[c.path][:, c.column]
                cols.append(CsvColumn(np.where(np.isfinite(x), x, np.nan), c.decimals))
            f.write(_tsv_lines(format_block(cols)))
            step(progress, cancel, f1 / n_rows)
    if n_rows == 0:
        step(progress, cancel, 1.0)


def _tsv_lines(block: bytes) -> bytes:
    """format_block's CSV lines (each ending in an empty last cell) as TSV with ``n/a``.
    Numbers never contain a comma, and ``nan`` is only ever a whole cell."""
    return block.replace(b",\n", b"\n").replace(b",", b"\t").replace(b"nan", NA.encode())


# ---- _channels.tsv, _motion.json --------------------------------------------------------------

CHANNEL_COLUMNS = ("name", "component", "type", "tracked_point", "units", "placement",
                   "reference_frame", "sampling_frequency", "status", "status_description",
                   "description")
# the reference frames of channels.tsv, described in _channels.json. A unit is planar: its
# sensor axes are x, z in the sagittal plane and y along the hinge, and how they sit on the body
# depends on how the band was put on, so no SpatialAxes (the spec's F/B/L/R/U/D letters, the
# legacy validator's A/P/L/R/S/I) can be given; RotationOrder has no meaning for one axis.
# "n/a" is left out rather than written: the legacy validator's enums do not have it.
REFERENCE_FRAMES: dict[str, JsonObject] = {
    "sensor": {"Description": "the sensor board's own axes: x and z in the sagittal plane, y "
                              "along the mediolateral hinge axis; their direction on the body "
                              "depends on how the board is worn (back, side or front)",
               "RotationRule": "right-hand"},
    "standing": {"Description": "rotation about the mediolateral axis from the standing pose "
                                "zeroed at the start (0 = upright), + counter-clockwise seen "
                                "from the subject's right",
                 "RotationRule": "right-hand"},
    "anatomical": {"Description": "sagittal joint angle between the proximal and distal "
                                  "segments' standing-pose tilts, clinical sign (flexion, "
                                  "dorsiflexion +)"},
    "sole": {"Description": "the sole of the foot: z is its normal, along which the force "
                            "sensor is loaded"},
}  # fmt: skip


def channels_json(chans: list[Channel]) -> JsonObject:
    """``_channels.json``: the reference frames the channels use."""
    used = dict.fromkeys(c.reference_frame for c in chans if c.reference_frame != NA)
    return {"reference_frame": {"Description": "the frame a channel's values are in",
                                "Levels": {k: REFERENCE_FRAMES[k] for k in used}}}


def channels_tsv(src: Source, chans: list[Channel]) -> str:
    rows = ["\t".join(CHANNEL_COLUMNS)]
    for c in chans:
        cells = (c.name, c.component, c.type, c.tracked_point, c.units, c.placement,
                 c.reference_frame, f"{src.fs_hz:g}", c.status, c.status_description,
                 c.description)
        rows.append("\t".join(tsv_cell(x) for x in cells))
    return "\n".join(rows) + "\n"


def effective_rate_hz(src: Source, frame: np.ndarray) -> float | str:
    """Rows of ``_motion.tsv`` per second of the recording computer's clock: a straight-line
    fit of the frames' host receive times (``/timeline/host_time_s``) against their grid
    frames (lost frames counted); ``n/a`` without usable receive times."""
    if len(frame) < 2 or not src.has("timeline/host_time_s"):
        return NA
    host = np.asarray(src.read("timeline/host_time_s"), np.float64)
    x = frame.astype(np.float64)
    if len(host) != len(x) or not np.all(np.isfinite(host)) or x[-1] <= x[0]:
        return NA
    slope = float(np.polyfit(x - x[0], host - host[0], 1)[0])
    return round(1.0 / slope, 6) if slope > 0 else NA


def motion_sidecar(src: Source, chans: list[Channel], n_rows: int, frame: np.ndarray,
                   scrub: Scrubber, task: str, system: str,
                   effective: float | str) -> JsonObject:
    """``_motion.json``: BIDS fields only (gaitmon's own are in :func:`gaitmon_sidecar`)."""
    device = scrub.device(src.group_attrs("device"))
    counts = Counter(c.type for c in chans)
    lost = n_rows - len(frame)
    n_gaps = int(np.count_nonzero(np.diff(frame) > 1)) if len(frame) else 0
    fields: JsonObject = {
        "TaskName": task,
        "TaskDescription": "gait recorded with a gaitmon wearable unit (planar IMUs on body, "
                           "thigh, shank and foot; heel and toe force sensors)",
        "SamplingFrequency": src.fs_hz,
        "SamplingFrequencyEffective": effective,
        "TrackingSystemName": system,
        "Manufacturer": MANUFACTURER,
        "ManufacturersModelName": as_text(device.get("name", "")) or NA,
        "SoftwareVersions": f"firmware {as_text(device.get('firmware', '')) or NA}; recorded "
                            f"by gaitmon {as_text(src.attrs.get('software_version', '')) or NA};"
                            f" exported by gaitmon {__version__}",
        "RecordingDuration": n_rows / src.fs_hz,
        "MotionChannelCount": len(chans),
        **{f"{t}ChannelCount": counts[t] for t in MOTION_TYPES},
        "MiscChannelCount": counts["MISC"],
        "TrackedPointsCount": len({c.tracked_point for c in chans}),
        "MissingValues": NA,
        "SubjectArtefactDescription": (
            f"{lost} lost frames ({n_gaps} gaps) are rows of n/a in _motion.tsv (row k is "
            f"at k / {src.fs_hz:g} s) and 'gap' events" if lost else NA),
    }
    side = {k: json_safe(v) for k, v in fields.items()}
    serial = device.get("serial", "")
    if not scrub.enabled and as_text(serial).strip():
        side["DeviceSerialNumber"] = as_text(serial)
    return scrub.mapping(side)


def gaitmon_sidecar(src: Source, scrub: Scrubber, rows: str,
                    **more: JsonValue) -> JsonObject:
    """``_gaitmon.json``: gaitmon's own metadata of one tracking system (not BIDS fields;
    ``.bidsignore`` lists these files)."""
    angles = src.angles()
    fields: JsonObject = {
        "mode": src.mode,
        "angles": {**angles, "convention": as_text(src.attrs.get("angle_convention", ""))},
        "rows": rows,
        **more,
    }
    return scrub.mapping({k: json_safe(v) for k, v in fields.items()})


# ---- events -----------------------------------------------------------------------------------

EVENTS_COLUMNS = ("onset", "duration", "trial_type", "sample", "label")

EVENTS_JSON: JsonObject = {
    "onset": {"Description": "time of the event from the first row of _motion.tsv "
                             "(= sample / SamplingFrequency)", "Units": "s"},
    "duration": {"Description": "0 for instantaneous events; for a gap, the time lost "
                                "(its n/a rows / SamplingFrequency)", "Units": "s"},
    "trial_type": {
        "Description": "kind of event",
        "Levels": {
            "heel_strike": "initial contact (heel strike), dated at the estimated true contact",
            "toe_off": "final contact (toe off)",
            "marker": "a marker the clinician set during the recording (text in label)",
            "gap": "frames lost by the link: the rows of _motion.tsv from sample on for "
                   "duration are n/a",
        },
    },
    "sample": {"Description": "0-based row of _motion.tsv at onset (first n/a row of a gap)"},
    "label": {"Description": "marker text, or the reason frames were lost (gap); n/a otherwise"},
}


@dataclass(frozen=True)
class Event:
    onset_s: float
    duration_s: float
    trial_type: str
    sample: int | None
    label: str


def events(src: Source, scrub: Scrubber, frame: np.ndarray) -> list[Event]:
    """Heel strikes, toe offs, markers and gaps on the grid of ``_motion.tsv``, by onset."""
    fs = src.fs_hz
    out: list[Event] = []
    for kind in ("heel_strike", "toe_off"):
        out += [Event(int(frame[r]) / fs, 0.0, kind, int(frame[r]), NA)
                for r in src.events(kind).tolist()]
    for mk in markers(src, scrub):
        r = int(frame[mk["sample_idx"]])
        out.append(Event(r / fs, 0.0, "marker", r, tsv_cell(mk["label"])))
    by_row: dict[int, list[ExportedGap]] = {}
    for g in gaps(src, scrub):
        by_row.setdefault(g["sample_idx"], []).append(g)
    for row, gs in by_row.items():
        reason = tsv_cell(" | ".join(dict.fromkeys(g["reason"] for g in gs)))
        if 0 < row < src.n:
            first = int(frame[row - 1]) + 1
            out.append(Event(first / fs, (int(frame[row]) - first) / fs, "gap", first, reason))
        else:  # before the first row or after the last one: no rows of the file are n/a
            lost_s = float(sum(g["duration_s"] for g in gs if np.isfinite(g["duration_s"])))
            at = 0.0 if row == 0 else (int(frame[-1]) + 1) / fs if len(frame) else 0.0
            out.append(Event(at - lost_s if row == 0 else at, lost_s, "gap", None, reason))
    order = {"gap": 0, "heel_strike": 1, "toe_off": 2, "marker": 3}
    return sorted(out, key=lambda e: (e.onset_s, order[e.trial_type]))


def events_tsv(evs: list[Event]) -> str:
    rows = ["\t".join(EVENTS_COLUMNS)]
    for e in evs:
        rows.append("\t".join((f"{e.onset_s:.6f}", f"{e.duration_s:.6f}", e.trial_type,
                               NA if e.sample is None else str(e.sample), e.label)))
    return "\n".join(rows) + "\n"


# ---- dataset-level files ----------------------------------------------------------------------


def acq_time(src: Source) -> str:
    """The recording's start as a BIDS date-time, or "" if the file has none usable."""
    created = as_text(src.attrs.get("created_utc", "")).strip()
    return created if _ISO_UTC.fullmatch(created) else ""


def merge_tsv(path: Path, row: dict[str, str], *more: dict[str, str]) -> str:
    """``path``'s rows plus ``row`` (and ``more``; each replacing the row with the same first
    cell), sorted; columns are the file's (a new column is added, ``n/a`` where unknown)."""
    columns = list(row)
    rows: dict[str, dict[str, str]] = {}
    if path.exists():
        try:
            with open(path, encoding="utf-8", newline="") as f:
                reader = csv.DictReader(f, delimiter="\t")
                have = [c for c in reader.fieldnames or () if c]
                if not have or have[0] != columns[0]:
                    raise ExportError(f"{path} does not start with a {columns[0]} column")
                columns = have + [c for c in columns if c not in have]
                for r in reader:
                    key = r.get(columns[0]) or ""
                    if key:
                        rows[key] = {c: (r.get(c) or NA) for c in have}
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            raise ExportError(f"cannot read {path}: {exc}") from None
    for r in (row, *more):
        rows[r[columns[0]]] = r
    buf = io.StringIO()
    buf.write("\t".join(columns) + "\n")
    for key in sorted(rows):
        buf.write("\t".join(tsv_cell(rows[key].get(c, NA)) for c in columns) + "\n")
    return buf.getvalue()


def tsv_cell(text: str) -> str:
    """A TSV cell: no tabs or line breaks; ``n/a`` for an empty one; text a spreadsheet will
    not run as a formula (``gaitmon.text.spreadsheet_cell``)."""
    text = re.sub(r"[\t\r\n]+", " ", str(text)).strip()
    return spreadsheet_cell(text) or NA


def write_text(path: Path, text: str) -> None:
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write(text)


def write_json(path: Path, data: JsonValue) -> None:
    with open(path, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=2, ensure_ascii=False, default=json_default)
        f.write("\n")
