"""The CSV format: one row per received sample plus a ``.meta.json`` side file for each unit
(the writer: :mod:`gaitmon.export.writers.csv`); a session of both legs adds the two-leg tables.

``gaitmon export both.h5 --format csv`` writes ``both_L.csv`` + ``both_L.meta.json`` and the
same for R (exactly what ``--side L|R`` writes: the one-unit path), then
``both_bilateral.csv`` (a row per heel strike), ``both_symmetry.csv`` and
``both_bilateral.meta.json`` (the columns, the cadence, the common time line). The strides
format (:mod:`.strides`) writes both legs the same way. Every path is checked before anything
is written; if a later step fails, the files written before it are removed.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from gaitmon.export.base import ExportRequest, ExportResult, Format, export_unit, write_atomic
from gaitmon.export.writers.errors import step
from gaitmon.export.writers.outputs import check_outputs, csv_meta_path

if TYPE_CHECKING:
    from gaitmon.export.writers.writer import FormatWriter
    from gaitmon.values import JsonObject


@dataclass(frozen=True)
class CsvFormat(Format):
    def unit_writer(self, options: Mapping[str, object] | None) -> FormatWriter:
        from gaitmon.export.writers import csv

        self.no_options(options)
        return csv

    def export_units(self, request: ExportRequest) -> ExportResult:
        return export_legs_and_tables(request)


CSV = CsvFormat("csv", ".csv", "CSV (spreadsheet, pandas, MATLAB readtable) + meta.json")


def table_paths(request: ExportRequest) -> list[Path]:
    """The two-leg tables' names: per heel strike, symmetry, their side file."""
    hs = request.named("bilateral")
    return [hs, request.named("symmetry"), csv_meta_path(hs)]


def export_legs_and_tables(request: ExportRequest) -> ExportResult:
    """Each leg as its one-unit export, then the two-leg tables (csv and strides)."""
    from gaitmon.export.legs import analysed, meta_header, problems_of
    from gaitmon.export.tables import (
        HEEL_STRIKE_COLUMNS,
        SYMMETRY_COLUMNS,
        columns_meta,
        write_heel_strikes_csv,
        write_symmetry_csv,
    )
    from gaitmon.export.writers.source import json_default, json_safe

    legs = {s: request.named(s) for s in ("L", "R")}
    leg_files = [p for s in legs for p in (legs[s], csv_meta_path(legs[s]))]
    tables = table_paths(request)
    check_outputs(leg_files + tables, request.src_path, request.force)
    results = []
    try:
        for k, (side, out) in enumerate(legs.items()):
            # its paths were checked above, with the tables'
            leg = replace(request.one_unit(side, out, 0.45 * k, 0.45 * (k + 1)), force=True)
            results.append(export_unit(leg))
        with analysed(request) as (b, _, t):
            step(request.progress, request.cancel, 0.95)
            meta: JsonObject = {
                **meta_header(request, b),
                "cadence_steps_min": t.cadence_steps_min,
                "heel_strikes": {"file": tables[0].name,
                                 "columns": columns_meta(HEEL_STRIKE_COLUMNS)},
                "symmetry": {"file": tables[1].name, "columns": columns_meta(SYMMETRY_COLUMNS)},
                "legs": {s: p.name for s, p in legs.items()},
                "missing_value": "an empty cell: the measure is not defined for that row",
            }  # fmt: skip

            def write(tmps: list[Path]) -> None:
                write_heel_strikes_csv(t, tmps[0])
                write_symmetry_csv(t, tmps[1])
                with open(tmps[2], "w", encoding="utf-8") as f:
                    json.dump(json_safe(meta), f, indent=1, default=json_default)
                    f.write("\n")

            written = write_atomic(request, tables, write)
            problems = problems_of(b, (p for r in results for p in r.problems))
    except BaseException:
        for r in results:  # the legs already in place: not without the tables
            for p in r.paths:
                with contextlib.suppress(OSError):
                    p.unlink()
        raise
    step(request.progress, request.cancel, 1.0)
    return ExportResult(
        tuple(p for r in results for p in r.paths) + tuple(written),
        sum(r.n_samples for r in results), results[0].mode,
        problems,
        None if any(r.n_strides is None for r in results) else sum(
            r.n_strides or 0 for r in results),
    )
