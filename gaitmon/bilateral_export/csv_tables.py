"""CSV (and per-stride CSV) of both legs: each leg's one-leg export, then the bilateral tables.

``gaitmon export both.h5 --format csv`` writes ``both_L.csv`` + ``both_L.meta.json`` and the
same for R (exactly what ``--side L|R`` writes: the one-leg writer is called), then
``both_bilateral.csv`` (a row per heel strike), ``both_symmetry.csv`` and
``both_bilateral.meta.json`` (the columns, the cadence, the common time line). ``--format
strides`` writes each leg's per-stride CSV (``both_L.strides.csv`` ...) and the same tables
(``both_bilateral.strides.csv`` ...). Every path is checked before anything is written; if a
later step fails, the files written before it are removed.
"""

from __future__ import annotations

import contextlib
import json
from pathlib import Path

from gaitmon.bilateral_export.job import Job, analysed, meta_header, write_atomic
from gaitmon.bilateral_export.tables import (
    HEEL_STRIKE_COLUMNS,
    SYMMETRY_COLUMNS,
    columns_meta,
    write_heel_strikes_csv,
    write_symmetry_csv,
)
from gaitmon.io.export import ExportResult, export_session
from gaitmon.io.export.errors import step
from gaitmon.io.export.outputs import check_outputs, csv_meta_path
from gaitmon.io.export.source import json_default, json_safe


def table_paths(job: Job) -> list[Path]:
    """The bilateral tables' names: per heel strike, symmetry, their side file."""
    hs = job.named("bilateral")
    return [hs, job.named("symmetry"), csv_meta_path(hs)]


def export_csv(job: Job) -> ExportResult:
    legs = {s: job.named(s) for s in ("L", "R")}
    leg_files = [p for s in legs for p in (legs[s], csv_meta_path(legs[s]))]
    tables = table_paths(job)
    check_outputs(leg_files + tables, job.src_path, job.force)
    results = []
    try:
        for k, (side, out) in enumerate(legs.items()):
            results.append(export_session(
                job.src_path, job.fmt, out, deidentify=job.deidentify, force=True,
                progress=job.stage(0.45 * k, 0.45 * (k + 1)), cancel=job.cancel,
                chunk_rows=job.chunk_rows, angles=job.angles, side=side,
            ))  # fmt: skip
        with analysed(job) as (b, _, t):
            step(job.progress, job.cancel, 0.95)
            meta = {
                **meta_header(job, b),
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

            written = write_atomic(job, tables, write)
    except BaseException:
        for r in results:  # the legs already in place: not without the tables
            for p in r.paths:
                with contextlib.suppress(OSError):
                    p.unlink()
        raise
    step(job.progress, job.cancel, 1.0)
    return ExportResult(
        tuple(p for r in results for p in r.paths) + tuple(written),
        sum(r.n_samples for r in results), results[0].mode,
        tuple(dict.fromkeys(p for r in results for p in r.problems)),
    )
