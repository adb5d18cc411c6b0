"""CF-style attributes on every dataset of a session file: what a reader without gaitmon needs.

A format-2 file stores its angles as int16 centidegrees (:mod:`.codec`); without these
attributes h5py, MATLAB's ``h5read`` or HDFView show integers like 444 with no unit, scale or
column names. Each dataset gaitmon writes carries (after the CF conventions, cfconventions.org):

* ``units`` - a UDUNITS string (``degree``, ``s``, ``m``, ``m s-2``, ``rad s-1``, ``1`` for
  counts, indices and flags) of the *physical* value;
* ``scale_factor`` (float64) - only on a quantised series: physical = stored x scale_factor
  (no series has an offset, so there is no ``add_offset``);
* ``_FillValue`` and ``missing_value`` (the dataset's own dtype) - where a stored value is a
  sentinel for "no value" (the integer minimum of a quantised series; -1 of an index);
* ``long_name`` - what it is, in words;
* ``columns`` - the labels of axis 1 (``body thigh shank foot``), ``components`` those of
  axis 2 (``acc_ms2``'s ``x z``);
* ``flag_values`` / ``flag_meanings`` (or ``flag_masks``) - of a state or flag series;
* ``field_units`` - of a compound table, one per field in the dtype's order.

The groups whose series a format-2 file derives on read instead of storing them
(``/processed``, ``/smoothed``) say which (``derived_on_read``) and how (``derivation``).

Attributes only describe: values, dtypes and chunks are unchanged, and readers that do not
know them ignore them (the format's rule for additions, so no new format version). Written
when a dataset is created (the writer, recovery, ``/smoothed``, ``/strides``, ``/overview``,
``/truth``, reprocessing, the two-leg combine) by :func:`describe`, which may run again at any
time: it sets the attributes of whatever the unit's layout holds.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

import h5py
import numpy as np

from gaitmon.dsp.channel_table import FSR_SENSORS, JOINT_TABLE, SEGMENTS
from gaitmon.dsp.gait import PHASE_NAMES
from gaitmon.dsp.stride_flags import FLAG_REASONS
from gaitmon.io.session.codec import CENTIDEG, JOINT_OF, RESOLUTION, derived
from gaitmon.io.session.series import attr_text

JOINTS = tuple(f"{j.name}_{j.motion}" for j in JOINT_TABLE)  # hip_flexion, ...
_ROW_INDEX = "row index (0-based) into the per-sample datasets"


@dataclass(frozen=True)
class Spec:
    """The attributes of one dataset (empty fields are not written)."""

    long_name: str
    units: str = ""
    columns: tuple[str, ...] = ()
    components: tuple[str, ...] = ()
    missing: int | None = None  # a sentinel of an exact (not quantised) integer dataset
    flag_values: tuple[int, ...] = ()
    flag_masks: tuple[int, ...] = ()
    flag_meanings: tuple[str, ...] = ()
    field_units: tuple[str, ...] = ()


def _words(names: Iterable[str]) -> tuple[str, ...]:
    # CF flag_meanings are blank-separated words of letters, digits and underscores
    return tuple("_".join(re.findall(r"[A-Za-z0-9]+", n)) for n in names)


_TILT = "sagittal tilt of each segment, positive counter-clockwise seen from the right"
_JOINT = "joint angle, clinical signs (hip and knee flexion +, ankle dorsiflexion +)"

# path relative to a unit's root -> its attributes (quantisation is added from codec.RESOLUTION)
SPECS: dict[str, Spec] = {
    "timeline/seq": Spec("the unit's sequence number, unwrapped", "1"),
    "timeline/host_time_s": Spec(
        "host monotonic clock when the sample's bytes arrived (wall clock = this + "
        "attribute wall_offset_s)", "s"),
    "timeline/t_s": Spec("true sample time from the session start", "s"),
    "raw/adc": Spec(
        "ADC counts; physical = (counts * vref_v / 2**adc_bits - zero_v) / "
        "sensitivity_v_per_unit of the column's row of /device/channels", "1"),
    "processed/tilt_deg": Spec(f"{_TILT} (causal Kalman filter)", "degree", SEGMENTS),
    "processed/tilt_acc_deg": Spec(f"{_TILT} (accelerometer)", "degree", SEGMENTS),
    "processed/tilt_gyro_deg": Spec(f"{_TILT} (integrated gyro)", "degree", SEGMENTS),
    "processed/joint_deg": Spec(f"{_JOINT} (causal Kalman filter)", "degree", JOINTS),
    "processed/joint_acc_deg": Spec(f"{_JOINT} (accelerometer tilts)", "degree", JOINTS),
    "processed/joint_gyro_deg": Spec(f"{_JOINT} (gyro tilts)", "degree", JOINTS),
    "processed/acc_ms2": Spec("low-passed acceleration per segment", "m s-2", SEGMENTS,
                              ("x", "z")),
    "processed/gyro_rad_s": Spec("sagittal angular rate, calibrated bias removed", "rad s-1",
                                 SEGMENTS),
    "processed/fsr_counts": Spec("low-passed force sensor (ADC counts)", "1", FSR_SENSORS),
    "processed/heel_loaded": Spec("heel contact state (lags its event by 8 samples)", "1",
                                  flag_values=(0, 1), flag_meanings=("unloaded", "loaded")),
    "processed/toe_loaded": Spec("toe contact state (lags its event by 8 samples)", "1",
                                 flag_values=(0, 1), flag_meanings=("unloaded", "loaded")),
    "processed/phase": Spec("gait phase (lags its event by 8 samples)", "1",
                            flag_values=tuple(range(len(PHASE_NAMES))),
                            flag_meanings=_words(PHASE_NAMES)),
    "smoothed/tilt_deg": Spec(f"{_TILT} (RTS smoother, zero lag)", "degree", SEGMENTS),
    "smoothed/joint_deg": Spec(f"{_JOINT} (RTS smoother, zero lag)", "degree", JOINTS),
    "events/heel_strike": Spec(f"heel strike: {_ROW_INDEX}", "1"),
    "events/toe_off": Spec(f"toe off: {_ROW_INDEX}", "1"),
    "events/fsr_faults": Spec("force sensors the foot-gyro check flagged",
                              field_units=("1", "1", "", "")),
    "markers": Spec("clinician and LSL markers", field_units=("1", "s", "")),
    "gaps": Spec("frames lost before a row", field_units=("1", "1", "s", "")),
    "link/crc_failures": Spec("cumulative CRC failures at a row", field_units=("1", "1")),
    "config/changes": Spec("settings changes (JSON) in force from a row", field_units=("1", "")),
    "calibration/changes": Spec("calibrations (JSON) in force from a row",
                                field_units=("1", "")),
    "device/channels": Spec(
        "the ADC channels: physical = (counts * vref_v / 2**adc_bits - zero_v) / "
        "sensitivity_v_per_unit", field_units=("1", "", "", "", "", "1", "V", "V", "")),
    "strides/heel_strike_idx": Spec(f"heel strikes the strides run between: {_ROW_INDEX}", "1"),
    "strides/stride_length_m": Spec("stride length (foot IMU), heel strike j to j + 1", "m"),
    "strides/foot_clearance_m": Spec("foot clearance of stride j (foot IMU)", "m"),
    "strides/foot_flat_idx": Spec(f"foot-flat anchors of stride j: {_ROW_INDEX}", "1",
                                  ("start", "stop"), missing=-1),
    "strides/flag": Spec("why a stride's measures are missing or untrusted", "1",
                         flag_masks=tuple(FLAG_REASONS),
                         flag_meanings=_words(FLAG_REASONS.values())),
    "truth/sample_idx": Spec("the simulator's sample of each row", "1", missing=-1),
    "truth/tilt_deg": Spec(f"true {_TILT} (no mounting offset)", "degree", SEGMENTS),
    "truth/joint_deg": Spec(f"true {_JOINT}", "degree", JOINTS),
    "truth/gyro_bias_rad_s": Spec("true gyro bias", "rad s-1", SEGMENTS),
    "truth/heel_strike": Spec(f"true heel strike: {_ROW_INDEX}", "1"),
    "truth/toe_off": Spec(f"true toe off: {_ROW_INDEX}", "1"),
    "truth/stride_length_m": Spec("true stride length of the stride a heel strike opens", "m"),
    "truth/stride_time_s": Spec("true stride time of the stride a heel strike opens", "s"),
    "truth/foot_clearance_m": Spec("true foot clearance of the stride a heel strike opens", "m"),
}
for _src, _prefix in (("processed_joint_deg", "processed"), ("smoothed_joint_deg", "smoothed")):
    for _k in ("min", "max"):
        SPECS[f"overview/{_src}/{_k}"] = Spec(
            f"{_k} of /{_prefix}/joint_deg over each 16 rows (attribute base_step)", "degree",
            JOINTS)
# overview bins are int16 centidegrees like the angles they summarise
_CENTIDEG_ALSO = tuple(p for p in SPECS if p.startswith("overview/"))

DERIVATION = (
    "joint_deg = (hip_flexion, knee_flexion, ankle_dorsiflexion) = (thigh - body, thigh - shank, "
    "foot - shank) of tilt_deg, each wrapped to (-180, 180] degree (joint_acc_deg from "
    "tilt_acc_deg, joint_gyro_deg from tilt_gyro_deg, the same way); gyro_rad_s = the gyro "
    "columns of /raw/adc in physical units (/device/channels) minus the calibration's "
    "gyro_bias_rad_s in force at the row (/calibration, then /calibration/changes)"
)
SYNC_FIELD_UNITS = ("s", "s", "s", "1")


def _version(root: h5py.Group) -> int:
    return int(root.attrs.get("format_version", root.file.attrs.get("format_version", 1)))


def _set(obj: h5py.HLObject, key: str, value: object, dtype: object = None) -> None:
    """Set one attribute of a dataset or group, leaving one that already holds the value as it
    is: describing runs at every step that adds a dataset, and rewriting an attribute in place
    of itself costs object-header space in HDF5's earliest file format (measured: the
    metadata of tests/test_session_storage.py's walk grew 31 KB instead of 18 KB)."""
    if isinstance(value, tuple) and value and isinstance(value[0], str):
        value, dtype = list(value), h5py.string_dtype("utf-8")
    if key in obj.attrs:
        old = obj.attrs[key]
        if isinstance(old, bytes):
            old = old.decode("utf-8")
        a, b = np.asarray(old, dtype=object), np.asarray(value, dtype=object)
        if a.shape == b.shape and np.array_equal(a, b):
            return
    if dtype is None:
        obj.attrs[key] = value
    else:
        obj.attrs.create(key, value, dtype=dtype)


def describe_dataset(ds: h5py.Dataset, path: str, version: int, columns: tuple[str, ...] = ()
                     ) -> None:
    """Set the attributes of the dataset ``ds`` holding the series ``path`` (unit-relative)."""
    spec = SPECS[path]
    _set(ds, "long_name", spec.long_name)
    if spec.units:
        _set(ds, "units", spec.units)
    cols = columns or spec.columns
    if cols and ds.ndim >= 2 and ds.shape[1] == len(cols):
        _set(ds, "columns", cols)
    if spec.components and ds.ndim >= 3 and ds.shape[2] == len(spec.components):
        _set(ds, "components", spec.components)
    quantised = ds.dtype.kind in "iu" and (
        (version >= 2 and path in RESOLUTION) or path in _CENTIDEG_ALSO
    )
    missing: int | None = None
    if quantised:
        res = RESOLUTION[path][1] if path in RESOLUTION else CENTIDEG
        _set(ds, "scale_factor", np.float64(res))
        missing = int(np.iinfo(ds.dtype).min)
    elif spec.missing is not None and ds.dtype.kind in "iu":
        missing = spec.missing
    if missing is not None:
        _set(ds, "_FillValue", missing, ds.dtype)
        _set(ds, "missing_value", missing, ds.dtype)
    if spec.flag_values:
        _set(ds, "flag_values", np.asarray(spec.flag_values), ds.dtype)
    if spec.flag_masks:
        _set(ds, "flag_masks", np.asarray(spec.flag_masks), ds.dtype)
    if spec.flag_meanings:
        _set(ds, "flag_meanings", " ".join(spec.flag_meanings))
    names = ds.dtype.names
    if spec.field_units and names is not None and len(spec.field_units) == len(names):
        _set(ds, "field_units", spec.field_units)


_held: ContextVar[bool] = ContextVar("gaitmon_describe_held", default=False)


@contextmanager
def described_once(root: h5py.Group) -> Iterator[None]:
    """Within the block, :func:`describe` holds off; at its end (not after an error) it
    describes ``root`` once. A command that adds datasets in steps, each of which describes
    what it wrote when run alone (the smoothed series, the strides, the overview), pays for one
    pass over the file's attributes (~15 ms on any file) instead of one a step."""
    token = _held.set(True)
    try:
        yield
    finally:
        _held.reset(token)
    describe(root)


def describe(root: h5py.Group) -> None:
    """Set the attributes of every dataset of the unit whose layout is rooted at ``root`` (a
    one-unit file, or a two-leg file's ``/units/<side>``), and of the groups that derive
    series on read. A two-leg file's root also gets ``/sync``'s and each unit's. Held within
    :func:`described_once`."""
    if _held.get():
        return
    if "units" in root and isinstance(root["units"], h5py.Group):
        for unit in root["units"].values():
            if isinstance(unit, h5py.Group):
                describe(unit)
        for side in root.get("sync", {}):
            g = root["sync"][side]
            if isinstance(g, h5py.Group) and "segments" in g:
                _set(g["segments"], "long_name",
                     "the unit's clock fit, one row per minute (docs/file-format.md)")
                _set(g["segments"], "field_units", SYNC_FIELD_UNITS)
        return
    version = _version(root)
    adc_columns: tuple[str, ...] = ()
    if "device/channels" in root:
        names = root["device/channels"].fields("name")[()] if len(root["device/channels"]) else []
        adc_columns = tuple(attr_text(n) for n in names)
    for path in SPECS:
        obj = root.get(path)
        if isinstance(obj, h5py.Dataset):
            describe_dataset(obj, path, version, adc_columns if path == "raw/adc" else ())
    if version >= 2:
        mode = str(root.attrs.get("mode", root.file.attrs.get("mode", "")))
        for group in ("processed", "smoothed"):
            g = root.get(group)
            names = sorted(p.split("/")[1] for p in derived(mode, version)
                           if p.startswith(group + "/"))  # fmt: skip
            if group == "smoothed":
                names = sorted(p.split("/")[1] for p in JOINT_OF if p.startswith("smoothed/"))
            if isinstance(g, h5py.Group) and names:
                _set(g, "derived_on_read", tuple(names))
                _set(g, "derivation", DERIVATION)
