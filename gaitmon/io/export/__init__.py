"""The file side of the exports: each unit's file layouts and their writers (CSV, MATLAB .mat,
C3D, BIDS), the read side (:mod:`.source`), atomic outputs (:mod:`.outputs`) and
de-identification (:mod:`.deidentify`).

The package owns the exported layouts (column names, MAT struct fields, C3D groups), the
precision each format keeps, and de-identification of what is exported. The layouts are
documented in docs/file-format.md, section "Export formats"; keep the two in step. Each writer
(:mod:`.csv`, :mod:`.mat`, :mod:`.c3d`, :mod:`.bids`) writes one unit of a session (a
:class:`~.writer.FormatWriter`); the format plugins that export a session of one or more
units, and ``export_session``, are :mod:`gaitmon.export` (a higher layer: the per-stride
format and the tables of both legs need the analysis). Importing this package is cheap (no
numpy).
"""

from __future__ import annotations

from gaitmon.io.export.deidentify import ANONYMOUS, REDACTED
from gaitmon.io.export.errors import Cancel, ExportCancelled, ExportError, Progress
from gaitmon.io.export.outputs import c3d_part_path, csv_meta_path

__all__ = [
    "ANONYMOUS",
    "REDACTED",
    "Cancel",
    "ExportCancelled",
    "ExportError",
    "Progress",
    "c3d_part_path",
    "csv_meta_path",
]
