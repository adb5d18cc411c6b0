"""What the bilateral report shows, gathered from a session of both legs (Qt-free).

Each leg is the one-leg report's content (:func:`gaitmon.report.gather_report`, its stride
exclusions from ``FILE.L.review.json`` / ``FILE.R.review.json``), built on the stride analysis
that :func:`gaitmon.analysis.analyse_bilateral` made of it, so the per-leg lines, the curves
and the symmetry table rest on one analysis. The symmetry table's numbers are
``analyse_bilateral``'s only, with the digits ``gaitmon info`` prints (definitions in
``docs/bilateral.md``). Drawing it is ``gaitmon.ui.report_pdf.bilateral`` (Qt).
"""

from __future__ import annotations

import datetime as _dt
import os
from dataclasses import dataclass, field

import numpy as np

from gaitmon import __version__
from gaitmon.analysis import BilateralAnalysis, analyse_bilateral
from gaitmon.dsp.bilateral import MEASURE_LABELS, symmetry_index_pct, symmetry_ratio
from gaitmon.finish.bilateral import Bilateral, open_bilateral
from gaitmon.normative import NormativeBands
from gaitmon.report import CycleCurves, ReportData, gather_report

SIDES = ("L", "R")
SIDE_NAMES = {"L": "left", "R": "right"}
# Faint strides drawn per leg: two legs' strides on one set of axes, so fewer than the one-leg
# report's 50 (the means and SDs use every included stride).
MAX_FAINT_PER_SIDE = 15
# the symmetry table's rows, in the order of the gait cycle (SideGait attribute names)
TABLE_MEASURES = (
    "step_s",
    "stride_s",
    "stance_s",
    "swing_s",
    "initial_double_support_s",
    "single_support_s",
    "terminal_double_support_s",
)
NO_PCT = ("step_s", "stride_s")  # not shown as % of the stride
TABLE_HEADER = ("Measure", "Left (s)", "Left (%)", "Right (s)", "Right (%)", "SR (L/R)", "SI (%)")


def cell(v: float, digits: int) -> str:
    """A table number with ``gaitmon info``'s digits; a dash when there is none."""
    return "–" if not np.isfinite(v) else f"{v:.{digits}f}"


@dataclass(frozen=True)
class SymmetryLine:
    """One row of the symmetry table: each side's mean (s and % of the stride), SR and SI."""

    measure: str
    left_s: float
    right_s: float
    left_pct: float  # NaN for the step and the stride
    right_pct: float
    ratio: float  # left / right
    index_pct: float  # 2 |L - R| / (L + R) x 100

    @property
    def label(self) -> str:
        return MEASURE_LABELS[self.measure]

    def cells(self) -> tuple[str, ...]:
        """The row as drawn (TABLE_HEADER's columns)."""
        return (self.label, cell(self.left_s, 3), cell(self.left_pct, 1), cell(self.right_s, 3),
                cell(self.right_pct, 1), cell(self.ratio, 3), cell(self.index_pct, 1))  # fmt: skip


def symmetry_lines(an: BilateralAnalysis) -> tuple[SymmetryLine, ...]:
    """The table's rows from ``analyse_bilateral``: its symmetry rows where it has them (SR
    and SI of the means), the same definitions for terminal double support."""
    g = an.gait
    have = {row.measure: row for row in g.symmetry}
    out = []
    for m in TABLE_MEASURES:
        lv, rv = g.left.mean(m), g.right.mean(m)
        row = have.get(m)
        ratio = row.ratio if row else symmetry_ratio(lv, rv)
        index = row.index_pct if row else symmetry_index_pct(lv, rv)
        lp, rp = ((np.nan, np.nan) if m in NO_PCT
                  else (g.left.pct_mean(m), g.right.pct_mean(m)))  # fmt: skip
        out.append(SymmetryLine(m, lv, rv, lp, rp, ratio, index))
    return tuple(out)


@dataclass(frozen=True, eq=False)
class BilateralReportData:
    sides: dict[str, ReportData]  # "L", "R": each leg's one-leg report content
    curves: tuple[CycleCurves, CycleCurves]  # left, right: what the cycle plots draw
    symmetry: tuple[SymmetryLine, ...]
    cadence_steps_min: float  # measured: 60 / the mean step time of both legs
    strides_counted: dict[str, int]  # strides in the symmetry table's means, per side
    strides_total: dict[str, int]  # every stride detected on that side
    units: str  # "serials L 1001, R 1002 (gaitmon-sim firmware 1.0.0)"; no serials when
    # de-identified
    duration_s: float  # on the common time line
    state: str  # complete / recovered / incomplete
    file_name: str  # "" when de-identified
    clocks: str  # each unit's clock against the common time line, one line
    conventions: tuple[str, ...]
    normative: NormativeBands | None = None
    generated_utc: str = ""
    software: str = f"gaitmon {__version__}"
    notes: tuple[str, ...] = field(default=())

    @property
    def left(self) -> ReportData:
        return self.sides["L"]

    @property
    def right(self) -> ReportData:
        return self.sides["R"]

    def strides_text(self, side: str) -> str:
        """"23 of 25": strides counted in the table of all detected on that side."""
        return f"{self.strides_counted[side]} of {self.strides_total[side]}"


def _clocks(b: Bilateral) -> str:
    ppm = ", ".join(f"{s} {(b.host_s_per_common_s / b.sync[s].mean_slope - 1.0) * 1e6:+.1f}"
                    for s in b.sides)  # fmt: skip
    delay = ", ".join(f"{s} {cell(b.sync[s].residual_p95_ms, 1)}" for s in b.sides)
    return (f"{ppm} ppm against the common time line; receive delay above the fit, p95: "
            f"{delay} ms")  # fmt: skip


def gather_bilateral_report(
    b: Bilateral,
    *,
    deidentify: bool = False,
    normative: NormativeBands | None = None,
    now_utc: _dt.datetime | None = None,
) -> BilateralReportData:
    """Everything the bilateral report shows, from an open bilateral session."""
    missing = [SIDE_NAMES[s] for s in SIDES if s not in b.units]
    if missing:
        from gaitmon.io.session import SessionError

        raise SessionError(f"{b.path.name} has no {' or '.join(missing)} leg; make a one-leg "
                           "report with --side")  # fmt: skip
    an = analyse_bilateral(b)
    now = now_utc or _dt.datetime.now(_dt.UTC)
    sides = {}
    for s in SIDES:
        sides[s] = gather_report(b.unit(s), deidentify=deidentify, normative=normative,
                                 now_utc=now, analysis=an.sides[s])  # fmt: skip
    curves = (sides["L"].curves(MAX_FAINT_PER_SIDE, "left"),
              sides["R"].curves(MAX_FAINT_PER_SIDE, "right"))  # fmt: skip
    g = an.gait
    counted = {s: int(np.isfinite(g.side(s).stride_s).sum()) for s in SIDES}
    dev = b.unit("L").device
    kind = f"{dev.get('name', '?')} firmware {dev.get('firmware', '?')}"
    serials = ", ".join(f"{s} {b.unit(s).device.get('serial', '?')}" for s in SIDES)
    units = kind if deidentify else f"serials {serials} ({kind})"
    state = "complete" if b.complete else ("recovered" if b.recovered else "incomplete")
    conventions = (
        sides["L"].conventions[0],
        "Cycle: 0 % and 100 % are successive heel strikes of the same leg, for each leg; "
        "strides time-normalised to 101 points; SD is the sample SD (n − 1).",
        "Both legs' events are on the session's common time line (each unit's clock fitted to "
        "the host's receive times). Step time X: from the other leg's heel strike to X's. "
        "Initial double support: X's heel strike to the other leg's toe off; single support: "
        "to the other leg's heel strike; terminal double support: to X's toe off. Percentages "
        "are of each stride's time, averaged over the strides counted.",
        "Cadence is measured: 60 / the mean step time of both legs. Symmetry ratio SR = left / "
        "right of the means (1 symmetric); symmetry index SI = 2 |L − R| / (L + R) × 100 % "
        "(0 % symmetric). A stride counts when it is included on its own leg.",
    )
    return BilateralReportData(
        sides=sides,
        curves=curves,
        symmetry=symmetry_lines(an),
        cadence_steps_min=g.cadence_steps_min,
        strides_counted=counted,
        strides_total={s: len(an.sides[s].rows) for s in SIDES},
        units=units,
        duration_s=float(b.attrs.get("duration_s", 0.0)),
        state=state,
        file_name="" if deidentify else b.path.name,
        clocks=_clocks(b),
        conventions=conventions,
        normative=normative,
        generated_utc=now.strftime("%Y-%m-%d %H:%M UTC"),
        notes=() if counted["L"] and counted["R"] else
        ("Too few strides on both legs to compare: the symmetry table is empty.",),
    )


def bilateral_report_from_file(
    path: str | os.PathLike[str],
    *,
    deidentify: bool = False,
    normative: NormativeBands | None = None,
) -> BilateralReportData:
    """Open (recovering and combining an interrupted recording if needed), gather, close.
    Raises ``SessionError`` for a bad file."""
    with open_bilateral(path) as b:
        return gather_bilateral_report(b, deidentify=deidentify, normative=normative)


__all__ = [
    "MAX_FAINT_PER_SIDE",
    "TABLE_HEADER",
    "TABLE_MEASURES",
    "BilateralReportData",
    "SymmetryLine",
    "bilateral_report_from_file",
    "gather_bilateral_report",
    "symmetry_lines",
]
