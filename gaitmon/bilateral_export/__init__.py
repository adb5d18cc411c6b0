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

from gaitmon.bilateral_export.job import Job
from gaitmon.io.export import ExportResult


def export_bilateral(job: Job) -> ExportResult:
    """Export both legs of a bilateral session and its bilateral measures; called by
    :func:`gaitmon.io.export.export_session` for a file of both legs without a side. Raises
    ExportError (one line)."""
    fmt = job.fmt
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


