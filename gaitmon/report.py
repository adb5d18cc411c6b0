"""What goes into the clinical report, gathered from a session (Qt-free).

This module owns the *content* of the report: the header (patient identifier, never a
name), the session notes typed when recording, the gait summary, the per-stride statistics,
the cycle-normalised mean ± SD curves, the filter settings and angle conventions in force, the
gaps (each one's times), losses and excluded ranges (times and reason), and the markers (time
and label). Nothing is shortened here: the layout wraps text and continues on further pages.
The stride analysis is ``gaitmon.analysis`` (the same as ``gaitmon info`` and the review
window), so the three always agree. Drawing it is ``gaitmon.ui.report_pdf`` (Qt); ``gaitmon
report`` wires the two together headless.
"""

from __future__ import annotations

import datetime as _dt
import os
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gaitmon import __version__
from gaitmon.analysis import (
    REASONS,
    USER,
    SessionAnalysis,
    SpatialSummary,
    StrideRow,
    analyse_session,
    cycles,
    evenly_chosen,
    spatial_summary,
    summary,
)
from gaitmon.dsp.channel_table import JOINT_TABLE, JOINTS, SEGMENTS
from gaitmon.dsp.gait import GaitSummary, cycle_mean_sd
from gaitmon.io.session import ANGLE_CONVENTION, Exclusion, Session, open_session
from gaitmon.normative import NormativeBands, deviation_deg
from gaitmon.text import count, no_gait_events, num

N_POINTS = 101
_CYCLE_CHUNK = 2048  # strides normalised per call
# axis labels with units and the clinical sign words (positive direction named)
JOINT_AXIS_LABELS: tuple[str, ...] = tuple(f"{j.label} (deg)" for j in JOINT_TABLE)
JOINT_TITLES: tuple[str, ...] = tuple(j.capitalize() for j in JOINTS)  # Hip, Knee, Ankle
REDACTED = "[removed]"
EXCLUSION_ORDER: tuple[str, ...] = REASONS
_SIDES = {"L": "left", "R": "right"}


@dataclass(frozen=True)
class ReportHeader:
    patient_id: str  # identifier only; REDACTED when de-identified, "" when none was entered
    side: str  # "left", "right" or ""
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


def _recorded(created_utc: str) -> str:
    try:
        t = _dt.datetime.fromisoformat(created_utc.replace("Z", "+00:00"))
    except ValueError:
        return created_utc
    return t.astimezone(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")


def _stat(name: str, values: Sequence[float]) -> JointStat:
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    v = v[np.isfinite(v)]
    n = len(v)
    mean = float(v.mean()) if n else float("nan")
    sd = float(v.std(ddof=1)) if n > 1 else float("nan")
    return JointStat(name, mean, sd, n)


def _tilt_method(session: Session) -> str:
    """The method behind the angles analysed here (the session's, see
    :mod:`gaitmon.io.session.smoothed`), and the live filter's with the settings it reads."""
    c = session.config
    live = session.angle_method_of("live")
    if c.tilt_method == "paper":
        live = (f"{live} ({c.kalman_form} form) Q_angle {c.q_angle:g}, Q_gyro {c.q_gyro:g}, "
                f"R {c.r:g}")  # fmt: skip
    else:
        live = f"{live} (accelerometer weighted by the segment's motion; docs/filters.md)"
    if session.angle_source == "live":
        return live
    return f"{session.angle_method} (zero-lag, offline); live view: {live}"


def _settings(session: Session) -> tuple[tuple[str, str], ...]:
    c = session.config
    out: list[tuple[str, str]] = []
    if session.mode == "raw":
        out.append(
            (
                "Signal chain",
                f"PC pipeline{' (reprocessed offline)' if session.reprocessed else ''}: "
                f"Butterworth low-pass {c.cutoff_hz:g} Hz order {c.filter_order} on "
                f"accelerometers and FSRs; tilt: {_tilt_method(session)}",
            )
        )
        out.append(
            (
                "Gait events",
                f"FSR threshold {c.fsr_threshold:g} LSB (hysteresis {c.fsr_hysteresis:g}), "
                f"min. contact {1000 * c.min_contact_s:g} ms; events back-dated "
                f"{session.event_delay_samples} samples for the filter delay"
                if c.compensate_event_delay
                else f"FSR threshold {c.fsr_threshold:g} LSB (hysteresis "
                f"{c.fsr_hysteresis:g}), min. contact {1000 * c.min_contact_s:g} ms; "
                "events not back-dated",
            )
        )
    else:
        what = "tilts" if session.mode == "tilt" else "joint angles and gait phase"
        out.append(("Signal chain", f"the unit's own {what} (mode {session.mode})"))
    n_changes = len(session.config_changes)
    if n_changes:
        out.append(
            ("Setting changes", f"{count(n_changes, 'change')} during the recording (the file "
             "logs each)")
        )  # fmt: skip
    off = np.degrees(session.calibration.tilt_offset_rad)
    zeroed = bool(np.any(off != 0)) or bool(session.calibration_changes)
    if zeroed:
        cal = (
            "standing pose zeroed; offsets "
            + ", ".join(f"{s} {num(v, 1, sign=True)}" for s, v in zip(SEGMENTS, off, strict=True))
            + " deg"
        )
        if session.calibration_changes:
            cal += f"; {count(len(session.calibration_changes), 'zeroing')} during the recording"
    else:
        cal = "not zeroed: angles are relative to the sensor axes (mounting offsets included)"
    out.append(("Calibration", cal))
    return tuple(out)


def _losses(
    session: Session, rows: Sequence[StrideRow], excluded_ranges: Sequence[tuple[int, int]]
) -> Losses:
    outages = [g for g in session.gaps if g.reason.startswith("link lost")]
    counts = Counter(r.excluded for r in rows if r.excluded)
    link = session.link
    return Losses(
        frames_lost=int(sum(g.n_lost for g in session.gaps)),
        n_gaps=len(session.gaps),
        outages=len(outages),
        outage_s=float(sum(g.duration_s for g in outages)),
        longest_gap_s=float(max((g.duration_s for g in session.gaps), default=0.0)),
        crc_failures=int(link.get("crc_failures", 0)),
        reconnects=int(link.get("reconnects", 0)),
        queue_overflow_frames=int(link.get("queue_overflow_frames", 0)),
        invalid_values=int(link.get("invalid_values", 0)),
        excluded={k: counts[k] for k in EXCLUSION_ORDER if counts.get(k)},
        excluded_ranges=tuple((int(a), int(b)) for a, b in excluded_ranges),
        problems=tuple(session.problems),
    )


def _timed_spans(
    session: Session, rows: Sequence[StrideRow], exclusions: Sequence[Exclusion]
) -> tuple[tuple[GapSpan, ...], tuple[ExcludedSpan, ...]]:
    """Every gap and every user-excluded range with its times in seconds."""
    n = session.n_samples
    if not n or not (session.gaps or exclusions):
        return (), ()
    t_s = np.asarray(session.read("timeline/t_s"), dtype=np.float64)
    dt = 1.0 / session.sample_rate_hz
    gaps = []
    for g in session.gaps:
        i = int(g.sample_idx)
        if 0 < i < len(t_s):
            to = float(t_s[i])
            start = to - g.n_lost * dt
        else:  # before the first row or after the last one
            start = float(t_s[-1]) + dt if i >= len(t_s) else float(t_s[0]) - g.duration_s
            to = start + g.n_lost * dt
        gaps.append(GapSpan(start, to, to - start, int(g.n_lost), str(g.reason)))
    spans = []
    for r in exclusions:
        a, b = max(0, r.start_idx), min(len(t_s), r.stop_idx)
        if b <= a:
            continue
        hit = sum(
            1 for row in rows
            if row.excluded == USER and row.stride.start_idx < b and row.stride.end_idx > a
        )  # fmt: skip
        spans.append(ExcludedSpan(float(t_s[a]), float(t_s[b - 1]), r.label, hit))
    return tuple(gaps), tuple(spans)


def gather_report(
    session: Session,
    *,
    deidentify: bool = False,
    normative: NormativeBands | None = None,
    excluded_ranges: Sequence[tuple[int, int] | Exclusion] | None = None,
    now_utc: _dt.datetime | None = None,
    analysis: SessionAnalysis | None = None,
) -> ReportData:
    """Everything the report shows, from an open session.

    ``excluded_ranges=None`` applies the exclusions stored for the session (made in review);
    the review window passes the ranges in force there (as :class:`Exclusion` s, so their
    labels are the reasons the report gives; bare row pairs get the default label).
    ``analysis``: the session's stride analysis when the caller has it already (the bilateral
    report passes each leg's from ``analyse_bilateral``); it replaces ``excluded_ranges``.
    """
    # the stride analysis exactly as ``gaitmon info`` and the review window do it; the joint
    # angles are read once (a whole-session read) and serve the strides and the cycles
    given = (
        None
        if excluded_ranges is None
        else [r if isinstance(r, Exclusion) else Exclusion(int(r[0]), int(r[1]))
              for r in excluded_ranges]
    )  # fmt: skip
    an = analysis if analysis is not None else analyse_session(session, exclusions=given)
    rows, joints = an.rows, an.joints_deg
    summ = summary(rows)
    if joints is not None and rows:
        # a few thousand strides at a time: the interpolation's temporaries are ~6x the
        # result, which for the 26 000 strides of 8 hours was 400 MB
        included_rows = [r for r in rows if r.included]
        parts = [cycles(joints, included_rows[i : i + _CYCLE_CHUNK], N_POINTS)
                 for i in range(0, len(included_rows), _CYCLE_CHUNK)]
        cyc = np.concatenate(parts) if parts else np.empty((0, N_POINTS, 3))
        del parts
    else:
        cyc = np.empty((0, N_POINTS, 3))
    mean, sd = cycle_mean_sd(cyc)
    deviation = deviation_deg(mean, normative) if normative is not None else np.full(3, np.nan)
    included = [r for r in rows if r.included]
    rom = tuple(_stat(JOINT_TITLES[j], [r.rom_deg[j] for r in included]) for j in range(3))
    peak = tuple(_stat(JOINT_TITLES[j], cyc[:, :, j].max(axis=1)) for j in range(3))
    trough = tuple(_stat(JOINT_TITLES[j], cyc[:, :, j].min(axis=1)) for j in range(3))
    notes: list[str] = []
    if an.problem:
        notes.append(an.problem)
    no_events = no_gait_events(session.mode)
    if no_events:
        notes.append(no_events[0].upper() + no_events[1:] + ".")
    elif not included:
        notes.append(
            f"{count(len(session.heel_strike_idx), 'heel strike')}, "
            f"{count(len(rows), 'stride')}: too few usable strides to analyse"
        )
    meta = session.meta
    dev = session.device
    state = "complete" if session.complete else ("recovered" if session.recovered else "incomplete")
    header = ReportHeader(
        patient_id=REDACTED if deidentify else meta.patient_id,
        side=_SIDES.get(meta.side or str(dev.get("side", "")), ""),
        operator=(REDACTED if meta.operator else "") if deidentify else meta.operator,
        # de-identified: no date (the report counts from the recording's start, as exports do)
        recorded_utc=REDACTED if deidentify else _recorded(session.created_utc),
        duration_s=session.duration_s,
        n_samples=session.n_samples,
        sample_rate_hz=session.sample_rate_hz,
        mode=session.mode,
        device=f"{dev.get('name', '?')} firmware {dev.get('firmware', '?')}"
        + ("" if deidentify else f", serial {dev.get('serial', '?')}"),
        file_name="" if deidentify else session.path.name,
        state=state,
        deidentified=deidentify,
    )
    convention = str(session.attrs.get("angle_convention", "")) or ANGLE_CONVENTION
    conventions = (
        convention,
        "Cycle: 0 % and 100 % are successive heel strikes of the measured leg; strides "
        "time-normalised to 101 points; SD is the sample SD (n - 1).",
        "Cadence is derived (120 / mean stride time): one leg is measured.",
    )
    now = now_utc or _dt.datetime.now(_dt.UTC)
    gaps, excluded_spans = _timed_spans(session, rows, an.exclusions)
    return ReportData(
        header=header,
        summary=summ,
        rows=tuple(rows),
        cycles_deg=cyc,
        mean_deg=mean,
        sd_deg=sd,
        toe_off_pct=summ.stance_pct_mean,
        rom=rom,  # type: ignore[arg-type]
        peak=peak,  # type: ignore[arg-type]
        trough=trough,  # type: ignore[arg-type]
        knee_peak_swing=_stat("Knee", [r.knee_peak_swing_deg for r in included]),
        stance_time=_stat("stance", [r.stride.stance_time_s for r in included]),
        swing_time=_stat("swing", [r.stride.swing_time_s for r in included]),
        spatial=spatial_summary(rows),
        settings=_settings(session),
        conventions=conventions,
        losses=_losses(session, rows, an.excluded_ranges),
        normative=normative,
        deviation_deg=deviation,
        notes=tuple(notes),
        session_notes=(REDACTED if deidentify and meta.notes else meta.notes),
        markers=tuple(MarkerItem(float(m.t_s), str(m.label)) for m in session.markers),
        gaps=gaps,
        excluded_spans=excluded_spans,
        generated_utc=now.strftime("%Y-%m-%d %H:%M UTC"),
    )


def report_from_file(
    path: str | os.PathLike[str],
    *,
    deidentify: bool = False,
    normative: NormativeBands | None = None,
    excluded_ranges: Sequence[tuple[int, int] | Exclusion] | None = None,
    side: str | None = None,
) -> ReportData:
    """Open (recovering if needed), gather, close. Raises ``SessionError`` for a bad file.

    ``excluded_ranges=None``: the exclusions stored for the session (as ``gaitmon report``).
    ``side``: "L" or "R", one leg of a bilateral file (required for one)."""
    with open_session(path, side=side) as s:
        return gather_report(
            s, deidentify=deidentify, normative=normative, excluded_ranges=excluded_ranges
        )
