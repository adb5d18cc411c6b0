"""The review window's Both legs panel, computed without Qt (so a worker and tests run it).

The numbers are :func:`gaitmon.analysis.analyse_bilateral`'s, the one place the bilateral
measures are computed (``gaitmon info`` prints the same, to the same digits): per side, the
step time, stance, swing, initial and terminal double support and single support (% of the
stride and seconds); the symmetry table (SR = left / right, SI = 2 |L - R| / (L + R)); the
measured cadence. Each side's excluded strides are left out as ``analyse_bilateral`` leaves
them out; the leg shown in review passes the ranges in force there, the other leg's are the
ones stored for it (``FILE.L|R.review.json``). Definitions: ``docs/bilateral.md``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.analysis import BilateralAnalysis, analyse_bilateral
from gaitmon.io.session.bilateral import open_bilateral

if TYPE_CHECKING:
    from gaitmon.dsp.bilateral import Symmetry
    from gaitmon.io.session.exclusions import Exclusion

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


@dataclass(frozen=True)
class BothLegs:
    """The bilateral measures of one bilateral file, with the exclusions they were made with."""

    path: Path
    analysis: BilateralAnalysis

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
        measures of the symmetry table only: one side's terminal double support is the
        other's initial one)."""
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

    def excluded_by_user(self) -> dict[str, int]:
        """Strides each side leaves out for a range the user excluded."""
        return {s: a.n_user_excluded for s, a in self.analysis.sides.items()}


def both_legs(
    path: str | Path, side: str = "", exclusions: Sequence[Exclusion] | None = None
) -> BothLegs:
    """Open the bilateral file at ``path`` (its own handles, closed before returning) and
    analyse both legs, ``side``'s with ``exclusions`` (the ranges in force in review) when
    given. Raises :class:`gaitmon.io.session.SessionError`."""
    path = Path(path)
    given = {side: list(exclusions)} if side and exclusions is not None else None
    with open_bilateral(path) as b:
        return BothLegs(path, analyse_bilateral(b, exclusions=given))
