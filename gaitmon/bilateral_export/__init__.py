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

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from gaitmon.bilateral_export.job import Job
from gaitmon.io.export import ExportError, ExportResult, default_output
from gaitmon.io.export.errors import Cancel, Progress
from gaitmon.io.export.registry import FORMATS

BILATERAL_FORMATS = ("csv", "strides", "mat", "c3d", "bids")


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


