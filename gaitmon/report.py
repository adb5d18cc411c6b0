"""What goes into the clinical report, gathered from a session of one or more units (Qt-free).

This module gathers the *content* of the report (its types: :mod:`gaitmon.report_content`):
the header (patient identifier, never a
name), the session notes typed when recording, the gait summary, the per-stride statistics,
the cycle-normalised mean ± SD curves, the filter settings and angle conventions in force, the
gaps (each one's times), losses and excluded ranges (times and reason), and the markers (time
and label). Nothing is shortened here: the layout wraps text and continues on further pages.
The stride analysis is ``gaitmon.analysis`` (the same as ``gaitmon info`` and the review
window), so the three always agree. Drawing it is ``gaitmon.ui.report_pdf`` (Qt); ``gaitmon
report`` wires the two together headless.

A session of both legs: each leg is the one-unit report's content (:func:`gather_report`, its
stride exclusions from ``FILE.L.review.json`` / ``FILE.R.review.json``), built on the stride
analysis that :func:`gaitmon.analysis.analyse_bilateral` made of it, so the per-leg lines, the
curves and the symmetry table rest on one analysis. The symmetry table's numbers are
``analyse_bilateral``'s only, with the digits ``gaitmon info`` prints (definitions in
``docs/bilateral.md``). :func:`units_report_from_file` gathers either.
"""

from __future__ import annotations

import datetime as _dt
import os
from collections import Counter
from collections.abc import Sequence

import numpy as np

from gaitmon.analysis import (
    REASONS,
    USER,
    BilateralAnalysis,
    SessionAnalysis,
    StrideRow,
    analyse_bilateral,
    analyse_session,
    cycles,
    spatial_summary,
    summary,
)
from gaitmon.dsp.channel_table import JOINT_TABLE, JOINTS, SEGMENTS
from gaitmon.dsp.gait import cycle_mean_sd, mean_sd
from gaitmon.finish import Session, open_session
from gaitmon.finish.bilateral import Bilateral, open_bilateral
from gaitmon.io.session import ANGLE_CONVENTION, Exclusion
from gaitmon.normative import NormativeBands, deviation_deg
from gaitmon.report_content import (
    MAX_FAINT_PER_SIDE,
    NO_PCT,
    SIDE_NAMES,
    SIDES,
    TABLE_HEADER,
    TABLE_MEASURES,
    BilateralReportData,
    CycleCurves,
    ExcludedSpan,
    GapSpan,
    JointStat,
    Losses,
    MarkerItem,
    ReportData,
    ReportHeader,
    SymmetryLine,
    cell,
)
from gaitmon.text import count, no_gait_events, num, side_text
from gaitmon.values import scalar

N_POINTS = 101
_CYCLE_CHUNK = 2048  # strides normalised per call
# axis labels with units and the clinical sign words (positive direction named)
JOINT_AXIS_LABELS: tuple[str, ...] = tuple(f"{j.label} (deg)" for j in JOINT_TABLE)
JOINT_TITLES: tuple[str, ...] = tuple(j.capitalize() for j in JOINTS)  # Hip, Knee, Ankle
REDACTED = "[removed]"
EXCLUSION_ORDER: tuple[str, ...] = REASONS


def _recorded(created_utc: str) -> str:
    try:
        t = _dt.datetime.fromisoformat(created_utc.replace("Z", "+00:00"))
    except ValueError:
        return created_utc
    return t.astimezone(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")


def _stat(name: str, values: Sequence[float] | np.ndarray) -> JointStat:
    return JointStat(name, *mean_sd(values))


def _tilt_method(session: Session) -> str:
    """The method behind the angles analysed here (the session's, see
    :mod:`gaitmon.finish.smoothed`), and the live filter's with the settings it reads."""
    c = session.config
    live = session.angle_method_of("live")
    live = f"{live} {c.method.describe(c)}"  # the method's own words (gaitmon.dsp.methods)
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
    # the row after the method's: where the angles' zero comes from (the one phrase every view
    # shows, gaitmon.dsp.calibration.zero_source), and the offsets a Zero set
    off = np.degrees(session.calibration.tilt_offset_rad)
    cal = f"zero: {session.zero_source}"
    if session.calibration.zeroed:
        cal += "; offsets " + ", ".join(
            f"{s} {num(v, 1, sign=True)}" for s, v in zip(SEGMENTS, off, strict=True)
        ) + " deg"
    elif session.mode == "raw":
        cal += "; mounting offsets included"
    if session.calibration_changes:
        cal += f"; {count(len(session.calibration_changes), 'zeroing')} during the recording"
    out.insert(1, ("Calibration", cal))  # beside the signal chain's method
    return tuple(out)


def session_losses(
    session: Session, rows: Sequence[StrideRow], excluded_ranges: Sequence[tuple[int, int]]
) -> Losses:
    """A session's gaps, link losses and excluded strides: the report's data-quality section
    and each session of ``gaitmon compare`` (one count for both)."""
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
        implausible_frames=int(link.get("implausible_frames", 0)),
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
        side=side_text(meta.side),  # as gaitmon info says it: never the unit's guess
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
        losses=session_losses(session, rows, an.excluded_ranges),
        normative=normative,
        deviation_deg=deviation,
        notes=tuple(notes),
        session_notes=(REDACTED if deidentify and meta.notes else meta.notes),
        markers=tuple(MarkerItem(float(m.t_s), str(m.label)) for m in session.markers),
        gaps=gaps,
        excluded_spans=excluded_spans,
        # de-identified: the report does not say when it was made either (it would date the visit)
        generated_utc="" if deidentify else now.strftime("%Y-%m-%d %H:%M UTC"),
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


# ---- a session of both legs ----


def symmetry_lines(an: BilateralAnalysis) -> tuple[SymmetryLine, ...]:
    """The table's rows from ``analyse_bilateral``: its symmetry rows (SR and SI of the
    means, computed there only, so review and ``gaitmon info`` show the same figures)."""
    g = an.gait
    out = []
    for m in TABLE_MEASURES:
        row = g.symmetry_of(m)
        lp, rp = ((np.nan, np.nan) if m in NO_PCT
                  else (g.left.pct_mean(m), g.right.pct_mean(m)))  # fmt: skip
        out.append(SymmetryLine(m, row.left, row.right, lp, rp, row.ratio, row.index_pct))
    return tuple(out)


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
        duration_s=float(scalar(b.attrs.get("duration_s", 0.0))),
        state=state,
        file_name="" if deidentify else b.path.name,
        clocks=_clocks(b),
        conventions=conventions,
        normative=normative,
        generated_utc="" if deidentify else now.strftime("%Y-%m-%d %H:%M UTC"),
        notes=() if counted["L"] and counted["R"] else
        ("Too few strides on both legs to compare: the symmetry table is empty.",),
        caveats=tuple(c.sentence for c in b.caveats()),
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


def units_report_from_file(
    path: str | os.PathLike[str],
    *,
    deidentify: bool = False,
    normative: NormativeBands | None = None,
    side: str | None = None,
) -> ReportData | BilateralReportData:
    """The report of a session of one or more units: one unit's (a one-leg file, or ``side``
    of a two-leg file) or both legs'. Raises ``SessionError`` for a bad file."""
    from gaitmon.io.session.parts import is_bilateral

    if side is None and is_bilateral(path):
        return bilateral_report_from_file(path, deidentify=deidentify, normative=normative)
    return report_from_file(path, deidentify=deidentify, normative=normative, side=side)


__all__ = [
    "MAX_FAINT_PER_SIDE",
    "REDACTED",
    "TABLE_HEADER",
    "TABLE_MEASURES",
    "BilateralReportData",
    "CycleCurves",
    "ExcludedSpan",
    "GapSpan",
    "JointStat",
    "Losses",
    "MarkerItem",
    "ReportData",
    "ReportHeader",
    "SymmetryLine",
    "bilateral_report_from_file",
    "gather_bilateral_report",
    "gather_report",
    "report_from_file",
    "symmetry_lines",
    "units_report_from_file",
]
