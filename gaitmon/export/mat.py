"""The MATLAB format: one v5 file with the struct ``session`` for one unit (the writer:
:mod:`gaitmon.export.writers.mat`); for both legs the structs ``L``, ``R`` and ``bilateral``.

``L`` and ``R`` are each the one-unit export's ``session`` struct (built and streamed by
:mod:`gaitmon.export.writers.mat`), with ``t_common_s``, every row's time on the session's common
time line, and ``events.heel_strike_t_common_s`` / ``toe_off_t_common_s``. ``bilateral`` holds
the per-heel-strike table (``heel_strikes``, one field a column, ``unit_row_idx`` 1-based),
the symmetry table (``symmetry``), the cadence, each column's unit and description, and the
common time line's clock figures.
"""

from __future__ import annotations

import io
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from gaitmon.export.base import ExportRequest, ExportResult, Format, write_atomic
from gaitmon.export.writers.errors import step

if TYPE_CHECKING:
    import numpy as np

    from gaitmon.export.tables import BilateralTables
    from gaitmon.export.writers.mat import MatStruct, MatValue
    from gaitmon.export.writers.writer import FormatWriter
    from gaitmon.values import JsonObject, JsonValue


@dataclass(frozen=True)
class MatFormat(Format):
    def unit_writer(self, options: Mapping[str, object] | None) -> FormatWriter:
        from gaitmon.export.writers import mat

        self.no_options(options)
        return mat

    def export_units(self, request: ExportRequest) -> ExportResult:
        return export_mat(request)


MAT = MatFormat("mat", ".mat", "MATLAB .mat (struct 'session', 1-based indices)")


def _column(v: JsonValue | np.ndarray) -> np.ndarray:
    import numpy as np

    return np.asarray(v, np.float64).reshape(-1, 1)


def bilateral_struct(tables: BilateralTables, head: JsonObject) -> dict[str, MatValue]:
    """The ``bilateral`` struct: the two-leg tables, their columns and the time line."""
    from gaitmon.export.tables import (
        HEEL_STRIKE_COLUMNS,
        PCT_MEASURES,
        SYMMETRY_COLUMNS,
        TIME_MEASURES,
    )
    from gaitmon.export.writers.mat import mat_cell, mat_value
    from gaitmon.export.writers.source import json_safe

    t = tables.heel_strikes
    hs: dict[str, MatValue] = {
        "side": mat_cell([str(s) for s in t.side]),
        "unit_row_idx": _column(t.unit_row + 1),
        "heel_strike_common_s": _column(t.heel_strike_s),
        "toe_off_common_s": _column(t.values["toe_off_s"]),
        **{m: _column(t.values[m]) for m, _ in TIME_MEASURES},
        **{m.removesuffix("_s") + "_pct": _column(t.pct(m)) for m in PCT_MEASURES},
        "counted": _column(t.counted),
        "exclusion": mat_cell(list(t.exclusion)),
    }
    rows = tables.symmetry
    sym: dict[str, MatValue] = {
        "measure": mat_cell([r.measure for r in rows]),
        "left_mean_s": _column([r.left for r in rows]),
        "right_mean_s": _column([r.right for r in rows]),
        "symmetry_ratio": _column([r.ratio for r in rows]),
        "symmetry_index_pct": _column([r.index_pct for r in rows]),
        "n_left": _column([tables.n_counted["L"][r.measure] for r in rows]),
        "n_right": _column([tables.n_counted["R"][r.measure] for r in rows]),
    }

    def described(columns: tuple[tuple[str, str, str], ...]) -> JsonObject:
        names = {"unit_row": "unit_row_idx"}  # 1-based here, as every MAT index
        return {"units": {names.get(c, c): u for c, u, _ in columns},
                "descriptions": {names.get(c, c): d for c, _, d in columns}}

    return {
        **{k: mat_value(json_safe(v)) for k, v in head.items()},
        "index_base": 1.0,
        "cadence_steps_min": float(tables.cadence_steps_min),
        "heel_strikes": hs,
        "symmetry": sym,
        "heel_strikes_columns": mat_value(described(HEEL_STRIKE_COLUMNS)),
        "symmetry_columns": mat_value(described(SYMMETRY_COLUMNS)),
    }


def export_mat(job: ExportRequest) -> ExportResult:
    """One file with the structs ``L``, ``R`` and ``bilateral``."""
    import numpy as np
    from scipy.io import savemat

    from gaitmon.export.legs import analysed, leg_sources, meta_header, problems_of
    from gaitmon.export.writers.mat import session_struct, write_struct
    from gaitmon.io.deidentify import Scrubber

    with analysed(job) as (b, _, tables), leg_sources(job) as srcs:
        def write(tmps: list[Path]) -> None:
            with open(tmps[0], "wb") as f:
                for k, (side, src) in enumerate(srcs.items()):
                    scrub = Scrubber(src.group_attrs("session"), job.deidentify)
                    session, big = session_struct(src, scrub, job.deidentify)
                    t = src.read("timeline/t_s").astype(np.float64) if src.n else np.zeros(0)
                    common = np.asarray(b.common_s(side, t), np.float64)
                    fields: MatStruct = {}
                    for key, v in session.items():
                        fields[key] = v
                        if key == "t_s":  # beside the unit's own time
                            fields["t_common_s"] = common.reshape(-1, 1)
                    events = fields["events"]
                    assert isinstance(events, dict)  # session_struct's events struct
                    for name in ("heel_strike", "toe_off"):
                        idx = src.events(name)
                        events[f"{name}_t_common_s"] = common[idx].reshape(-1, 1)
                    write_struct(f, side, fields, big, src, job.stage(0.45 * k, 0.45 * (k + 1)),
                                 job.cancel, header=k == 0, dated=not job.deidentify)  # fmt: skip
                buf = io.BytesIO()
                savemat(buf, {"bilateral": bilateral_struct(tables, meta_header(job, b))},
                        format="5", oned_as="column", long_field_names=True,
                        do_compression=False)  # fmt: skip
                f.write(buf.getvalue()[128:])  # the variable, after scipy's file header

        written = write_atomic(job, [job.out], write)
        n = sum(src.n for src in srcs.values())
        mode = srcs["L"].mode
        problems = problems_of(b, (p for src in srcs.values() for p in src.problems))
    step(job.progress, job.cancel, 1.0)
    return ExportResult(tuple(written), n, mode, problems)
