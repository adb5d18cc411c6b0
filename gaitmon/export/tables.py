"""The two-leg tables every export of both legs writes: one row per heel strike, and symmetry.

Every number comes from :func:`gaitmon.analysis.analyse_bilateral` (the one analysis ``gaitmon
info`` prints): the heel strikes' common times, the rows that count, the symmetry table and the
cadence. A heel strike that does not count (its stride is excluded on its side: first, last,
across a gap, settling, the user's range) keeps its measured values here, computed by the same
``dsp.bilateral.bilateral_gait`` from the same event times, with ``counted`` "no" and the
reason; the symmetry table is over the rows that count, as ``info`` has it. Definitions:
docs/bilateral.md; columns: docs/file-format.md, "Export formats".
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gaitmon.text import spreadsheet_cell

if TYPE_CHECKING:
    from gaitmon.analysis import BilateralAnalysis
    from gaitmon.dsp.bilateral import Symmetry
    from gaitmon.finish.bilateral import Bilateral

# (column, what it is); seconds on the common time line, % of the row's stride time
TIME_MEASURES: tuple[tuple[str, str], ...] = (
    ("step_s", "step time: the other leg's preceding heel strike to this one"),
    ("stride_s", "stride time: this heel strike to the next of the same leg"),
    ("stance_s", "stance: this heel strike to the toe off in the stride"),
    ("swing_s", "swing: that toe off to the next heel strike"),
    ("initial_double_support_s", "initial double support: this heel strike to the other "
                                 "leg's next toe off"),
    ("single_support_s", "single support: that toe off to the other leg's next heel strike"),
    ("terminal_double_support_s", "terminal double support: that heel strike to this leg's "
                                  "toe off"),
)  # fmt: skip
PCT_MEASURES: tuple[str, ...] = tuple(m for m, _ in TIME_MEASURES[2:])
NO_STRIDE = "opens no stride"  # a heel strike with no stride of its side after it

# the per-heel-strike CSV's columns, in order, with their unit and meaning
HEEL_STRIKE_COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("side", "", "L or R"),
    ("unit_row", "", "0-based row of the heel strike in its leg's own export (FILE_L.csv ...)"),
    ("heel_strike_common_s", "s", "heel strike on the session's common time line"),
    ("toe_off_common_s", "s", "the toe off inside the stride this heel strike opens"),
    *((m, "s", what) for m, what in TIME_MEASURES),
    *((m.removesuffix("_s") + "_pct", "%", f"{m.removesuffix('_s').replace('_', ' ')} as % "
       "of the row's stride time") for m in PCT_MEASURES),
    ("counted", "yes/no", "whether the row counts in the symmetry table and cadence"),
    ("exclusion", "", "why it does not count: the reason its stride is left out on its side"),
)  # fmt: skip
SYMMETRY_COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("measure", "", "the measure (a column of the heel-strike table)"),
    ("left_mean_s", "s", "mean over the left rows that count"),
    ("right_mean_s", "s", "mean over the right rows that count"),
    ("symmetry_ratio", "L/R", "SR = left mean / right mean (1 symmetric)"),
    ("symmetry_index_pct", "%", "SI = 2 |L - R| / (L + R) x 100 (0 symmetric)"),
    ("n_left", "", "left rows that count and have the measure"),
    ("n_right", "", "right rows that count and have the measure"),
)


@dataclass(frozen=True)
class HeelStrikeTable:
    """Both legs' heel strikes in common-time order, with their measures (seconds)."""

    side: np.ndarray  # (K,) "L" / "R"
    unit_row: np.ndarray  # (K,) int64: the row in the leg's unit
    heel_strike_s: np.ndarray
    values: dict[str, np.ndarray]  # toe_off_s and every TIME_MEASURES column, as measured
    counted: np.ndarray  # (K,) bool
    exclusion: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.side)

    def pct(self, measure: str) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.asarray(100.0 * self.values[measure] / self.values["stride_s"])


@dataclass(frozen=True)
class BilateralTables:
    heel_strikes: HeelStrikeTable
    symmetry: tuple[Symmetry, ...]
    n_counted: dict[str, dict[str, int]]  # side -> measure -> rows that count and have it
    cadence_steps_min: float


def bilateral_tables(b: Bilateral, an: BilateralAnalysis) -> BilateralTables:
    """The tables of ``an`` (``analyse_bilateral(b)``)."""
    from gaitmon.analysis import heel_strike_rows
    from gaitmon.dsp.bilateral import bilateral_gait

    # the measures before analyse_bilateral sets the rows that do not count to NaN
    measured = bilateral_gait(an.heel_strike_s["L"], an.toe_off_s["L"],
                              an.heel_strike_s["R"], an.toe_off_s["R"])  # fmt: skip
    names = ("toe_off_s", *(m for m, _ in TIME_MEASURES))
    parts: list[dict[str, Any]] = []
    for side in b.sides:
        sg = measured.side(side)
        rows = heel_strike_rows(b.unit(side), an.heel_strike_s[side])
        reasons = {r.stride.start_idx: r.excluded for r in an.sides[side].rows}
        # a row counts where analyse_bilateral kept it (its heel strike's stride is included)
        counted = np.array([int(r) in reasons and not reasons[int(r)] for r in rows], bool)
        parts.append({
            "side": np.full(len(sg), side), "unit_row": rows.astype(np.int64),
            "heel_strike_s": sg.heel_strike_s, "counted": counted,
            "exclusion": ["" if c else reasons.get(int(r), NO_STRIDE) or NO_STRIDE
                          for r, c in zip(rows, counted, strict=True)],
            **{m: np.asarray(getattr(sg, m), np.float64) for m in names},
        })  # fmt: skip
    t = np.concatenate([p["heel_strike_s"] for p in parts]) if parts else np.empty(0)
    order = np.argsort(t, kind="stable")  # both legs on one time line; L first on a tie

    def cat(key: str) -> np.ndarray:
        return np.concatenate([np.asarray(p[key]) for p in parts])[order]

    table = HeelStrikeTable(
        side=cat("side"), unit_row=cat("unit_row"), heel_strike_s=t[order],
        values={m: cat(m) for m in names}, counted=cat("counted"),
        exclusion=tuple(str(x) for x in cat("exclusion")),
    )  # fmt: skip
    n = {s: {row.measure: int(np.isfinite(getattr(an.gait.side(s), row.measure)).sum())
             for row in an.gait.symmetry} for s in ("L", "R")}  # fmt: skip
    return BilateralTables(table, an.gait.symmetry, n, an.gait.cadence_steps_min)


def _num(v: float, decimals: int) -> str:
    """A cell: empty where the value is not defined (pandas and readtable read it as NaN)."""
    return f"{v:.{decimals}f}" if np.isfinite(v) else ""


def write_heel_strikes_csv(tables: BilateralTables, out: Path) -> None:
    t = tables.heel_strikes
    pct = {m: t.pct(m) for m in PCT_MEASURES}
    with open(out, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow([c for c, _, _ in HEEL_STRIKE_COLUMNS])
        for k in range(len(t)):
            w.writerow([
                t.side[k], int(t.unit_row[k]), _num(t.heel_strike_s[k], 6),
                _num(t.values["toe_off_s"][k], 6),
                *(_num(t.values[m][k], 6) for m, _ in TIME_MEASURES),
                *(_num(pct[m][k], 3) for m in PCT_MEASURES),
                "yes" if t.counted[k] else "no", spreadsheet_cell(t.exclusion[k]),
            ])  # fmt: skip


def write_symmetry_csv(tables: BilateralTables, out: Path) -> None:
    with open(out, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow([c for c, _, _ in SYMMETRY_COLUMNS])
        for row in tables.symmetry:
            w.writerow([row.measure, _num(row.left, 6), _num(row.right, 6),
                        _num(row.ratio, 6), _num(row.index_pct, 4),
                        tables.n_counted["L"][row.measure],
                        tables.n_counted["R"][row.measure]])  # fmt: skip


def columns_meta(columns: tuple[tuple[str, str, str], ...]) -> list[dict[str, str]]:
    return [{"name": c, "unit": u, "description": d} for c, u, d in columns]
