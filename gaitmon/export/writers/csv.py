"""CSV export: one header row, one row per received sample, plus a ``<stem>.meta.json`` file.

Row k is session sample index k. Rows are streamed in chunks so an 8-hour file never sits in
memory; metadata, events, markers and gaps also go to the JSON side file. Layout:
docs/file-format.md, "Export formats".
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from gaitmon.export.writers.csv_text import CsvColumn, decimals_of, format_block
from gaitmon.export.writers.errors import Cancel, Progress, step
from gaitmon.export.writers.outputs import csv_meta_path
from gaitmon.export.writers.source import (
    PROCESSED_SERIES,
    Series,
    Source,
    export_header,
    gaps,
    json_default,
    json_rows,
    json_safe,
    markers,
    metadata,
)
from gaitmon.io.deidentify import Scrubber
from gaitmon.text import spreadsheet_cell
from gaitmon.values import JsonObject

CSV_CHUNK_ROWS = 32_768  # ~15 MB of text per chunk
CSV_EXTRA_COLUMNS: tuple[str, ...] = ("heel_strike", "toe_off", "gap_lost_frames", "marker")
MARKER_PLACEHOLDER = "marker"  # the marker column's text for a marker set without a label


def planned_outputs(src: Source, scrub: Scrubber, out: Path) -> list[Path]:
    return [out, csv_meta_path(out)]


def write(src: Source, outputs: list[Path], scrub: Scrubber, deidentify: bool,
          progress: Progress | None, cancel: Cancel | None, chunk_rows: int | None) -> None:
    tmp_csv, tmp_meta = outputs
    _write_csv(src, tmp_csv, scrub, progress, cancel,
               CSV_CHUNK_ROWS if chunk_rows is None else chunk_rows)
    meta = json_safe(_csv_meta(src, scrub, deidentify))
    with open(tmp_meta, "w", encoding="utf-8") as f:
        json.dump(meta, f, indent=1, ensure_ascii=False, default=json_default)
        f.write("\n")


def _csv_cell(text: str) -> str:
    """RFC 4180 quoting for the free-text column, which no spreadsheet runs as a formula
    (``gaitmon.text.spreadsheet_cell``: a marker ``=HYPERLINK(...)`` is text)."""
    text = spreadsheet_cell(text)
    if any(c in text for c in ',"\r\n') or text != text.strip():
        return '"' + text.replace('"', '""') + '"'
    return text


def _csv_columns(src: Source) -> list[Series]:
    order = ["timeline/t_s", "timeline/seq"]
    order += [s.path for s in PROCESSED_SERIES]
    order += ["raw/adc", "timeline/host_time_s"]
    by_path = {s.path: s for s in src.series}
    return [by_path[p] for p in order if p in by_path]


def _write_csv(src: Source, out: Path, scrub: Scrubber, progress: Progress | None,
               cancel: Cancel | None, chunk_rows: int) -> None:
    series = _csv_columns(src)
    header = [c for s in series for c in s.columns] + list(CSV_EXTRA_COLUMNS)
    hs = src.events("heel_strike")
    to = src.events("toe_off")
    gap_at: dict[int, int] = {}
    for g in gaps(src, scrub):
        gap_at[g["sample_idx"]] = gap_at.get(g["sample_idx"], 0) + g["n_lost"]
    marker_at: dict[int, list[str]] = {}
    for mk in markers(src, scrub):
        # a marker without a label is still a marker: a visible placeholder, not an empty cell
        label = mk["label"].strip() or MARKER_PLACEHOLDER
        marker_at.setdefault(mk["sample_idx"], []).append(label)
    n = src.n
    cols_dec = [decimals_of(s.fmt) for s in series for _ in s.columns]
    with open(out, "wb") as f:
        f.write((",".join(header) + "\n").encode("utf-8"))
        for start in range(0, n, chunk_rows):
            stop = min(n, start + chunk_rows)
            m = stop - start
            blocks = [np.asarray(src.read(s.path, start, stop)).reshape(m, -1) for s in series]
            extra = np.zeros((m, 3), dtype=np.int64)
            extra[hs[(hs >= start) & (hs < stop)] - start, 0] = 1
            extra[to[(to >= start) & (to < stop)] - start, 1] = 1
            for idx, lost in gap_at.items():
                if start <= idx < stop:
                    extra[idx - start, 2] = lost
            values = [b[:, i] for b in blocks for i in range(b.shape[1])]
            columns = [CsvColumn(v, d) for v, d in zip(values, cols_dec, strict=True)]
            columns += [CsvColumn(extra[:, i], None) for i in range(3)]
            tails = {idx - start: _csv_cell(" | ".join(labels))
                     for idx, labels in marker_at.items() if start <= idx < stop}
            f.write(format_block(columns, tails))
            step(progress, cancel, stop / n)
    if n == 0:
        step(progress, cancel, 1.0)


def _csv_meta(src: Source, scrub: Scrubber, deidentify: bool) -> JsonObject:
    cols: list[JsonObject] = []
    for s in _csv_columns(src):
        for c in s.columns:
            cols.append({"name": c, "unit": s.unit, "source": "/" + s.path,
                         "description": s.description,
                         "decimals": _decimals(s.fmt)})
    cols += [
        {"name": "heel_strike", "unit": "0/1", "source": "/events/heel_strike",
         "description": "1 on the row of a heel strike", "decimals": 0},
        {"name": "toe_off", "unit": "0/1", "source": "/events/toe_off",
         "description": "1 on the row of a toe off", "decimals": 0},
        {"name": "gap_lost_frames", "unit": "frames", "source": "/gaps",
         "description": "frames lost just before this row (0 if none)", "decimals": 0},
        {"name": "marker", "unit": "", "source": "/markers",
         "description": "clinician marker label(s) on this row, joined with ' | ' "
                        "('marker' for one set without a label)",
         "decimals": None},
    ]
    return {
        **export_header(src, "csv", deidentify),
        "row_index": "data row k (0-based, header excluded) is session sample index k",
        "columns": cols,
        "events": {"index_base": 0,
                   "heel_strike_idx": src.events("heel_strike").tolist(),
                   "toe_off_idx": src.events("toe_off").tolist()},
        "markers": json_rows(markers(src, scrub)),
        "gaps": json_rows(gaps(src, scrub)),
        **metadata(src, scrub),
    }


def _decimals(fmt: str) -> int | None:
    if fmt == "%d":
        return 0
    if fmt.startswith("%.") and fmt.endswith("f"):
        return int(fmt[2:-1])
    return None
