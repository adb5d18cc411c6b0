"""What an export format is (:class:`Format`, the plugin's base), one export's request and
result, and the path every format shares: one unit written through its writer, atomically.

A format plugin is a :class:`Format` subclass in a module of its own, listed in
:mod:`.registry`. It exports a session of one or more units: one unit (a one-leg file, or one
leg of a two-leg file with ``--side``) through :meth:`Format.unit_writer` and
:func:`export_unit`; a session of both legs through :meth:`Format.export_units`, which a
format that cannot write one does not override, so it says so in one line. Importing this
module is cheap (no numpy): the command-line parser lists the formats.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from gaitmon.errors import output_error_text
from gaitmon.export.writers.errors import Cancel, ExportError, Progress
from gaitmon.io.deidentify import DEIDENTIFIED_STEM

if TYPE_CHECKING:
    from gaitmon.export.writers.writer import FormatWriter


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote: the final paths, in the order the format plans them."""

    paths: tuple[Path, ...]
    n_samples: int
    mode: str
    problems: tuple[str, ...] = ()  # what the session reader noticed (e.g. not stopped cleanly)
    n_strides: int | None = None  # the rows of a per-stride export (None: rows are samples)

    @property
    def amount(self) -> str:
        """What was exported, in the unit of its rows: "5,665 samples", "47 strides"."""
        if self.n_strides is not None:
            return f"{self.n_strides:,} {'stride' if self.n_strides == 1 else 'strides'}"
        return f"{self.n_samples:,} {'sample' if self.n_samples == 1 else 'samples'}"


@dataclass(frozen=True)
class ExportRequest:
    """One export as :func:`gaitmon.export.export_session` resolved it (its output name and
    de-identification decided)."""

    src_path: Path
    form: Format
    out: Path  # the output name (both legs: their files' names are made from it)
    deidentify: bool
    force: bool
    progress: Progress | None
    cancel: Cancel | None
    chunk_rows: int | None
    angles: str
    options: Mapping[str, object] | None
    # the session's units to export: (None,) a one-leg file, ("L",) one leg of a two-leg
    # file, ("L", "R") both legs
    units: tuple[str | None, ...] = (None,)

    @property
    def fmt(self) -> str:
        return self.form.name

    def named(self, tag: str) -> Path:
        """``out`` with ``_tag`` before the format's suffix: out.csv -> out_L.csv,
        out.strides.csv -> out_L.strides.csv (as ``--side L`` names it)."""
        suffix = self.form.suffix
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

    def one_unit(self, side: str | None, out: Path, lo: float = 0.0, hi: float = 1.0,
                 ) -> ExportRequest:
        """The export of one of the units, to ``out``, as stage [lo, hi] of this one."""
        return replace(self, out=out, units=(side,), progress=self.stage(lo, hi))


@dataclass(frozen=True)
class Format:
    """One export format: how it is named and listed, and how it writes a session's units."""

    name: str
    suffix: str  # the output file's extension, with the dot
    description: str  # one line for the export dialog and --help
    # appended to temporary output names: ezc3d adds ".c3d" to a name not ending in it
    temp_suffix: str = ""
    folder: bool = False  # the output is a folder the format fills (BIDS), not one file
    deidentify_default: bool = False  # de-identified unless asked otherwise

    def check_available(self) -> None:
        """Raise ExportError if an optional package the writer needs is not installed."""

    def unit_writer(self, options: Mapping[str, object] | None) -> FormatWriter:
        """The writer of one unit for one export (a fresh one: it may keep its plan)."""
        raise NotImplementedError

    def export(self, request: ExportRequest) -> ExportResult:
        """Export the request's units: one through :func:`export_unit`, several through
        :meth:`export_units`."""
        if len(request.units) == 1:
            return export_unit(request)
        return self.export_units(request)

    def export_units(self, request: ExportRequest) -> ExportResult:
        """Export a session of both legs (a format that writes them overrides this)."""
        raise ExportError(f"{self.name.upper()} export cannot write a session of both legs; "
                          "export each leg with --side L or R")  # fmt: skip

    def no_options(self, options: Mapping[str, object] | None) -> None:
        """Refuse options for a format that takes none."""
        if options:
            raise ExportError(f"{self.name.upper()} export takes no options ({', '.join(options)})")


def output_name(src_path: str | os.PathLike[str], form: Format, *, deidentify: bool = False
                ) -> Path:
    """FILE with the format's extension (session.h5 -> session.csv); de-identified, a name
    that carries nothing of the input's (often a patient code): deidentified-1f3a9c0e.csv,
    random, beside the input."""
    src = Path(src_path)
    if deidentify:
        token = secrets.token_hex(4)
        return src.with_name(f"{DEIDENTIFIED_STEM}-{token}{form.suffix}")
    if form.folder:  # a dataset folder beside the file: walk.h5 -> walk-bids
        return src.with_name(f"{src.stem}-{form.name}")
    return src.with_suffix(form.suffix)


def write_atomic(request: ExportRequest, finals: list[Path],
                 write: Callable[[list[Path]], None], folders: list[Path] | None = None,
                 shared: frozenset[Path] = frozenset()) -> list[Path]:
    """Check ``finals``, call ``write`` with their temporary names, rename them into place;
    nothing is left under a final name if anything fails. ``folders``: made for the
    outputs (removed again on failure if empty); ``shared``: files several exports add a row
    to (they may exist without --force)."""
    from gaitmon.export.writers.outputs import AtomicOutputs, check_outputs

    atomic = AtomicOutputs()
    try:
        check_outputs([p for p in finals if p not in shared], request.src_path, request.force)
        check_outputs([p for p in finals if p in shared], request.src_path, True)
        tmps = [atomic.tmp(p, request.form.temp_suffix) for p in finals]
        write(tmps)
        return atomic.commit()
    except OSError as exc:
        atomic.discard(folders)
        if exc.errno is None:  # the HDF5 library's, reading the source: never a file written
            from gaitmon.io.session.h5file import _short_error

            raise ExportError(
                f"{request.src_path.name} is damaged and cannot be exported "
                f"({_short_error(exc)}); the recording's own journal or a backup may hold a "
                "good copy"
            ) from None
        raise ExportError(output_error_text(exc, atomic.final_of(exc.filename, request.out))
                          ) from None
    except BaseException:
        atomic.discard(folders)
        raise


def export_unit(request: ExportRequest) -> ExportResult:
    """Export the one unit of ``request`` through its format's unit writer."""
    from gaitmon.export.writers.outputs import make_folders
    from gaitmon.export.writers.source import open_source
    from gaitmon.io.deidentify import Scrubber

    (side,) = request.units
    form, out_path = request.form, request.out
    form.check_available()
    writer = form.unit_writer(request.options)
    with open_source(request.src_path, request.angles, side) as src:
        scrub = Scrubber(src.group_attrs("session"), request.deidentify)
        if request.deidentify:  # times count from the recording's start; none says when
            src.shift_host_time()
        outputs = writer.planned_outputs(src, scrub, out_path)
        merges = getattr(writer, "merges_existing", None)
        shared = frozenset(p for p in outputs if merges is not None and merges(p))
        made: list[Path] = []
        if form.folder:
            try:
                made = make_folders(out_path, outputs)
            except OSError as exc:
                raise ExportError(output_error_text(exc, exc.filename or out_path)) from None

        def write(tmps: list[Path]) -> None:
            writer.write(src, tmps, scrub, request.deidentify, request.progress,
                         request.cancel, request.chunk_rows)

        written = write_atomic(request, outputs, write, made, shared)
        n_strides = getattr(writer, "n_strides", None)  # a per-stride writer counts its rows
        return ExportResult(tuple(written), src.n, src.mode, src.problems,
                            None if n_strides is None else int(n_strides))
