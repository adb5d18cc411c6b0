"""Reprocessing a raw session into a new file: the pipeline re-run from the raw counts.

The original is never modified: the new file is a copy (written as ``NEW.partial`` and moved
into place atomically) whose ``/processed`` series, ``/events`` and ``/config`` come from the
new settings; standing calibrations logged during the recording are replayed at their rows.
``gaitmon process`` and the review window's "Save reprocessed as…" both call
:func:`rewrite_processed`, so they report progress and honour Cancel the same way.
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import ChannelTable
from gaitmon.dsp.fsr_check import FsrFault
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.errors import DAMAGE_ERRORS, Cancelled
from gaitmon.finish.replay import RECOVERY_REPLAY_ROWS, flags_kept, replay_pipeline
from gaitmon.finish.session import Session, open_session
from gaitmon.finish.smoothed import KeptFirstPass, store_smoothed
from gaitmon.finish.strides import store_strides
from gaitmon.io.session.attributes import described_once
from gaitmon.io.session.chunk_write import RowWriter
from gaitmon.io.session.codec import encode
from gaitmon.io.session.h5file import _short_error, open_cached
from gaitmon.io.session.header import SessionError
from gaitmon.io.session.layout import _TABLE_CHUNK_ROWS, _TABLES
from gaitmon.io.session.rows import (
    LazyRows,
    LostRows,
    losses_from_gaps,
    stored_pipeline_rows,
)
from gaitmon.io.session.stored_overview import OverviewBuilder, write_overview
from gaitmon.io.session.trust import CheckedCounts, full_scale_of, written_here

# the copy is this share of the progress bar, the replay the rest (both are I/O bound)
COPY_SHARE = 0.25
COPY_CHUNK_BYTES = 4 << 20  # an 8-hour session (~400 MB) is ~100 cancel points
# 16384 rows = 2.7 min at 100 Hz per cancel point; the pipeline's block for them is ~12 MB with
# its temporaries (65536 rows: ~50 MB, twice over while the next was made); chunking does not
# change the pipeline's output (its contract)
REPLAY_CHUNK_ROWS = RECOVERY_REPLAY_ROWS
# The raw counts are read two or three times (the replay, the smoother, the stride measures):
# held decoded in HDF5's chunk cache when they fit in this (~6 h of record), they are
# decompressed once
RAW_CACHE_MAX_BYTES = 64 << 20

Progress = Callable[[float], object]
Cancel = Callable[[], bool]


@dataclass(frozen=True)
class RewriteResult:
    path: Path  # the new session file
    n_frames: int  # rows reprocessed
    config: PipelineConfig  # the settings now in the file


def partial_path(dst: str | os.PathLike[str]) -> Path:
    """Where the new file is built before it is moved into place."""
    p = Path(dst)
    return p.with_name(p.name + ".partial")


def check_raw(s: Session) -> None:
    """:class:`SessionError` unless the open session holds raw counts (what a reprocessing
    replays)."""
    if s.mode != "raw":
        raise SessionError(
            f"{s.path.name} holds the unit's own {s.mode} angles, not raw counts; only "
            "raw-mode sessions can be reprocessed"
        )


def rewrite_processed(
    src: Path,
    dst: Path,
    config: PipelineConfig,
    *,
    progress: Progress | None = None,
    cancel: Cancel | None = None,
    overwrite: bool = False,
    unit: UnitInputs | None = None,
) -> RewriteResult:
    """Write ``dst``: a copy of the raw session ``src`` reprocessed with ``config``.
    ``unit``: what the replay takes from ``src``, where the caller has read it already
    (``gaitmon process``: it read the settings from the same open); else read here.

    ``progress(fraction)`` goes from 0 to 1 (the copy, then the replay); ``cancel()`` is asked
    between chunks, and when it answers True the partial file is deleted and
    :class:`gaitmon.errors.Cancelled` raised. Every other failure raises :class:`SessionError`
    with a one-line message. ``src`` is never modified.
    """
    src, dst = Path(src), Path(dst)
    check_destination(src, dst, overwrite)
    report = _reporter(progress)
    check_cancel = _canceller(cancel)
    report(0.0)
    tmp = partial_path(dst)
    with _building(tmp, dst, src):
        if unit is None:
            with open_session(src) as s:
                unit = UnitInputs.of(s)
        _copy(src, tmp, lambda f: report(COPY_SHARE * f), check_cancel)
        # the events are made anew, and a file from before the attributes gets them too:
        # described once, when it is whole
        with h5py.File(tmp, "r+") as f, described_once(f):
            rewrite_unit(f, unit, config, lambda f: report(COPY_SHARE + (1.0 - COPY_SHARE) * f),
                         check_cancel)  # fmt: skip
        check_cancel()
        os.replace(tmp, dst)
    written_here(dst)  # (read back next: the summary)
    report(1.0)
    return RewriteResult(dst, unit.n, config)


def check_destination(src: Path, dst: Path, overwrite: bool) -> None:
    """``SessionError`` unless ``dst`` may be written: not the recording itself, not an
    existing file (unless ``overwrite``), in a folder that exists."""
    if dst.exists() and dst.resolve() == src.resolve():
        raise SessionError(
            f"{dst.name} is the recording itself: write the reprocessed session to another "
            "file (the original recording is never modified)"
        )
    if dst.exists() and not overwrite:
        raise SessionError(f"{dst} already exists; choose another name")
    if not dst.parent.is_dir():
        raise SessionError(f"folder {dst.parent} does not exist")


def _reporter(progress: Progress | None) -> Progress:
    def report(fraction: float) -> None:
        if progress is not None:
            progress(min(1.0, max(0.0, fraction)))

    return report


def _canceller(cancel: Cancel | None) -> Callable[[], None]:
    def check_cancel() -> None:
        if cancel is not None and cancel():
            raise Cancelled

    return check_cancel


@contextlib.contextmanager
def _building(tmp: Path, dst: Path, src: Path | None = None) -> Iterator[None]:
    """The partial file ``tmp`` is deleted whatever makes building it fail (a cancel, a full
    disk, damage found in ``src`` while it is replayed, an interrupt): never left behind. A
    write failure becomes one ``SessionError`` line, and so does damage of ``src``."""
    try:
        yield
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if isinstance(exc, (OSError, RuntimeError)):  # h5py reports some write failures so
            raise SessionError(
                f"cannot write {dst}: {getattr(exc, 'strerror', None) or exc}"
            ) from None
        if src is not None and isinstance(exc, DAMAGE_ERRORS):
            raise SessionError(
                f"{src.name} is damaged and cannot be reprocessed ({_short_error(exc)})"
            ) from None
        raise


@dataclass(frozen=True)
class UnitInputs:
    """What the replay of one unit takes from its recording (read before it is copied)."""

    n: int
    calibration: Calibration
    calibration_log: list[tuple[int, Calibration]]
    table: ChannelTable  # the unit's own conversion, as recovery and review use
    lost: LostRows  # the frames lost before each row (sparse: no per-row array)
    config: PipelineConfig  # the settings it was recorded with
    fsr_faults: tuple[FsrFault, ...] = ()  # those from row 0 stay flagged (flags_kept)
    name: str = ""  # the recording's file name, for messages

    @classmethod
    def of(cls, s: Session) -> UnitInputs:
        check_raw(s)
        n = s.n_samples
        return cls(n, s.calibration, list(s.calibration_changes), s.header.table,
                   LostRows(losses_from_gaps(s.gaps, n), n), s.config, tuple(s.fsr_faults),
                   s.path.name)  # fmt: skip


def _copy(src: Path, tmp: Path, report: Progress, check_cancel: Callable[[], None]) -> None:
    """``shutil.copyfile`` in chunks, so a long copy reports progress and can be cancelled."""
    total = max(1, src.stat().st_size)
    done = 0
    with open(src, "rb") as fin, open(tmp, "wb") as fout:
        # in the kernel where it can (no copy through this process: ~1/3 of the CPU)
        in_kernel = hasattr(os, "copy_file_range")
        while True:
            if in_kernel:
                try:
                    k = os.copy_file_range(fin.fileno(), fout.fileno(), COPY_CHUNK_BYTES)
                except OSError:  # (a file system or kernel without it: copied here)
                    in_kernel = False
                    fin.seek(done)
                    fout.seek(done)
                    continue
            else:
                chunk = fin.read(COPY_CHUNK_BYTES)
                k = fout.write(chunk)
            if not k:
                break
            done += k
            report(done / total)
            check_cancel()


def rewrite_unit(
    f: h5py.Group,
    unit: UnitInputs,
    config: PipelineConfig,
    report: Progress,
    check_cancel: Callable[[], None],
) -> None:
    """Reprocess the one unit whose layout is rooted at ``f`` (a one-unit file, or a bilateral
    file's ``/units/<side>``) in place with ``config``. Its steps describe what they write;
    callers hold that until the file is whole (``attributes.described_once``: one pass)."""
    n, calibration, calibration_log = unit.n, unit.calibration, unit.calibration_log
    table, lost = unit.table, unit.lost
    v2 = int(f.attrs.get("format_version", 1)) >= 2
    proc = f["processed"]
    # the raw counts are read a chunk at a time (the copy holds the recording's own)
    raw = open_cached(f, "raw/adc", RAW_CACHE_MAX_BYTES)  # (store_strides' open shares it)
    adc = LazyRows(CheckedCounts(unit.name, full_scale_of(table), raw), n)
    hs: list[np.ndarray] = []
    to: list[np.ndarray] = []
    paths = stored_pipeline_rows(f)
    overview = OverviewBuilder()  # the joints' overview, of the tilts as written
    writers = {p: RowWriter(f[p].id) for p in paths}
    replay = replay_pipeline(
        adc,
        config,
        calibration,
        calibration_log,
        table=table,
        chunk_rows=REPLAY_CHUNK_ROWS,
        lost_before=lost,
        flagged_at_start=flags_kept(unit.fsr_faults, unit.config, config),
        only=paths,
    )
    faults: list[tuple[int, int, str, str]] = []
    # the pipeline's filter is the smoother's first pass: kept, so it runs once
    with KeptFirstPass(os.path.dirname(f.file.filename) or None) as kept:
        for start, rows, hs_rows, to_rows, found, first_pass in replay:
            faults += found
            stop = start + len(rows["processed/tilt_deg"])
            kept.add(start, first_pass)
            for path, data in rows.items():
                stored = encode(path, data) if v2 else data
                writers[path].write(start, stored)
                overview.add(path, start, stored)
            hs.append(hs_rows)
            to.append(to_rows)
            del rows, data, stored, first_pass  # (not alive while the next chunk is replayed)
            report(stop / max(n, 1))
            check_cancel()
        proc.attrs["reprocessed"] = True
        proc.attrs["source"] = "pc"
        proc.attrs["tilt_method"] = config.tilt_method_label
        store_smoothed(f, adc.rows, n, table, calibration, calibration_log, lost.losses,
                       config.fs_hz, kept.first_pass, overview)  # fmt: skip
    ev = f["events"]
    for name, parts in (("heel_strike", hs), ("toe_off", to)):
        data = np.concatenate(parts) if parts else np.empty(0, np.int64)
        del ev[name]
        ev.create_dataset(name, data=data.astype(np.int64), maxshape=(None,), chunks=True)
    if "fsr_faults" in ev:  # (a file written before the table existed has none)
        del ev["fsr_faults"]
    ev.create_dataset(
        "fsr_faults",
        data=np.array(faults, dtype=_TABLES["events/fsr_faults"]),
        maxshape=(None,),
        chunks=(_TABLE_CHUNK_ROWS,),
    )
    cfg = f["config"]
    for key, value in config.as_dict().items():
        cfg.attrs[key] = value
    cfg.attrs["event_delay_samples"] = config.event_delay_samples
    # the new settings hold for the whole file: no changes during the recording
    del cfg["changes"]
    cfg.create_dataset(
        "changes",
        data=np.array([], dtype=_TABLES["config/changes"]),
        maxshape=(None,),
        chunks=(_TABLE_CHUNK_ROWS,),
    )
    cfg.attrs["reprocessed_from"] = json.dumps({"settings": config.as_dict()})
    write_overview(f, overview)  # the joint angles changed: so did their overview
    # so may have the heel strikes (the measures of the same ones are kept: other tilt
    # settings leave them as they were)
    store_strides(f, table, calibration, config.fs_hz, keep_valid=True)
    report(1.0)
