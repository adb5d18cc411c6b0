"""Session-level gait analysis: strides with exclusions, per-stride joint figures, summary.

Shared by ``gaitmon info``, the review window and the clinical report, so that all three agree:
:func:`analyse_session` is the one path from an open session (its events, gaps, true timeline,
joint angles and the exclusions stored beside it) to the stride rows.
:func:`stride_exclusion` is the ONE rule for which strides count, used here for a whole session
and by the live gait panel (``gaitmon.engine.live_gait``) on its rolling strides. A stride is
excluded from the statistics (and says why) when it is the first or last of the recording (or,
live, the first since the start: start-up and stopping are not steady walking), when it crosses
a gap longer than ``MAX_GAP_S`` (a link outage: a frame or two lost on a noisy link do not spoil
a stride, since times come from the true timeline ``t_s``), when it overlaps the ``SETTLE_S``
after such a gap while the filters settle (``gaitmon.dsp.pipeline`` restarts them there), or when
it overlaps a range the user excluded (e.g. a turn). Strides longer than
``gaitmon.dsp.gait.DEFAULT_MAX_STRIDE_TIME_S`` are pauses, not strides, in both paths.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gaitmon.dsp.gait import (
    GaitSummary,
    Stride,
    gait_summary,
    mean_sd,
    normalise_strides,
    strides_from_events,
)
from gaitmon.dsp.lost_frames import BRIDGE_MAX_S, settling_ranges
from gaitmon.dsp.stride_extremes import stride_extremes, stride_extremes_sliced

if TYPE_CHECKING:
    from gaitmon.dsp.bilateral import BilateralGait
    from gaitmon.dsp.stride_length import StrideMeasures
    from gaitmon.finish import Session
    from gaitmon.finish.bilateral import Bilateral
    from gaitmon.io.session import Exclusion
    from gaitmon.io.session.row_times import RowValues

MAX_GAP_S = BRIDGE_MAX_S  # gaps up to 5 frames at 100 Hz are bridged and leave a stride usable

FIRST = "first stride"
LAST = "last stride"
GAP = "crosses a gap"
SETTLING = "settling after a gap"  # the filters restart after a long gap and settle (3 s)
USER = "excluded range"
REASONS = (FIRST, LAST, GAP, SETTLING, USER)  # every reason a stride is left out


def session_gaps(session: Session) -> list[tuple[int, float]]:
    """(row where data resumed, gap duration in s) of every gap of a session."""
    return [(g.sample_idx, g.duration_s) for g in session.gaps]


def session_settling(session: Session) -> list[tuple[int, int]]:
    """[start, stop) rows where the filters settle after a long gap: the strides there are
    excluded (``SETTLING``), and the windows shade them."""
    rows = long_gap_rows(session_gaps(session))
    return settling_ranges(rows, session.sample_rate_hz, session.n_samples)


def long_gap_rows(gaps: Sequence[tuple[int, float]]) -> np.ndarray:
    """Rows where data resumed after a gap longer than ``MAX_GAP_S`` (where the filters restart)."""
    return np.asarray(sorted(i for i, d in gaps if d > MAX_GAP_S + 1e-9), dtype=np.int64)


def stride_exclusion(
    s: Stride,
    k: int,
    n: int | None,
    gap_rows: np.ndarray,
    settling: Sequence[tuple[int, int]],
    excluded_ranges: Sequence[tuple[int, int]] = (),
) -> str:
    """Why stride ``s`` (the ``k``-th of ``n``; ``n=None`` live, where the last is not known yet)
    is left out of the statistics, or "" when it counts. ``gap_rows``: see
    :func:`long_gap_rows`; ``settling``: [start, stop) rows after them (see
    ``gaitmon.dsp.lost_frames.settling_ranges``); ``excluded_ranges``: the user's [start, stop)."""
    return stride_exclusions([s.start_idx], [s.end_idx], [k], n, gap_rows, settling,
                             excluded_ranges)[0]  # fmt: skip


def stride_exclusions(
    start_idx: Sequence[int] | np.ndarray,
    end_idx: Sequence[int] | np.ndarray,
    k: Sequence[int] | np.ndarray,
    n: int | None,
    gap_rows: np.ndarray,
    settling: Sequence[tuple[int, int]],
    excluded_ranges: Sequence[tuple[int, int]] = (),
) -> list[str]:
    """:func:`stride_exclusion` of many strides at once (their first and last rows, their
    numbers ``k``): the first reason that applies, in the order FIRST, LAST, GAP, SETTLING,
    USER, or "" (26 000 strides of 8 hours: one numpy pass per rule, not per stride)."""
    start = np.asarray(start_idx, dtype=np.int64)
    end = np.asarray(end_idx, dtype=np.int64)
    num = np.asarray(k, dtype=np.int64)
    out = np.full(len(start), "", dtype=object)
    # the rules from the last to the first, so that the first that applies is the one left
    for a, b in excluded_ranges:
        out[(a < end) & (b > start)] = USER
    for a, b in settling:
        out[(a <= end) & (b > start)] = SETTLING
    g = np.sort(np.asarray(gap_rows, dtype=np.int64).ravel())
    if len(g):  # a gap row in (start, end]
        out[np.searchsorted(g, end, "right") > np.searchsorted(g, start, "right")] = GAP
    if n is not None:
        out[num == n - 1] = LAST
    out[num == 0] = FIRST
    return [str(x) for x in out.tolist()]


@dataclass(frozen=True)
class StrideRow:
    stride: Stride
    excluded: str  # "" when the stride counts in the statistics, else the reason
    knee_peak_swing_deg: float  # peak knee flexion between toe off and the next heel strike
    rom_deg: tuple[float, float, float]  # range of motion of hip, knee, ankle over the stride
    # from the foot IMU (gaitmon.dsp.stride_length); NaN where not computed (no raw data, no
    # foot-flat found, or the subject stood mid-stride)
    stride_length_m: float = float("nan")
    foot_clearance_m: float = float("nan")

    @property
    def included(self) -> bool:
        return not self.excluded

    @property
    def speed_m_s(self) -> float:
        """Gait speed over the stride: stride length / stride time (true timeline)."""
        return self.stride_length_m / self.stride.stride_time_s


@dataclass(frozen=True)
class SpatialSummary:
    """Stride length and gait speed over the included strides that have them."""

    n_strides: int  # included strides with a stride length
    stride_length_mean_m: float
    stride_length_sd_m: float  # sample SD (ddof=1)
    stride_length_cv_pct: float
    speed_mean_m_s: float
    speed_sd_m_s: float
    speed_cv_pct: float
    foot_clearance_mean_m: float
    # sample SD (ddof=1) of the foot clearance over the same strides (those with a finite one)
    foot_clearance_sd_m: float = float("nan")
    foot_clearance_n: int = 0  # strides the clearance's mean and SD are taken over

    def clearance_text(self) -> str:
        """The foot clearance as every output shows it: "5.2 ± 1.1 cm" (mean ± SD over the
        included strides; no SD with one stride); "-" without one."""
        m, sd = self.foot_clearance_mean_m * 100.0, self.foot_clearance_sd_m * 100.0
        if not np.isfinite(m):
            return "-"
        return f"{m:.1f} ± {sd:.1f} cm" if np.isfinite(sd) else f"{m:.1f} cm"


def _mean_sd_cv(v: np.ndarray) -> tuple[float, float, float]:
    mean, sd, _ = mean_sd(v)
    return mean, sd, 100.0 * sd / mean


def spatial_summary(rows: Sequence[StrideRow]) -> SpatialSummary:
    """Stride length, speed and clearance statistics over the included strides (NaN-free)."""
    ok = [r for r in rows if r.included and np.isfinite(r.stride_length_m)]
    length = np.array([r.stride_length_m for r in ok])
    speed = np.array([r.speed_m_s for r in ok])
    clear = np.array([r.foot_clearance_m for r in ok])
    lm, lsd, lcv = _mean_sd_cv(length)
    sm, ssd, scv = _mean_sd_cv(speed)
    # the only place the foot clearance's statistics are taken (info, review, report, compare
    # and the batch table all read them from here)
    clear = clear[np.isfinite(clear)]
    cm, csd, _ = _mean_sd_cv(clear)
    return SpatialSummary(len(ok), lm, lsd, lcv, sm, ssd, scv, cm, csd, len(clear))


def clearance_symmetry_text(left: SpatialSummary, right: SpatialSummary) -> str:
    """Both legs' foot clearance and its symmetry, as the two-leg report and review show it:
    "L 5.2 ± 1.0 cm, R 8.8 ± 1.3 cm; SR 0.591, SI 51.4 %" (SR = L / R, SI = 2 |L − R| /
    (L + R), of the means: ``gaitmon.dsp.bilateral``'s definitions)."""
    from gaitmon.dsp.bilateral import symmetry_index_pct, symmetry_ratio  # two legs only

    lm, rm = left.foot_clearance_mean_m, right.foot_clearance_mean_m
    text = f"L {left.clearance_text()}, R {right.clearance_text()}"
    if np.isfinite(lm) and np.isfinite(rm):
        text += f"; SR {symmetry_ratio(lm, rm):.3f}, SI {symmetry_index_pct(lm, rm):.1f} %"
    return text


def with_stride_measures(rows: list[StrideRow], m: StrideMeasures | None) -> list[StrideRow]:
    """The rows with their stride length and foot clearance from the foot IMU (``m``: one value
    per pair of consecutive heel strikes, matched to a row by its opening heel strike; see
    ``Session.foot_stride_measures``)."""
    if m is None or not len(m) or not rows:
        return rows
    at = {int(h): k for k, h in enumerate(m.heel_strike_idx)}
    length, clearance = m.stride_length_m.tolist(), m.foot_clearance_m.tolist()
    out = []
    for r in rows:
        k = at.get(r.stride.start_idx)
        if k is None:
            out.append(r)
            continue
        out.append(StrideRow(r.stride, r.excluded, r.knee_peak_swing_deg, r.rom_deg, length[k],
                             clearance[k]))  # fmt: skip
    return out


@dataclass(frozen=True)
class StrideColumn:
    """One column of the per-stride table: the review's stride table and the per-stride
    exports (``gaitmon export --format strides``, batch) show the same cells."""

    key: str  # the export's column name (unit in it)
    title: str  # the table's two-line header
    tip: str
    sample: str  # the widest cell, for the table's column width
    decimals: int | None  # None: text


def _status(r: StrideRow) -> str:
    return "included" if r.included else f"excluded: {r.excluded}"


# (column, value of a row given its number and start time in s)
_STRIDE_TABLE: tuple[tuple[StrideColumn, Callable[[StrideRow, int, float], float | str]], ...] = (
    (StrideColumn("stride", "#", "stride number", "0000", 0), lambda r, k, t: k),
    (StrideColumn("start_s", "start\ns", "heel strike that starts the stride, seconds from "
                  "the session start", "00000.00", 2), lambda r, k, t: t),
    (StrideColumn("stride_s", "stride\ns", "heel strike to the next heel strike of the same "
                  "foot", "0.000", 3), lambda r, k, t: r.stride.stride_time_s),
    (StrideColumn("stance_s", "stance\ns", "heel strike to toe off", "0.000", 3),
     lambda r, k, t: r.stride.stance_time_s),
    (StrideColumn("swing_s", "swing\ns", "toe off to the next heel strike", "0.000", 3),
     lambda r, k, t: r.stride.swing_time_s),
    (StrideColumn("stance_pct", "stance\n%", "stance time as % of the stride (swing: the rest)",
                  "00.0", 1),
     lambda r, k, t: r.stride.stance_pct),
    (StrideColumn("stride_length_m", "length\nm", "stride length from the foot IMU (forward "
                  "displacement between foot-flats)", "0.00", 2),
     lambda r, k, t: r.stride_length_m),
    (StrideColumn("speed_m_s", "speed\nm/s", "gait speed over the stride: stride length / "
                  "stride time", "0.00", 2), lambda r, k, t: r.speed_m_s),
    (StrideColumn("foot_clearance_cm", "clear.\ncm", "foot clearance from the foot IMU: the "
                  "sensor's highest point in swing above its foot-flat height", "00.0", 1),
     lambda r, k, t: r.foot_clearance_m * 100.0),
    (StrideColumn("knee_peak_swing_deg", "knee\npeak °", "peak knee flexion between toe off "
                  "and the next heel strike", "000.0", 1),
     lambda r, k, t: r.knee_peak_swing_deg),
    (StrideColumn("hip_rom_deg", "hip\nROM °", "range of motion of the hip over the stride",
                  "000.0", 1), lambda r, k, t: r.rom_deg[0]),
    (StrideColumn("knee_rom_deg", "knee\nROM °", "range of motion of the knee over the stride",
                  "000.0", 1), lambda r, k, t: r.rom_deg[1]),
    (StrideColumn("ankle_rom_deg", "ankle\nROM °", "range of motion of the ankle over the "
                  "stride", "000.0", 1), lambda r, k, t: r.rom_deg[2]),
    (StrideColumn("status", "status", "included in the statistics, or why not",
                  "excluded: " + max(REASONS, key=len), None), lambda r, k, t: _status(r)),
)  # fmt: skip
STRIDE_COLUMNS: tuple[StrideColumn, ...] = tuple(c for c, _ in _STRIDE_TABLE)


def stride_start_times(rows: Sequence[StrideRow], t_s: np.ndarray) -> list[float]:
    """Each stride's opening heel strike on the session's true timeline, s."""
    t = np.asarray(t_s)
    if not len(t):
        return [float("nan")] * len(rows)
    return [float(t[min(r.stride.start_idx, len(t) - 1)]) for r in rows]


def stride_values(row: StrideRow, number: int, start_t_s: float) -> list[float | str]:
    """The table's values of one stride, unrounded (numbers; the status as text): what
    :func:`stride_cells` prints and the public API's stride table holds."""
    return [value(row, number, start_t_s) for _, value in _STRIDE_TABLE]


def stride_cells(row: StrideRow, number: int, start_t_s: float) -> list[str]:
    """The table's cells of one stride, as text (a dash for a missing number, no "-0.0")."""
    from gaitmon.text import num

    out = []
    for col, v in zip(STRIDE_COLUMNS, stride_values(row, number, start_t_s), strict=True):
        out.append(str(v) if col.decimals is None else num(float(v), col.decimals))
    return out


@dataclass(frozen=True)
class JointSlices:
    """A record's joint angles (``n_rows`` of them) read a slice at a time: ``read(a, b)`` gives
    rows a:b (the stride figures without the whole series in memory)."""

    n_rows: int
    read: Callable[[int, int], np.ndarray]


def analyse_strides(
    heel_strike_idx: np.ndarray,
    toe_off_idx: np.ndarray,
    fs_hz: float,
    joint_deg: np.ndarray | JointSlices | None = None,
    gaps: Sequence[tuple[int, float]] = (),
    excluded_ranges: Sequence[tuple[int, int]] = (),
    t_s: np.ndarray | RowValues | None = None,
) -> list[StrideRow]:
    """One row per stride, in time order.

    ``gaps``: (row where data resumed, gap duration in s); ``excluded_ranges``: (start, stop)
    row ranges the user excluded; ``t_s``: the true time of each row (stride, stance and swing
    times are taken from it when given, so lost frames do not shorten a stride; a
    :class:`~gaitmon.io.session.row_times.RowValues` of it at the events serves as well).
    """
    strides = strides_from_events(heel_strike_idx, toe_off_idx, fs_hz)
    if t_s is not None:
        strides = _retime_all(strides, t_s)
    long_gaps = long_gap_rows(gaps)
    settling = settling_ranges(long_gaps, fs_hz)
    n = len(strides)
    start = np.fromiter((s.start_idx for s in strides), np.int64, n)
    end = np.fromiter((s.end_idx for s in strides), np.int64, n)
    toe = np.fromiter((s.toe_off_idx for s in strides), np.int64, n)
    if isinstance(joint_deg, JointSlices):
        peak, rom = stride_extremes_sliced(joint_deg.n_rows, joint_deg.read, start, end, toe)
    else:
        peak, rom = stride_extremes(joint_deg, start, end, toe)
    reasons = stride_exclusions(start, end, np.arange(n), n, long_gaps, settling,
                                excluded_ranges)  # fmt: skip
    rows = [StrideRow(s, reasons[k], peak[k], rom[k]) for k, s in enumerate(strides)]
    return rows


def _retime_all(strides: list[Stride], t_s: np.ndarray | RowValues) -> list[Stride]:
    """Stride, stance and swing times from the rows' true times (``_retime`` for every stride
    inside ``t_s``, as plain float arithmetic on arrays: same values, no per-stride numpy)."""
    inside = [k for k, s in enumerate(strides) if s.end_idx < len(t_s)]
    if not inside:
        return strides
    t = t_s if hasattr(t_s, "take") else np.asarray(t_s)  # (an array, or RowValues)
    a = t.take([strides[k].start_idx for k in inside])
    # differences in t_s's own dtype, as _retime takes them
    strides_s = (t.take([strides[k].end_idx for k in inside]) - a).tolist()
    stances_s = (t.take([strides[k].toe_off_idx for k in inside]) - a).tolist()
    out = strides  # replaced in place (analyse_strides's own list): the old go as the new come
    for k, stride, stance in zip(inside, strides_s, stances_s, strict=True):
        s = strides[k]
        out[k] = Stride(s.start_idx, s.end_idx, s.toe_off_idx, stride, stance, stride - stance,
                        100.0 * stance / stride, 100.0 * (stride - stance) / stride)
    return out


def included_strides(rows: Sequence[StrideRow]) -> list[Stride]:
    return [r.stride for r in rows if r.included]


def summary(rows: Sequence[StrideRow]) -> GaitSummary:
    """Statistics over the included strides only."""
    return gait_summary(included_strides(rows))


def cycles(joint_deg: np.ndarray, rows: Sequence[StrideRow], n_points: int = 101) -> np.ndarray:
    """(k, n_points, 3) cycle-normalised joint angles of the included strides."""
    strides = included_strides(rows)
    if not strides:
        return np.empty((0, n_points, joint_deg.shape[1]))
    return normalise_strides(joint_deg, strides, n_points)


CYCLE_BLOCK_STRIDES = 2048  # strides resampled at a time by cycle_stats (~5 MB of cycles)


def evenly_chosen(k: int, m: int) -> np.ndarray:
    """Indices of at most ``m`` of ``k`` items, evenly spread, first and last included."""
    if k <= 0 or m <= 0:
        return np.empty(0, np.int64)
    return np.unique(np.linspace(0, k - 1, min(k, m)).round().astype(np.int64))


def cycle_stats(
    joint_deg: np.ndarray, rows: Sequence[StrideRow], n_points: int = 101, keep: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean, sd, kept) of the included strides' cycles: the mean and SD exactly (to the bit)
    as ``cycle_mean_sd(cycles(joint_deg, rows, n_points))``, and the ``keep`` cycles
    :func:`evenly_chosen` (in stride order), without the whole (k, n_points, 3) float64 array
    (63 MB for the 26 000 strides of 8 hours, and as much again for the SD's temporaries):
    the strides are resampled a block at a time, twice (the sums, then the squared
    deviations, each added in stride order as numpy's reduction over the first axis does)."""
    strides = included_strides(rows)
    width = joint_deg.shape[1]
    blocks = [strides[i : i + CYCLE_BLOCK_STRIDES]
              for i in range(0, len(strides), CYCLE_BLOCK_STRIDES)]  # fmt: skip

    def each() -> Any:
        done = 0
        for b in blocks:
            c = normalise_strides(joint_deg, b, n_points)
            yield done, c
            done += len(c)

    def add(acc: np.ndarray | None, c: np.ndarray) -> np.ndarray | None:
        if not len(c):
            return acc
        return np.add.reduce(c if acc is None else np.concatenate([acc[None], c]), axis=0)

    total: np.ndarray | None = None
    k = 0
    for _, c in each():
        total = add(total, c)
        k += len(c)
    if total is None:
        nan = np.full((n_points, width), np.nan)
        return nan, nan.copy(), np.empty((0, n_points, width))
    mean = total / k
    pick = evenly_chosen(k, keep)
    kept = np.empty((len(pick), n_points, width))
    squares: np.ndarray | None = None
    for first, c in each():
        inside = (pick >= first) & (pick < first + len(c))
        kept[inside] = c[pick[inside] - first]
        if k > 1:
            x = c - mean
            squares = add(squares, np.multiply(x, x, out=x))
    sd = np.sqrt(squares / (k - 1)) if squares is not None else np.full_like(mean, np.nan)
    return mean, sd, kept


@dataclass(frozen=True)
class SessionAnalysis:
    """The strides of one session with the exclusions in force, and where those came from."""

    rows: list[StrideRow]
    # (n, 3) hip/knee/ankle as read (float32), None if empty or not kept (analyse_session)
    joints_deg: np.ndarray | None
    exclusions: tuple[Exclusion, ...]  # the user's ranges applied
    side_file: Path  # where stored exclusions live (FILE.review.json, or the user store)
    problem: str = ""  # one line when the stored exclusions could not be used, else ""

    @property
    def n_included(self) -> int:
        return sum(1 for r in self.rows if r.included)

    @property
    def n_excluded(self) -> int:
        return len(self.rows) - self.n_included

    @property
    def n_user_excluded(self) -> int:
        """Strides left out only because they overlap a range the user excluded."""
        return sum(1 for r in self.rows if r.excluded == USER)

    @property
    def excluded_ranges(self) -> tuple[tuple[int, int], ...]:
        return tuple((r.start_idx, r.stop_idx) for r in self.exclusions)

    def summary(self) -> GaitSummary:
        return summary(self.rows)

    def spatial(self) -> SpatialSummary:
        return spatial_summary(self.rows)


def analyse_session(
    session: Session,
    *,
    exclusions: Sequence[Exclusion] | None = None,
    joints: np.ndarray | None = None,
    events: tuple[np.ndarray, np.ndarray] | None = None,
    t_s: np.ndarray | None = None,
    keep_joints: bool = True,
) -> SessionAnalysis:
    """The stride analysis of ``session`` as ``gaitmon info``, the report and review show it.

    ``exclusions=None`` means the ranges stored for this session (the review window's side
    file; an unusable side file applies none and says why in ``problem``). ``joints``,
    ``events`` (heel strike, toe off rows) and ``t_s`` default to the recorded ones; review
    passes a reprocessed source's joints and events instead. ``keep_joints=False`` (``gaitmon
    info``, which shows no cycles): the recorded joint angles are read a slice at a time for
    the stride figures, the same figures, and not kept (``joints_deg`` is None).
    """
    from gaitmon.io.session.exclusions import stored_path

    problem = ""
    if exclusions is None:
        found, problem = session.exclusions()
        exclusions = found
    source: np.ndarray | JointSlices | None = joints
    if joints is None and session.n_samples:
        # float32 as read (not a float64 copy, 8 bytes a value): the figures take their
        # samples exactly (gaitmon.dsp.gait computes in float64 from them)
        if keep_joints:
            joints = source = session.read("processed/joint_deg")
        else:
            source = JointSlices(session.n_samples, lambda a, b: session.read_range(
                a, b, ["processed/joint_deg"])["processed/joint_deg"])  # fmt: skip
    hs, to = events if events is not None else (session.heel_strike_idx, session.toe_off_idx)
    times: np.ndarray | RowValues | None = t_s
    if times is None and session.n_samples:
        # the times at the events only (the strides' ends), not the whole series
        from gaitmon.io.session.row_times import RowValues

        times = RowValues.read(session, "timeline/t_s", np.concatenate([hs, to]))
    ranges = tuple(exclusions)
    rows = analyse_strides(
        hs,
        to,
        session.sample_rate_hz,
        source,
        session_gaps(session),
        [(r.start_idx, r.stop_idx) for r in ranges],
        t_s=times,
    )
    rows = with_stride_measures(rows, session.foot_stride_measures(hs))
    return SessionAnalysis(rows, joints, ranges, stored_path(session.exclusions_key), problem)


@dataclass(frozen=True)
class BilateralAnalysis:
    """Both legs of a bilateral session: each side's own stride analysis (its exclusions
    applied) and the bilateral measures of their events on the session's common time line
    (``gaitmon.dsp.bilateral``; definitions in ``docs/bilateral.md``)."""

    sides: dict[str, SessionAnalysis]
    heel_strike_s: dict[str, np.ndarray]  # every detected heel strike, common seconds
    toe_off_s: dict[str, np.ndarray]
    gait: BilateralGait  # the rows of excluded strides set to NaN; symmetry over the rest


def analyse_bilateral(
    bilateral: Bilateral, *, exclusions: Mapping[str, Sequence[Exclusion]] | None = None
) -> BilateralAnalysis:
    """Each side analysed as one unit (``analyse_session``: its stride exclusions), its events
    mapped to common time by the session's clock fits, then ``dsp.bilateral.bilateral_gait``.
    A heel strike's row counts when the stride it opens is included on its side; cadence is
    measured from both legs' steps.

    ``exclusions``: a side's ranges in force (review passes the leg it shows, as it has them);
    a side not given has the ranges stored for it (``FILE.L|R.review.json``)."""
    from gaitmon.dsp.bilateral import bilateral_gait, keep_rows

    per: dict[str, SessionAnalysis] = {}
    hs_s: dict[str, np.ndarray] = {}
    to_s: dict[str, np.ndarray] = {}
    included: dict[str, set[int]] = {}
    for side in ("L", "R"):
        if side not in bilateral.units:
            hs_s[side] = to_s[side] = np.empty(0)
            included[side] = set()
            continue
        s = bilateral.unit(side)
        an = analyse_session(s, exclusions=None if exclusions is None else exclusions.get(side))
        per[side] = an
        t = s.read("timeline/t_s") if s.n_samples else np.empty(0)
        hs, to = s.heel_strike_idx, s.toe_off_idx
        hs = hs[hs < len(t)]
        to = to[to < len(t)]
        hs_s[side] = bilateral.common_s(side, t[hs])
        to_s[side] = bilateral.common_s(side, t[to])
        included[side] = {r.stride.start_idx for r in an.rows if r.included}
    gait = bilateral_gait(hs_s["L"], to_s["L"], hs_s["R"], to_s["R"])
    keep = []
    for side, sg in (("L", gait.left), ("R", gait.right)):
        if side not in per:
            keep.append(np.zeros(len(sg), bool))
            continue
        rows_sorted = heel_strike_rows(bilateral.unit(side), hs_s[side])
        keep.append(np.array([int(r) in included[side] for r in rows_sorted], bool))
    return BilateralAnalysis(per, hs_s, to_s, keep_rows(gait, keep[0], keep[1]))


def heel_strike_rows(unit: Session, heel_strike_s: np.ndarray) -> np.ndarray:
    """The unit's row of each of ``bilateral_gait``'s rows for this side: it sorts the heel
    strikes' common times, so its rows map back to the unit's heel strikes in that order."""
    order = np.argsort(heel_strike_s, kind="stable")
    return np.asarray(unit.heel_strike_idx[: len(heel_strike_s)][order])
