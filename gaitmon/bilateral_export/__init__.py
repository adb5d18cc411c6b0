"""Exports of a bilateral session (both legs in one file): ``gaitmon export both.h5 --format F``.

Each leg is exported as its one-leg export (``--side``) gives it, and the bilateral measures of
:func:`gaitmon.analysis.analyse_bilateral` (:mod:`.tables`) are added:

* csv, strides: ``FILE_L.csv`` and ``FILE_R.csv`` (the one-leg writers, unchanged), plus
  ``FILE_bilateral.csv`` (a row per heel strike), ``FILE_symmetry.csv`` and
  ``FILE_bilateral.meta.json`` (:mod:`.csv_tables`);
* mat: one file with structs ``L``, ``R`` (the one-leg ``session`` struct, plus each row's
  common time ``t_common_s``) and ``bilateral`` (:mod:`.mat`);
* c3d: one file, both legs resampled onto one frame grid on the common time line, events in
  the Left / Right contexts (:mod:`.c3d`, the grid: :mod:`.grid`);
* bids: one recording with two tracking systems, ``tracksys-imuL`` and ``tracksys-imuR``, on
  that grid, and one events file of both legs (:mod:`.bids`).

A format of layer 4 (it needs the analysis); the one-leg writers of ``gaitmon.io.export`` are
reused, not copied. Documented in docs/bilateral.md ("Exports") and docs/file-format.md.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gaitmon.io.export import ExportError, ExportResult, default_output
from gaitmon.io.export.errors import Cancel, Progress
from gaitmon.io.export.registry import FORMATS

if TYPE_CHECKING:
    from gaitmon.analysis import BilateralAnalysis
    from gaitmon.bilateral_export.tables import BilateralTables
    from gaitmon.io.export.source import Source
    from gaitmon.io.session.bilateral import Bilateral

BILATERAL_FORMATS = ("csv", "strides", "mat", "c3d", "bids")


@dataclass(frozen=True)
class Job:
    """One export of both legs: what ``export_bilateral`` was asked."""

    src_path: Path
    fmt: str
    out: Path  # the output name the legs' and tables' names are made from
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


def export_bilateral(
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
) -> ExportResult:
    """Export both legs of a bilateral session and its bilateral measures (arguments as
    :func:`gaitmon.io.export.export_session`). Raises ExportError (one line)."""
    if fmt not in FORMATS:
        raise ExportError(f"unknown format {fmt!r} (choose from {', '.join(FORMATS)})")
    form = FORMATS[fmt]
    deid = form.deidentify_default if deidentify is None else bool(deidentify)
    src_path = Path(src_path)
    if src_path.is_dir():
        raise ExportError(f"{src_path} is a directory, not a session file")
    base = Path(out) if out is not None else default_output(src_path, fmt, deidentify=deid)
    form.check_available()
    job = Job(src_path, fmt, base, deid, force, progress, cancel, chunk_rows, angles, options)
    if fmt in ("csv", "strides"):
        from gaitmon.bilateral_export.csv_tables import export_csv
        return export_csv(job)
    if fmt == "mat":
        from gaitmon.bilateral_export.mat import export_mat
        return export_mat(job)
    if fmt == "c3d":
        from gaitmon.bilateral_export.c3d import export_c3d
        return export_c3d(job)
    from gaitmon.bilateral_export.bids import export_bids
    return export_bids(job)


@contextlib.contextmanager
def analysed(job: Job) -> Iterator[tuple[Bilateral, BilateralAnalysis, BilateralTables]]:
    """The session opened as both legs, its analysis and its tables."""
    from gaitmon.analysis import analyse_bilateral
    from gaitmon.bilateral_export.tables import bilateral_tables
    from gaitmon.io.session import SessionError
    from gaitmon.io.session.bilateral import open_bilateral

    try:
        b = open_bilateral(job.src_path)
    except SessionError as exc:
        raise ExportError(str(exc)) from None
    with b:
        if set(b.sides) != {"L", "R"}:
            raise ExportError(f"{job.src_path.name} holds one leg only; export it with --side")
        an = analyse_bilateral(b)
        yield b, an, bilateral_tables(b, an)


@contextlib.contextmanager
def leg_sources(job: Job) -> Iterator[dict[str, Source]]:
    """Each leg as the one-leg exporters read it (angles as asked; host clock from 0 when
    de-identified, as ``export_session`` does)."""
    from gaitmon.io.export.source import open_source

    with contextlib.ExitStack() as stack:
        srcs = {s: stack.enter_context(open_source(job.src_path, job.angles, s))
                for s in ("L", "R")}  # fmt: skip
        if job.deidentify:
            for src in srcs.values():
                src.shift_host_time()
        yield srcs


def write_atomic(job: Job, finals: list[Path], write: Callable[[list[Path]], None],
                 folders: list[Path] | None = None) -> list[Path]:
    """Check ``finals``, call ``write`` with their temporary names, rename them into place;
    nothing is left under a final name if anything fails. ``folders``: made for the
    outputs (removed again on failure if empty)."""
    from gaitmon.io.export.outputs import AtomicOutputs, check_outputs

    check_outputs(finals, job.src_path, job.force)
    atomic = AtomicOutputs()
    try:
        tmps = [atomic.tmp(p, FORMATS[job.fmt].temp_suffix) for p in finals]
        write(tmps)
        return atomic.commit()
    except OSError as exc:
        atomic.discard(folders)
        raise ExportError(f"cannot write {exc.filename or job.out}: {exc.strerror or exc}"
                          ) from None
    except BaseException:
        atomic.discard(folders)
        raise


def meta_header(job: Job, b: Bilateral) -> dict[str, Any]:
    """What every bilateral side file says of the export and of the common time line."""
    from gaitmon.io.export.source import export_header_fields

    head = export_header_fields(f"bilateral-{job.fmt}", job.deidentify)
    if not job.deidentify:
        head["source_file"] = job.src_path.name
    head["common_time"] = {
        "definition": "common_s = (host(side, t_s) - host_t0_s) / host_s_per_common_s: each "
                      "unit's clock fit (/sync) mapped onto one time line, 0 at the first "
                      "sample of the unit that started first (docs/bilateral.md)",
        "host_s_per_common_s": b.host_s_per_common_s,
        "clock_ppm": {s: (b.host_s_per_common_s / b.sync[s].mean_slope - 1.0) * 1e6
                      for s in b.sides},
        "receive_delay_p95_ms": {s: b.sync[s].residual_p95_ms for s in b.sides},
    }  # fmt: skip
    return head
