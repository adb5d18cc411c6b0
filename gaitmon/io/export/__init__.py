"""Export of recorded sessions (HDF5, docs/file-format.md) to CSV, MATLAB .mat, C3D and BIDS.

The package owns the exported layouts (column names, MAT struct fields, C3D groups), the
precision each format keeps, and de-identification of what is exported. The layouts are
documented in docs/file-format.md, section "Export formats"; keep the two in step.

A format is a plugin (:mod:`.registry`): one module per format (:mod:`.csv`, :mod:`.mat`,
:mod:`.c3d`, :mod:`.bids`) writes a :class:`~.source.Source` (the read side, :mod:`.source`)
to temporary files that :mod:`.outputs` renames into place only when everything was written,
so an error, a cancel or Ctrl-C never leaves a half-written file under the final name.

:func:`export_session` is the one entry point, for ``gaitmon export`` and the review window's
export dialog alike. A file of both legs without a side goes to :mod:`gaitmon.bilateral_export`
(a higher layer: it needs the analysis), imported by name, as the strides format is.
Importing this package is cheap (no numpy): the format modules are loaded when an export
runs, so the command-line parser can list :data:`FORMATS`.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from gaitmon.io.export.deidentify import ANONYMOUS, REDACTED
from gaitmon.io.export.errors import Cancel, ExportCancelled, ExportError, Progress
from gaitmon.io.export.outputs import c3d_part_path, csv_meta_path, default_output
from gaitmon.io.export.registry import FORMATS, Format

if TYPE_CHECKING:
    # mypy checks each registered module against the FormatWriter contract (here, above the
    # writers, so that the registry they are listed in imports none of them)
    from gaitmon.io.export import bids, c3d, csv, mat
    from gaitmon.io.export.registry import FormatWriter

    _WRITERS: tuple[FormatWriter, ...] = (csv, mat, c3d, bids.configure(None))

__all__ = [
    "ANONYMOUS",
    "FORMATS",
    "REDACTED",
    "Cancel",
    "ExportCancelled",
    "ExportError",
    "ExportRequest",
    "ExportResult",
    "Format",
    "Progress",
    "c3d_part_path",
    "csv_meta_path",
    "default_output",
    "export_session",
    "session_length",
]


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote: the final paths, in the order the format plans them."""

    paths: tuple[Path, ...]
    n_samples: int
    mode: str
    problems: tuple[str, ...] = ()  # what the session reader noticed (e.g. not stopped cleanly)


@dataclass(frozen=True)
class ExportRequest:
    """One export as :func:`export_session` resolved it (its output name and
    de-identification decided): what the export of both legs is given."""

    src_path: Path
    fmt: str
    out: Path  # the output name (both legs: their files' names are made from it)
    deidentify: bool
    force: bool
    progress: Progress | None
    cancel: Cancel | None
    chunk_rows: int | None
    angles: str
    options: Mapping[str, Any] | None

    def named(self, tag: str) -> Path:
        """``out`` with ``_tag`` before the format's suffix: out.csv -> out_L.csv,
        out.strides.csv -> out_L.strides.csv (as ``--side L`` names it)."""
        suffix = FORMATS[self.fmt].suffix
        name = self.out.name
        if suffix and name.endswith(suffix) and name != suffix:
            stem, ext = name[: -len(suffix)], suffix
        else:
            stem, ext = self.out.stem, self.out.suffix
        return self.out.with_name(f"{stem}_{tag}{ext}")

    def stage(self, lo: float, hi: float) -> Progress | None:
        """Progress of one stage, mapped onto [lo, hi] of the whole."""
        progress = self.progress
        if progress is None:
            return None
        return lambda f: progress(lo + (hi - lo) * float(f))


def session_length(src_path: str | os.PathLike[str], side: str | None = None) -> int:
    """Rows in a session file (raises ExportError for a bad file)."""
    from gaitmon.io.export.source import open_source

    with open_source(Path(src_path), side=side) as src:
        return src.n


def export_session(
    src_path: str | os.PathLike[str],
    fmt: str,
    out: str | os.PathLike[str] | None = None,
    *,
    deidentify: bool | None = None,
    force: bool = False,
    progress: Progress | None = None,
    cancel: Cancel | None = None,
    chunk_rows: int | None = None,
    angles: str = "smoothed",
    options: Mapping[str, Any] | None = None,
    side: str | None = None,
) -> ExportResult:
    """Export one session file; returns the files written. Raises ExportError (one line).

    ``progress(fraction)`` is called as the export goes; ``cancel()`` is asked at the same
    points and, once it returns True, the export stops with :class:`ExportCancelled`. If
    either raises, every temporary output is removed and the exception propagates.
    ``chunk_rows``: rows per read for the streaming formats (CSV); None for their default.
    ``angles``: "smoothed" (the zero-lag offline estimate, where the session has one) or
    "live" (the causal filter's, as shown while recording); the metadata names the method.
    ``deidentify``: None for the format's default (BIDS: de-identified; the others: not).
    ``side``: "L" or "R", one leg of a bilateral file; None for a bilateral file: both legs
    and the bilateral measures (:mod:`gaitmon.bilateral_export`; docs/bilateral.md).
    ``options``: the format's own options (BIDS: subject, subject_map,
    subject_from_patient_id, session, task; see :class:`.bids_labels.BidsOptions`).
    """
    from gaitmon.io.export.deidentify import Scrubber
    from gaitmon.io.export.outputs import AtomicOutputs, check_outputs, make_folders
    from gaitmon.io.export.source import open_source
    from gaitmon.io.session.parts import is_bilateral

    if fmt not in FORMATS:
        raise ExportError(f"unknown format {fmt!r} (choose from {', '.join(FORMATS)})")
    form = FORMATS[fmt]
    deidentify = form.deidentify_default if deidentify is None else bool(deidentify)
    src_path = Path(src_path)
    if side is None and is_bilateral(src_path):
        # both legs and their bilateral measures: a higher layer (it needs the analysis),
        # imported by name as the strides format is
        form.check_available()
        request = ExportRequest(
            src_path, fmt,
            Path(out) if out is not None else default_output(src_path, fmt, deidentify=deidentify),
            deidentify, force, progress, cancel, chunk_rows, angles, options,
        )  # fmt: skip
        both = importlib.import_module("gaitmon.bilateral_export")
        return cast("ExportResult", both.export_bilateral(request))
    # one leg of a bilateral file: both.h5 --side L -> both_L.csv
    named = src_path if side is None else src_path.with_name(
        f"{src_path.stem}_{side}{src_path.suffix}")  # fmt: skip
    out_path = (Path(out) if out is not None
                else default_output(named, fmt, deidentify=deidentify))
    form.check_available()
    writer = form.writer(options)
    with open_source(src_path, angles, side) as src:
        scrub = Scrubber(src.group_attrs("session"), deidentify)
        if deidentify:  # times count from the recording's start; none says when it was made
            src.shift_host_time()
        outputs = writer.planned_outputs(src, scrub, out_path)
        merges = getattr(writer, "merges_existing", None)
        shared = {p for p in outputs if merges is not None and merges(p)}
        atomic = AtomicOutputs()
        made: list[Path] = []
        try:
            if form.folder:
                made = make_folders(out_path, outputs)
            check_outputs([p for p in outputs if p not in shared], src_path, force)
            check_outputs([p for p in outputs if p in shared], src_path, True)
            tmps = [atomic.tmp(final, form.temp_suffix) for final in outputs]
            writer.write(src, tmps, scrub, deidentify, progress, cancel, chunk_rows)
            written = atomic.commit()
        except OSError as exc:
            atomic.discard(made)
            where = exc.filename or out_path
            raise ExportError(f"cannot write {where}: {exc.strerror or exc}") from None
        except BaseException:
            atomic.discard(made)
            raise
        return ExportResult(tuple(written), src.n, src.mode, src.problems)
