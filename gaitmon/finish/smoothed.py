"""A raw-mode session's zero-lag angles: ``/smoothed``, the best estimate every reader uses.

The live view can only use the causal filter (``/processed/tilt_deg`` and ``joint_deg``, what the
clinician saw). A recorded session is analysed on the offline estimate: the RTS smoother over
the gait-aware Kalman model (:mod:`gaitmon.dsp.smoother`) run over the whole record, with the
calibration in force at each row and a fresh start after every long gap (as the live pipeline
restarts there). It is computed once, when a recording is closed, recovered or reprocessed, and
stored beside the live series:

    /smoothed/tilt_deg   (N, 4) float32   zeroed segment tilts
    /smoothed/joint_deg  (N, 3) float32   hip, knee, ankle (clinical signs)
    /smoothed.attrs["method"]             e.g. "gait-aware Kalman + RTS smoother"

A file without it (written before it existed, or a stop that could not finish it) gets the same
numbers computed in memory when a reader asks (:func:`smoothed_from_file`). Tilt and joint mode
sessions hold the unit's own angles only: there is nothing to smooth.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import logging
from collections.abc import Callable, Iterator, Mapping
from typing import IO, TYPE_CHECKING

import h5py
import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channel_table import N_JOINTS, N_SEGMENTS
from gaitmon.dsp.channels import ChannelTable
from gaitmon.dsp.lost_frames import Losses
from gaitmon.io.session.attributes import describe
from gaitmon.io.session.chunk_write import RowWriter
from gaitmon.io.session.layout import CHUNK_ROWS
from gaitmon.io.session.rows import losses_from_gaps, lost_before_from_gaps
from gaitmon.io.session.series import attr_text

if TYPE_CHECKING:  # (the overview's builder comes from the caller)
    from gaitmon.io.session.stored_overview import OverviewBuilder


def smoothed_method_label() -> str:
    from gaitmon.dsp.methods import smoothing_method

    return str(smoothing_method().offline_label)


# Pieces longer than this are smoothed in blocks of it, each with SMOOTH_OVERLAP_ROWS of context
# on either side (kept inside the piece) whose results are dropped: the smoother's memory is
# ~140 MB per hour of record, so an 8-hour record in one go peaked at ~1.3 GB (close, recovery,
# gaitmon process). The difference to one pass falls ~40-fold per 15 s of context (measured on
# 20 simulated minutes in blocks of 5: 0.2 deg with 15 s, 0.005 with 30 s, 3e-5 with 60 s);
# 2 minutes put it below float32, far below the 0.01 deg the angles are stored at. The four
# segments of a block are smoothed side by side: 15-min blocks hold ~25 MB (30-min ones, ~50 MB,
# put recovery's peak RSS of an 8-hour record at 380-420 MB, with the compiled filters' runtime).
SMOOTH_BLOCK_ROWS = 90_000  # 15 min at 100 Hz
SMOOTH_OVERLAP_ROWS = 12_000  # 120 s


log = logging.getLogger(__name__)

Counts = Callable[[int, int], np.ndarray]  # rows a:b of the raw counts
# the smoother's first pass of rows a:b (rad, (b - a, 4)), given their raw counts: a
# gaitmon.dsp.smoother.CausalFirstPass's rows, or the same tilts kept from a replay
FirstPass = Callable[[int, int, np.ndarray], np.ndarray]


def smoothed_blocks(
    counts: Counts,
    n: int,
    table: ChannelTable,
    calibration: Calibration,
    calibration_changes: list[tuple[int, Calibration]],
    restarts: np.ndarray,
    fs_hz: float,
    first_pass: FirstPass | None = None,
    filled: Mapping[int, int] | None = None,
) -> Iterator[tuple[int, np.ndarray]]:
    """(first row, tilts in rad (rows, 4) float64) of a raw record of ``n`` rows, block after
    block in row order; ``counts(a, b)`` gives rows a:b of the raw counts, asked for one block
    with its context at a time (at most :data:`SMOOTH_BLOCK_ROWS` + 2 x
    :data:`SMOOTH_OVERLAP_ROWS` rows), so memory does not grow with the session.

    The record is smoothed in pieces split at the ``restarts`` rows (after a long gap, where
    the live pipeline restarts, :func:`gaitmon.dsp.lost_frames.restart_rows`): the segments moved
    while no data came, so nothing links the angle before a gap to the one after it. A long
    piece is smoothed in blocks with :data:`SMOOTH_OVERLAP_ROWS` of context either side.

    The smoother's first pass, the causal filter, runs over the whole record in row order as
    the live pipeline does (:class:`gaitmon.dsp.smoother.CausalFirstPass`); ``first_pass``
    gives those tilts where they are known already (a replay of the pipeline kept them);
    ``filled``: the bridged losses (gaitmon.dsp.lost_frames.bridged_losses), filled in for the
    first pass and the smoother alike: both step the unit's uniform time base."""
    from gaitmon.dsp import kernels
    from gaitmon.dsp.lost_frames import fill_lost
    from gaitmon.dsp.smoother import CausalFirstPass, smooth_record_tilts

    kernels.expect(n)  # a long record runs numba's compiled loops where they are cached
    changes = sorted(((max(0, int(r)), c) for r, c in calibration_changes), key=lambda x: x[0])
    if first_pass is None:
        first_pass = CausalFirstPass(table, calibration, changes, restarts, fs_hz, filled).rows

    fill_rows = np.array(sorted(filled or {}), dtype=np.int64)
    fill_n = np.array([(filled or {})[int(r)] for r in fill_rows], dtype=np.int64)

    def smooth(a: int, b: int) -> np.ndarray:
        in_force = calibration
        for r, c in changes:
            if r <= a:
                in_force = c
        cals = [(0, in_force), *[(r - a, c) for r, c in changes if a < r < b]]
        rows = counts(a, b)
        theta = first_pass(a, b, rows)
        # the bridged losses filled in, as the live filter saw them: the smoother's model
        # steps one frame at a time (gaitmon.dsp.lost_frames.fill_lost); rows out
        fill = np.zeros(b - a, dtype=np.int64)
        lo, hi = np.searchsorted(fill_rows, [a, b])
        fill[fill_rows[lo:hi] - a] = fill_n[lo:hi]
        if not fill.any():
            del fill
            # handed over, not kept here: the smoother lets go of them before its last solve
            held = [rows, theta]
            del rows, theta
            return smooth_record_tilts(held.pop(0), table, cals, fs_hz, held.pop())
        prev = counts(a - 1, a)[0].astype(np.float64) if fill[0] and a > 0 else None
        if prev is None:
            fill[0] = 0
        ext, pos = fill_lost(np.asarray(rows, dtype=np.float64), fill, prev)
        theta_ext, _ = fill_lost(theta, fill, theta[0])
        if pos is None:
            return smooth_record_tilts(rows, table, cals, fs_hz, theta)
        # a calibration in force from row r is so from the frames filled in before it too
        cals_ext = [(int(pos[r] - fill[r]) if r < len(pos) else len(ext), c) for r, c in cals]
        return smooth_record_tilts(ext, table, cals_ext, fs_hz, theta_ext)[pos]

    cuts = sorted({0, n, *(int(r) for r in restarts if 0 < r < n)})
    block, overlap = SMOOTH_BLOCK_ROWS, SMOOTH_OVERLAP_ROWS
    if n >= block:
        trim_heap()  # (the holes a replay or a recording left; once: a trim a block cost ~8 %)
    try:
        for a, b in itertools.pairwise(cuts):
            step = b - a if b - a <= block + 2 * overlap else block
            for s0 in range(a, b, step):
                s1 = min(b, s0 + step)
                r0, r1 = max(a, s0 - overlap), min(b, s1 + overlap)
                yield s0, smooth(r0, r1)[s0 - r0 : s1 - r0]
    finally:
        # the smoother's cached factors (~10 MB each) serve this record's blocks; a review
        # window or batch worker living on does not keep them
        from gaitmon.dsp.smoother import release_factors

        release_factors()


def trim_heap() -> None:
    """Give the free pages of the C heap back to the system (glibc's ``malloc_trim``; nothing
    elsewhere). Once glibc has seen a few-MB array freed it serves arrays of that size from
    its heap, and the holes they leave there stay resident until trimmed: an 8-hour replay
    left ~20 MB of them under the smoother's blocks. The pages given back are faulted in again
    when used: a trim before each block cost ~8 % of a close's CPU for ~4 MB of its peak."""
    if not _malloc_trim:
        _malloc_trim.append(_find_malloc_trim())
    trim = _malloc_trim[0]
    if trim is not None:
        trim(0)


def _find_malloc_trim() -> Callable[[int], int] | None:
    import ctypes
    import sys

    if not sys.platform.startswith("linux"):
        return None
    try:
        trim: Callable[[int], int] = ctypes.CDLL("libc.so.6").malloc_trim
    except (OSError, AttributeError):  # not glibc (musl has no malloc_trim)
        return None
    return trim


_malloc_trim: list[Callable[[int], int] | None] = []  # looked up once


# the first pass of a record up to this size is held in memory, a longer one's in a file
KEPT_IN_MEMORY_MAX_BYTES = 16 << 20


class KeptFirstPass:
    """The smoother's first pass kept from a replay of the pipeline (``ReplayChunk.first_pass_rad``,
    bit for bit what :class:`gaitmon.dsp.smoother.CausalFirstPass` computes), so the smoother
    does not run the filter again. The replay's own arrays are held (no copy) while they take
    at most ``memory_max_bytes`` (:data:`KEPT_IN_MEMORY_MAX_BYTES`: 1.4 hours); a longer
    record's rows wait in an unnamed temporary file in ``directory`` (float64: 32 bytes a row,
    92 MB for 8 hours), which is gone once closed (a context manager). A replay chunk without
    it (another filter, new settings), or a temporary file that cannot be made or written (a
    full disk), ends the keeping: :attr:`first_pass` is then None and the smoother runs its
    own, to the same numbers. The arrays given to :meth:`add` must not change afterwards."""

    def __init__(
        self, directory: str | None = None, memory_max_bytes: int | None = None
    ) -> None:  # fmt: skip
        self._n = 0
        self._directory = directory
        self._memory_max_bytes = (KEPT_IN_MEMORY_MAX_BYTES if memory_max_bytes is None
                                  else memory_max_bytes)  # fmt: skip
        self._held: list[np.ndarray] | None = []  # (None: in the file, or nothing kept)
        self._file: IO[bytes] | None = None

    def __enter__(self) -> KeptFirstPass:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def add(self, start: int, tilt_rad: np.ndarray | None) -> None:
        """Rows ``start:start + len(tilt_rad)`` (start = the rows kept so far)."""
        if self._held is None and self._file is None:
            return
        if tilt_rad is None:
            self.close()
            return
        if start != self._n:
            raise ValueError(f"first-pass rows from {start} given after {self._n} rows")
        data = np.ascontiguousarray(tilt_rad, dtype=np.float64)
        if self._held is not None:
            self._held.append(data)
            self._n += len(data)
            if self._n * _ROW_BYTES > self._memory_max_bytes:
                self._spill()
            return
        if self._write(self._n, data):
            self._n += len(data)

    def _spill(self) -> None:
        """Move the rows held in memory to the temporary file (made now)."""
        import tempfile

        held, self._held = self._held or [], None
        try:
            self._file = tempfile.TemporaryFile(dir=self._directory)  # noqa: SIM115 (close)
        except OSError as e:
            log.info("the smoother's first pass is computed again (no temporary file: %s)", e)
            return
        at = 0
        for data in held:
            if not self._write(at, data):
                return
            at += len(data)

    def _write(self, at: int, data: np.ndarray) -> bool:
        """Rows ``at:`` into the file; False (and nothing kept) where that fails."""
        assert self._file is not None
        try:
            self._file.seek(at * _ROW_BYTES)
            self._file.write(memoryview(data).cast("B"))  # type: ignore[arg-type]  # (no copy)
        except OSError as e:
            log.info("the smoother's first pass is computed again (temporary file: %s)", e)
            self.close()
            return False
        return True

    @property
    def first_pass(self) -> FirstPass | None:
        return None if self._held is None and self._file is None else self._rows

    def _rows(self, a: int, b: int, counts: np.ndarray | None = None) -> np.ndarray:
        if (self._held is None and self._file is None) or not 0 <= a <= b <= self._n:
            raise ValueError(f"first-pass rows {a}:{b} asked of {self._n} kept")
        # a new writeable array (the compiled loops take those: gaitmon.dsp.kernels)
        out = np.empty((b - a, N_SEGMENTS))
        if a == b:
            return out  # (an empty buffer cannot be read into)
        if self._held is not None:
            at = 0
            for data in self._held:
                lo, hi = max(a, at), min(b, at + len(data))
                if lo < hi:
                    out[lo - a : hi - a] = data[lo - at : hi - at]
                at += len(data)
            return out
        assert self._file is not None
        self._file.seek(a * _ROW_BYTES)
        view = memoryview(out).cast("B")  # type: ignore[arg-type]  # (numpy arrays are buffers)
        if self._file.readinto(view) != out.nbytes:  # type: ignore[attr-defined]  # (a file)
            raise ValueError(f"first-pass rows {a}:{b}: the temporary file is short")
        return out

    def close(self) -> None:
        self._held = None
        if self._file is not None:
            with contextlib.suppress(OSError):
                self._file.close()
            self._file = None


_ROW_BYTES = N_SEGMENTS * 8


def _losses(lost_before: np.ndarray | Losses, n: int) -> Losses:
    """The losses of the first ``n`` rows (per row, or already :class:`Losses`)."""
    if isinstance(lost_before, Losses):
        keep = lost_before.rows < n
        return Losses(lost_before.rows[keep], lost_before.n_lost[keep])
    return Losses.of(np.asarray(lost_before)[:n])


def _restarts(lost_before: np.ndarray | Losses, n: int, fs_hz: float) -> np.ndarray:
    from gaitmon.dsp.lost_frames import restart_rows

    return restart_rows(_losses(lost_before, n), fs_hz)


def _filled(lost_before: np.ndarray | Losses, n: int, fs_hz: float) -> dict[int, int]:
    from gaitmon.dsp.lost_frames import bridged_losses

    return bridged_losses(_losses(lost_before, n), fs_hz)


def _tilt_deg(part_rad: np.ndarray) -> np.ndarray:
    """One block's tilts in degrees, float32 (as stored and read)."""
    return np.degrees(part_rad).astype(np.float32)


def _joint_deg(part_rad: np.ndarray) -> np.ndarray:
    """One block's joint angles in degrees, float32 (as stored and read)."""
    from gaitmon.dsp.angles import joint_angles

    return np.degrees(joint_angles(part_rad)).astype(np.float32)


def smoothed_angles(
    adc: np.ndarray,
    table: ChannelTable,
    calibration: Calibration,
    calibration_changes: list[tuple[int, Calibration]],
    lost_before: np.ndarray,
    fs_hz: float,
) -> dict[str, np.ndarray]:
    """``{"smoothed/tilt_deg": (N, 4), "smoothed/joint_deg": (N, 3)}`` float32 of a raw record
    held in memory (:func:`smoothed_blocks`, collected; :func:`store_smoothed` writes them to
    a file block by block instead)."""
    counts = np.asarray(adc)
    n = len(counts)
    tilt_deg = np.empty((n, N_SEGMENTS), np.float32)
    joint_deg = np.empty((n, N_JOINTS), np.float32)
    for s0, part in smoothed_blocks(lambda a, b: counts[a:b], n, table, calibration,
                                    calibration_changes, _restarts(lost_before, n, fs_hz),
                                    fs_hz, filled=_filled(lost_before, n, fs_hz)):  # fmt: skip
        s1 = s0 + len(part)
        tilt_deg[s0:s1], joint_deg[s0:s1] = _tilt_deg(part), _joint_deg(part)
    return {"smoothed/tilt_deg": tilt_deg, "smoothed/joint_deg": joint_deg}


def store_smoothed(
    f: h5py.File,
    counts: Counts,
    n: int,
    table: ChannelTable,
    calibration: Calibration,
    calibration_changes: list[tuple[int, Calibration]],
    lost_before: np.ndarray | Losses,
    fs_hz: float,
    first_pass: FirstPass | None = None,
    overview: OverviewBuilder | None = None,
) -> None:
    """Compute and store (or replace) ``/smoothed`` of a raw record of ``n`` rows in a file open
    for writing, a block at a time (``counts(a, b)``: rows a:b of the raw counts): the same
    datasets, values and chunks as :func:`write_smoothed` of :func:`smoothed_angles`, without
    the whole series in memory (an 8-hour record: ~80 MB of angles, several times that while
    they were quantised at once). ``lost_before``: the frames lost before each row, or only
    the rows that lost some (:class:`~gaitmon.dsp.lost_frames.Losses`, as the close passes
    them: no per-row array). ``first_pass``: see :func:`smoothed_blocks`. ``overview``: given
    the rows as stored (the joints' overview is made of them)."""
    from gaitmon.io.session.codec import COMPRESSION, JOINT_OF, RESOLUTION

    v2 = int(f.attrs.get("format_version", 1)) >= 2
    grp = f.require_group("smoothed")
    out: dict[str, h5py.Dataset] = {}
    for path, cols in (("smoothed/tilt_deg", N_SEGMENTS), ("smoothed/joint_deg", N_JOINTS)):
        name = path.split("/", 1)[1]
        if name in grp:
            del grp[name]
        if v2 and path in JOINT_OF:
            continue
        dtype = RESOLUTION[path][0] if v2 and path in RESOLUTION else np.dtype(np.float32)
        out[path] = grp.create_dataset(
            name, shape=(n, cols), dtype=dtype, chunks=(min(CHUNK_ROWS, max(1, n)), cols),
            **_empty_ok(n, cols), **(COMPRESSION if v2 else {}),
        )  # fmt: skip
    writers = {path: _AlignedWriter(ds, v2, path) for path, ds in out.items()}
    for s0, part in smoothed_blocks(counts, n, table, calibration, calibration_changes,
                                    _restarts(lost_before, n, fs_hz), fs_hz,
                                    first_pass, _filled(lost_before, n, fs_hz)):  # fmt: skip
        for path, deg in (("smoothed/tilt_deg", _tilt_deg), ("smoothed/joint_deg", _joint_deg)):
            if path in writers:  # (format 2 derives the joints on read: not made)
                stored = writers[path].write(s0, deg(part))
                if overview is not None:
                    overview.add(path, s0, stored)
                del stored
        del part  # (not alive while the next block is smoothed)
    for w in writers.values():
        w.finish()
    grp.attrs["method"] = smoothed_method_label()
    describe(f)


def _empty_ok(n: int, cols: int) -> dict[str, tuple[int | None, int]]:
    """The dataset options that let a series of ``n`` = 0 rows (a recording killed before
    its first rows were saved) have its one-row chunks: HDF5 refuses a chunk larger than a
    fixed shape, not than an extensible one."""
    return {"maxshape": (None, cols)} if n == 0 else {}


class _AlignedWriter:
    """Writes consecutive row blocks to a chunked dataset in whole chunks (the rows of a chunk
    split between two blocks wait for the next one): a compressed chunk is written once."""

    def __init__(self, ds: h5py.Dataset, encoded: bool, path: str = "") -> None:
        self._writer = RowWriter(ds.id)
        # the codec's name of the series: relative to the unit's root (a bilateral file's
        # /units/<side>/smoothed/... is smoothed/...)
        self._path = path or ds.name.lstrip("/")
        self._encoded = encoded
        self._rows = ds.chunks[0] if ds.chunks else 1
        self._start = 0  # first row not yet written
        self._pending: list[np.ndarray] = []

    def write(self, s0: int, data: np.ndarray) -> np.ndarray:
        """Rows ``s0:`` (after those given before); returns them as stored."""
        from gaitmon.io.session.codec import encode

        assert s0 == self._start + sum(len(p) for p in self._pending)
        stored = encode(self._path, data) if self._encoded else data
        self._pending.append(stored)
        end = s0 + len(data)
        cut = end - end % self._rows  # rows up to here fill whole chunks
        if cut > self._start:
            rows = np.concatenate(self._pending) if len(self._pending) > 1 else self._pending[0]
            k = cut - self._start
            self._writer.write(self._start, rows[:k])
            self._pending = [rows[k:]] if k < len(rows) else []
            self._start = cut
        return stored

    def finish(self) -> None:
        if self._pending:
            rows = np.concatenate(self._pending)
            self._writer.write(self._start, rows)
            self._start += len(rows)
            self._pending = []


def _inputs(f: h5py.File) -> tuple[int, list[tuple[int, Calibration]], np.ndarray]:
    """(rows, calibration changes, frames lost before each row) of a session file."""
    n = _rows(f)
    return n, _changes(f), lost_before_from_gaps(f["gaps"][()], n)


def _rows(f: h5py.File) -> int:
    return min(f["raw/adc"].shape[0], f["timeline/t_s"].shape[0])


def _changes(f: h5py.File) -> list[tuple[int, Calibration]]:
    return [
        (int(r["sample_idx"]), Calibration.from_dict(json.loads(attr_text(r["json"]))))
        for r in f["calibration/changes"][()]
    ]




def smoothed_from_file(
    f: h5py.File, table: ChannelTable, calibration: Calibration, fs_hz: float,
    read_counts: Counts | None = None,
) -> dict[str, np.ndarray]:
    """The smoothed angles of a raw-mode session file open in ``f`` (computed, not read);
    ``read_counts(a, b)``: rows of ``/raw/adc`` as a reader checks them (default: as stored)."""
    n, changes, lost = _inputs(f)
    counts = read_counts(0, n) if read_counts is not None else f["raw/adc"][:n]
    return smoothed_angles(counts, table, calibration, changes, lost, fs_hz)


def write_smoothed(f: h5py.File, series: dict[str, np.ndarray]) -> None:
    """Store (or replace) ``/smoothed`` in a file open for writing (format 2: the tilts
    quantised and compressed, the joint angles derived from them on read)."""
    from gaitmon.io.session.codec import COMPRESSION, JOINT_OF, encode

    v2 = int(f.attrs.get("format_version", 1)) >= 2
    grp = f.require_group("smoothed")
    for path, data in series.items():
        name = path.split("/", 1)[1]
        if name in grp:
            del grp[name]
        if v2 and path in JOINT_OF:
            continue
        grp.create_dataset(
            name, data=encode(path, data) if v2 else data,
            chunks=(min(CHUNK_ROWS, max(1, len(data))), data.shape[1]),
            **_empty_ok(len(data), data.shape[1]), **(COMPRESSION if v2 else {}),
        )  # fmt: skip
    grp.attrs["method"] = smoothed_method_label()
    describe(f)


def smooth_into(
    f: h5py.File, table: ChannelTable, calibration: Calibration, fs_hz: float
) -> None:
    """Compute and store ``/smoothed`` of the raw-mode session open (writable) in ``f``, reading
    its raw counts a block at a time."""
    n = _rows(f)
    lost = losses_from_gaps(f["gaps"][()], n)  # sparse: the close holds no per-row array
    ds = f["raw/adc"]
    store_smoothed(f, lambda a, b: ds[a:b], n, table, calibration, _changes(f), lost, fs_hz)

