"""The low-level HDF5 side: creating the session layout and appending to it, fsync helpers.

Shared by the live writer and the recovery; knows nothing about journals. Also the one-line
wording of OS and h5py errors used in every :class:`SessionError`.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TypeAlias, cast

import h5py
import numpy as np

from gaitmon.io.journal_files import journal_lock
from gaitmon.io.session.chunk_write import RowWriter
from gaitmon.io.session.codec import COMPRESSION, encode
from gaitmon.io.session.layout import (
    _DEVICE_KEYS,
    _EVENT_CHUNK_ROWS,
    _PER_SAMPLE,
    _STR,
    _TABLE_CHUNK_ROWS,
    _TABLES,
    ANGLE_CONVENTION,
    CHUNK_ROWS,
    FORMAT,
    FORMAT_VERSION,
    LINK_TOTALS,
    LINK_TOTALS_IF_ANY,
    _field_names,
    stored_datasets,
    stored_dtype,
)

# One row of a compound table (markers, gaps, changes, ...): its fields in the table's order
TableRow: TypeAlias = "tuple[str | int | float | bool | np.generic, ...]"

# HDF5 chunk cache of the writing side; 0 = none (the benchmark compares it with HDF5's 1 MB)
WRITER_CHUNK_CACHE_BYTES = 0


def open_cached(group: h5py.Group, path: str, max_bytes: int) -> h5py.Dataset:
    """``group[path]`` opened with a chunk cache that holds the whole dataset as decoded, if
    that is at most ``max_bytes``: a dataset read in several passes is decompressed once. (A
    larger one is opened as usual: a cache of part of it holds nothing a pass in order would
    read again.) The cache lives while the returned object (or another open of the same
    dataset, which shares it) is alive."""
    ds = group[path]
    chunks = ds.chunks
    if chunks is None:
        return ds
    n_chunks = int(np.prod([-(-n // c) for n, c in zip(ds.shape, chunks, strict=True)]))
    nbytes = n_chunks * int(np.prod(chunks)) * ds.dtype.itemsize
    if nbytes <= 1 << 20 or nbytes > max_bytes:  # HDF5's own default holds it; too big
        return ds
    dapl = h5py.h5p.create(h5py.h5p.DATASET_ACCESS)
    # hash slots: ~10 per cached chunk keeps collisions (which evict) rare
    dapl.set_chunk_cache(10 * n_chunks + 1, nbytes, 1.0)
    del ds  # (the dataset's first open fixes its cache)
    return h5py.Dataset(h5py.h5d.open(group.id, path.encode(), dapl=dapl))


class _H5File:
    """Creates the session layout and appends to it; knows nothing about journals."""

    def __init__(
        self, path: Path, header: Mapping[str, object], *, mode: str, reprocessed: bool,
        in_memory: bool = False, version: int = FORMAT_VERSION,
    ) -> None:
        # no chunk cache: writes go straight to the file (see gaitmon.io.session.layout, "Chunking")
        # in_memory: a file that never touches the disk (recovery while the disk is full)
        # A new file on disk is laid out in memory and written as one image by os.write, then
        # opened: a full disk at creation is an OSError before HDF5 holds the file (issue 26:
        # HDF5 failing to write a file it was creating left objects it could not close, two
        # "Exception ignored" tracebacks and a segfault at exit).
        self.f = h5py.File(path, mode if in_memory else "w", driver="core", backing_store=False,
                           rdcc_nbytes=WRITER_CHUNK_CACHE_BYTES)  # fmt: skip
        # format 1 (uncompressed float32, written in place on every flush) is written only
        # for comparisons (gaitmon bench --suite size) and tests of older files
        self.version = int(version)
        try:
            self._create(header, reprocessed)
            if not in_memory:
                self.f.flush()
                image = self.f.id.get_file_image()
                self.f.close()
        except BaseException:
            with contextlib.suppress(Exception):
                self.f.close()
            raise
        if not in_memory:
            _write_new(path, image, exclusive=mode == "x")
            self.f = h5py.File(path, "r+", rdcc_nbytes=WRITER_CHUNK_CACHE_BYTES)
        self._writers: dict[str, RowWriter] = {}
        self.rows = 0  # rows appended (format 2: some still staged in memory)
        # format 2: the chunk being filled, per dataset, written whole once full (a compressed
        # chunk rewritten on every flush would cost its compression each time)
        self._stage: dict[str, np.ndarray] = {}
        self._staged = 0  # rows of the current chunk in _stage
        self._aligned = 0  # rows written in whole chunks: the current chunk's first row
        self._in_file = 0  # rows in the file's datasets (whole chunks, + a drained tail)
        self.n_events = {"heel_strike": 0, "toe_off": 0}
        self.events_sorted = True
        self._last_event = {"heel_strike": -1, "toe_off": -1}

    def _create(self, header: Mapping[str, object], reprocessed: bool) -> None:
        from gaitmon.dsp.estimate import method_label  # a writer's; readers need no method

        # the header is SessionHeader.as_dict()'s form (its nested parts are dicts and lists)
        h = cast("Mapping[str, Any]", header)
        f = self.f
        mode = h["mode"]
        a = f.attrs
        a["format"] = FORMAT
        a["format_version"] = np.int64(self.version)
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

        filters = COMPRESSION if self.version >= 2 else {}
        for path in stored_datasets(mode, self.version):
            shape = _PER_SAMPLE[path][0]
            f.create_dataset(
                path,
                shape=(0, *shape),
                maxshape=(None, *shape),
                dtype=stored_dtype(path, self.version),
                chunks=(CHUNK_ROWS, *shape),
                fill_time="never",
                **filters,
            )
        f["timeline/host_time_s"].attrs["wall_offset_s"] = 0.0
        p = f["processed"]
        p.attrs["source"] = "pc" if mode == "raw" else "device"
        p.attrs["reprocessed"] = bool(reprocessed)
        # what made tilt_deg / joint_deg (rewrite_processed replaces it when it smooths)
        p.attrs["tilt_method"] = (
            method_label(str(h["config"].get("tilt_method", "paper")))
            if mode == "raw"
            else "the unit's own"
        )

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
        from gaitmon.io.session.attributes import describe

        describe(f)  # units, scale, columns: a file a reader without gaitmon understands

    def set_wall_offset(self, wall_offset_s: float) -> None:
        self.f["timeline/host_time_s"].attrs["wall_offset_s"] = float(wall_offset_s)

    def append_rows(self, cols: Mapping[str, np.ndarray], n: int) -> None:
        """Append ``n`` rows of every per-sample series (as readers get them: series the
        format derives are dropped, quantised ones encoded). Rows reach the file a whole
        chunk at a time; :meth:`drain` writes the chunk being filled."""
        if n == 0:
            return
        if self.version < 2:  # uncompressed: every flush writes its rows in place
            for path, data in cols.items():
                _append_low_level(self._writer(path), self.rows, data)
            self.rows += n
            return
        enc = {p: encode(p, d) for p, d in cols.items() if p in self.f}
        if not self._stage:
            self._stage = {
                p: np.empty((CHUNK_ROWS, *d.shape[1:]), dtype=self._writer(p).dsid.dtype)
                for p, d in enc.items()
            }
        done = 0
        while done < n:
            take = min(n - done, CHUNK_ROWS - self._staged)
            for p, d in enc.items():
                self._stage[p][self._staged : self._staged + take] = d[done : done + take]
            self._staged += take
            done += take
            if self._staged == CHUNK_ROWS:
                self._write_chunk(CHUNK_ROWS)
                self._aligned += CHUNK_ROWS
                self._in_file = self._aligned
                self._staged = 0
        self.rows += n

    def _write_chunk(self, k: int) -> None:
        for p, buf in self._stage.items():
            _append_low_level(self._writer(p), self._aligned, buf[:k])

    def drain(self) -> None:
        """Write the rows of the chunk being filled (at the end of a recording; they stay
        staged, so later rows still complete that chunk)."""
        if self._staged:
            self._write_chunk(self._staged)
            self._in_file = self._aligned + self._staged

    def staged_row(self, path: str, idx: int) -> np.ndarray | None:
        """Row ``idx`` of ``path`` as stored, if it is still staged, else None."""
        if self._stage and self._aligned <= idx < self._aligned + self._staged:
            return self._stage[path][idx - self._aligned]
        return None

    def _writer(self, path: str) -> RowWriter:
        w = self._writers.get(path)
        if w is None:
            w = self._writers[path] = RowWriter(self.f[path].id)
        return w

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

    def append_table(self, name: str, records: Sequence[TableRow]) -> None:
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
        for k in LINK_TOTALS_IF_ANY:
            if int(totals.get(k, 0)):
                link.attrs[k] = np.int64(totals[k])

    def t_s_at(self, idx: int) -> float:
        staged = self.staged_row("timeline/t_s", idx)
        if staged is not None:
            return float(staged)
        return float(self.f["timeline/t_s"][idx])

    def finish(self, *, complete: bool, recovered: bool, stop_reason: str, fs_hz: float) -> None:
        self.drain()
        if self.rows:
            from gaitmon.io.session.stored_overview import write_overview

            write_overview(self.f)
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


def _write_new(path: Path, image: bytes, *, exclusive: bool) -> None:
    """Write a new file's whole image (``exclusive``: it must not exist). A failed write (a
    full disk) removes what it wrote and raises the OSError."""
    flags = os.O_WRONLY | os.O_CREAT | (os.O_EXCL if exclusive else os.O_TRUNC)
    fd = os.open(path, flags, 0o644)
    try:
        view = memoryview(image)
        while view:
            view = view[os.write(fd, view) :]
    except BaseException:
        os.close(fd)
        with contextlib.suppress(OSError):
            os.unlink(path)
        raise
    os.close(fd)


def _append_low_level(writer: RowWriter, start: int, data: np.ndarray) -> None:
    """Grow a dataset along axis 0 and write ``data`` at ``start``: the same as h5py's
    ``resize`` + slice assignment, at a fraction of its per-call cost (it runs ~17 times per
    flush, 10 flushes a second); whole chunks compressed by libdeflate."""
    data = np.ascontiguousarray(data, dtype=writer.dsid.dtype)
    writer.dsid.set_extent((start + data.shape[0], *data.shape[1:]))
    writer.write(start, data)


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


# What the HDF5 library says about a file it cannot read, in words a user can act on (its own
# text, "Unable to synchronously open file (file signature not found)", must not reach them).
_H5_PHRASES: tuple[tuple[str, str], ...] = (
    ("file signature not found", "not an HDF5 file"),
    ("truncated file", "the file is cut short"),
    ("file locking", "the file is locked by another program"),
    ("unable to lock file", "the file is locked by another program"),
    ("no space left", "the disk is full"),
    ("file too large", "the file size limit is reached"),
    ("permission denied", "permission denied"),
    ("no such file", "the file does not exist"),
)
_H5_LIBRARY_WORDS = ("unable to", "can't", "synchronously", "b-tree", "object header",
                     "addr overflow", "bad ", "wrong ", "errno =", "h5", "invalid ")


def _short_error(e: BaseException) -> str:
    """A one-line reason from an OSError or an h5py error (whose text can be very long and is
    written for HDF5's developers: it is translated, or replaced by a plain phrase)."""
    if isinstance(e, OSError) and e.errno:
        return f"{os.strerror(e.errno)} (errno {e.errno})"
    text = " ".join(str(e).split()) or type(e).__name__
    lower = text.lower()
    for phrase, plain in _H5_PHRASES:
        if phrase in lower:
            return plain
    # h5py: "Can't write data (file write failed: time = ..., errno = 27, error message = ...)"
    for marker in ("error message = '", 'error message = "'):
        if marker in text:
            return text.split(marker, 1)[1].split("'", 1)[0].split('"', 1)[0]
    if any(w in lower for w in _H5_LIBRARY_WORDS):
        return "its internal structure is damaged"
    return text[:200]
