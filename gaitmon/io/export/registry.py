"""The export formats as plugins: what a format is, the registry of them, and their contract.

A format is a row of data (name, file suffix, one-line description) plus the module that
implements it. The command line (``gaitmon export --format``) and the review window's export
dialog list :data:`FORMATS` instead of their own lists, so a new format is one module and one
entry here.

The implementing module is imported on first use: building the command-line parser only needs
the names, and must not pay for numpy, scipy or ezc3d. This module itself imports none of them.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, cast

from gaitmon.io.export.errors import Cancel, ExportError, Progress

if TYPE_CHECKING:
    from gaitmon.io.export.deidentify import Scrubber
    from gaitmon.io.export.source import Source

class FormatWriter(Protocol):
    """What a format module provides (mypy checks csv, mat and c3d against it in the package's
    ``__init__``, so this module imports none of them)."""

    def planned_outputs(self, src: Source, scrub: Scrubber, out: Path) -> list[Path]:
        """The final paths this export will write for the output name ``out``."""
        ...

    def write(self, src: Source, outputs: list[Path], scrub: Scrubber, deidentify: bool,
              progress: Progress | None, cancel: Cancel | None, chunk_rows: int | None) -> None:
        """Write the files; ``outputs`` are the temporary names of ``planned_outputs``, in
        the same order. ``chunk_rows`` is the read chunk of streaming formats (None:
        their default); formats that read whole series ignore it."""
        ...

    # Optional: ``merges_existing(path) -> bool`` says an output is a file several exports
    # share and add a row to (BIDS participants.tsv): it may exist already without --force.
    # Optional, for the module: ``configure(options) -> FormatWriter``, a fresh writer for one
    # export with its format's options (BIDS subject, session, task); see Format.writer.


@dataclass(frozen=True)
class Format:
    """One export format: how it is named and listed, and where its writer lives."""

    name: str
    suffix: str  # the output file's extension, with the dot
    description: str  # one line for the export dialog and --help
    module: str  # the implementing module (a FormatWriter), imported on first use
    requires: str | None = None  # an optional package the writer imports
    # appended to temporary output names: ezc3d adds ".c3d" to a name not ending in it
    temp_suffix: str = ""
    folder: bool = False  # the output is a folder the format fills (BIDS), not one file
    deidentify_default: bool = False  # de-identified unless asked otherwise

    def writer(self, options: Mapping[str, Any] | None = None) -> FormatWriter:
        """The writer of one export: the module itself, or, for a module with
        ``configure(options)``, a fresh writer for these options."""
        module = importlib.import_module(self.module)
        configure = getattr(module, "configure", None)
        if configure is not None:
            return cast("FormatWriter", configure(options))
        if options:
            raise ExportError(
                f"{self.name.upper()} export takes no options ({', '.join(options)})"
            )
        return cast("FormatWriter", module)

    def check_available(self) -> None:
        """Raise ExportError if the optional package this format needs is not installed."""
        if self.requires is None:
            return
        try:
            importlib.import_module(self.requires)
        except ImportError:
            raise ExportError(
                f"{self.name.upper()} export needs the {self.requires} package "
                f"(pip install {self.requires})"
            ) from None


FORMATS: dict[str, Format] = {
    f.name: f
    for f in (
        Format("csv", ".csv", "CSV (spreadsheet, pandas, MATLAB readtable) + meta.json",
               "gaitmon.io.export.csv"),
        Format("mat", ".mat", "MATLAB .mat (struct 'session', 1-based indices)",
               "gaitmon.io.export.mat"),
        Format("c3d", ".c3d", "C3D (Mokka, Nexus, btk; angles as points, events)",
               "gaitmon.io.export.c3d", temp_suffix=".c3d"),
        Format("strides", ".strides.csv", "per-stride CSV (one row per stride, as the review's "
               "stride table) + meta.json", "gaitmon.strides_export"),
        Format("bids", "", "BIDS motion dataset folder (Motion-BIDS; de-identified by default)",
               "gaitmon.io.export.bids", folder=True, deidentify_default=True),
    )
}
