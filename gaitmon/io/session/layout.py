"""The session file's layout: format name and version, modes, dataset paths, dtypes, chunking.

One table says which per-sample datasets a session of each mode holds (``docs/file-format.md``);
the writer, the recovery and the reader all take names and dtypes from here.

Chunking. Per-sample datasets use chunks of :data:`CHUNK_ROWS` = 4096 rows (41 s at 100 Hz):
an 8-hour session (2.88 M rows) is ~700 chunks per dataset (a small chunk index, fast to
open), and a typical review window of 10-60 s touches one or two chunks per dataset.

Format 2 (written now) compresses every per-sample dataset (shuffle + gzip, built into every
HDF5 library) and stores the processed floats quantised, the joint angles and gyro rate derived
(:mod:`gaitmon.io.session.codec`): ~49 bytes a row instead of ~224. A compressed chunk is
written once, whole: the writer stages the rows of the chunk being filled in memory (the
journal holds them meanwhile, see :mod:`gaitmon.io.session.writer`). Format 1 (uncompressed
float32, each flush writing its rows in place) is still read everywhere. Both use the default
(earliest) HDF5 file-format version, for the oldest readers.
"""

from __future__ import annotations

import h5py
import numpy as np

from gaitmon.dsp.channel_table import N_CHANNELS, N_FSR, N_JOINTS, N_SEGMENTS, joint_convention

FORMAT = "gaitmon-session"
FORMAT_VERSION = 2  # what this gaitmon writes; it reads every version up to it
# chunk cache of a reader, per dataset: ~30 decoded 4096-row chunks (format 2 chunks are
# compressed: a pan over rows read a moment ago must not decode them again)
READER_CHUNK_CACHE_BYTES = 4 << 20
MODES = ("raw", "tilt", "joint")
CHUNK_ROWS = 4096
_TABLE_CHUNK_ROWS = 256
_EVENT_CHUNK_ROWS = 1024
_RECOVERY_CHUNK_ROWS = 1 << 16

ANGLE_CONVENTION = (
    "Segment tilts are sagittal, positive counter-clockwise seen from the subject's right side, "
    f"zero in the upright standing calibration pose. {joint_convention()}; every difference "
    "wrapped to (-180, 180] degrees."
)

_F4 = np.dtype("<f4")
_STR = h5py.string_dtype("utf-8")

# path -> (row shape, dtype, modes it is present in); per the table in docs/file-format.md
_PER_SAMPLE: dict[str, tuple[tuple[int, ...], np.dtype, frozenset[str]]] = {
    "timeline/seq": ((), np.dtype("<i8"), frozenset(MODES)),
    "timeline/host_time_s": ((), np.dtype("<f8"), frozenset(MODES)),
    "timeline/t_s": ((), np.dtype("<f8"), frozenset(MODES)),
    "raw/adc": ((N_CHANNELS,), np.dtype("<u2"), frozenset({"raw"})),
    "processed/tilt_deg": ((N_SEGMENTS,), _F4, frozenset({"raw", "tilt"})),
    "processed/tilt_acc_deg": ((N_SEGMENTS,), _F4, frozenset({"raw", "tilt"})),
    "processed/tilt_gyro_deg": ((N_SEGMENTS,), _F4, frozenset({"raw"})),
    "processed/joint_deg": ((N_JOINTS,), _F4, frozenset(MODES)),
    "processed/joint_acc_deg": ((N_JOINTS,), _F4, frozenset(MODES)),
    "processed/joint_gyro_deg": ((N_JOINTS,), _F4, frozenset({"raw"})),
    "processed/acc_ms2": ((N_SEGMENTS, 2), _F4, frozenset({"raw"})),
    "processed/gyro_rad_s": ((N_SEGMENTS,), _F4, frozenset({"raw"})),
    "processed/fsr_counts": ((N_FSR,), _F4, frozenset({"raw"})),
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
# link totals written to /link only when not 0 (a file without one had none of them)
LINK_TOTALS_IF_ANY = ("implausible_frames",)

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
    """The per-sample series a session of this mode holds, in a fixed order (what readers
    get, whether the file stores them or derives them: see :func:`stored_datasets`)."""
    return tuple(p for p, (_, _, modes) in _PER_SAMPLE.items() if mode in modes)


def stored_datasets(mode: str, version: int = FORMAT_VERSION) -> tuple[str, ...]:
    """The per-sample datasets a file of this mode and format version stores (format 2
    derives the joint angles and the gyro rate on read: :mod:`gaitmon.io.session.codec`)."""
    from gaitmon.io.session.codec import derived

    skip = derived(mode, version)
    return tuple(p for p in per_sample_datasets(mode) if p not in skip)


def stored_dtype(path: str, version: int = FORMAT_VERSION) -> np.dtype:
    """The dtype a per-sample dataset is stored as (format 2 quantises the processed floats)."""
    from gaitmon.io.session.codec import RESOLUTION

    if version >= 2 and path in RESOLUTION:
        return RESOLUTION[path][0]
    return _PER_SAMPLE[path][1]


def resolution(version: int = FORMAT_VERSION) -> dict[str, float]:
    """Per-sample series stored quantised -> their resolution (in the series' unit): what a
    reader of this format version gets within +- half of it. Format 1 stores float32."""
    from gaitmon.io.session.codec import RESOLUTION

    return {p: res for p, (_, res) in RESOLUTION.items()} if version >= 2 else {}


def _field_names(dtype: np.dtype) -> tuple[str, ...]:
    """The field names of a structured dtype (numpy's ``.names`` is None for plain ones)."""
    names = dtype.names
    assert names is not None, f"{dtype} is not a structured dtype"
    return names


# the live series a smoothed one stands in for (``/smoothed``: computed by gaitmon.finish.smoothed)
SMOOTHED: dict[str, str] = {
    "processed/tilt_deg": "smoothed/tilt_deg",
    "processed/joint_deg": "smoothed/joint_deg",
}
ANGLE_SOURCES = ("smoothed", "live")


def stored_smoothed(f: h5py.File | h5py.Group, n_samples: int) -> bool:
    """Whether ``f`` holds a complete ``/smoothed`` for its ``n_samples`` rows (format 2
    stores the tilts only: the joint angles are derived from them)."""
    from gaitmon.io.session.codec import JOINT_OF

    v2 = int(f.attrs.get("format_version", 1)) >= 2
    return all(
        p in f and isinstance(f[p], h5py.Dataset) and f[p].shape[0] == n_samples
        for p in SMOOTHED.values()
        if not (v2 and p in JOINT_OF)
    )
