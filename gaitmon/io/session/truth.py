"""The ``/truth`` group of a simulated session: the simulator's ground truth per row.

Only sessions recorded from the simulated unit have it; :mod:`gaitmon.io.sim.truth` computes
what it holds (mapping every row back to the sample the unit generated) and writes it with
:func:`write_truth` into the finished file. Readers get the true tilts with :func:`read_truth`
or :meth:`gaitmon.io.session.StoredSession.truth`.
"""

from __future__ import annotations

import contextlib
import errno
import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np
import numpy.typing as npt

from gaitmon.io.session.attributes import describe
from gaitmon.io.session.header import SessionError

GROUP = "truth"
DESCRIPTION = (
    "simulator ground truth per row: segment tilts and joint angles in degrees "
    "(clinical signs, no mounting offset); events as row indices"
)
# per-row: sample_idx (int64, -1 where unmapped), tilt_deg (n, 4), joint_deg (n, 3),
# gyro_bias_rad_s (n, 4) as float32 with NaN on unmapped rows; events: heel_strike, toe_off
# (int64 row indices); attribute mount_offset_deg (4,)

Truth = tuple[np.ndarray | None, np.ndarray | None]


def write_truth(
    path: str | os.PathLike[str], datasets: Mapping[str, np.ndarray], mount_offset_deg: np.ndarray
) -> None:
    """Write (or replace) ``/truth`` in a finished session file. Raises OSError."""
    with truth_writer(path, mount_offset_deg) as g:
        for name, data in datasets.items():
            g.put(name, data)


class _TruthGroup:
    """``/truth`` of a file open for writing: datasets replaced whole (:meth:`put`) or created
    to be filled in row blocks (:meth:`rows`)."""

    def __init__(self, g: h5py.Group) -> None:
        self.g = g

    def _fresh(self, name: str) -> None:
        if name in self.g:
            del self.g[name]

    def put(self, name: str, data: np.ndarray) -> None:
        self._fresh(name)
        self.g.create_dataset(name, data=data)

    def column(self, name: str, n: int, dtype: npt.DTypeLike) -> h5py.Dataset:
        """An (n,) dataset to fill (the same layout :meth:`put` gives)."""
        self._fresh(name)
        return self.g.create_dataset(name, shape=(n,), dtype=dtype)

    def rows(self, name: str, n: int, cols: int) -> h5py.Dataset:
        """An (n, cols) float32 dataset to fill (the same layout :meth:`put` gives)."""
        self._fresh(name)
        return self.g.create_dataset(name, shape=(n, cols), dtype=np.float32)


@contextmanager
def truth_writer(
    path: str | os.PathLike[str], mount_offset_deg: np.ndarray, reserve_bytes: int = 0
) -> Iterator[_TruthGroup]:
    """``/truth`` of a finished session file, to write (or replace). Raises OSError.

    ``reserve_bytes`` (what the writing adds, with room to spare) is claimed on the disk first
    (:func:`reserve_space`): a full disk then raises the OSError before HDF5 has written a
    byte. HDF5 meeting a full disk itself fails inside its own close and leaves the library
    in a state that crashed the process at exit (a segmentation fault after the message)."""
    if reserve_bytes > 0:
        reserve_space(path, reserve_bytes)
    with h5py.File(path, "r+") as f:  # its close gives back what it did not use (to its EOA)
        g = f.require_group(GROUP)
        g.attrs["description"] = DESCRIPTION
        g.attrs["mount_offset_deg"] = mount_offset_deg
        yield _TruthGroup(g)
        describe(f)  # units, long names and columns on what was written (attributes.py)


RESERVE_BLOCK_BYTES = 1 << 20


def reserve_space(path: str | os.PathLike[str], nbytes: int) -> None:
    """Claim ``nbytes`` of disk past the end of the file at ``path`` (blocks allocated, not a
    sparse hole): OSError (ENOSPC, EFBIG, EDQUOT) if the disk cannot give them, the file as
    before then. An HDF5 file may be longer than its data: HDF5 writes its next objects from
    where its data end, into the claimed blocks, and its close cuts the file to its data."""
    with open(path, "r+b") as fh:
        size = fh.seek(0, os.SEEK_END)
        try:
            try:
                os.posix_fallocate(fh.fileno(), size, nbytes)
                return
            except AttributeError:  # Windows: zeros written claim the blocks
                pass
            except OSError as e:
                if e.errno not in (errno.EOPNOTSUPP, errno.EINVAL, errno.ENOSYS):
                    raise
            left = nbytes
            while left > 0:
                left -= fh.write(bytes(min(left, RESERVE_BLOCK_BYTES)))
            fh.flush()
            os.fsync(fh.fileno())
        except BaseException:
            with contextlib.suppress(OSError):
                fh.truncate(size)
            raise


def truth_from_file(f: h5py.File, start: int, stop: int) -> Truth:
    """(true tilts in rad for rows start:stop, mounting offsets in rad) from an open file;
    (None, None) when it has no ``/truth``. Rows the simulator could not map are NaN."""
    if GROUP not in f or "tilt_deg" not in f[GROUP]:
        return None, None
    g = f[GROUP]
    tilt = np.radians(np.asarray(g["tilt_deg"][start:stop], dtype=np.float64))
    mount = g.attrs.get("mount_offset_deg")
    return tilt, None if mount is None else np.radians(np.asarray(mount, np.float64))


def read_truth(path: str | os.PathLike[str], start: int, stop: int) -> Truth:
    """:func:`truth_from_file` of the session at ``path``; raises :class:`SessionError`."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            return truth_from_file(f, start, stop)
    except (OSError, KeyError, ValueError) as e:
        raise SessionError(f"{path.name}: cannot read /truth ({e})") from e
