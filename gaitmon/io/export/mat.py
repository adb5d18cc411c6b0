"""MAT export: one struct ``session`` in a v5 MAT file (MATLAB ``load``, ``scipy.io.loadmat``).

Every ``*_idx`` field is a 1-based MATLAB row index. Layout: docs/file-format.md, "Export
formats".
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from gaitmon.io.export.deidentify import Scrubber
from gaitmon.io.export.errors import Cancel, ExportError, Progress, step
from gaitmon.io.export.source import (
    Source,
    export_header,
    gaps,
    json_default,
    markers,
    metadata,
)

# MATLAB's v5/v7 MAT formats cap one variable at 2 GB (v7.3 lifts it, but scipy cannot read
# v7.3); the whole `session` struct is one variable, so it must fit. Margin for headers/names.
MAT_V5_MAX_BYTES = 2**31 - 2**24


def planned_outputs(src: Source, scrub: Scrubber, out: Path) -> list[Path]:
    return [out]


def write(src: Source, outputs: list[Path], scrub: Scrubber, deidentify: bool,
          progress: Progress | None, cancel: Cancel | None, chunk_rows: int | None) -> None:
    (out,) = outputs
    _write_mat(src, out, scrub, deidentify, progress, cancel)


def _cell(strings: list[str] | tuple[str, ...]) -> np.ndarray:
    """A MATLAB cell array of char (column), as scipy.io.savemat wants it."""
    arr = np.empty((len(strings), 1), dtype=object)
    for i, s in enumerate(strings):
        arr[i, 0] = s
    return arr


def _mat_value(v: Any) -> Any:
    """Plain metadata -> something savemat stores sensibly (None -> [], lists -> arrays/cells)."""
    if v is None:
        return np.zeros((0, 0))
    if isinstance(v, dict):
        return {_mat_name(k): _mat_value(x) for k, x in v.items()}
    if isinstance(v, list):
        if v and all(isinstance(x, dict) for x in v):
            # list of records -> struct of column arrays
            keys = list(v[0].keys())
            return {_mat_name(k): _mat_value([x.get(k) for x in v]) for k in keys}
        if all(isinstance(x, str) for x in v):
            return _cell(v)
        if all(isinstance(x, bool | int | float) for x in v):
            return np.asarray(v, dtype=np.float64).reshape(-1, 1)
        return _cell([json.dumps(x, default=json_default) for x in v])
    if isinstance(v, bool):
        return np.uint8(v)
    return v


def _mat_name(k: str) -> str:
    """MATLAB field names: letters, digits, underscore, starting with a letter, <= 63 chars."""
    s = "".join(c if (c.isascii() and (c.isalnum() or c == "_")) else "_" for c in k)
    if not s or not s[0].isalpha():
        s = "f_" + s
    return s[:63]


def _mat_bytes(src: Source) -> int:
    """Bytes of the per-sample arrays in the MAT `session` variable (timeline as double)."""
    total = 0
    for s in src.series:
        size = 8 if s.path.startswith("timeline/") else int(src.h5[s.path].dtype.itemsize)
        total += src.n * len(s.columns) * size
    return total

def _one_based(v: Any) -> Any:
    """Metadata with every ``*_idx`` field of its table rows made 1-based, as everywhere in
    the MAT file (tables are lists of row dicts; see source.METADATA_SECTIONS)."""
    if isinstance(v, dict):
        return {k: _one_based(x) for k, x in v.items()}
    if isinstance(v, list) and v and all(isinstance(row, dict) for row in v):
        return [{k: int(x) + 1 if k.endswith("_idx") else x for k, x in row.items()}
                for row in v]
    return v


def _write_mat(src: Source, out: Path, scrub: Scrubber, deidentify: bool,
               progress: Progress | None, cancel: Cancel | None) -> None:
    from scipy.io import savemat

    series = src.series
    total = _mat_bytes(src)
    if total > MAT_V5_MAX_BYTES:
        raise ExportError(
            f"{src.path.name} is too long for one MAT v5 variable ({total / 2**30:.1f} GB > "
            "2 GB MATLAB limit); export --format csv, or read the .h5 directly in MATLAB "
            "(h5read)"
        )
    session: dict[str, Any] = {}
    head = export_header(src, "mat", deidentify)
    for k, v in head.items():
        session[k] = _mat_value(v)
    session["index_base"] = 1.0
    session["t0_s"] = 0.0
    labels: dict[str, Any] = {}
    for n_done, s in enumerate(series, start=1):
        arr = np.asarray(src.read(s.path))
        if s.path.startswith("timeline/"):
            arr = arr.astype(np.float64)  # MATLAB works in double; seq < 2**53 stays exact
        session[s.key] = arr.reshape(src.n, 1) if arr.ndim == 1 else arr
        labels[s.key] = _cell(s.columns) if s.key != "acc_ms2" else _cell(s.labels)
        step(progress, cancel, 0.8 * n_done / len(series))
    session["labels"] = labels
    session["units"] = {s.key: s.unit for s in series}
    t = src.read("timeline/t_s").astype(np.float64) if src.n else np.zeros(0)
    events: dict[str, Any] = {}
    for name in ("heel_strike", "toe_off"):
        idx = src.events(name)
        events[f"{name}_idx"] = (idx + 1).astype(np.float64).reshape(-1, 1)
        events[f"{name}_t_s"] = t[idx].reshape(-1, 1)
    session["events"] = events
    mks = markers(src, scrub)
    session["markers"] = {
        "sample_idx": np.array([m["sample_idx"] + 1 for m in mks], float).reshape(-1, 1),
        "t_s": np.array([m["t_s"] for m in mks], float).reshape(-1, 1),
        "label": _cell([m["label"] for m in mks]),
    }
    gps = gaps(src, scrub)
    session["gaps"] = {
        "sample_idx": np.array([g["sample_idx"] + 1 for g in gps], float).reshape(-1, 1),
        "n_lost": np.array([g["n_lost"] for g in gps], float).reshape(-1, 1),
        "duration_s": np.array([g["duration_s"] for g in gps], float).reshape(-1, 1),
        "reason": _cell([g["reason"] for g in gps]),
    }
    session["meta"] = _mat_value(_one_based(metadata(src, scrub)))
    with open(out, "wb") as f:
        savemat(f, {"session": session}, format="5", oned_as="column",
                long_field_names=True, do_compression=False)
    step(progress, cancel, 1.0)


