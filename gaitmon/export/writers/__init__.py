"""The file side of the exports: each unit's file layouts and their writers (CSV, MATLAB .mat,
C3D, BIDS), the read side (:mod:`.source`) and atomic outputs (:mod:`.outputs`); what
de-identification removes is :mod:`gaitmon.io.deidentify` (the session format's de-identified
copy uses the same rules).

The package owns the exported layouts (column names, MAT struct fields, C3D groups), the
precision each format keeps, and how de-identification applies to each. The layouts are
documented in docs/file-format.md, section "Export formats"; keep the two in step. Each writer
(:mod:`.csv`, :mod:`.mat`, :mod:`.c3d`, :mod:`.bids`) writes one unit of a session (a
:class:`~.writer.FormatWriter`); the format plugins that export a session of one or more
units, and ``export_session``, are this package's parent, :mod:`gaitmon.export`. Importing
this package is cheap (no numpy).
"""

from __future__ import annotations

from gaitmon.export.writers.errors import Cancel, ExportCancelled, ExportError, Progress
from gaitmon.export.writers.outputs import c3d_part_path, csv_meta_path
from gaitmon.io.deidentify import ANONYMOUS, REDACTED

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
