"""Bilateral gait measures from both legs' heel strikes and toe offs on one time line.

One function, :func:`bilateral_gait`, turns the left and right legs' event times (seconds on a
common time base: the simulator's truth, or a recording's events once both units' clocks are
mapped onto the session timeline) into per-heel-strike measures for each side and a symmetry
table. The simulator's ground truth (``gaitmon.io.sim.bilateral``) and the analysis of measured
events compute them here, so both follow the same definitions. Pure numpy.

Definitions (X one side, C the contralateral side; HS heel strike, TO toe off)
------------------------------------------------------------------------------
Each row of :class:`SideGait` belongs to one heel strike HS_X[k] of side X:

* **step time** X: from the C heel strike just before HS_X[k] to HS_X[k] (the step that X's
  foot ends). NaN when no C heel strike lies between HS_X[k-1] and HS_X[k], or when the step
  would be longer than ``max_stride_s``.
* **stride time** X: HS_X[k] to HS_X[k+1] (NaN for the last heel strike, or when longer than
  ``max_stride_s``: a stride across a gap in the events is not a stride).

  For a complete stride, with TO_X the first X toe off inside it (NaN fields below when one of
  the events it needs is missing):

* **stance** HS_X[k] -> TO_X; **swing** TO_X -> HS_X[k+1];
* **initial double support**: HS_X[k] -> the first C toe off after it (before TO_X);
* **single support**: that C toe off -> the next C heel strike (before TO_X): C swings while X
  carries the body alone;
* **terminal double support**: that C heel strike -> TO_X.

  So stance = initial double support + single support + terminal double support, and X's
  initial double support is C's terminal one (the same interval seen from the other leg).
  Percentages are of the row's stride time (``pct``).

Symmetry (:class:`Symmetry`, one per measure in ``SYMMETRY_MEASURES``), of the per-side means
(this table is the one place SR and SI are computed: the report, review's Both legs tab,
``gaitmon info`` and the exports all show its rows):

* **symmetry ratio** SR = left / right. 1 is symmetric. When the affected side is known,
  affected / unaffected is ``Symmetry.ratio_of(affected)`` (= SR for "L", 1 / SR for "R").
* **symmetry index** SI = 2 |L - R| / (L + R) x 100 %. 0 is symmetric; it does not say which
  side is larger.

Cadence is measured: 60 / (mean step time of both sides), steps per minute.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SIDES = ("L", "R")

# the measures of the symmetry table, in its order (SideGait attribute names)
SYMMETRY_MEASURES = (
    "step_s",
    "stride_s",
    "stance_s",
    "swing_s",
    "single_support_s",
    "initial_double_support_s",
    # one leg's terminal double support is the other's initial one, but the table (and so the
    # report, review and info, which all read it) keeps both rows: issue 25 #11
    "terminal_double_support_s",
)
MEASURE_LABELS = {
    "step_s": "step time",
    "stride_s": "stride time",
    "stance_s": "stance",
    "swing_s": "swing",
    "single_support_s": "single support",
    "initial_double_support_s": "initial double support",
    "terminal_double_support_s": "terminal double support",
}


def symmetry_ratio(left: float, right: float) -> float:
    """left / right (NaN if either is NaN or right is 0)."""
    if not (np.isfinite(left) and np.isfinite(right)) or right == 0:
        return float("nan")
    return float(left / right)


def symmetry_index_pct(left: float, right: float) -> float:
    """2 |left - right| / (left + right) x 100 (NaN if either is NaN or the sum is 0)."""
    if not (np.isfinite(left) and np.isfinite(right)) or left + right == 0:
        return float("nan")
    return float(200.0 * abs(left - right) / (left + right))


@dataclass(frozen=True)
class SideGait:
    """One side's measures, one row per heel strike (seconds; NaN where undefined)."""

    side: str
    heel_strike_s: np.ndarray  # (K,) sorted
    step_s: np.ndarray  # the step this heel strike ends
    stride_s: np.ndarray  # the stride this heel strike opens (NaN for the last)
    toe_off_s: np.ndarray  # the toe off inside that stride
    stance_s: np.ndarray
    swing_s: np.ndarray
    initial_double_support_s: np.ndarray
    single_support_s: np.ndarray
    terminal_double_support_s: np.ndarray

    def __len__(self) -> int:
        return len(self.heel_strike_s)

    def pct(self, measure: str) -> np.ndarray:
        """A per-stride measure as % of its stride time."""
        return np.asarray(100.0 * getattr(self, measure) / self.stride_s)

    def mean(self, measure: str) -> float:
        """Mean over the rows where the measure is defined (NaN if none is)."""
        v = np.asarray(getattr(self, measure), dtype=np.float64)
        v = v[np.isfinite(v)]
        return float(v.mean()) if len(v) else float("nan")

    def pct_mean(self, measure: str) -> float:
        """Mean of :meth:`pct` over the rows where it is defined (NaN if none is)."""
        v = self.pct(measure)
        v = v[np.isfinite(v)]
        return float(v.mean()) if len(v) else float("nan")


@dataclass(frozen=True)
class Symmetry:
    """One row of the symmetry table: a measure's left and right means, SR and SI."""

    measure: str  # a SideGait attribute, e.g. "step_s"
    left: float
    right: float
    ratio: float  # left / right
    index_pct: float  # 2 |L - R| / (L + R) x 100

    @property
    def label(self) -> str:
        return MEASURE_LABELS.get(self.measure, self.measure)

    def ratio_of(self, affected: str) -> float:
        """affected / unaffected."""
        if affected not in SIDES:
            raise ValueError(f"affected side must be L or R, got {affected!r}")
        return self.ratio if affected == "L" else symmetry_ratio(self.right, self.left)


@dataclass(frozen=True)
class BilateralGait:
    """Both sides' measures and the symmetry table."""

    left: SideGait
    right: SideGait
    symmetry: tuple[Symmetry, ...]
    cadence_steps_min: float  # 60 / mean step time of both sides (NaN without steps)

    def side(self, side: str) -> SideGait:
        if side not in SIDES:
            raise ValueError(f"side must be L or R, got {side!r}")
        return self.left if side == "L" else self.right

    def symmetry_of(self, measure: str) -> Symmetry:
        for row in self.symmetry:
            if row.measure == measure:
                return row
        raise KeyError(f"no symmetry row for {measure!r}; rows: {SYMMETRY_MEASURES}")


def _clean(t: np.ndarray | list[float]) -> np.ndarray:
    a = np.asarray(t, dtype=np.float64).ravel()
    return np.sort(a[np.isfinite(a)])


def _first_in(events: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Per interval (lo, hi), open at both ends: the first event inside it, else NaN."""
    out = np.full(len(lo), np.nan)
    if len(events) == 0 or len(lo) == 0:
        return out
    i = np.searchsorted(events, lo, side="right")
    ok = i < len(events)
    v = events[np.minimum(i, len(events) - 1)]
    ok &= v < hi  # False where hi is NaN
    out[ok] = v[ok]
    return out


def _side(
    side: str,
    hs: np.ndarray,
    to: np.ndarray,
    hs_c: np.ndarray,
    to_c: np.ndarray,
    max_stride_s: float,
) -> SideGait:
    n = len(hs)
    nxt = np.full(n, np.nan)
    nxt[:-1] = hs[1:]
    stride = nxt - hs
    complete = stride <= max_stride_s  # False where NaN
    nxt = np.where(complete, nxt, np.nan)
    stride = np.where(complete, stride, np.nan)

    # the step this heel strike ends: the last C heel strike before it, after the previous X one
    prev = np.full(n, -np.inf)
    prev[1:] = hs[:-1]
    j = np.searchsorted(hs_c, hs, side="left") - 1
    c_before = np.where(j >= 0, hs_c[np.maximum(j, 0)] if len(hs_c) else np.nan, np.nan)
    step = hs - c_before
    step = np.where((c_before > prev) & (step <= max_stride_s), step, np.nan)

    toe = _first_in(to, hs, nxt)
    c_to = _first_in(to_c, hs, toe)
    c_hs = _first_in(hs_c, c_to, toe)
    return SideGait(
        side=side,
        heel_strike_s=hs,
        step_s=step,
        stride_s=stride,
        toe_off_s=toe,
        stance_s=toe - hs,
        swing_s=nxt - toe,
        initial_double_support_s=c_to - hs,
        single_support_s=c_hs - c_to,
        terminal_double_support_s=toe - c_hs,
    )


def bilateral_gait(
    heel_strike_left_s: np.ndarray | list[float],
    toe_off_left_s: np.ndarray | list[float],
    heel_strike_right_s: np.ndarray | list[float],
    toe_off_right_s: np.ndarray | list[float],
    *,
    max_stride_s: float = np.inf,
) -> BilateralGait:
    """Per-side measures and the symmetry table from both legs' event times (common seconds).

    Events need not be sorted; NaNs are dropped. A stride longer than ``max_stride_s`` (a gap
    in the events, a stop) and the step ending it are left out (NaN).
    """
    if not max_stride_s > 0:
        raise ValueError(f"max_stride_s must be > 0, got {max_stride_s}")
    hs_l, to_l = _clean(heel_strike_left_s), _clean(toe_off_left_s)
    hs_r, to_r = _clean(heel_strike_right_s), _clean(toe_off_right_s)
    left = _side("L", hs_l, to_l, hs_r, to_r, max_stride_s)
    right = _side("R", hs_r, to_r, hs_l, to_l, max_stride_s)
    return _assemble(left, right)


def keep_rows(gait: BilateralGait, keep_left: np.ndarray, keep_right: np.ndarray) -> BilateralGait:
    """``gait`` with the rows (heel strikes) not kept set to NaN (their heel-strike times
    stay), and the symmetry table and cadence taken over the rows kept: the analysis leaves
    out the strides its exclusions name (a gap, a turn the user excluded)."""
    sides = []
    for sg, keep in ((gait.left, keep_left), (gait.right, keep_right)):
        k = np.asarray(keep, bool)
        fields = {
            m: np.where(k, getattr(sg, m), np.nan)
            for m in ("step_s", "stride_s", "toe_off_s", "stance_s", "swing_s",
                      "initial_double_support_s", "single_support_s",
                      "terminal_double_support_s")
        }  # fmt: skip
        sides.append(SideGait(side=sg.side, heel_strike_s=sg.heel_strike_s, **fields))
    return _assemble(sides[0], sides[1])


def _assemble(left: SideGait, right: SideGait) -> BilateralGait:
    rows = []
    for m in SYMMETRY_MEASURES:
        lv, rv = left.mean(m), right.mean(m)
        rows.append(Symmetry(m, lv, rv, symmetry_ratio(lv, rv), symmetry_index_pct(lv, rv)))
    steps = np.concatenate([left.step_s, right.step_s])
    steps = steps[np.isfinite(steps)]
    cadence = 60.0 / float(steps.mean()) if len(steps) else float("nan")
    return BilateralGait(left=left, right=right, symmetry=tuple(rows), cadence_steps_min=cadence)
