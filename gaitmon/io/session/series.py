"""What a session reader hands out besides arrays, and the checks of a file's edge.

:class:`SeriesView` (a per-sample series read by slicing), :class:`Marker`, :class:`Gap`, the
HDF5 attribute values as plain Python (:data:`AttrValue`), and the checks that turn damaged
metadata into one :class:`~gaitmon.io.session.header.SessionError` line (sample rate, event
rows, per-sample dataset shapes).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple, Protocol, TypeAlias, cast

import h5py
import numpy as np

from gaitmon.io.session.header import SessionError
from gaitmon.io.session.layout import _PER_SAMPLE

if TYPE_CHECKING:  # annotations only: numpy.typing costs ~0.6 ms to import
    import numpy.typing as npt

# An HDF5 attribute's value as plain Python (strings decoded, numpy scalars as Python ones,
# arrays as lists).
AttrValue: TypeAlias = "str | int | float | bool | list[AttrValue]"

# What a series view can be sliced with: rows, a range of rows, rows and columns, or an index
# array (as numpy indexes the whole series).
Index: TypeAlias = "int | slice | tuple[int | slice, ...] | npt.NDArray[np.integer] | list[int]"


class SeriesSource(Protocol):
    """The reader a :class:`SeriesView` slices (a stored session)."""

    @property
    def h5(self) -> h5py.File | h5py.Group: ...

    def shape_of(self, name: str) -> tuple[int, ...]: ...

    def read(self, name: str) -> np.ndarray: ...

    def read_range(
        self, start: int, stop: int, names: list[str] | None = None
    ) -> dict[str, np.ndarray]: ...


class SeriesView:
    """A per-sample series read by slicing (``view[a:b]``), decoded by the session reader."""

    def __init__(self, session: SeriesSource, name: str) -> None:
        self._s = session
        self.name = name
        self.shape = session.shape_of(name)
        self.dtype = np.dtype(_PER_SAMPLE[name][1])
        self.ndim = len(self.shape)
        self.file = session.h5

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key: Index) -> np.ndarray:
        if isinstance(key, slice) and key.step in (None, 1):
            a, b, _ = key.indices(self.shape[0])
            return self._s.read_range(a, b, [self.name])[self.name]
        return self._s.read(self.name)[key]

    def __array__(self, dtype: npt.DTypeLike | None = None, copy: bool | None = None) -> np.ndarray:
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


def attr_text(x: object) -> str:
    """An HDF5 string attribute or field as text, however h5py hands it over: str, bytes
    (decoded as UTF-8, a damaged byte replaced rather than raised) or a 0-d array of either."""
    if isinstance(x, bytes):
        return x.decode("utf-8", errors="replace")
    if isinstance(x, np.ndarray) and x.shape == ():
        return attr_text(x[()])
    return str(x)


def _py(x: object) -> AttrValue:
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
    # str, int, float, bool: what h5py gives for the attributes gaitmon writes; anything else
    # is handed on as read
    return cast("AttrValue", x)


# No unit samples faster; a larger recorded rate is a damaged attribute (1e300 Hz overflows
# the time grids of the exports).
MAX_SAMPLE_RATE_HZ = 100_000.0


def _sample_rate(name: str, value: object) -> float:
    """The recorded sample rate; a damaged one (0, NaN, negative, not a number) is said here,
    at the file's edge, rather than as a ValueError deep inside the analysis."""
    if value is None:
        raise SessionError(f"{name} is damaged: it has no sample rate")
    try:
        fs = float(value) if isinstance(value, int | float | str) else float("nan")
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
