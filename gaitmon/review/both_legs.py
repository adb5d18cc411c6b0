"""The review window's Both legs panel, computed without Qt (so a worker and tests run it).

The numbers are :func:`gaitmon.analysis.analyse_bilateral`'s, the one place the bilateral
measures are computed (``gaitmon info`` prints the same, to the same digits): per side, the
step time, stance, swing, initial and terminal double support and single support (% of the
stride and seconds); the symmetry table (SR = left / right, SI = 2 |L - R| / (L + R)); the
measured cadence. Each side's excluded strides are left out as ``analyse_bilateral`` leaves
them out; the leg shown in review passes the ranges in force there, the other leg's are the
ones stored for it (``FILE.L|R.review.json``). Definitions: ``docs/bilateral.md``.

Each leg's cycle-normalised mean ± SD (:class:`SideCycles`) is the one-leg review's and the
report's: :func:`gaitmon.analysis.cycle_stats` over the strides ``analyse_bilateral`` included on
that leg, of the angles the review shows (the smoothed ones by default, as the report).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.analysis import (
    BilateralAnalysis,
    SessionAnalysis,
    analyse_bilateral,
    clearance_symmetry_text,
    cycle_stats,
)
from gaitmon.finish.bilateral import open_bilateral

if TYPE_CHECKING:
    from gaitmon.dsp.bilateral import Symmetry
    from gaitmon.finish.session import Session
    from gaitmon.io.session.exclusions import Exclusion

N_POINTS = 101  # 0..100 % of the stride, as the review's and the report's cycles
JOINT = "processed/joint_deg"

# the table's rows: (label, SideGait measure, shown as % of the stride too)
MEASURES: tuple[tuple[str, str, bool], ...] = (
    ("step time", "step_s", False),
    ("stride time", "stride_s", False),
    ("stance", "stance_s", True),
    ("swing", "swing_s", True),
    ("initial double support", "initial_double_support_s", True),
    ("terminal double support", "terminal_double_support_s", True),
    ("single support", "single_support_s", True),
)
COLUMNS = ("Measure", "Left %", "Left s", "Right %", "Right s", "SR (L/R)", "SI")


def fmt(v: float, digits: int, unit: str = "") -> str:
    """A figure as ``gaitmon info`` prints it ("-" where it is undefined)."""
    return "-" if not np.isfinite(v) else f"{v:.{digits}f}{unit}"


@dataclass(frozen=True, eq=False)
class SideCycles:
    """One leg's cycle-normalised joint angles over its included strides."""

    mean_deg: np.ndarray  # (101, 3) hip, knee, ankle
    sd_deg: np.ndarray  # (101, 3) the sample SD (n - 1); NaN with one stride
    toe_off_pct: float  # the mean stance, % of the stride (NaN without strides)
    n_strides: int
    angle_method: str  # what made the angles, for people


def side_cycles(unit: Session, an: SessionAnalysis, angles: str | None = None) -> SideCycles:
    """``unit`` 's mean cycles over the strides ``an`` includes, of the angles ``angles``
    (smoothed | live; None or one the unit lacks: those ``an`` read, the unit's default)."""
    joints, method = an.joints_deg, unit.angle_method
    if angles and angles != unit.angle_source and angles in unit.angle_sources:
        view = unit.with_angles(angles)  # a view of the same open file (closed with it)
        joints = view.read(JOINT) if unit.n_samples else None
        method = view.angle_method
    if joints is None:
        nan = np.full((N_POINTS, 3), np.nan)
        return SideCycles(nan, nan.copy(), float("nan"), 0, method)
    mean, sd, _ = cycle_stats(joints, an.rows, N_POINTS)
    return SideCycles(mean, sd, an.summary().stance_pct_mean, an.n_included, method)


@dataclass(frozen=True)
class BothLegs:
    """The bilateral measures of one bilateral file, with the exclusions they were made with."""

    path: Path
    analysis: BilateralAnalysis
    # per side: (first, last unit time s, and both on the common time line): the unit's clock
    # as a line, to show the other leg at the same moment (its wander is well under a ms)
    clock: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    cycles: dict[str, SideCycles] = field(default_factory=dict)  # by side
    # what may make these measures misleading, as sentences (the clock fits' warning, a brief
    # time together: ``gaitmon.finish.bilateral.caveats``, as info and the report say them)
    caveats: tuple[str, ...] = ()

    @property
    def n_strides(self) -> dict[str, int]:
        """Strides that count, per side (those with a stride time after the exclusions)."""
        g = self.analysis.gait
        return {s.side: int(np.isfinite(s.stride_s).sum()) for s in (g.left, g.right)}

    @property
    def comparable(self) -> bool:
        """Both legs have a stride that counts: there is something to compare."""
        n = self.n_strides
        return bool(n["L"] and n["R"])

    @property
    def cadence_steps_min(self) -> float:
        return self.analysis.gait.cadence_steps_min

    @property
    def symmetry(self) -> tuple[Symmetry, ...]:
        return self.analysis.gait.symmetry

    def rows(self) -> list[tuple[str, ...]]:
        """The table's cells, one row a measure (:data:`COLUMNS`): each side's mean as % of
        the stride (the phases of the stride only) and in seconds, then SR and SI (the
        analysis's symmetry table: the figures the report and ``gaitmon info`` show)."""
        g = self.analysis.gait
        sym = {r.measure: r for r in g.symmetry}
        out = []
        for label, m, pct in MEASURES:
            cells = [label]
            for sg in (g.left, g.right):
                cells += [fmt(sg.pct_mean(m), 1, " %") if pct else "", fmt(sg.mean(m), 3, " s")]
            r = sym.get(m)
            cells += ["", ""] if r is None else [fmt(r.ratio, 3), fmt(r.index_pct, 1, " %")]
            out.append(tuple(cells))
        return out

    def moved_to(self, side: str, other: str, t_s: float) -> float:
        """``side``'s unit time ``t_s`` as ``other``'s unit time at the same moment (the
        common time line); unchanged when a side's clock is not known."""
        if side not in self.clock or other not in self.clock:
            return t_s
        a0, a1, c0, c1 = self.clock[side]
        common = c0 + (t_s - a0) * ((c1 - c0) / (a1 - a0) if a1 > a0 else 1.0)
        b0, b1, d0, d1 = self.clock[other]
        return b0 + (common - d0) * ((b1 - b0) / (d1 - d0) if d1 > d0 else 1.0)

    def clearance_text(self) -> str:
        """Both legs' foot clearance and its SR / SI ("" when neither leg has one): the
        figures of ``gaitmon.analysis.spatial_summary``, as the report shows them."""
        sides = self.analysis.sides
        if "L" not in sides or "R" not in sides:
            return ""
        ls, rs = sides["L"].spatial(), sides["R"].spatial()
        if not (ls.foot_clearance_n or rs.foot_clearance_n):
            return ""
        return clearance_symmetry_text(ls, rs)

    def excluded_by_user(self) -> dict[str, int]:
        """Strides each side leaves out for a range the user excluded."""
        return {s: a.n_user_excluded for s, a in self.analysis.sides.items()}


def both_legs(
    path: str | Path,
    side: str = "",
    exclusions: Sequence[Exclusion] | None = None,
    angles: str | None = None,
) -> BothLegs:
    """Open the bilateral file at ``path`` (its own handles, closed before returning) and
    analyse both legs, ``side``'s with ``exclusions`` (the ranges in force in review) when
    given, their cycles of ``angles`` (the review's: smoothed | live; None: the file's
    default). Raises :class:`gaitmon.io.session.SessionError`."""
    path = Path(path)
    given = {side: list(exclusions)} if side and exclusions is not None else None
    with open_bilateral(path) as b:
        clock = {}
        for s in b.sides:
            u = b.unit(s)
            if u.n_samples > 1:
                t = u.read("timeline/t_s")
                ends = np.array([t[0], t[-1]], dtype=np.float64)
                c = b.common_s(s, ends)
                clock[s] = (float(ends[0]), float(ends[1]), float(c[0]), float(c[1]))
        an = analyse_bilateral(b, exclusions=given)
        cycles = {s: side_cycles(b.unit(s), a, angles) for s, a in an.sides.items()}
        return BothLegs(path, an, clock, cycles, tuple(c.sentence for c in b.caveats()))
