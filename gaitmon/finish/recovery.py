"""Rebuilding an interrupted file from its journal (the replay: :mod:`gaitmon.finish.replay`).

:func:`recover_session` rebuilds the whole file from the journal (the raw counts are the truth;
processed series are recomputed from row 0 with the logged settings, as ``gaitmon process``
would) and replaces the file atomically.
"""

from __future__ import annotations

import bisect
import contextlib
import itertools
import json
import os
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.gait import ContactEdges
from gaitmon.dsp.lost_frames import Losses
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.errors import Cancelled
from gaitmon.finish.replay import (
    RECOVERY_REPLAY_ROWS,
    ReplayChunk,
    flagged_at_start,
    replay_pipeline,
)
from gaitmon.finish.smoothed import KeptFirstPass
from gaitmon.io.journal import (
    IDENTITY_FIELDS,
    IDENTITY_IN_FILE,
    N_COMMON_FIELDS,
    JournalContents,
    JournalRows,
    RecordType,
    journal_lock,
    journal_path,
    read_journal,
)
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session.h5file import TableRow, _fsync_path, _H5File, _short_error
from gaitmon.io.session.header import (
    DamagedSource,
    RecoveryNotSaved,
    SessionError,
    SessionHeader,
)
from gaitmon.io.session.layout import _RECOVERY_CHUNK_ROWS, _field_names
from gaitmon.io.session.opening import open_h5
from gaitmon.io.session.rows import (
    LazyRows,
    _device_rows,
    _extrapolated_t,
    _Timeline,
    stored_pipeline_rows,
)
from gaitmon.io.session.series import attr_text
from gaitmon.text import clean_label
from gaitmon.values import JsonValue, scalar


def _journal_changes(
    contents: JournalContents,
) -> list[tuple[int, PipelineConfig | Calibration]]:
    out: list[tuple[int, PipelineConfig | Calibration]] = []
    for rtype, obj in contents.changes:
        idx = int(obj["sample_idx"])
        if rtype == RecordType.CONFIG:
            out.append((idx, PipelineConfig.from_stored(obj["config"])))
        else:
            out.append((idx, Calibration.from_dict(obj["calibration"])))
    return out


class _ChunkedTimeline:
    """The live writer's t_s (see :class:`_Timeline`), computed a block of rows at a time in row
    order (a whole 8-hour record's would be 23 MB beside the journal's rows), remembering the
    times of the rows in ``keep`` (the markers') and of the last row. Any cut gives the same
    times: ``k`` is an integer count and each gap row starts a block of its own."""

    def __init__(
        self, lost_before: LazyRows, gaps: Sequence[Mapping[str, JsonValue]], fs: float,
        keep: Iterable[int] = (),
    ) -> None:  # fmt: skip
        self._lost = lost_before
        self._per_row: dict[int, float] = {}
        for g in gaps:  # gaps at the same row add up, in journal order, as the writer does
            idx = int(scalar(g["sample_idx"]))
            self._per_row[idx] = self._per_row.get(idx, 0.0) + float(scalar(g["duration_s"]))
        self._tl = _Timeline(fs)
        self._next = 0
        self._keep = sorted(set(int(i) for i in keep))
        self.kept: dict[int, float] = {}
        self.last: float | None = None  # the time of the last row given

    def rows(self, a: int, b: int) -> np.ndarray:
        if a != self._next:
            raise ValueError(f"timeline rows {a}:{b} asked after row {self._next}")
        cuts = sorted({a, b, *(i for i in self._per_row if a < i < b)})
        parts = [self._tl.times(self._lost[x:y], self._per_row.get(x) if x else None)
                 for x, y in itertools.pairwise(cuts) if y > x]  # fmt: skip
        t = np.concatenate(parts) if parts else np.empty(0)
        for i in self._keep[bisect.bisect_left(self._keep, a) : bisect.bisect_left(self._keep, b)]:
            self.kept[i] = float(t[i - a])
        self._next = b
        if len(t):
            self.last = float(t[-1])
        return t


def recover_session(
    path: str | os.PathLike[str],
    progress: Callable[[float], bool | None] | None = None,
) -> Path:
    """Rebuild ``path`` from its journal; returns the path. Raises :class:`SessionError`.

    The new file is written beside the old one and moved over it atomically, so a crash during
    recovery loses nothing (the journal is deleted last). ``progress(fraction)`` is called as
    the work advances; returning ``False`` cancels (the journal is kept).
    """
    path = Path(path)
    jpath = journal_path(path)
    name = path.name
    if not jpath.exists():
        raise SessionError(f"{name} has no journal ({jpath.name}) to recover from")
    try:
        with journal_lock(jpath) as free:
            if not free:
                raise SessionError(
                    f"{name} is being recorded right now; open it after the recording stops"
                )
            return _recover_locked(path, jpath, progress)
    except OSError as e:
        raise SessionError(f"cannot read {jpath.name}: {_short_error(e)}") from e


IDENTITY_LOST = (
    "the patient id, operator and notes were lost with the file's damaged header (the journal "
    "never holds them)"
)


def _with_identity(path: Path, header: dict[str, Any]) -> dict[str, Any]:
    """The journal's header with the identity fields the HDF5 file holds (the journal keeps
    them blank, see gaitmon.io.journal.IDENTITY_FIELDS). A journal from before that rule
    has them itself; a file whose header cannot be read leaves them blank and says so."""
    if not header.get(IDENTITY_IN_FILE):
        return header
    session = dict(header.get("session", {}))
    try:
        # through open_h5: a file from elsewhere gives no patient id from another file
        with open_h5(path) as f:
            attrs = f["session"].attrs
            for k in IDENTITY_FIELDS:
                v = attrs.get(k, "")
                session[k] = attr_text(v)
    except Exception:  # any damage (h5py raises many kinds): recover the data without them
        session["notes"] = IDENTITY_LOST
    return {k: v for k, v in header.items() if k != IDENTITY_IN_FILE} | {"session": session}


# Above this journal size a recovery in memory is not attempted (an 8-hour raw journal is
# ~150 MB and its session ~600 MB in memory).
IN_MEMORY_MAX_JOURNAL_BYTES = 256 * 2**20


def recover_in_memory(path: str | os.PathLike[str]) -> h5py.File:
    """The session ``path`` as its journal holds it, rebuilt in memory only (nothing is
    written, the journal stays): what a reader gets while a full disk prevents
    :func:`recover_session`, so that it sees every row the recorder reported as saved.
    Raises :class:`SessionError`."""
    path = Path(path)
    jpath = journal_path(path)
    try:
        if jpath.stat().st_size > IN_MEMORY_MAX_JOURNAL_BYTES:
            raise SessionError(f"{jpath.name} is too large to recover in memory")
        with journal_lock(jpath) as free:
            if not free:
                raise SessionError(f"{path.name} is being recorded right now")
            contents = read_journal(jpath)
    except OSError as e:
        raise SessionError(f"cannot read {jpath.name}: {_short_error(e)}") from e
    if contents.header is None or contents.rows is None:
        raise SessionError(f"its journal is unusable ({contents.problem})")
    contents.header = _with_identity(path, contents.header)
    try:
        header = SessionHeader.from_dict(contents.header)
        changes = _journal_changes(contents)
        # a name of its own: the core driver without a backing store never touches it
        memory_name = path.with_name(path.name + ".in-memory")
        f = _build_recovered(memory_name, header, contents, changes, None, in_memory=True)
    except (KeyError, TypeError, ValueError, OSError, RuntimeError) as e:
        raise SessionError(f"cannot recover {path.name} in memory ({_short_error(e)})") from e
    assert f is not None
    return f


def _recover_locked(
    path: Path, jpath: Path, progress: Callable[[float], bool | None] | None
) -> Path:
    name = path.name
    try:
        contents = read_journal(jpath)
    except OSError as e:
        raise SessionError(f"cannot read {jpath.name}: {_short_error(e)}") from e
    if contents.header is None or contents.rows is None:
        raise DamagedSource(
            f"cannot recover {name}: its journal {jpath.name} is unusable ({contents.problem})"
        )
    contents.header = _with_identity(path, contents.header)
    try:
        header = SessionHeader.from_dict(contents.header)
        changes = _journal_changes(contents)
    except (KeyError, TypeError, ValueError) as e:
        raise DamagedSource(f"cannot recover {name}: bad settings in its journal ({e})") from e

    tmp = path.with_name(path.name + ".recovering")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()  # left by a recovery that was itself interrupted
    try:
        _build_recovered(tmp, header, contents, changes, progress)
        contents.rows = None  # (the journal's map goes with them: then it can be deleted)
        _fsync_path(tmp)
        os.replace(tmp, path)
        _fsync_path(path.parent, directory=True)
        jpath.unlink()
    except Cancelled:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise SessionError(
            f"recovery of {name} cancelled; the journal is kept, open the file again to recover"
        ) from None
    except (OSError, RuntimeError) as e:
        with contextlib.suppress(OSError):
            tmp.unlink()
        why = _short_error(e)
        raise RecoveryNotSaved(
            f"cannot recover {name}: {why}; free some disk space and open it again "
            "(the journal is kept)", why
        ) from e
    return path


def _build_recovered(
    tmp: Path,
    header: SessionHeader,
    contents: JournalContents,
    changes: list[tuple[int, PipelineConfig | Calibration]],
    progress: Callable[[float], bool | None] | None,
    *,
    in_memory: bool = False,
    imported_from: str = "",
) -> h5py.File | None:
    """Write the recovered session to ``tmp``; ``in_memory``: build it in memory instead and
    return the open file (the caller closes it), for reading while the disk is full.
    ``imported_from``: the rows come from another recording of the same streams (an XDF
    file, :func:`build_session`), not from a journal: the file is complete, not recovered. A
    raw recording written to disk has ``contents.rows`` let go before its smoothed angles are
    computed (memory)."""
    hdr = contents.header
    assert hdr is not None and contents.rows is not None
    rows = contents.rows
    n = len(rows)
    fs = header.sample_rate_hz
    mode = header.mode
    # raw: a fresh pipeline from row 0 (the live one may have run before the recording)
    h5 = _H5File(tmp, hdr, mode="w", reprocessed=mode == "raw", in_memory=in_memory)
    ok = False
    kept: KeptFirstPass | None = None
    try:
        if contents.wall_offset_s is not None:
            h5.set_wall_offset(contents.wall_offset_s)
        # the journal's columns are read a chunk at a time (no whole-session copies)
        seq = LazyRows(rows["seq"])
        host = LazyRows(rows["host_time_s"])
        lost_rows = LazyRows(rows["lost_before"], dtype=np.int64)
        timeline = _ChunkedTimeline(lost_rows, contents.gaps, fs,
                                    (int(m["sample_idx"]) for m in contents.markers))  # fmt: skip
        lost_at: list[tuple[np.ndarray, np.ndarray]] = []  # rows with frames lost before them

        def report(done: int) -> None:
            if progress is not None and progress(done / n if n else 1.0) is False:
                raise Cancelled("recovery cancelled")

        if mode == "raw":
            adc = LazyRows(rows["adc"])
            chunks: Iterator[ReplayChunk] = (
                replay_pipeline(
                    adc,
                    header.config,
                    header.calibration,
                    changes,
                    table=header.table,
                    lost_before=lost_rows,
                    chunk_rows=RECOVERY_REPLAY_ROWS,
                    flagged_at_start=flagged_at_start(
                        (f["sample_idx"], f["sensor"], f["reason"]) for f in contents.fsr_faults
                    ),
                    only=stored_pipeline_rows(h5.f),  # (not the rows a format-2 file derives)
                )
            )
        else:
            chunks = _device_chunks(rows, FrameKind.TILT if mode == "tilt" else FrameKind.JOINT)
        # the replayed pipeline's filter is the smoother's first pass: kept for it (where both
        # run at the same rate: the smoother takes the header's, the pipeline its settings')
        if mode == "raw" and n and not in_memory and header.config.fs_hz == fs:
            kept = KeptFirstPass(str(Path(tmp).parent))
        for a, proc, hs, to, faults, first_pass in chunks:
            b = a + len(next(iter(proc.values())))
            if kept is not None:
                kept.add(a, first_pass)
            cols = {
                "timeline/seq": seq[a:b],
                "timeline/host_time_s": host[a:b],
                "timeline/t_s": timeline.rows(a, b),
                **proc,
            }
            if mode == "raw":
                cols["raw/adc"] = adc[a:b]
                lost_chunk = lost_rows[a:b]
                nz = np.flatnonzero(lost_chunk)
                lost_at.append((nz + a, lost_chunk[nz]))
            h5.append_rows(cols, b - a)
            h5.append_events("heel_strike", hs)
            h5.append_events("toe_off", to)
            h5.append_table("events/fsr_faults", faults)
            if isinstance(rows, JournalRows):  # rows in order: the map's pages read go
                rows.release_before(b)
            del proc, first_pass, cols  # (not alive while the next chunk is replayed)
            report(b)

        h5.append_table(
            "gaps",
            [
                (int(g["sample_idx"]), int(g["n_lost"]), float(g["duration_s"]), str(g["reason"]))
                for g in contents.gaps
            ],
        )
        markers = []
        for m in contents.markers:
            idx = int(m["sample_idx"])
            t = timeline.kept[idx] if 0 <= idx < n else _extrapolated_t(timeline.last, idx, n, fs)
            # a journal written before labels were cleaned may hold a NUL (which HDF5 cannot)
            markers.append((idx, t, clean_label(m.get("label", ""))))
        h5.append_table("markers", markers)
        cfg_log = [
            (i, json.dumps(c.as_dict())) for i, c in changes if isinstance(c, PipelineConfig)
        ]
        cal_log = [(i, json.dumps(c.as_dict())) for i, c in changes if isinstance(c, Calibration)]
        h5.append_table("config/changes", cfg_log)
        h5.append_table("calibration/changes", cal_log)
        crc_log: list[TableRow] = []
        last_crc = 0
        totals: Mapping[str, Any] = {}
        for rec in contents.links:
            totals = rec["totals"]
            crc = int(totals.get("crc_failures", 0))
            if crc > last_crc:
                crc_log.append((int(rec["sample_idx"]), crc))
                last_crc = crc
        h5.append_table("link/crc_failures", crc_log)
        h5.set_link_totals(totals)
        if mode == "raw" and n and not in_memory:  # in memory, the reader computes them if asked
            from gaitmon.finish.smoothed import store_smoothed

            cal_changes = [(i, c) for i, c in changes if isinstance(c, Calibration)]
            # the journal's rows (~50 bytes a row) are let go first: the smoother reads the
            # counts back from the new file a block at a time, as a recorder's close does
            contents.rows = None
            del rows, adc, seq, host, chunks, lost_rows, timeline  # (they view the rows)
            # sparse: no per-row array (8 bytes a row)
            lost = Losses(np.concatenate([at for at, _ in lost_at] or [np.empty(0, np.int64)]),
                          np.concatenate([c for _, c in lost_at] or [np.empty(0, np.int64)]))
            del lost_at
            h5.drain()
            ds = h5.f["raw/adc"]
            from gaitmon.finish.strides import store_strides
            from gaitmon.io.session.attributes import described_once

            with described_once(h5.f):
                store_smoothed(h5.f, lambda a, b: ds[a:b], n, header.table,
                               header.calibration, cal_changes, lost, fs,
                               None if kept is None else kept.first_pass)  # fmt: skip
                h5.drain()  # the chunk being filled: the stride measures read every row
                store_strides(h5.f, header.table, header.calibration, fs)
        if imported_from:
            h5.f.attrs["imported_from"] = imported_from
            h5.finish(complete=True, recovered=False, stop_reason=f"imported from {imported_from}",
                      fs_hz=fs)  # fmt: skip
        else:
            h5.finish(complete=False, recovered=True, stop_reason="recovered", fs_hz=fs)
        report(n)
        ok = True
    finally:
        if kept is not None:
            kept.close()
        if not (ok and in_memory):
            h5.close()
    return h5.f if in_memory else None


def build_session(
    path: str | os.PathLike[str],
    contents: JournalContents,
    changes: Sequence[tuple[int, PipelineConfig | Calibration]],
    *,
    imported_from: str,
    overwrite: bool = False,
    progress: Callable[[float], bool | None] | None = None,
) -> Path:
    """Write a whole session file from rows held in memory as a journal would hold them
    (``contents``: header, rows of the mode's :data:`gaitmon.io.journal.ROW_DTYPES`, gaps,
    markers; ``changes``: settings and calibrations from their rows on): the recovery's own
    path, so the processed series, events, ``/smoothed`` and ``/overview`` are what a
    recording of the same rows holds. Used by the XDF import (``imported_from`` names the
    source). Written as ``PATH.partial`` and moved into place. Raises :class:`SessionError`."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise SessionError(f"{path} already exists; choose another name")
    if not path.parent.is_dir():
        raise SessionError(f"folder {path.parent} does not exist")
    if contents.header is None or contents.rows is None:
        raise SessionError("no header or no rows to write")
    try:
        header = SessionHeader.from_dict(contents.header)
    except (KeyError, TypeError, ValueError) as e:
        raise SessionError(f"bad session header ({e})") from e
    tmp = path.with_name(path.name + ".partial")
    try:
        _build_recovered(tmp, header, contents, list(changes), progress,
                         imported_from=imported_from)  # fmt: skip
        os.replace(tmp, path)
    except Cancelled:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    except (OSError, RuntimeError) as e:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise SessionError(f"cannot write {path}: {_short_error(e)}") from e
    return path


def _device_chunks(rows: np.ndarray | JournalRows, kind: FrameKind) -> Iterator[ReplayChunk]:
    edges = ContactEdges() if kind == FrameKind.JOINT else None
    names = _field_names(rows.dtype)[N_COMMON_FIELDS:]
    empty = np.empty(0, np.int64)
    for a in range(0, len(rows), _RECOVERY_CHUNK_ROWS):
        part = rows[a : a + _RECOVERY_CHUNK_ROWS]
        proc = _device_rows(kind, {k: part[k] for k in names})
        if edges is not None:
            hs, to = edges.process(part["heel_loaded"], part["toe_loaded"], a)
        else:
            hs, to = empty, empty
        yield ReplayChunk(a, proc, hs, to, [])
