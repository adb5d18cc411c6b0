"""The session file's layout: format name and version, modes, dataset paths, dtypes, chunking.

One table says which per-sample datasets a session of each mode holds (``docs/file-format.md``);
the writer, the recovery and the reader all take names and dtypes from here.

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

import h5py
import numpy as np

FORMAT = "gaitmon-session"
FORMAT_VERSION = 1
MODES = ("raw", "tilt", "joint")
CHUNK_ROWS = 4096
_TABLE_CHUNK_ROWS = 256
_EVENT_CHUNK_ROWS = 1024
_RECOVERY_CHUNK_ROWS = 1 << 16

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
    # force sensors the foot-gyro cross-check flagged (gaitmon.dsp.fsr_check): the row from
    # which the fault is known (events come from the foot gyro from there on), the first row
    # of the failing strides, the sensor (heel | toe) and what it did
    "events/fsr_faults": np.dtype(
        [("sample_idx", "<i8"), ("stride_start_idx", "<i8"), ("sensor", _STR), ("reason", _STR)]
    ),
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


def _field_names(dtype: np.dtype) -> tuple[str, ...]:
    """The field names of a structured dtype (numpy's ``.names`` is None for plain ones)."""
    names = dtype.names
    assert names is not None, f"{dtype} is not a structured dtype"
    return names
