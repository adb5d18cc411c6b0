"""``gaitmon info FILE``: what a session of one or both legs holds; recovers an interrupted
recording first."""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.commands import damaged_file_guard
from gaitmon.errors import UserError
from gaitmon.text import count, duration_text, implausible_text, no_gait_events, num, side_text

if TYPE_CHECKING:
    from gaitmon.analysis import BilateralAnalysis, SessionAnalysis
    from gaitmon.finish import Session
    from gaitmon.finish.bilateral import Bilateral
    from gaitmon.review.settings import PipelineSetting


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", help="session file (.h5)")


def progress_printer(label: str) -> Callable[[float], None]:
    """A progress callback printing whole percents to stderr (for long recoveries)."""
    last = [-1]

    def report(fraction: float) -> None:
        pct = int(fraction * 100)
        if pct != last[0] and sys.stderr.isatty():
            last[0] = pct
            print(f"\r{label} {pct:3d} %", end="", file=sys.stderr, flush=True)
        if fraction >= 1.0 and sys.stderr.isatty():
            print(file=sys.stderr)

    return report


@dataclass(frozen=True)
class LinkCounts:
    """What a recording lost, as its file states it: the frames of its gaps (with those this
    computer received and did not keep, by cause: a receive queue nobody read fast enough, a
    recorder queue a stalled disk did not empty), the CRC failures and reconnects of its
    ``/link``. ``gaitmon info`` and the closing line of ``gaitmon record`` both say these (the
    link's own totals also count what it lost before the recording started and after it
    stopped)."""

    frames_lost: int
    gaps: int
    crc_failures: int
    reconnects: int
    implausible_frames: int = 0  # CRC-valid frames the decoder dropped (a false CRC accept)
    dropped_here: tuple[tuple[str, int], ...] = ()  # (cause, frames): "recorder queue full"

    @classmethod
    def of(cls, s: Session) -> LinkCounts:
        by_cause = Counter[str]()
        for g in s.gaps:
            if g.reason.endswith("queue full"):
                by_cause[g.reason.removeprefix("frames lost: ")] += g.n_lost
        return cls(sum(g.n_lost for g in s.gaps), len(s.gaps), s.link.get("crc_failures", 0),
                   s.link.get("reconnects", 0), int(s.link.get("implausible_frames", 0)),
                   tuple(by_cause.items()))  # fmt: skip

    def _causes(self) -> list[str]:
        return [f"{n} {why}" for why, n in self.dropped_here]

    def text(self) -> str:
        """"N frames lost in G gaps[ (b recorder queue full)], C CRC failures, [I implausible
        frames, ]R reconnects" (``gaitmon info``'s link line)."""
        here = f" ({', '.join(self._causes())})" if self.dropped_here else ""
        return (f"{count(self.frames_lost, 'frame')} lost in {count(self.gaps, 'gap')}{here}, "
                + self.units_text())

    def lost_text(self) -> str:
        """"N frames lost[ (a on the link, b receive queue full, c recorder queue full)]"
        (``gaitmon record``'s closing line)."""
        text = f"{count(self.frames_lost, 'frame')} lost"
        if not self.dropped_here:
            return text
        on_link = self.frames_lost - sum(n for _, n in self.dropped_here)
        parts = ([f"{on_link} on the link"] if on_link else []) + self._causes()
        return f"{text} ({', '.join(parts)})"

    def units_text(self) -> str:
        """What follows the frames lost: "C CRC failures, [I implausible frames, ]R reconnects"."""
        return (f"{count(self.crc_failures, 'CRC failure')}, "
                + implausible_text(self.implausible_frames)
                + count(self.reconnects, "reconnect"))


def run(args: argparse.Namespace) -> int:
    from gaitmon.analysis import analyse_session
    from gaitmon.finish import open_session
    from gaitmon.io.session import SessionError, journal_path
    from gaitmon.io.session.parts import is_bilateral

    if is_bilateral(args.file):
        return _run_units(args.file)
    interrupted = journal_path(args.file).exists()
    try:
        with (
            open_session(args.file, progress=progress_printer("recovering")) as s,
            damaged_file_guard(args.file),
        ):
            # (no cycles shown: the joint angles are read a slice at a time, not kept)
            an = analyse_session(s, keep_joints=False)
            print("\n".join(_lines(s, an, interrupted)))
    except SessionError as exc:
        raise UserError(str(exc)) from None
    return 0


def _lines(s: Session, an: SessionAnalysis, interrupted: bool) -> list[str]:
    fs = s.sample_rate_hz
    rows = an.rows
    summ = an.summary()
    state = "complete" if s.complete else ("recovered" if s.recovered else "incomplete")
    if s.recovery_not_saved:  # (a full disk): never said to be recovered, it is not saved
        state = (f"interrupted, not recovered: the recovery could not be saved "
                 f"({s.recovery_not_saved}); the journal is kept")
    elif interrupted and s.recovered:
        state += " (the recording was interrupted; recovered now from its journal)"
    mode = {"raw": "raw ADC, computed on the PC", "tilt": "the unit's tilts",
            "joint": "the unit's joint angles"}[s.mode]
    dev = s.device
    link = LinkCounts.of(s)
    lines = [
        f"{s.path.name}: gaitmon session, format {s.attrs.get('format_version')}, {state}",
        f"  recorded     {s.created_utc or 'date removed'}, {duration_text(s.duration_s)}, "
        f"{s.n_samples} frames at {fs:g} Hz, mode {s.mode} ({mode})",
        f"  patient      {s.meta.patient_id or '-'}   side {side_text(s.meta.side)}   "
        f"operator {s.meta.operator or '-'}",
    ]
    if s.meta.notes:
        lines.append(f"  notes        {s.meta.notes}")
    lines += [
        f"  device       {dev.get('name', '?')} firmware {dev.get('firmware', '?')} serial "
        f"{dev.get('serial') or '-'} via {dev.get('transport') or '-'}",
        f"  link         {link.text()}",
    ]
    reasons = Counter(r.excluded for r in rows if r.excluded)
    why = ", ".join(f"{n} {reason}" for reason, n in reasons.items())
    lines.append(
        f"  strides      {an.n_included} included, {an.n_excluded} excluded"
        + (f" ({why})" if why else "")
    )
    if summ.n_strides:
        sd = summ.stride_time_sd_s
        spread = "" if np.isnan(sd) else f" ± {sd:.2f} s (CV {summ.stride_time_cv_pct:.1f} %)"
        lines.append(
            f"  gait         stride time {summ.stride_time_mean_s:.2f} s{spread}, "
            f"stance {summ.stance_pct_mean:.1f} %, cadence "
            f"{summ.cadence_derived_steps_per_min:.0f} steps/min (derived), over the included "
            "strides"
        )
        sp = an.spatial()
        if sp.n_strides:
            cv = "" if np.isnan(sp.speed_cv_pct) else f" (CV {sp.speed_cv_pct:.1f} %)"
            lines.append(
                f"  spatial      stride length {sp.stride_length_mean_m:.2f} ± "
                f"{sp.stride_length_sd_m:.2f} m, gait speed {sp.speed_mean_m_s:.2f} ± "
                f"{sp.speed_sd_m_s:.2f} m/s{cv}, foot clearance "
                f"{sp.clearance_text()}, over {count(sp.n_strides, 'stride')} "
                "(foot IMU)"
            )
    elif no_gait_events(s.mode):
        lines.append(f"  gait         none: {no_gait_events(s.mode)}")
    else:
        lines.append(
            f"  gait         {count(len(s.heel_strike_idx), 'heel strike')}, "
            f"{count(len(rows), 'stride')}; too few to analyse"
        )
    if an.exclusions:
        k = len(an.exclusions)
        lines.append(
            f"  exclusions   {count(k, 'user-excluded range')} from "
            f"{an.side_file.name} ({an.n_user_excluded} strides left out)"
        )
    if an.problem:
        lines.append(f"  exclusions   {an.problem}")
    lines.append(f"  events       from {s.event_source}")
    if s.angle_source == "smoothed":
        lines.append(f"  angles       {s.angle_method} (zero-lag, analysed here); live view: "
                     f"{s.angle_method_of('live')}; zero: {s.zero_source}")  # fmt: skip
    else:
        lines.append(f"  angles       {s.angle_method}; zero: {s.zero_source}")
    c = s.config
    # a method that reads the Kalman settings is shown by them, the others by their label
    read = _settings_read(c.settings_read)
    kalman = (
        "Kalman " + " ".join(f"{st.short} {getattr(c, st.name):g}" for st in read)
        + f" ({c.kalman_form} form)"
        if read
        else c.tilt_method_label
    )
    lines.append(
        f"  settings     low-pass {c.cutoff_hz:g} Hz order {c.filter_order}, {kalman}, FSR "
        f"threshold {c.fsr_threshold:g} LSB; {len(s.config_changes)} changes during the recording"
    )
    off = np.degrees(s.calibration.tilt_offset_rad)
    zeroed = bool(np.any(off != 0)) or bool(s.calibration_changes)
    lines.append(
        "  calibration  "
        + (
            "standing offsets body/thigh/shank/foot "
            + " / ".join(num(v, 1, sign=True) for v in off)
            + f" deg; {count(len(s.calibration_changes), 'zeroing')} during the recording"
            if zeroed
            else "not zeroed (tilts relative to the sensor axes)"
        )
    )
    if s.markers:
        shown = ", ".join(f"{m.t_s:.1f} s {m.label!r}" for m in s.markers[:8])
        more = f" and {len(s.markers) - 8} more" if len(s.markers) > 8 else ""
        lines.append(f"  markers      {len(s.markers)}: {shown}{more}")
    for p in s.problems:
        lines.append(f"  note         {p}")
    return lines


def _settings_read(names: tuple[str, ...]) -> list[PipelineSetting]:
    """The settings (gaitmon.review.settings, in its order) a method reads; the settings'
    table is loaded only for such a method (the default reads none)."""
    if not names:
        return []
    from gaitmon.review.settings import PIPELINE_SETTINGS

    return [st for st in PIPELINE_SETTINGS if st.name in names]


def _run_units(path: str) -> int:
    """A session of both legs: its header, each leg as a one-unit session, and the two-leg
    measures (step time, stance / swing, double and single support, symmetry; docs/bilateral.md)."""
    from gaitmon.analysis import analyse_bilateral
    from gaitmon.finish.bilateral import missing_lines, open_bilateral
    from gaitmon.io.session import SessionError
    from gaitmon.io.session.parts import parts_of

    interrupted = bool(parts_of(path))
    try:
        with (
            open_bilateral(path, progress=progress_printer("recovering")) as b,
            damaged_file_guard(path),
        ):
            an = analyse_bilateral(b)
            out = _units_header_lines(b, interrupted)
            for side, unit in b.units.items():
                out.append(f"{'left' if side == 'L' else 'right'} leg ({side}):")
                out += ["  " + ln for ln in _lines(unit, an.sides[side], False)[1:]]
            out += _both_legs_lines(an, b.missing)
            for line in missing_lines(path, b.missing):
                print(f"gaitmon info: warning: {line}", file=sys.stderr)
            print("\n".join(out))
    except SessionError as exc:
        raise UserError(str(exc)) from None
    return 0


# ---- a session of both legs ----


def _f(v: float, digits: int, unit: str = "") -> str:
    return "-" if not np.isfinite(v) else f"{v:.{digits}f}{unit}"


def _units_header_lines(b: Bilateral, interrupted: bool) -> list[str]:
    from gaitmon.io.session.parts import SIDE_NAMES
    from gaitmon.values import scalar

    state = "complete" if b.complete else ("recovered" if b.recovered else "incomplete")
    if interrupted:
        state += " (the recording was interrupted; its parts recovered and combined now)"
    a = b.attrs
    legs = "both legs"
    if b.missing:
        legs = " and ".join(f"{SIDE_NAMES[s]} leg" for s in b.sides) + " only: " + " and ".join(
            f"the {SIDE_NAMES[s]} leg is missing" for s in b.missing)
    lines = [
        f"{b.path.name}: gaitmon bilateral session ({legs}), format "
        f"{a.get('format_version')}, {state}",
        f"  recorded     {a.get('created_utc') or 'date removed'}, "
        f"{duration_text(float(scalar(a.get('duration_s', 0.0))))} on the common time line, units "
        + " and ".join(f"{s} serial {b.unit(s).device.get('serial') or '-'}" for s in b.sides),
    ]
    lines += [f"  missing      {SIDE_NAMES[s]} leg ({s}): {why}" for s, why in b.missing.items()]
    ppm = ", ".join(
        f"{s} {(b.host_s_per_common_s / b.sync[s].mean_slope - 1.0) * 1e6:+.1f}" for s in b.sides
    )
    delay = ", ".join(f"{s} {_f(b.sync[s].residual_p95_ms, 1)}" for s in b.sides)
    lines.append(
        f"  clocks       {ppm} ppm against the common time line "
        f"({count(len(b.sync[b.sides[0]].x0_s), 'segment')}); receive delay above the fit, "
        f"p95: {delay} ms"
    )
    # the clock fits' warning and a brief time together (one wording: finish.bilateral.caveats)
    lines += [f"  {c.key:<12s} {c.text}" for c in b.caveats()]
    return lines


def _both_legs_lines(an: BilateralAnalysis, missing: Iterable[str] = ()) -> list[str]:
    from gaitmon.io.session.parts import SIDE_NAMES

    g = an.gait
    lines = ["both legs (on the common time line; each side's excluded strides left out):"]
    gone = [f"the {SIDE_NAMES[s]} leg" for s in missing]
    if gone:
        lines.append(f"  gait         {' and '.join(gone)} is missing: no bilateral measures")
        return lines
    n = {s.side: int(np.isfinite(s.stride_s).sum()) for s in (g.left, g.right)}
    if not (n["L"] and n["R"]):
        lines.append("  gait         too few strides on both legs to compare")
        return lines
    lines.append(
        f"  cadence      {_f(g.cadence_steps_min, 0)} steps/min (measured: both legs' steps); "
        f"strides L {n['L']}, R {n['R']}"
    )
    sides = (("L", g.left), ("R", g.right))
    lines.append(
        "  step time    " + ", ".join(f"{s} {_f(sg.mean('step_s'), 3, ' s')}" for s, sg in sides)
    )

    def pct(measure: str) -> str:
        parts = []
        for s, sg in sides:
            parts.append(
                f"{s} {_f(sg.pct_mean(measure), 1, ' %')} ({_f(sg.mean(measure), 3, ' s')})"
            )
        return ", ".join(parts)

    lines.append(f"  stance       {pct('stance_s')} of the stride")
    lines.append(f"  swing        {pct('swing_s')}")
    lines.append(f"  double supp. initial {pct('initial_double_support_s')}")
    lines.append(f"               terminal {pct('terminal_double_support_s')}")
    lines.append(f"  single supp. {pct('single_support_s')}")
    from gaitmon.dsp.bilateral import MEASURE_LABELS

    lines.append("  symmetry     measure                   left      right     SR (L/R)  SI")
    for row in g.symmetry:
        lines.append(
            f"               {MEASURE_LABELS[row.measure]:<25s} {_f(row.left, 3, ' s'):<9s} "
            f"{_f(row.right, 3, ' s'):<9s} {_f(row.ratio, 3):<9s} {_f(row.index_pct, 1, ' %')}"
        )
    lines.append(
        "               SR = left / right of the means (1 symmetric); SI = 2 |L - R| / (L + R)"
        " (0 % symmetric)"
    )
    return lines

