"""The per-stride format: ``gaitmon export FILE --format strides`` writes one CSV row per stride.

The columns are the review window's stride table (:data:`gaitmon.analysis.STRIDE_COLUMNS`: the
same cells, from the same analysis as ``gaitmon info`` and the report): number, start on the
true timeline, stride / stance / swing times, stance %, stride length and gait speed from the
foot IMU, peak knee flexion in swing, range of motion per joint, and "included" or the reason a
stride is left out of the statistics. A dash ("–", ``gaitmon.text.DASH``, named in the side
file's ``missing_value``) marks a figure that cannot be computed. The
session's metadata and the angles' method go to ``OUT.meta.json`` as for the CSV export. A
session of both legs: each leg's per-stride CSV and the two-leg tables, as the CSV format
writes them (:func:`.csv.export_legs_and_tables`).
"""

from __future__ import annotations

import csv
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from gaitmon.export.base import ExportRequest, ExportResult, Format
from gaitmon.export.csv import export_legs_and_tables
from gaitmon.export.writers.errors import Cancel, Progress, step
from gaitmon.export.writers.outputs import csv_meta_path
from gaitmon.text import spreadsheet_cell

if TYPE_CHECKING:
    from gaitmon.export.writers.source import Source
    from gaitmon.export.writers.writer import FormatWriter
    from gaitmon.io.deidentify import Scrubber


class StridesWriter:
    """One unit's per-stride CSV and its side file; ``n_strides``: the rows written."""

    n_strides: int | None = None

    def planned_outputs(self, src: Source, scrub: Scrubber, out: Path) -> list[Path]:
        return [out, csv_meta_path(out)]

    def write(self, src: Source, outputs: list[Path], scrub: Scrubber, deidentify: bool,
              progress: Progress | None, cancel: Cancel | None, chunk_rows: int | None) -> None:
        import numpy as np

        from gaitmon.analysis import (
            STRIDE_COLUMNS,
            analyse_session,
            stride_cells,
            stride_start_times,
        )
        from gaitmon.export.writers.source import json_default, json_safe, metadata
        from gaitmon.text import DASH

        out, meta_out = outputs
        session = src.session
        an = analyse_session(session)
        t_s = session.read("timeline/t_s") if session.n_samples else np.empty(0)
        starts = stride_start_times(an.rows, t_s)
        step(progress, cancel, 0.5)
        with open(out, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow([c.key for c in STRIDE_COLUMNS])
            for k, (row, t) in enumerate(zip(an.rows, starts, strict=True)):
                w.writerow([spreadsheet_cell(c) for c in stride_cells(row, k + 1, t)])
        self.n_strides = len(an.rows)
        meta = metadata(src, scrub)
        meta["strides"] = {
            "columns": [{"name": c.key, "description": c.tip} for c in STRIDE_COLUMNS],
            "included": an.n_included,
            "excluded": an.n_excluded,
            "missing_value": DASH,  # what stride_cells writes for a figure not computed
        }
        with open(meta_out, "w", encoding="utf-8") as f:
            json.dump(json_safe(meta), f, indent=1, ensure_ascii=False, default=json_default)
        step(progress, cancel, 1.0)


@dataclass(frozen=True)
class StridesFormat(Format):
    def unit_writer(self, options: Mapping[str, object] | None) -> FormatWriter:
        self.no_options(options)
        return StridesWriter()

    def export_units(self, request: ExportRequest) -> ExportResult:
        return export_legs_and_tables(request)


STRIDES = StridesFormat("strides", ".strides.csv", "per-stride CSV (one row per stride, as the "
                        "review's stride table) + meta.json")
