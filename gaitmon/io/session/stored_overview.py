"""``/overview``: the joint angles' min/max per 16-row bin, stored so a long session's first view
reads kilobytes instead of decoding every chunk.

The review window draws the knee over the whole session from a min/max pyramid
(:class:`gaitmon.io.overview.PeakPyramid`, base step 16 rows). Building it means reading the
whole joint series: ~0.1 GB of float32 for 8 hours from a format-1 file, hundreds of gzip chunks
from a format-2 file. A format-2 file stores the pyramid's finest level instead, written at
close, by recovery and by reprocessing, for the live and the smoothed joint angles:

    /overview/processed_joint_deg/min, /max   (ceil(N / 16), 3) int16, centidegrees
    /overview/smoothed_joint_deg/min, /max     the same for /smoothed
    /overview.attrs: base_step (16), n_rows (N)

The values are the min and max of the joint angles exactly as the reader returns them
(quantised, and decoding is monotonic), so :meth:`Session.stored_pyramid` gives the same
pyramid as one built from the rows, from a ~0.6 MB read (8 hours). The coarser levels are
computed from this one in memory. A file without it (format 1, or whose overview is stale)
is read as before.
"""

from __future__ import annotations

import h5py
import numpy as np

from gaitmon.dsp.angles import JOINT_PAIRS
from gaitmon.io.session.codec import (
    CENTIDEG,
    COMPRESSION,
    JOINT_OF,
    dequantise,
    derived,
    joint_centideg,
    joints_from_stored_tilts,
    quantise,
)
from gaitmon.io.session.series import attr_text

BASE_STEP = 16  # rows per bin (gaitmon.io.overview.BASE_STEP)
_READ_ROWS = 1 << 16  # rows per read while building (a whole number of bins)
_DTYPE = np.dtype("<i2")
_NAN = int(np.iinfo(_DTYPE).min)  # the stored NaN code (gaitmon.io.session.codec.quantise)
_NONE_LOW = 1 << 20  # above every code: a bin's min where all its rows are NaN
_PLUS = [p for p, _ in JOINT_PAIRS]
_MINUS = [m for _, m in JOINT_PAIRS]
SERIES = ("processed/joint_deg", "smoothed/joint_deg")
_JOINT_OF_TILT = {JOINT_OF[p]: p for p in SERIES}


def _key(path: str) -> str:
    return path.replace("/", "_")


def _mode(f: h5py.File) -> str:
    return attr_text(f.attrs.get("mode", ""))  # (a bytes attribute decoded, not "b'raw'")


def _version(f: h5py.File) -> int:
    return int(f.attrs.get("format_version", 1))


def _joint_codes(f: h5py.File, path: str, a: int, b: int) -> np.ndarray | None:
    """Rows a:b of a joint series in stored centidegree codes (int32; the int16 NaN code where
    the reader gives NaN), or None if the file has none. The reader's float32 value of a code
    c is c / 100 correctly rounded, which quantises back to c: the bins of the codes are the
    quantised bins of the angles as read, computed without the float round trip."""
    if path in derived(_mode(f), _version(f)):
        tilt = JOINT_OF[path]
        return _codes_of_tilts(f[tilt][a:b], tilt) if tilt in f else None
    if path not in f:
        return None
    stored = f[path][a:b]
    if stored.dtype.kind == "f":
        return quantise(stored, _DTYPE, CENTIDEG).astype(np.int32)
    return stored.astype(np.int32)


def _codes_of_tilts(stored: np.ndarray, tilt_path: str) -> np.ndarray:
    """The joint codes (:func:`_joint_codes`) of stored tilt rows."""
    if stored.dtype.kind == "f":  # (not expected in format 2; kept total)
        joints = joints_from_stored_tilts(stored, tilt_path)
        return quantise(joints, _DTYPE, CENTIDEG).astype(np.int32)
    codes = joint_centideg(stored)
    nan = stored == _NAN
    codes[nan[:, _PLUS] | nan[:, _MINUS]] = _NAN
    return codes


class OverviewBuilder:
    """The bins of a format-2 file's derived joint series (:data:`SERIES`), made from their
    stored tilt rows as a writer writes them, in order from row 0: :func:`write_overview`
    takes them instead of reading the rows back. A series whose rows did not all come in
    order is read back as usual."""

    def __init__(self) -> None:
        self._parts: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
        self._tail: dict[str, np.ndarray] = {}  # rows of a bin not yet whole
        self._rows: dict[str, int] = {}  # rows taken; -1: not in order (not used)

    def add(self, tilt_path: str, start: int, stored: np.ndarray) -> None:
        """Stored tilt rows ``start:`` of ``tilt_path`` (e.g. ``processed/tilt_deg``)."""
        path = _JOINT_OF_TILT.get(tilt_path)
        if path is None:
            return
        if self._rows.get(path, 0) != start:
            self._rows[path] = -1
            return
        tail = self._tail.get(path)
        rows = stored if tail is None or not len(tail) else np.concatenate([tail, stored])
        k = len(rows) - len(rows) % BASE_STEP
        if k:
            self._parts.setdefault(path, []).append(_code_bins(_codes_of_tilts(rows[:k],
                                                                               tilt_path)))
        self._tail[path] = rows[k:]
        self._rows[path] = start + len(stored)

    def bins(self, path: str, n: int) -> tuple[np.ndarray, np.ndarray] | None:
        """(mins, maxs) of all ``n`` rows of ``path``, or None if they did not all come."""
        if self._rows.get(path) != n or n == 0:
            return None
        parts = list(self._parts.get(path, []))
        tail = self._tail.get(path)
        if tail is not None and len(tail):
            parts.append(_code_bins(_codes_of_tilts(tail, JOINT_OF[path])))
        return (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]))


def write_overview(f: h5py.File, built: OverviewBuilder | None = None) -> None:
    """Compute and store (or replace) ``/overview`` of a format-2 file open for writing;
    ``built``: the bins a writer made of the rows it wrote (any series it lacks is read)."""
    if _version(f) < 2:
        return
    n = min((f[p].shape[0] for p in ("timeline/t_s",) if p in f), default=0)
    if "overview" in f:
        del f["overview"]
    if n == 0:
        return
    g = f.create_group("overview")
    g.attrs["base_step"] = np.int64(BASE_STEP)
    g.attrs["n_rows"] = np.int64(n)
    m = -(-n // BASE_STEP)
    for path in SERIES:
        # each block's bins quantised and written as they come (_READ_ROWS is a whole number
        # of bins): no level of the whole record in memory (issue 26)
        grp = g.create_group(_key(path))
        out = {name: grp.create_dataset(name, shape=(m, 3), dtype=_DTYPE,
                                        chunks=(min(m, 1 << 14), 3), **COMPRESSION)
               for name in ("min", "max")}  # fmt: skip
        made = built.bins(path, n) if built is not None and path in JOINT_OF else None
        if made is not None and _derived_here(f, path):
            out["min"][()], out["max"][()] = made
            continue
        for a in range(0, n, _READ_ROWS):
            codes = _joint_codes(f, path, a, min(n, a + _READ_ROWS))
            if codes is None or len(codes) < min(n, a + _READ_ROWS) - a:
                del g[_key(path)]  # a series not stored whole: none of it
                break
            k = a // BASE_STEP
            for name, bins in zip(("min", "max"), _code_bins(codes), strict=True):
                out[name][k : k + len(bins)] = bins
    from gaitmon.io.session.attributes import describe

    describe(f)


def _derived_here(f: h5py.File, path: str) -> bool:
    """Whether ``f`` derives ``path`` from its stored tilts (what OverviewBuilder bins)."""
    return path in derived(_mode(f), _version(f)) and f[JOINT_OF[path]].dtype == _DTYPE


def _code_bins(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """int16 min and max of the codes over each BASE_STEP rows (the last bin may be short),
    NaN codes skipped; an all-NaN bin is the NaN code (as gaitmon.io.overview's bins of the
    angles: fmin/fmax)."""
    starts = np.arange(0, len(codes), BASE_STEP)
    nan = codes == _NAN
    lo = np.minimum.reduceat(np.where(nan, _NONE_LOW, codes), starts, axis=0)
    hi = np.maximum.reduceat(np.where(nan, -_NONE_LOW, codes), starts, axis=0)
    lo[lo == _NONE_LOW] = _NAN
    hi[hi == -_NONE_LOW] = _NAN
    return lo.astype(_DTYPE), hi.astype(_DTYPE)


def read_overview(f: h5py.File, path: str, n_rows: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(mins, maxs) float32 of ``path``'s 16-row bins if the file stores them for ``n_rows``
    rows, else None."""
    g = f.get("overview")
    if g is None or int(g.attrs.get("n_rows", -1)) != n_rows:
        return None
    if int(g.attrs.get("base_step", 0)) != BASE_STEP:
        return None
    grp = g.get(_key(path))
    if grp is None or "min" not in grp or "max" not in grp:
        return None
    m = -(-n_rows // BASE_STEP)
    lo, hi = grp["min"][()], grp["max"][()]
    if lo.shape != (m, 3) or hi.shape != (m, 3):
        return None
    return dequantise(lo, CENTIDEG), dequantise(hi, CENTIDEG)
