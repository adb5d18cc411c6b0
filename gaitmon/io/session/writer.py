"""Recording a session: :class:`SessionWriter`, the recorder thread's only tool.

How a recording survives a crash. Every :meth:`SessionWriter.append` first writes the block to
the journal (``FILE.journal``, see :mod:`gaitmon.io.journal`) with one ``write()``, so a killed
process loses nothing it had handed over; the rows are staged in memory and written to the
HDF5 file, which is flushed and the journal synced, every ``flush_interval_s`` (100 ms); format 2
compresses its datasets, so the file receives each 4096-row chunk once, whole, when it is full
(:class:`gaitmon.io.session.h5file._H5File` stages the chunk being filled: it is in the journal
meanwhile, and a reader of the file as it is sees the whole chunks). A clean
:meth:`SessionWriter.close` marks the file complete and deletes the journal. A journal found
beside a file means the recording was interrupted (see :mod:`gaitmon.finish.recovery`).

Why writes are batched per flush rather than per block: an h5py resize + write costs tens of
microseconds per dataset, and a block touches ~17 datasets, so per-block HDF5 writes at
100 blocks/s would cost a noticeable fraction of a core; journal + staging cost a few
microseconds, and the HDF5 work is done 10 times a second in one go.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from types import TracebackType

import h5py
import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.gait import ContactEdges
from gaitmon.dsp.pipeline import PipelineBlock, PipelineConfig
from gaitmon.io.device import LinkStats, SampleBlock
from gaitmon.io.journal import (
    BLOCK_TYPES,
    N_COMMON_FIELDS,
    ROW_DTYPES,
    JournalWriter,
    RecordType,
    encode_block,
    encode_json,
    journal_path,
    without_identity,
)
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session.h5file import (
    TableRow,
    _being_recorded,
    _fsync_path,
    _H5File,
    _short_error,
)
from gaitmon.io.session.header import SessionError, SessionHeader
from gaitmon.io.session.layout import (
    _TABLES,
    FORMAT_VERSION,
    LINK_TOTALS,
    LINK_TOTALS_IF_ANY,
    _field_names,
    per_sample_datasets,
)
from gaitmon.io.session.rows import (
    _device_rows,
    _extrapolated_t,
    _Timeline,
    fault_rows,
    rows_from_pipeline,
)
from gaitmon.text import clean_label

# What the finishing layer adds to a raw recording at its close, from the rows the file holds
# (the open file, the recording's header, its sample rate): see SessionWriter.close.
Derive = Callable[[h5py.File, SessionHeader, float], None]


class SessionWriter:
    """Records one session: HDF5 file + journal. Used by one thread (the recorder); not
    thread-safe.

    Call :meth:`append` for every block and :meth:`maybe_flush` also while no data arrive
    (e.g. on a queue timeout), so the 100 ms guarantee holds through link outages.

    Any failure to write (disk full, file size limit, I/O error, a removed drive) raises
    :class:`SessionError` once with the whole story; the writer is then dead (every later call
    raises the same error, :meth:`close` just releases the files), the journal is left in
    place and the next :func:`open_session` recovers every row that was written before.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        header: SessionHeader,
        *,
        flush_interval_s: float = 0.1,
        overwrite: bool = False,
        format_version: int = FORMAT_VERSION,
    ) -> None:
        self._path = Path(path)
        self.header = header
        self.flush_interval_s = float(flush_interval_s)
        self._fs = float(header.sample_rate_hz)
        self._kind = {"raw": FrameKind.RAW, "tilt": FrameKind.TILT, "joint": FrameKind.JOINT}[
            header.mode
        ]
        self._rtype = BLOCK_TYPES[header.mode]
        self._row_dtype = ROW_DTYPES[self._rtype]
        self._datasets = per_sample_datasets(header.mode)
        jpath = journal_path(self._path)
        name = self._path.name
        if not overwrite:
            if self._path.exists():
                raise SessionError(f"{name} already exists; choose another file name")
            if jpath.exists():
                raise SessionError(
                    f"{jpath.name} exists: an interrupted recording named {name} waits to be "
                    "recovered; open it first, or choose another file name"
                )
        elif jpath.exists() and _being_recorded(jpath):
            # never overwrite a recording in progress (another window or process): deleting
            # its journal and file would lose the whole session
            raise SessionError(
                f"{name} is being recorded right now; stop that recording first, or "
                "choose another file name"
            )
        self._journal: JournalWriter | None = None
        self._h5: _H5File | None = None
        hdr = header.as_dict()
        try:
            if overwrite:
                with contextlib.suppress(FileNotFoundError):
                    jpath.unlink()
            self._journal = JournalWriter(jpath)
            self._journal.write_raw(encode_json(RecordType.HEADER, without_identity(hdr)))
            self._journal.sync()
            self._h5 = _H5File(self._path, hdr, mode="w" if overwrite else "x", reprocessed=False,
                               version=format_version)  # fmt: skip
            self._h5.f.flush()
        except (OSError, RuntimeError) as e:
            self._release()
            for p in (jpath, self._path):
                with contextlib.suppress(OSError):
                    p.unlink()
            raise SessionError(f"cannot create {name}: {_short_error(e)}") from e

        self._rows = 0  # rows handed to the journal (the truth)
        self._timeline = _Timeline(self._fs)
        self._pending_gap_s: float | None = None
        self._staged: dict[str, list[np.ndarray]] = {p: [] for p in self._datasets}
        self._staged_rows = 0
        self._staged_events: dict[str, list[np.ndarray]] = {"heel_strike": [], "toe_off": []}
        self._staged_tables: dict[str, list[TableRow]] = {k: [] for k in _TABLES}
        self._pending_markers: list[tuple[int, str]] = []
        self._edges = ContactEdges() if header.mode == "joint" else None
        self._wall_offset_s: float | None = None
        self._link_totals: dict[str, int] = dict.fromkeys((*LINK_TOTALS, *LINK_TOTALS_IF_ANY), 0)
        self._link_dirty = False
        self._last_seq: int | None = None
        self._dirty = False
        self._last_flush = time.monotonic()
        self._bytes = self._h5.size_bytes()
        self._error: SessionError | None = None
        self._closed = False

    # -- properties ---------------------------------------------------------------------------

    @property
    def path(self) -> Path:
        return self._path

    @property
    def rows(self) -> int:
        """Rows recorded so far (all of them in the journal, at most 100 ms not yet in HDF5)."""
        return self._rows

    @property
    def bytes_written(self) -> int:
        """Size of the HDF5 file at the last flush (what the UI shows as the file size)."""
        return self._bytes

    @property
    def error(self) -> SessionError | None:
        """The write error that stopped this recording, if any."""
        return self._error

    @property
    def closed(self) -> bool:
        return self._closed

    # -- recording ------------------------------------------------------------------------------

    def append(
        self,
        samples: SampleBlock,
        processed: PipelineBlock | None = None,
        *,
        event_offset: int = 0,
    ) -> None:
        """Record one block. Raw mode: ``samples.adc`` plus the pipeline's ``processed`` block
        for the same samples; event indices minus ``event_offset`` are row numbers (events
        before row 0 are dropped). Tilt/joint modes: ``processed`` is None."""
        self._check_usable()
        n = len(samples)
        if n == 0:
            self.maybe_flush()
            return
        if FrameKind(samples.kind) != self._kind:
            raise ValueError(
                f"this is a {self.header.mode} session; got a {FrameKind(samples.kind).name} block"
            )
        seq = np.asarray(samples.seq, dtype=np.int64)
        if (self._last_seq is not None and seq[0] <= self._last_seq) or np.any(np.diff(seq) <= 0):
            raise ValueError("sequence numbers must increase strictly across blocks")
        lost = getattr(samples, "lost_before", None)
        if lost is None:  # a block that does not say: take every sequence step as losses
            prev = seq[0] - 1 if self._last_seq is None else self._last_seq
            lost = np.diff(seq, prepend=prev) - 1
        lost = np.asarray(lost, dtype=np.int64)
        if lost.shape != (n,) or np.any(lost < 0):
            raise ValueError("lost_before must be (N,) counts >= 0")
        rec = np.empty(n, dtype=self._row_dtype)
        rec["seq"] = seq
        rec["host_time_s"] = samples.host_time_s
        rec["lost_before"] = lost
        if self._kind == FrameKind.RAW:
            if processed is None or processed.n != n:
                raise ValueError("raw mode needs the pipeline block of the same samples")
            rec["adc"] = samples.adc
            rows = rows_from_pipeline(processed)
            faults = fault_rows(processed.fsr_faults, processed.start_idx, self._rows)
            for decided, first, sensor, reason in faults:  # (those at row 0 seed recovery)
                self._write_journal(encode_json(RecordType.FSR_FAULT, {
                    "sample_idx": decided, "stride_start_idx": first, "sensor": sensor,
                    "reason": reason}))  # fmt: skip
            self._staged_tables["events/fsr_faults"] += faults
        else:
            if processed is not None:
                raise ValueError(f"{self.header.mode} mode takes no pipeline block")
            kind_fields = _field_names(self._row_dtype)[N_COMMON_FIELDS:]
            for name in kind_fields:
                rec[name] = getattr(samples, name)
            rows = _device_rows(self._kind, {k: rec[k] for k in kind_fields})
        wall = float(samples.wall_offset_s)
        self._write_journal(encode_block(self._rtype, wall, rec))

        start = self._rows
        self._rows += n
        self._last_seq = int(seq[-1])
        if self._wall_offset_s is None:
            self._wall_offset_s = wall
        t_s = self._timeline.times(lost, self._pending_gap_s)
        self._pending_gap_s = None
        st = self._staged
        st["timeline/seq"].append(seq)
        st["timeline/host_time_s"].append(np.asarray(samples.host_time_s, dtype=np.float64))
        st["timeline/t_s"].append(t_s)
        if self._kind == FrameKind.RAW:
            st["raw/adc"].append(rec["adc"])
            ev = self._staged_events
            assert processed is not None
            for name, idx in (
                ("heel_strike", processed.heel_strike_idx),
                ("toe_off", processed.toe_off_idx),
            ):
                if len(idx):
                    r = np.asarray(idx, dtype=np.int64) - event_offset
                    ev[name].append(r[r >= 0])
        elif self._edges is not None:
            hs, to = self._edges.process(rec["heel_loaded"], rec["toe_loaded"], start)
            self._staged_events["heel_strike"].append(hs)
            self._staged_events["toe_off"].append(to)
        for path, data in rows.items():
            st[path].append(data)
        self._staged_rows += n
        self._dirty = True
        self.maybe_flush()

    def add_marker(self, label: str, sample_idx: int | None = None) -> None:
        """A clinician's marker at ``sample_idx`` (default: the next row). The label is
        cleaned (``gaitmon.text.clean_label``): an HDF5 string cannot hold a NUL, and one
        label must never stop a recording."""
        self._check_usable()
        label = clean_label(label)
        idx = self._rows if sample_idx is None else int(sample_idx)
        if idx < 0:
            raise ValueError(f"marker sample_idx must be >= 0, got {idx}")
        self._write_journal(
            encode_json(RecordType.MARKER, {"sample_idx": idx, "label": str(label)})
        )
        self._pending_markers.append((idx, str(label)))
        self._dirty = True

    def add_gap(self, n_lost: int, duration_s: float, reason: str) -> None:
        """Frames missing before the next row (``reason``: 'frames lost', 'link lost: ...')."""
        self._check_usable()
        rec = {
            "sample_idx": self._rows,
            "n_lost": int(n_lost),
            "duration_s": float(duration_s),
            "reason": str(reason),
        }
        self._write_journal(encode_json(RecordType.GAP, rec))
        self._staged_tables["gaps"].append(
            (self._rows, int(n_lost), float(duration_s), str(reason))
        )
        self._pending_gap_s = (self._pending_gap_s or 0.0) + float(duration_s)
        self._dirty = True

    def log_config(self, config: PipelineConfig) -> None:
        """New pipeline settings, in force from the next row."""
        self._check_usable()
        d = config.as_dict()
        self._write_journal(encode_json(RecordType.CONFIG, {"sample_idx": self._rows, "config": d}))
        self._staged_tables["config/changes"].append((self._rows, json.dumps(d)))
        self._dirty = True

    def log_calibration(self, cal: Calibration) -> None:
        """A new standing calibration (zeroing), in force from the next row."""
        self._check_usable()
        d = cal.as_dict()
        self._write_journal(
            encode_json(RecordType.CALIBRATION, {"sample_idx": self._rows, "calibration": d})
        )
        self._staged_tables["calibration/changes"].append((self._rows, json.dumps(d)))
        self._dirty = True

    def update_link(self, stats: LinkStats, reconnects_base: int = 0) -> None:
        """Link totals; journalled only when they changed (cheap to call on every block).
        ``reconnects_base``: the link's reconnects before this recording began (the count is
        the connection's; the file's is the recording's own)."""
        self._check_usable()
        d = stats.decoder
        totals = {
            "frames_ok": int(d.frames_ok),
            "frames_lost": int(d.frames_lost),
            "crc_failures": int(d.crc_failures),
            "bytes_received": int(d.bytes_received),
            "bytes_skipped": int(d.bytes_skipped),
            "invalid_values": int(d.invalid_values),
            "reconnects": max(0, int(stats.reconnects) - reconnects_base),
            "queue_overflow_frames": int(stats.queue_overflow_frames),
            "implausible_frames": int(d.implausible_frames),
        }
        if totals == self._link_totals:
            return
        self._write_journal(
            encode_json(RecordType.LINK, {"sample_idx": self._rows, "totals": totals})
        )
        if totals["crc_failures"] > self._link_totals["crc_failures"]:
            self._staged_tables["link/crc_failures"].append((self._rows, totals["crc_failures"]))
        self._link_totals = totals
        self._link_dirty = True
        self._dirty = True

    def maybe_flush(self) -> None:
        """Flush HDF5 and sync the journal if ``flush_interval_s`` has passed since the last."""
        if self._error is not None or self._closed:
            return
        now = time.monotonic()
        if now - self._last_flush >= self.flush_interval_s:
            self._last_flush = now
            if self._dirty:
                self.flush()

    def flush(self) -> None:
        """Write everything staged to HDF5, flush it to the OS, sync the journal to disk."""
        self._check_usable()
        assert self._h5 is not None and self._journal is not None
        try:
            self._write_staged()
            self._h5.f.flush()
            self._journal.sync()
            self._bytes = self._h5.size_bytes()
        except (OSError, RuntimeError) as e:
            raise self._fail(e) from e
        self._dirty = False

    def close(self, *, stop_reason: str = "user", derive: Derive | None = None) -> None:
        """Finish the file (complete, n_samples, duration_s, stop_reason) and delete the journal.

        ``derive`` adds what is computed from the stored rows (``/smoothed``, ``/strides``: the
        finishing layer's, :func:`gaitmon.finish.close_recording`) to the file once every row,
        event and marker is in it and before it is marked complete, so a crash meanwhile
        leaves the journal for recovery; its write errors fail the close as any write does.
        The writer itself stores only.

        After a write error this only releases the files (the journal stays for recovery).
        """
        if self._closed:
            return
        if self._error is not None:
            self._closed = True
            self._release()
            return
        assert self._h5 is not None and self._journal is not None
        try:
            self._write_staged()
            self._h5.drain()  # the chunk being filled, so that derive reads every row
            self._write_markers(final=True)
            if derive is not None and self._kind == FrameKind.RAW and self._rows:
                derive(self._h5.f, self.header, self._fs)
            self._h5.finish(complete=True, recovered=False, stop_reason=stop_reason, fs_hz=self._fs)
            self._bytes = self._h5.size_bytes()
            self._h5.close()
            self._h5 = None
            _fsync_path(self._path)  # the complete file is on disk before its journal goes
            self._journal.close()
            self._journal = None
            journal_path(self._path).unlink()
            _fsync_path(self._path.parent, directory=True)
        except (OSError, RuntimeError) as e:
            err = self._fail(e)
            self._closed = True
            raise err from e
        self._closed = True

    def abort(self, exc: BaseException) -> str:
        """Stop after an unexpected error (a bug, not a write failure): release the files
        without finishing the HDF5 file and keep the journal, so the next open recovers every
        row handed over. Returns the one-line message (also :attr:`error` from now on)."""
        if self._error is None:
            what = " ".join(str(exc).split())[:200] or type(exc).__name__
            self._error = SessionError(
                f"recording to {self._path.name} stopped by an internal error "
                f"({type(exc).__name__}: {what}); everything up to row {self._rows} "
                f"({self._rows / self._fs:.1f} s) is saved and is recovered when the file is "
                "next opened"
            )
        self._closed = True
        self._release()
        return str(self._error)

    def __enter__(self) -> SessionWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:  # fmt: skip
        if exc is None:
            self.close()
        else:
            with contextlib.suppress(SessionError):
                self.close(stop_reason=f"error: {' '.join(str(exc).split())[:200]}")

    # -- internals -------------------------------------------------------------------------------

    def _check_usable(self) -> None:
        if self._error is not None:
            raise self._error
        if self._closed:
            raise SessionError(f"the recording to {self._path.name} is already stopped")

    def _write_journal(self, record: bytes) -> None:
        assert self._journal is not None
        try:
            self._journal.write_raw(record)
        except OSError as e:
            raise self._fail(e) from e

    def _write_staged(self) -> None:
        h5 = self._h5
        assert h5 is not None
        if self._wall_offset_s is not None and h5.rows == 0 and self._staged_rows:
            h5.set_wall_offset(self._wall_offset_s)
        if self._staged_rows:
            cols = {p: _cat(parts) for p, parts in self._staged.items()}
            h5.append_rows(cols, self._staged_rows)
            for parts in self._staged.values():
                parts.clear()
            self._staged_rows = 0
        for name, parts in self._staged_events.items():
            if parts:
                h5.append_events(name, _cat(parts))
                parts.clear()
        for name, recs in self._staged_tables.items():
            if recs:
                h5.append_table(name, recs)
                recs.clear()
        if self._link_dirty:
            h5.set_link_totals(self._link_totals)
            self._link_dirty = False
        self._write_markers(final=False)

    def _write_markers(self, *, final: bool) -> None:
        """Markers wait until their row exists (their t_s is that row's time); at the end, a
        marker beyond the last row gets a time extrapolated at the nominal rate."""
        h5 = self._h5
        assert h5 is not None
        ready: list[TableRow] = []
        while self._pending_markers:
            idx, label = self._pending_markers[0]
            if idx < h5.rows:
                t = h5.t_s_at(idx)
            elif final:
                t = _extrapolated_t(
                    h5.t_s_at(h5.rows - 1) if h5.rows else None, idx, h5.rows, self._fs
                )
            else:
                break
            ready.append((idx, t, label))
            self._pending_markers.pop(0)
        h5.append_table("markers", ready)

    def _fail(self, e: BaseException) -> SessionError:
        fs = self._fs
        err = SessionError(
            f"disk full or write error while recording {self._path.name}: {_short_error(e)}; "
            f"recording stopped, everything up to row {self._rows} "
            f"({self._rows / fs:.1f} s) is saved and is recovered when the file is next opened"
        )
        self._error = err
        self._release()
        return err

    def _release(self) -> None:
        if self._h5 is not None:
            with contextlib.suppress(Exception):
                self._h5.close()
            self._h5 = None
        if self._journal is not None:
            with contextlib.suppress(OSError):
                self._journal.close()
            self._journal = None


def _cat(parts: list[np.ndarray]) -> np.ndarray:
    return parts[0] if len(parts) == 1 else np.concatenate(parts)
