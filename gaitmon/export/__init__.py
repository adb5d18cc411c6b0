"""Export of recorded sessions (HDF5, docs/file-format.md) to CSV, MATLAB .mat, C3D, per-stride
CSV and BIDS: a session of one or more units (one leg is one unit), one path per format.

A format is a plugin (:class:`.base.Format`) in a module of its own (:mod:`.csv`, :mod:`.mat`,
:mod:`.c3d`, :mod:`.strides`, :mod:`.bids`), listed in :mod:`.registry`. It writes one unit
through its writer in :mod:`gaitmon.export.writers` (the file layouts, the read side, atomic
outputs and de-identification) and both legs of a two-leg session with the tables and the
common grid they share (:mod:`.tables`, :mod:`.grid`, :mod:`.legs`). A format that cannot
write both legs says so in one line. The layouts are documented in docs/file-format.md,
section "Export formats", and docs/bilateral.md, "Exports".

:func:`export_session` is the one entry point, for ``gaitmon export`` and the review window's
export dialog alike. Importing this package is cheap (no numpy), so the command-line parser
can list :data:`FORMATS`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from gaitmon.export.base import ExportRequest, ExportResult, Format, output_name
from gaitmon.export.registry import FORMATS
from gaitmon.export.writers.errors import Cancel, ExportCancelled, ExportError, Progress
from gaitmon.export.writers.outputs import c3d_part_path, csv_meta_path
from gaitmon.io.deidentify import ANONYMOUS, REDACTED

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


def default_output(src_path: str | os.PathLike[str], fmt: str, *, deidentify: bool = False
                   ) -> Path:
    """The output's default name: FILE with the format's extension (session.h5 ->
    session.csv); de-identified, a random name that carries nothing of the input's."""
    return output_name(src_path, FORMATS[fmt], deidentify=deidentify)


def session_length(src_path: str | os.PathLike[str], side: str | None = None) -> int:
    """Rows in a session file (raises ExportError for a bad file)."""
    from gaitmon.export.writers.source import open_source

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
    options: Mapping[str, object] | None = None,
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
    ``side``: "L" or "R", one leg of a two-leg file; None for a two-leg file: both legs
    and the two-leg measures (docs/bilateral.md).
    ``options``: the format's own options (BIDS: subject, subject_map,
    subject_from_patient_id, session, task; see
    :class:`gaitmon.export.writers.bids_labels.BidsOptions`).
    """
    from gaitmon.io.session.header import SessionError
    from gaitmon.io.session.parts import is_bilateral

    if fmt not in FORMATS:
        raise ExportError(f"unknown format {fmt!r} (choose from {', '.join(FORMATS)})")
    form = FORMATS[fmt]
    deidentify = form.deidentify_default if deidentify is None else bool(deidentify)
    src_path = Path(src_path)
    units: tuple[str | None, ...] = (side,)
    named = src_path
    if side is None and is_bilateral(src_path):
        units = ("L", "R")
    elif side is not None:  # one leg of a two-leg file: both.h5 --side L -> both_L.csv
        named = src_path.with_name(f"{src_path.stem}_{side}{src_path.suffix}")
    out_path = Path(out) if out is not None else output_name(named, form, deidentify=deidentify)
    form.check_available()
    try:
        return form.export(ExportRequest(src_path, form, out_path, deidentify, force, progress,
                                         cancel, chunk_rows, angles, options, units))
    except SessionError as exc:  # damage met while reading, past the opening's checks
        raise ExportError(str(exc)) from None
