"""What a report holds (Qt-free): the content of one unit's report, and of both legs'
(each leg's content, their cycle curves and the symmetry table). :mod:`gaitmon.report`
gathers it from a session of one or more units; ``gaitmon.ui.report_pdf`` draws it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gaitmon import __version__
from gaitmon.analysis import SpatialSummary, StrideRow, evenly_chosen
from gaitmon.dsp.bilateral import MEASURE_LABELS
from gaitmon.dsp.gait import GaitSummary
from gaitmon.normative import NormativeBands

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
class ReportHeader:
    patient_id: str  # identifier only; REDACTED when de-identified, "" when none was entered
    side: str  # "left", "right" or "not recorded" (gaitmon.text.side_text, as info says it)
    operator: str
    recorded_utc: str  # "2026-11-22 04:10 UTC" (or "" when unknown)
    duration_s: float
    n_samples: int
    sample_rate_hz: float
    mode: str  # raw / tilt / joint
    device: str  # "gaitmon-sim firmware 1.0.0, serial 1"
    file_name: str  # "" when de-identified
    state: str  # complete / recovered / incomplete
    deidentified: bool


@dataclass(frozen=True)
class JointStat:
    """Mean ± SD over the included strides of one per-stride figure (deg)."""

    name: str
    mean_deg: float
    sd_deg: float
    n: int


@dataclass(frozen=True)
class GapSpan:
    """Lost data: samples from ``from_s`` up to (not including) ``to_s`` are missing."""

    from_s: float  # time of the first missing sample
    to_s: float  # time of the first sample after the gap
    duration_s: float  # to_s - from_s (n_lost / fs)
    n_lost: int
    reason: str


@dataclass(frozen=True)
class ExcludedSpan:
    """A range the user excluded in review, with the strides it left out."""

    from_s: float
    to_s: float
    reason: str  # the label given to the range
    n_strides: int  # strides excluded because they overlap it


@dataclass(frozen=True)
class MarkerItem:
    t_s: float
    label: str


@dataclass(frozen=True)
class Losses:
    frames_lost: int
    n_gaps: int
    outages: int  # gaps whose reason is a lost link
    outage_s: float  # total duration of those
    longest_gap_s: float
    crc_failures: int
    reconnects: int
    queue_overflow_frames: int
    invalid_values: int
    implausible_frames: int  # CRC-valid frames dropped: an impossible sequence jump
    excluded: dict[str, int]  # exclusion reason -> strides (in EXCLUSION_ORDER)
    excluded_ranges: tuple[tuple[int, int], ...]  # rows the user excluded
    problems: tuple[str, ...]  # what the session reader noticed


@dataclass(frozen=True, eq=False)
class CycleCurves:
    """What a cycle plot draws of one leg (Qt-free): the mean ± SD of every included stride
    and a bounded, evenly chosen set of them drawn faint (the statistics use them all)."""

    label: str  # "" for the one-leg report; "left" / "right" for the bilateral one
    mean_deg: np.ndarray  # (101, 3) hip / knee / ankle
    sd_deg: np.ndarray  # (101, 3), NaN with fewer than 2 strides
    faint_deg: np.ndarray  # (m, 101, 3), m <= the limit asked for
    n: int  # included strides (the mean's n)
    toe_off_pct: float  # mean stance % (NaN without strides)


@dataclass(frozen=True, eq=False)
class ReportData:
    header: ReportHeader
    summary: GaitSummary
    rows: tuple[StrideRow, ...]
    cycles_deg: np.ndarray  # (k, 101, 3) included strides, hip / knee / ankle
    mean_deg: np.ndarray  # (101, 3)
    sd_deg: np.ndarray  # (101, 3), NaN with fewer than 2 strides
    toe_off_pct: float  # mean stance % (NaN without strides)
    rom: tuple[JointStat, JointStat, JointStat]  # per-stride range of motion
    peak: tuple[JointStat, JointStat, JointStat]  # per-stride maximum
    trough: tuple[JointStat, JointStat, JointStat]  # per-stride minimum
    knee_peak_swing: JointStat  # peak knee flexion between toe off and the next heel strike
    stance_time: JointStat  # seconds (mean ± SD)
    swing_time: JointStat
    settings: tuple[tuple[str, str], ...]  # (label, value) lines
    conventions: tuple[str, ...]
    losses: Losses
    normative: NormativeBands | None = None
    # per joint, RMS distance of ``mean_deg`` from the band's mean (gaitmon.normative.
    # deviation_deg); NaN without a band, a joint the band lacks, or no included strides
    deviation_deg: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    notes: tuple[str, ...] = field(default=())  # why a section is empty, etc.
    session_notes: str = ""  # typed in the record form; REDACTED when de-identified
    markers: tuple[MarkerItem, ...] = field(default=())
    gaps: tuple[GapSpan, ...] = field(default=())
    excluded_spans: tuple[ExcludedSpan, ...] = field(default=())
    generated_utc: str = ""
    software: str = f"gaitmon {__version__}"
    # stride length, gait speed, foot clearance (gaitmon.analysis.spatial_summary); n 0 when the
    # session has no foot IMU data
    spatial: SpatialSummary | None = None

    @property
    def n_included(self) -> int:
        return int(self.cycles_deg.shape[0])

    def curves(self, max_faint: int, label: str = "") -> CycleCurves:
        """The cycle plot's curves: the mean ± SD and at most ``max_faint`` strides."""
        faint = self.cycles_deg[evenly_chosen(self.n_included, max_faint)]
        return CycleCurves(label, self.mean_deg, self.sd_deg, faint, self.n_included,
                           self.toe_off_pct)  # fmt: skip


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
    # what may make the two-leg measures misleading, as sentences: the clock fits' warning, a
    # brief time together (``gaitmon.finish.bilateral.caveats``, as ``gaitmon info`` says it)
    caveats: tuple[str, ...] = field(default=())

    @property
    def left(self) -> ReportData:
        return self.sides["L"]

    @property
    def right(self) -> ReportData:
        return self.sides["R"]

    def strides_text(self, side: str) -> str:
        """"23 of 25": strides counted in the table of all detected on that side."""
        return f"{self.strides_counted[side]} of {self.strides_total[side]}"
