"""Progress across sessions: two or more recordings of one patient side by side (Qt-free).

:func:`compare_sessions` opens each file, analyses it with
:func:`gaitmon.analysis.analyse_session` (the strides, exclusions and figures of ``gaitmon
info``, the report and review), orders the sessions by recording date, checks that they are of
one patient, and gives per session every summary measure the report shows with its
between-stride SD, and the mean ± SD cycles. For each later session it gives the change from
the first session (the baseline) and from the one before, judged by ONE rule,
:func:`judge_change` (``docs/compare.md``):

    a change is *beyond the minimal detectable change* when |Δmean| > MDC95 =
    1.96 · √2 · SEM, with SEM the pooled stride-to-stride SD of the two sessions,
    sqrt(((n1 − 1)·SD1² + (n2 − 1)·SD2²) / (n1 + n2 − 2)), each session with at least 2
    included strides; otherwise it is not judged.

Each session also says its gaps (link outages: count and seconds) and its excluded strides
(count and reasons), :func:`session_quality`, counted as its report counts them.

``gaitmon compare`` draws a :class:`Comparison` as a PDF (``gaitmon.ui.report_pdf.compare``)
and the review window shows the same one (``gaitmon.ui.review.compare_view``).
:func:`list_recordings` is the patient list: the recordings of a folder by patient id and date
with their key measures.
"""

from __future__ import annotations

import datetime as _dt
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.dsp.channel_table import JOINTS as TABLE_JOINTS
from gaitmon.dsp.gait import mean_sd
from gaitmon.errors import Cancelled, UserError
from gaitmon.text import count, no_gait_events, num, side_text

if TYPE_CHECKING:
    from gaitmon.analysis import SessionAnalysis
    from gaitmon.finish import Session

N_POINTS = 101
JOINTS: tuple[str, ...] = tuple(j.capitalize() for j in TABLE_JOINTS)  # Hip, Knee, Ankle
REDACTED = "[removed]"
_CYCLE_CHUNK = 2048  # strides normalised per call (as the report: bounded temporaries)
# what analysing a damaged file's contents can raise past the reader's checks
_DAMAGE = (ValueError, IndexError, KeyError, OSError, RuntimeError, ZeroDivisionError,
           FloatingPointError, OverflowError)  # fmt: skip
Progress = Callable[[float], bool | None]  # fraction done; False: stop (Cancelled)


class CompareError(UserError):
    """A comparison that cannot be made: one line naming the problem and what to do."""


@dataclass(frozen=True)
class Measure:
    """One row of the comparison table."""

    key: str
    label: str
    unit: str
    decimals: int
    judged: bool = True  # False: a count or a ratio with no between-stride SD (never flagged)


MEASURES: tuple[Measure, ...] = (
    Measure("n_strides", "Strides included", "", 0, judged=False),
    Measure("stride_time", "Stride time", "s", 2),
    Measure("stride_time_cv", "Stride time CV", "%", 1, judged=False),
    Measure("cadence", "Cadence (derived)", "steps/min", 0),
    Measure("stance_pct", "Stance", "% of cycle", 1),
    Measure("swing_pct", "Swing", "% of cycle", 1),
    Measure("stance_time", "Stance time", "s", 2),
    Measure("swing_time", "Swing time", "s", 2),
    Measure("stride_length", "Stride length", "m", 2),
    Measure("speed", "Gait speed", "m/s", 2),
    Measure("foot_clearance", "Foot clearance", "cm", 1),
    Measure("knee_peak_swing", "Peak knee flexion in swing", "deg", 1),
    *(Measure(f"rom_{j.lower()}", f"ROM {j.lower()}", "deg", 1) for j in JOINTS),
    *(Measure(f"max_{j.lower()}", f"Maximum {j.lower()}", "deg", 1) for j in JOINTS),
    *(Measure(f"min_{j.lower()}", f"Minimum {j.lower()}", "deg", 1) for j in JOINTS),
)
MEASURE_BY_KEY = {m.key: m for m in MEASURES}
Z95 = 1.96  # two-sided 95 % of a normal distribution
MDC_FACTOR = Z95 * math.sqrt(2.0)  # 2.77: the difference of two measurements, each with SD SEM
RULE_TEXT = (
    "A change is flagged when |Δmean| exceeds the minimal detectable change MDC95 = 1.96 · √2 · "
    "SEM, where SEM is the two sessions' pooled stride-to-stride SD (each session with at least "
    "2 included strides). Variability between the strides of one session is not test-retest "
    "reliability between days (sensor placement, zeroing, the day itself): an unflagged change "
    "is within stride-to-stride noise; a flagged one may still be within day-to-day variation."
)


@dataclass(frozen=True)
class Value:
    """A measure of one session: the value shown, the SD between its strides and how many."""

    mean: float
    sd: float  # sample SD (n − 1) between the included strides; NaN when undefined
    n: int


@dataclass(frozen=True)
class Change:
    """A later session's measure against an earlier one's."""

    delta: float  # later − earlier
    pooled_sd: float  # the SEM of the rule: pooled stride-to-stride SD; NaN when not judged
    mdc: float  # MDC95 = 1.96 · √2 · pooled_sd, the threshold; NaN when not judged
    beyond: bool | None  # |delta| > mdc; None: not judged (a count, or < 2 strides)


def pooled_sd(a: Value, b: Value) -> float:
    """The pooled between-stride SD of two sessions (NaN with fewer than 2 strides in one)."""
    if a.n < 2 or b.n < 2 or not (math.isfinite(a.sd) and math.isfinite(b.sd)):
        return float("nan")
    return math.sqrt(((a.n - 1) * a.sd**2 + (b.n - 1) * b.sd**2) / (a.n + b.n - 2))


def mdc95(a: Value, b: Value) -> float:
    """The minimal detectable change of a measure between two sessions: 1.96 · √2 · SEM with
    SEM the pooled stride-to-stride SD (NaN with fewer than 2 strides in one)."""
    return MDC_FACTOR * pooled_sd(a, b)


def judge_change(earlier: Value, later: Value, judged: bool = True) -> Change:
    """THE rule (module doc, docs/compare.md): beyond when |Δmean| > MDC95."""
    delta = later.mean - earlier.mean
    sd = pooled_sd(earlier, later) if judged else float("nan")
    mdc = MDC_FACTOR * sd
    beyond = bool(abs(delta) > mdc) if math.isfinite(mdc) and math.isfinite(delta) else None
    return Change(delta, sd, mdc, beyond)


def change_text(ch: Change, m: Measure, *, unit: bool = False, minus: str = "−") -> str:
    """A change with its threshold beside it, "−0.1 (MDC 0.2)" (``unit``: "−0.1 deg (MDC 0.2
    deg)"), so that the reader sees why it is or is not flagged; a count or an unjudged change
    is the signed difference alone."""
    u = f" {m.unit}" if unit and m.unit else ""
    d = m.decimals
    if math.isfinite(ch.mdc) and num(abs(ch.delta), d) == num(ch.mdc, d):
        d += 1  # "+0.01 (MDC 0.01)" would not show which is larger
    text = num(ch.delta, d, sign=True, minus=minus)
    text += u if math.isfinite(ch.delta) else ""
    if math.isfinite(ch.mdc):
        text += f" (MDC {num(ch.mdc, d)}{u})"
    return text


@dataclass(frozen=True)
class SessionQuality:
    """A session's gaps and excluded strides (:func:`session_quality`)."""

    outages: int  # gaps where the link was lost
    outage_s: float  # their total duration
    other_gaps: int  # shorter losses (frames lost on a noisy link)
    excluded: dict[str, int]  # exclusion reason -> strides, in gaitmon.analysis.REASONS order
    side: str = ""  # the leg measured, as info and the report say it (text.side_text)
    zero: str = ""  # where the angles' zero comes from (dsp.calibration.zero_source)

    @property
    def n_excluded(self) -> int:
        return sum(self.excluded.values())

    def text(self) -> str:
        """One line: "1 link outage (5.4 s); 5 strides excluded (first stride 1, …)"."""
        link = (f"{count(self.outages, 'link outage')} ({num(self.outage_s, 1)} s)"
                if self.outages else "no link outage")  # fmt: skip
        if self.other_gaps:
            link += f", {count(self.other_gaps, 'other gap')}"
        why = ", ".join(f"{reason} {n}" for reason, n in self.excluded.items())
        excl = (f"{count(self.n_excluded, 'stride')} excluded ({why})" if why
                else "no stride excluded")  # fmt: skip
        # the leg and the zero first: sessions of different legs, or one zeroed standing and
        # one not, differ by more than the gait (a mounting offset moves every angle)
        where = f"side {side_text(self.side)}; " + (f"zero: {self.zero}; " if self.zero else "")
        return f"{where}{link}; {excl}"


def session_quality(session: Session, an: SessionAnalysis) -> SessionQuality:
    """What the report's data-quality section counts (``gaitmon.report.session_losses``)."""
    from gaitmon.report import session_losses

    lo = session_losses(session, an.rows, an.excluded_ranges)
    return SessionQuality(lo.outages, lo.outage_s, lo.n_gaps - lo.outages, dict(lo.excluded),
                          session.meta.side, session.zero_source)  # fmt: skip


@dataclass(frozen=True, eq=False)
class SessionResult:
    """One session of a comparison."""

    path: Path
    file_name: str  # REDACTED when de-identified
    patient_id: str  # as recorded ("" when none); REDACTED when de-identified
    recorded_utc: str  # "2026-11-22 04:10 UTC", "" when unknown, "day 28" when de-identified
    created: _dt.datetime | None  # the recording's start (ordering)
    duration_s: float
    mode: str
    angle_method: str  # the method behind the angles analysed
    n_strides_total: int
    values: dict[str, Value]
    mean_deg: np.ndarray  # (101, 3) hip / knee / ankle
    sd_deg: np.ndarray  # (101, 3), NaN with fewer than 2 strides
    label: str  # the legend's name for it: date and file (or session number and day)
    quality: SessionQuality  # its gaps and excluded strides
    side: str = ""  # the leg measured: "L", "R" or "" (not recorded)

    @property
    def n_included(self) -> int:
        return self.values["n_strides"].n

    @property
    def stance_pct(self) -> float:
        return self.values["stance_pct"].mean


@dataclass(frozen=True, eq=False)
class Comparison:
    sessions: tuple[SessionResult, ...]  # oldest first: sessions[0] is the baseline
    warnings: tuple[str, ...]  # one line each (patient ids, dates, angle methods)
    patient_id: str  # the one patient id, or "" when they differ or are missing
    deidentified: bool = False
    ids_differ: bool = False  # two or more different patient ids

    @property
    def who(self) -> str:
        """Whose sessions, for a title: the patient id, or why there is none."""
        if self.patient_id:
            return self.patient_id
        return "patient ids differ" if self.ids_differ else "no patient ID"

    def change(self, k: int, key: str, since: int = 0) -> Change:
        """Session ``k``'s change in measure ``key`` from session ``since`` (0: baseline)."""
        m = MEASURE_BY_KEY[key]
        return judge_change(self.sessions[since].values[key], self.sessions[k].values[key],
                            m.judged)  # fmt: skip

    def changes(self, since: str = "baseline") -> list[dict[str, Change]]:
        """For every later session (1, 2, …), its changes from the baseline or the previous."""
        return [{m.key: self.change(k, m.key, 0 if since == "baseline" else k - 1)
                 for m in MEASURES} for k in range(1, len(self.sessions))]  # fmt: skip

    def beyond(self, k: int, since: int = 0) -> list[str]:
        """The measures of session ``k`` whose change from ``since`` is beyond the rule."""
        return [m.key for m in MEASURES if self.change(k, m.key, since).beyond]

    def n_beyond(self) -> int:
        """How many changes from the baseline are beyond the rule (every later session)."""
        return sum(len(self.beyond(k)) for k in range(1, len(self.sessions)))


# ------------------------------------------------------------------------------------------
# one session


def _stat(values: Sequence[float] | np.ndarray) -> Value:
    return Value(*mean_sd(values))


def parse_utc(created_utc: str) -> _dt.datetime | None:
    try:
        t = _dt.datetime.fromisoformat(created_utc.replace("Z", "+00:00"))
    except ValueError:
        return None
    return t if t.tzinfo else t.replace(tzinfo=_dt.UTC)


def format_utc(t: _dt.datetime | None) -> str:
    return t.astimezone(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC") if t is not None else ""


def _cycles(an: SessionAnalysis) -> np.ndarray:
    from gaitmon.analysis import cycles

    included = [r for r in an.rows if r.included]
    if an.joints_deg is None or not included:
        return np.empty((0, N_POINTS, 3))
    parts = [cycles(an.joints_deg, included[i: i + _CYCLE_CHUNK], N_POINTS)
             for i in range(0, len(included), _CYCLE_CHUNK)]  # fmt: skip
    return np.concatenate(parts)


def session_values(an: SessionAnalysis, cyc: np.ndarray) -> dict[str, Value]:
    """Every measure of :data:`MEASURES` from one session's analysis and its cycles."""
    s = an.summary()
    inc = [r for r in an.rows if r.included]
    n = len(inc)
    sp = an.spatial()
    stride_t = np.array([r.stride.stride_time_s for r in inc], dtype=np.float64)
    with np.errstate(divide="ignore"):
        cadence = 120.0 / stride_t
    out = {
        "n_strides": Value(float(s.n_strides), math.nan, s.n_strides),
        # the summary's own figures are the values shown (as the report), the per-stride SD
        # is the variability the changes are judged against
        "stride_time": Value(s.stride_time_mean_s, s.stride_time_sd_s, n),
        "stride_time_cv": Value(s.stride_time_cv_pct, math.nan, n),
        "cadence": Value(s.cadence_derived_steps_per_min, _stat(cadence).sd, n),
        "stance_pct": Value(s.stance_pct_mean, _stat([r.stride.stance_pct for r in inc]).sd, n),
        "swing_pct": Value(s.swing_pct_mean, _stat([r.stride.swing_pct for r in inc]).sd, n),
        "stance_time": _stat([r.stride.stance_time_s for r in inc]),
        "swing_time": _stat([r.stride.swing_time_s for r in inc]),
        # the figures of gaitmon.analysis.spatial_summary (as info, review and report): from
        # the foot IMU, NaN (a dash) for a session without raw counts; clearance in cm
        "stride_length": Value(sp.stride_length_mean_m, sp.stride_length_sd_m, sp.n_strides),
        "speed": Value(sp.speed_mean_m_s, sp.speed_sd_m_s, sp.n_strides),
        "foot_clearance": Value(sp.foot_clearance_mean_m * 100.0,
                                sp.foot_clearance_sd_m * 100.0, sp.foot_clearance_n),
        "knee_peak_swing": _stat([r.knee_peak_swing_deg for r in inc]),
    }
    for j, name in enumerate(JOINTS):
        key = name.lower()
        out[f"rom_{key}"] = _stat([r.rom_deg[j] for r in inc])
        out[f"max_{key}"] = _stat(cyc[:, :, j].max(axis=1) if len(cyc) else [])
        out[f"min_{key}"] = _stat(cyc[:, :, j].min(axis=1) if len(cyc) else [])
    return out


@dataclass(frozen=True, eq=False)
class _Analysed:
    path: Path
    patient_id: str
    created: _dt.datetime | None
    created_utc: str
    duration_s: float
    mode: str
    angle_method: str
    n_strides_total: int
    values: dict[str, Value]
    mean_deg: np.ndarray
    sd_deg: np.ndarray
    side: str
    quality: SessionQuality


def _analyse_file(path: Path) -> _Analysed:
    """Open, analyse, close; CompareError for a file that cannot be compared."""
    from gaitmon.analysis import analyse_session
    from gaitmon.dsp.gait import cycle_mean_sd
    from gaitmon.finish import open_session
    from gaitmon.io.session import SessionError
    from gaitmon.io.session.parts import session_files

    name = path.name
    if path.is_dir():
        raise CompareError(f"{name} is a folder; give session files (.h5)")
    if not session_files(path):  # (its journal or parts alone are a session, recovered here)
        raise CompareError(f"{name} does not exist; check the file name and folder")
    try:
        with open_session(path) as s:
            an = analyse_session(s)
            cyc = _cycles(an)
            pid, created_utc, duration_s = s.meta.patient_id.strip(), s.created_utc, s.duration_s
            mode, method = s.mode, s.angle_method
            side = s.meta.side  # as info and the report read it (text.side_text)
            quality = session_quality(s, an)
    except SessionError as exc:
        raise CompareError(str(exc)) from None
    except _DAMAGE as exc:
        what = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise CompareError(
            f"{name} is damaged and cannot be analysed ({what}); the "
            "recording's own journal or a backup may hold a good copy"
        ) from None
    if no_gait_events(mode):
        raise CompareError(f"{name}: {no_gait_events(mode)}; compare sessions recorded in raw "
                           "or joint mode")  # fmt: skip
    if not any(r.included for r in an.rows):
        raise CompareError(
            f"{name} has no stride to compare ({count(len(an.rows), 'stride')}, none included); "
            "record at least a few steps of walking, or include its excluded ranges in review"
        )
    mean, sd = cycle_mean_sd(cyc)
    return _Analysed(path, pid, parse_utc(created_utc), created_utc, float(duration_s), mode,
                     method, len(an.rows), session_values(an, cyc), mean, sd,
                     side if side in ("L", "R") else "", quality)  # fmt: skip


# ------------------------------------------------------------------------------------------
# the comparison


def compare_sessions(
    paths: Sequence[str | os.PathLike[str]],
    *,
    deidentify: bool = False,
    progress: Progress | None = None,
) -> Comparison:
    """Compare two or more session files (see the module doc). ``CompareError`` (one line)
    when they cannot be compared; ``progress(fraction)`` returning False cancels
    (:class:`gaitmon.errors.Cancelled`)."""
    files = [Path(p) for p in paths]
    if len(files) < 2:
        raise CompareError(
            f"compare needs two or more sessions, got {len(files)}; give the files to compare "
            "(e.g. the first visit and the latest)"
        )
    seen: dict[Path, str] = {}
    for f in files:
        key = f.resolve()
        if key in seen:
            raise CompareError(f"{f.name} is given twice; give each session once")
        seen[key] = f.name
    done = []
    for k, f in enumerate(files):
        done.append(_analyse_file(f))
        if progress is not None and progress((k + 1) / len(files)) is False:
            raise Cancelled()
    return _assemble(done, deidentify)


def _assemble(done: list[_Analysed], deidentify: bool) -> Comparison:
    warnings: list[str] = []
    undated = [a.path.name for a in done if a.created is None]
    if undated:
        warnings.append(f"No recording date in {', '.join(undated)}: placed after the dated "
                        "sessions, in the order given")  # fmt: skip
    # stable: sessions of the same minute (or without a date) keep the order given
    order = sorted(
        range(len(done)),
        key=lambda i: (done[i].created is None, done[i].created or _dt.datetime.min, i),
    )
    ordered = [done[i] for i in order]
    ids = [a.patient_id for a in ordered]
    missing = [a.path.name for a in ordered if not a.patient_id]
    distinct = sorted({i for i in ids if i})
    patient = distinct[0] if len(distinct) == 1 and not missing else ""
    if len(distinct) > 1:
        listing = ", ".join(f"{a.patient_id or 'none'} ({a.path.name})" for a in ordered)
        if deidentify:
            listing = f"{len(distinct)} different ids"
        warnings.append(f"Patient ids differ: {listing}; check that these are one patient's "
                        "sessions")  # fmt: skip
    if missing:
        names = ", ".join(missing) if not deidentify else count(len(missing), "session")
        warnings.append(f"No patient id in {names}: the sessions cannot be checked to be one "
                        "patient's")  # fmt: skip
    sides = {a.side for a in ordered if a.side}
    if len(sides) > 1:
        leg = {"L": "left", "R": "right"}
        legs = ", ".join(f"{leg.get(a.side, 'not recorded')} "
                         f"({a.path.name if not deidentify else f'session {k + 1}'})"
                         for k, a in enumerate(ordered))  # fmt: skip
        warnings.append(f"The sessions measured different legs: {legs}; a change may be the "
                        "other leg's")  # fmt: skip
    methods = sorted({a.angle_method for a in ordered})
    if len(methods) > 1:
        warnings.append(
            "The angles come from different methods ("
            + "; ".join(methods)
            + "): part of a change in the joint figures may be the method's"
        )
    t0 = ordered[0].created
    sessions = []
    for k, a in enumerate(ordered):
        if deidentify:
            days = (a.created - t0).total_seconds() / 86400 if a.created and t0 else math.nan
            when = f"day {days:.0f}" if math.isfinite(days) else "date withheld"
            label = f"Session {k + 1} ({when})"
            name, pid = REDACTED, REDACTED if a.patient_id else ""
        else:
            when = format_utc(a.created) or a.created_utc or "date unknown"
            label = f"{format_utc(a.created)[:10] or 'undated'} · {a.path.name}"
            name, pid = a.path.name, a.patient_id
        sessions.append(SessionResult(
            a.path, name, pid, when, a.created, a.duration_s, a.mode, a.angle_method,
            a.n_strides_total, a.values, a.mean_deg, a.sd_deg, label, a.quality,
            a.side))  # fmt: skip
    if deidentify and patient:
        patient = REDACTED
    return Comparison(tuple(sessions), tuple(warnings), patient, deidentify, len(distinct) > 1)


# ------------------------------------------------------------------------------------------
# the patient list


@dataclass(frozen=True)
class Recording:
    """One recording of a folder, as the patient list shows it."""

    path: Path
    patient_id: str
    created: _dt.datetime | None
    recorded_utc: str
    duration_s: float
    mode: str
    n_strides: int  # included strides
    cadence_steps_min: float
    knee_peak_swing_deg: float
    problem: str = ""  # why it cannot be compared ("" when it can)


def list_recordings(folder: str | os.PathLike[str],
                    progress: Progress | None = None) -> list[Recording]:  # fmt: skip
    """Every session file (``*.h5``, ``*.hdf5``) of ``folder`` by patient id, then date; a
    file that cannot be analysed is listed with its problem."""
    from gaitmon.io.session.parts import sessions_in

    d = Path(folder)
    if not d.is_dir():
        raise CompareError(f"{d} is not a folder; pick the folder that holds the recordings")
    files = sessions_in(d, recursive=False)  # (also those left as a journal or parts)
    out = []
    for k, f in enumerate(files):
        out.append(_recording(f))
        if progress is not None and progress((k + 1) / max(1, len(files))) is False:
            raise Cancelled()
    return sorted(
        out,
        key=lambda r: (
            r.patient_id == "",
            r.patient_id.lower(),
            r.created or _dt.datetime.max,
            r.path.name,
        ),
    )


def _recording(f: Path) -> Recording:
    try:
        a = _analyse_file(f)
    except CompareError as exc:
        pid, created, mode, dur = _header_only(f)
        return Recording(f, pid, created, format_utc(created), dur, mode, 0, math.nan, math.nan,
                         str(exc))  # fmt: skip
    return Recording(f, a.patient_id, a.created, format_utc(a.created), a.duration_s, a.mode,
                     a.values["n_strides"].n, a.values["cadence"].mean,
                     a.values["knee_peak_swing"].mean)  # fmt: skip


def _header_only(f: Path) -> tuple[str, _dt.datetime | None, str, float]:
    """What can be read of a file that cannot be compared (nothing, for a damaged one)."""
    from gaitmon.finish import open_session
    from gaitmon.io.session import SessionError

    try:
        with open_session(f, recover=False) as s:
            return s.meta.patient_id.strip(), parse_utc(s.created_utc), s.mode, s.duration_s
    except (SessionError, *_DAMAGE):
        return "", None, "", math.nan


__all__ = [
    "MDC_FACTOR",
    "MEASURES",
    "RULE_TEXT",
    "Change",
    "CompareError",
    "Comparison",
    "Measure",
    "Recording",
    "SessionQuality",
    "SessionResult",
    "Value",
    "change_text",
    "compare_sessions",
    "judge_change",
    "list_recordings",
    "mdc95",
    "pooled_sd",
    "session_quality",
]
