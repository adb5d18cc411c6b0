"""The report's content laid out on A4 pages: :func:`paint_report` and one function per
section (title, header grid, cycle plots, summary and stride statistics; then session notes,
data quality with every gap and excluded range, markers, settings and conventions, and the
clinician's comments), with the key-value rows and tables they are made of.

The head of page 1 has a fixed size: each of its sections draws from its top ``y`` (mm) and
returns the ``y`` below it. The rest is a flow of blocks (:mod:`~gaitmon.ui.report_pdf.flow`)
that continues on further pages when it does not fit, so nothing is ever cut short; every page
has the footer ("page k of n") and a continuation page a one-line header.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor, QPaintDevice, QPainter

from gaitmon.analysis import FIRST, GAP, LAST, MAX_GAP_S, SETTLING, USER
from gaitmon.dsp.pipeline import SETTLE_S
from gaitmon.normative import CAVEAT, DEVIATION_LABEL, NormativeBands
from gaitmon.report import JOINT_TITLES, GapSpan, ReportData, ReportHeader
from gaitmon.text import count, duration_text, no_gait_events
from gaitmon.ui.report_pdf import flow
from gaitmon.ui.report_pdf.cycle_plot import MAX_FAINT_STRIDES, draw_cycle_plot
from gaitmon.ui.report_pdf.flow import Block, TableColumn
from gaitmon.ui.report_pdf.page import (
    ACCENT,
    INK,
    MARGIN_MM,
    MUTED,
    NORM,
    NORM_EDGE,
    NORM_MEAN,
    PAGE_H_MM,
    PAGE_W_MM,
    RULE,
    SHADE,
    Page,
    fmt,
    fmt_pm,
    fmt_stat,
)

# the text column every section spans
LEFT_MM, RIGHT_MM = MARGIN_MM, PAGE_W_MM - MARGIN_MM
WIDTH_MM = RIGHT_MM - LEFT_MM
FOOTER_MM = PAGE_H_MM - 12.0  # the footer's rule; nothing else is drawn below FOOTER_MM - 2
CONTINUED_TOP_MM = 22.0  # where the flow starts on a continuation page
# Lists longer than this are not written out one by one (an 8-hour session with 2 % random
# loss has ~60 000 one-frame gaps: hundreds of pages); the report then says how many more there
# are and what they add up to.
MAX_LISTED = 400


def kv_rows(
    p: Page,
    x: float,
    y: float,
    w: float,
    rows: Sequence[tuple[str, str]],
    label_w: float,
    row_h: float = 4.9,
    size_pt: float = 8.0,
) -> float:
    for k, (label, value) in enumerate(rows):
        if k % 2 == 0:
            p.fill(x, y + k * row_h, w, row_h, SHADE)
        p.text(x + 1.2, y + k * row_h, label_w, row_h, label, size_pt - 0.5, colour=MUTED)
        p.text(x + 1.2 + label_w, y + k * row_h, w - label_w - 2.4, row_h, value, size_pt)
    return y + len(rows) * row_h


def table(
    p: Page,
    x: float,
    y: float,
    widths: Sequence[float],
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    row_h: float = 4.9,
) -> float:
    right = Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter
    cx = x
    for k, (wcol, h) in enumerate(zip(widths, header, strict=True)):
        p.text(
            cx + 1.2,
            y,
            wcol - 2.4,
            row_h,
            h,
            7.0,
            bold=True,
            colour=MUTED,
            align=right if k else Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter,
        )
        cx += wcol
    total = float(sum(widths))
    p.hline(x, x + total, y + row_h, RULE, 0.25)
    y += row_h + 0.3
    for r, row in enumerate(rows):
        if r % 2 == 1:
            p.fill(x, y, total, row_h, SHADE)
        cx = x
        for k, (wcol, cell) in enumerate(zip(widths, row, strict=True)):
            p.text(
                cx + 1.2,
                y,
                wcol - 2.4,
                row_h,
                cell,
                8.0,
                bold=(k == 0),
                align=right if k else Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter,
            )
            cx += wcol
        y += row_h
    return y


def paint_report(
    painter: QPainter,
    device: QPaintDevice,
    data: ReportData,
    new_page: Callable[[], object] | None = None,
) -> Page:
    """Draw the report on ``device`` (its full area is one A4 page).

    ``new_page`` starts the next page of a multi-page device (``QPdfWriter.newPage``); without
    it only the first page is drawn (an image preview). Returns the :class:`Page` (its
    ``boxes`` record where each text went; the number of pages is ``n_pages``)."""
    p = Page(painter, device, device.width() / PAGE_W_MM)
    painter.setRenderHint(QPainter.RenderHint.TextAntialiasing, True)
    painter.fillRect(p.rect(0, 0, PAGE_W_MM, PAGE_H_MM), QColor("#ffffff"))
    y = title(p, data.software, data.generated_utc, "one leg")
    y = header_grid(p, header_cells(data.header), y)
    y = _cycle_plots(p, data, y)
    y = _summary_and_stride_statistics(p, data, y)
    blocks = [
        *session_notes(p, data),
        *data_quality(p, data),
        *markers(p, data),
        *settings_and_conventions(p, data),
        comments_block(p),
    ]
    bottom = FOOTER_MM - 3.0
    pages = flow.paginate(blocks, y, CONTINUED_TOP_MM, bottom)
    flow.paint_pages(p, pages, new_page, lambda: continued(p, data.header),
                     lambda k, n: footer(p, k, n))
    return p


def continued(p: Page, h: ReportHeader) -> None:
    """The head of a continuation page: whose report it is."""
    who = h.patient_id or "no patient ID"
    p.text(LEFT_MM, 11.0, WIDTH_MM * 0.6, 6.0, "Gait analysis report (continued)", 11.0,
           bold=True, colour=ACCENT)  # fmt: skip
    p.text(LEFT_MM + WIDTH_MM * 0.5, 11.5, WIDTH_MM * 0.5, 4.0,
           f"{who} · recorded {h.recorded_utc or 'unknown'}", 7.5, colour=MUTED,
           align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)  # fmt: skip
    p.hline(LEFT_MM, RIGHT_MM, 18.0, ACCENT, 0.6)


def title(p: Page, software: str, generated_utc: str, what: str) -> float:
    """The report's title line: ``what`` is "one leg" or "both legs"."""
    y = 11.0
    p.text(LEFT_MM, y, WIDTH_MM * 0.6, 8.0, "Gait analysis report", 16.0, bold=True, colour=ACCENT)
    p.text(
        LEFT_MM + WIDTH_MM * 0.5,
        y + 0.6,
        WIDTH_MM * 0.5,
        4.0,
        f"wearable sagittal gait unit{'s' if what == 'both legs' else ''} · {what}",
        7.5,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )
    p.text(
        LEFT_MM + WIDTH_MM * 0.5,
        y + 4.2,
        WIDTH_MM * 0.5,
        4.0,
        f"{software} · report {generated_utc}" if generated_utc else f"{software} · report",
        7.0,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )
    y += 9.5
    p.hline(LEFT_MM, RIGHT_MM, y, ACCENT, 0.6)
    return y + 2.5


def header_cells(h: ReportHeader) -> list[tuple[str, str]]:
    """Who, when and how was recorded: the identifier only, never a name."""
    cells = [
        ("PATIENT ID", h.patient_id or "not recorded"),
        ("SIDE MEASURED", h.side),  # text.side_text: as gaitmon info says it
        ("RECORDED", h.recorded_utc or "unknown"),
        ("OPERATOR", h.operator or "not recorded"),
        ("DURATION", f"{duration_text(h.duration_s)} ({h.n_samples} frames at "
                     f"{h.sample_rate_hz:g} Hz)"),
        (
            "MODE",
            {
                "raw": "raw sensors (PC pipeline)",
                "tilt": "the unit's tilts",
                "joint": "the unit's joint angles",
            }.get(h.mode, h.mode),
        ),
        ("DEVICE", h.device),
        ("FILE", h.file_name or ("withheld (de-identified)" if h.deidentified else "–")),
        ("RECORDING", h.state + (" · de-identified report" if h.deidentified else "")),
    ]
    return cells


def header_grid(p: Page, cells: Sequence[tuple[str, str]], y: float) -> float:
    """The header's nine cells, three to a row; the first two in large type."""
    col_w = WIDTH_MM / 3
    p.fill(LEFT_MM, y, WIDTH_MM, 3 * 8.6 + 1.0, SHADE)
    for k, (label, value) in enumerate(cells):
        cx = LEFT_MM + (k % 3) * col_w + 2.0
        cy = y + 0.8 + (k // 3) * 8.6
        p.text(cx, cy, col_w - 4.0, 3.4, label, 6.0, bold=True, colour=MUTED)
        big = k in (0, 1)
        p.fitted(cx, cy + 3.4, col_w - 4.0, 4.6, value, 10.0 if big else 8.0, bold=big)
    y += 3 * 8.6 + 1.0 + 4.0
    return y


def _cycle_plots(p: Page, data: ReportData, y: float) -> float:
    y = p.section(LEFT_MM, y, WIDTH_MM, "Joint kinematics over the gait cycle")
    n = data.n_included
    drawn = (
        "individual strides faint"
        if n <= MAX_FAINT_STRIDES
        else f"{MAX_FAINT_STRIDES} of them, evenly chosen, drawn faint"
    )
    sub = (
        f"Mean ± 1 SD of {n} included strides (blue band), {drawn}; dashed "
        f"line: mean toe off at {fmt(data.toe_off_pct)} % of the cycle."
        if n
        else f"No gait events: {no_gait_events(data.header.mode)}."
        if no_gait_events(data.header.mode)
        else "No included strides: nothing to average."
    )
    y += p.wrapped(LEFT_MM, y, WIDTH_MM, sub, 7.5, colour=MUTED) + 1.2
    gap = 5.0
    pw = (WIDTH_MM - 2 * gap) / 3
    ph = 68.0 if data.normative is None else 62.0  # room for the band's caption below
    for j in range(3):
        draw_cycle_plot(p, data, j, LEFT_MM + j * (pw + gap), y, pw, ph)
    y += ph + 5.0
    if data.normative is not None:
        y += _reference_lines(p, data, y) + 3.0
    return y


def _reference_lines(p: Page, data: ReportData, y: float) -> float:
    """Under the cycle plots: which band is drawn, and what it cannot tell (gaitmon's angles
    are not a marker lab's). Returns the height used (mm)."""
    nb = data.normative
    assert nb is not None
    # the legend key, then its entry and what it cannot tell, wrapped beside it
    normal_legend(p, LEFT_MM + 1.0, y - 1.0, "", key_only=True)
    text = (f"{normal_legend_text(nb.label)}: amber band and solid line (source and licence: "
            f"see Settings). Caveat: {CAVEAT}.")  # fmt: skip
    return p.wrapped(LEFT_MM + 10.5, y - 1.0, WIDTH_MM - 10.5, text, 7.0, colour=MUTED) - 1.0


def normal_legend_text(label: str) -> str:
    return f"normal mean ± 1 SD ({label})"


def normal_legend(p: Page, x: float, y: float, label: str, *, key_only: bool = False) -> None:
    """The normal band's legend key (band, edges and solid mean, 8 x 3 mm) and its entry
    "normal mean ± 1 SD (name)", on one line from ``y``."""
    p.fill(x, y + 0.5, 8.0, 3.0, NORM)
    p.hline(x, x + 8.0, y + 0.5, NORM_EDGE, 0.15)
    p.hline(x, x + 8.0, y + 3.5, NORM_EDGE, 0.15)
    p.hline(x, x + 8.0, y + 2.0, NORM_MEAN, 0.35)
    if key_only:
        return
    p.text(x + 9.5, y, WIDTH_MM - (x - LEFT_MM) - 10.0, 4.0, normal_legend_text(label), 7.5,
           colour=INK)  # fmt: skip


def summary_rows(data: ReportData, *, derived_cadence: bool = True) -> list[tuple[str, str]]:
    """The gait summary's lines (the derived cadence left out where it is measured)."""
    s = data.summary
    n_all = len(data.rows)
    cv = f" (CV {fmt(s.stride_time_cv_pct)} %)" if np.isfinite(s.stride_time_cv_pct) else ""
    rows = [
        ("Strides analysed", f"{s.n_strides} of {n_all} ({n_all - s.n_strides} excluded)"),
        ("Stride time", fmt_pm(s.stride_time_mean_s, s.stride_time_sd_s, 2, "s") + cv),
        (
            "Cadence (derived)",
            f"{fmt(s.cadence_derived_steps_per_min, 0)} steps/min (from stride time)",
        ),
        ("Stance / swing", f"{fmt(s.stance_pct_mean)} % / {fmt(s.swing_pct_mean)} % of the cycle"),
        ("Stance / swing time",
         f"{fmt_stat(data.stance_time, 2, 's')} / {fmt_stat(data.swing_time, 2, 's')}"),
    ]  # fmt: skip
    if not derived_cadence:
        del rows[2]
    sp = data.spatial
    if sp is not None and sp.n_strides:
        rows.append((
            "Stride length, speed",
            f"{fmt_pm(sp.stride_length_mean_m, sp.stride_length_sd_m, 2, 'm')}, "
            f"{fmt_pm(sp.speed_mean_m_s, sp.speed_sd_m_s, 2, 'm/s')}",
        ))  # fmt: skip
        rows.append(("Foot clearance", sp.clearance_text()))
    return rows


def joint_statistics(p: Page, data: ReportData, x: float, y: float, w: float,
                     note: bool = True) -> float:  # fmt: skip
    """Per-joint ROM, maximum and minimum (and the deviation from the band, if one is drawn),
    the peak knee flexion in swing and (``note``) what ROM means; returns the y below."""
    header: tuple[str, ...] = ("Joint", "ROM", "Maximum", "Minimum")
    widths: tuple[float, ...] = (w * 0.22, w * 0.26, w * 0.26, w * 0.26)
    table_rows: list[tuple[str, ...]] = [
        (JOINT_TITLES[j], fmt_stat(data.rom[j]), fmt_stat(data.peak[j]), fmt_stat(data.trough[j]))
        for j in range(3)
    ]
    band = data.normative
    if band is not None:  # the deviation from the band: one more column, no more height
        header += ("Dev.*",)
        widths = (w * 0.14, w * 0.24, w * 0.24, w * 0.24, w * 0.14)
        table_rows = [(*r, fmt(float(data.deviation_deg[j])))
                      for j, r in enumerate(table_rows)]  # fmt: skip
    y = table(p, x, y, widths, header, table_rows)
    y += 1.0
    y = kv_rows(p, x, y, w, [("Peak knee flexion in swing", fmt_stat(data.knee_peak_swing, 1,
                                                                       "deg"))], label_w=40.0)
    if note:
        y += 0.6
        y += p.wrapped(x, y, w, rom_note(band), 6.5, colour=MUTED)
    return y


def rom_note(band: NormativeBands | None) -> str:
    return ("ROM = maximum − minimum within each stride; maximum and minimum from the "
            "time-normalised stride."
            + ("" if band is None else
               f" *{DEVIATION_LABEL[0].upper()}{DEVIATION_LABEL[1:]}: RMS distance of the mean "
               f"cycle from the mean of {band.label}."))  # fmt: skip


def _summary_and_stride_statistics(p: Page, data: ReportData, y: float) -> float:
    """Two columns: the gait summary, and per-joint stride statistics."""
    colw = (WIDTH_MM - 8.0) / 2
    xa, xb = LEFT_MM, LEFT_MM + colw + 8.0
    ya = p.section(xa, y, colw, "Summary")
    yb = p.section(xb, y, colw, "Stride statistics (deg, mean ± SD)")
    ya = kv_rows(p, xa, ya, colw, summary_rows(data), label_w=29.0)
    yb = joint_statistics(p, data, xb, yb, colw)
    return max(ya, yb) + 5.0


def session_notes(p: Page, data: ReportData) -> list[Block]:
    """The notes typed in the record form, in full."""
    if not data.session_notes:
        return []
    return [
        flow.heading(p, LEFT_MM, WIDTH_MM, "Session notes"),
        *flow.paragraph(p, LEFT_MM + 1.2, WIDTH_MM - 2.4, data.session_notes, 8.0),
        flow.gap(3.0),
    ]


def _link_line(data: ReportData) -> str:
    lo = data.losses
    link = (
        f"{count(lo.frames_lost, 'frame')} lost in {count(lo.n_gaps, 'gap')}"
        + (f" (longest {fmt(lo.longest_gap_s, 2)} s)" if lo.n_gaps else "")
        + f"; {count(lo.outages, 'link outage')}"
        + (f" ({fmt(lo.outage_s)} s in total)" if lo.outages else "")
        + f"; {count(lo.crc_failures, 'CRC failure')}; {count(lo.reconnects, 'reconnect')}"
    )
    if lo.queue_overflow_frames:
        link += f"; {count(lo.queue_overflow_frames, 'frame')} dropped by a full queue"
    if lo.invalid_values:
        link += f"; {count(lo.invalid_values, 'invalid value')}"
    if lo.implausible_frames:
        link += f"; {count(lo.implausible_frames, 'implausible frame')}"
    return link


def data_quality(
    p: Page, data: ReportData, title: str = "Data quality: gaps, losses and exclusions"
) -> list[Block]:
    """Gaps, losses and exclusions: the counts, then every gap and excluded range."""
    lo = data.losses
    names = {
        FIRST: "first stride (start-up)",
        LAST: "last stride (stopping)",
        GAP: f"crosses a gap > {1000 * MAX_GAP_S:.0f} ms",
        SETTLING: f"filters settling after a gap ({SETTLE_S:g} s)",
        USER: "in a range excluded by the user",
    }
    excl = ", ".join(f"{names.get(k, k)}: {v}" for k, v in lo.excluded.items()) or "none"
    rows = [("Link", _link_line(data)), ("Strides excluded", excl)]
    if data.excluded_spans:
        rows.append(("Excluded ranges", f"{count(len(data.excluded_spans), 'range')} chosen "
                     "in review (listed below)"))  # fmt: skip
    rows += [("Note", note) for note in (*data.notes, *lo.problems)]
    blocks = [flow.heading(p, LEFT_MM, WIDTH_MM, title)]
    for k, (label, value) in enumerate(rows):
        blocks += flow.kv_row(p, LEFT_MM, WIDTH_MM, label, value, shaded=k % 2 == 0)
    blocks += _gap_list(p, data)
    blocks += _excluded_list(p, data)
    blocks.append(flow.gap(3.0))
    return blocks


def _longest_first(items: Sequence[GapSpan]) -> tuple[list[GapSpan], list[GapSpan]]:
    """(listed, left out): the MAX_LISTED longest, in time order, and the rest."""
    if len(items) <= MAX_LISTED:
        return list(items), []
    order = sorted(range(len(items)), key=lambda i: -items[i].duration_s)
    keep = set(order[:MAX_LISTED])
    return ([g for i, g in enumerate(items) if i in keep],
            [g for i, g in enumerate(items) if i not in keep])  # fmt: skip


def _gap_list(p: Page, data: ReportData) -> list[Block]:
    """Every gap: outages (longer than MAX_GAP_S) in a table, short losses grouped by size."""
    if not data.gaps:
        return []
    long = [g for g in data.gaps if g.duration_s > MAX_GAP_S + 1e-9]
    short = [g for g in data.gaps if g.duration_s <= MAX_GAP_S + 1e-9]
    blocks: list[Block] = [flow.gap(1.5)]
    if long:
        listed, rest = _longest_first(long)
        blocks.append(flow.subheading(LEFT_MM, WIDTH_MM,
                                      f"Gaps longer than {1000 * MAX_GAP_S:.0f} ms (lost data)"))
        cols = (TableColumn("from (s)", 22.0, True), TableColumn("to (s)", 22.0, True),
                TableColumn("duration (s)", 24.0, True), TableColumn("frames lost", 22.0, True),
                TableColumn("cause", WIDTH_MM - 90.0))  # fmt: skip
        blocks += flow.table(p, LEFT_MM, cols, [
            (fmt(g.from_s, 2), fmt(g.to_s, 2), fmt(g.duration_s, 2), str(g.n_lost), g.reason)
            for g in listed
        ])  # fmt: skip
        if rest:
            blocks += flow.paragraph(
                p, LEFT_MM + 1.2, WIDTH_MM - 2.4,
                f"{count(len(rest), 'shorter gap')} of more than {1000 * MAX_GAP_S:.0f} ms "
                f"({fmt(sum(g.duration_s for g in rest), 2)} s in total) are not listed one by "
                "one; the review window shades every gap.", 7.5, colour=MUTED)  # fmt: skip
        blocks.append(flow.gap(1.5))
    if short:
        blocks.append(flow.subheading(
            LEFT_MM, WIDTH_MM,
            f"Short gaps (up to {1000 * MAX_GAP_S:.0f} ms each; strides across them are kept)"))
        sizes = sorted({g.n_lost for g in short})
        left = MAX_LISTED
        for n in sizes:
            of_size = [g for g in short if g.n_lost == n]
            shown = of_size[: max(0, left)]
            left -= len(shown)
            dur = of_size[0].duration_s
            if not shown:  # the list's room is spent: this size only counted
                text = (f"{count(len(of_size), 'gap')} of {count(n, 'frame')} "
                        f"({fmt(1000 * dur, 0)} ms) each ({fmt(len(of_size) * dur, 2)} s in "
                        "total), not listed one by one")  # fmt: skip
            else:
                text = (f"{count(n, 'frame')} ({fmt(1000 * dur, 0)} ms) lost at "
                        + ", ".join(fmt(g.from_s, 2) for g in shown) + " s")  # fmt: skip
            if shown and len(shown) < len(of_size):
                more = len(of_size) - len(shown)
                text += (f"; and {count(more, 'more gap')} of this size "
                         f"({fmt(more * dur, 2)} s in total), not listed one by one")  # fmt: skip
            blocks += flow.paragraph(p, LEFT_MM + 1.2, WIDTH_MM - 2.4, text, 7.0, after_mm=0.6)
    return blocks


def _excluded_list(p: Page, data: ReportData) -> list[Block]:
    if not data.excluded_spans:
        return []
    cols = (TableColumn("from (s)", 22.0, True), TableColumn("to (s)", 22.0, True),
            TableColumn("strides left out", 26.0, True),
            TableColumn("reason", WIDTH_MM - 70.0))  # fmt: skip
    return [
        flow.gap(1.5),
        flow.subheading(LEFT_MM, WIDTH_MM, "Ranges excluded in review"),
        *flow.table(
            p,
            LEFT_MM,
            cols,
            [
                (fmt(e.from_s, 2), fmt(e.to_s, 2), str(e.n_strides), e.reason)
                for e in data.excluded_spans
            ],
        ),
    ]


def markers(p: Page, data: ReportData, title: str = "Markers") -> list[Block]:
    """Every marker, time and label, in two columns (read across)."""
    if not data.markers:
        return []
    half = (WIDTH_MM - 6.0) / 2
    cols = (TableColumn("time (s)", 20.0, True), TableColumn("label", half - 20.0),
            TableColumn("", 6.0),
            TableColumn("time (s)", 20.0, True), TableColumn("label", half - 20.0))  # fmt: skip
    ms = list(data.markers)
    rows = []
    for k in range(0, len(ms), 2):
        a = ms[k]
        b = ms[k + 1] if k + 1 < len(ms) else None
        rows.append((fmt(a.t_s, 2), a.label or "(no label)", "",
                     fmt(b.t_s, 2) if b else "", (b.label or "(no label)") if b else ""))
    return [
        flow.heading(p, LEFT_MM, WIDTH_MM, f"{title} ({len(ms)})"),
        *flow.table(p, LEFT_MM, cols, rows),
        flow.gap(3.0),
    ]


def settings_and_conventions(
    p: Page, data: ReportData, settings: Sequence[tuple[str, str]] | None = None,
    conventions: Sequence[str] | None = None,
) -> list[Block]:  # fmt: skip
    """The settings and conventions (``data``'s unless given) and the reference band."""
    blocks = [flow.heading(p, LEFT_MM, WIDTH_MM, "Settings and conventions in force")]
    rows = list(data.settings if settings is None else settings)
    conv = data.conventions if conventions is None else conventions
    rows += [("Conventions" if k == 0 else "", line) for k, line in enumerate(conv)]
    if data.normative is not None:
        nb = data.normative
        rows.append(("Reference band", f"{nb.label}; source: {nb.source}; licence: {nb.licence}"))
    for label, value in rows:
        blocks += flow.kv_row(p, LEFT_MM, WIDTH_MM, label, value, size_pt=7.0)
    return blocks


# the comments box's least height: 3 mm space, the heading (6.6 mm) and a box of at least 9 mm
# with its signature line (the flow keeps 3 mm above the footer's rule, the box 4 mm)
COMMENTS_MIN_MM = 3.0 + 6.6 + 10.0


def comments_block(p: Page) -> Block:
    """The clinician's comments as the flow's last block: always there, on the last page, and
    on a page of its own only when :data:`COMMENTS_MIN_MM` does not fit below the rest; the
    box reaches down to the footer."""
    return Block(COMMENTS_MIN_MM, lambda p_, y: comments(p_, y))


def comments(p: Page, y: float) -> None:
    """The clinician's comments, from ``y`` down to the footer of the page."""
    painter = p.p
    fy = FOOTER_MM
    y += 3.0
    y = p.section(LEFT_MM, y, WIDTH_MM, "Clinician's comments")
    painter.setPen(p.pen(RULE, 0.2))
    painter.setBrush(Qt.BrushStyle.NoBrush)
    painter.drawRect(p.rect(LEFT_MM, y, WIDTH_MM, fy - 4.0 - y))
    p.text(
        LEFT_MM + WIDTH_MM - 62.0,
        fy - 10.0,
        60.0,
        4.0,
        "signature / date: ____________________",
        7.0,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )


def footer(p: Page, page: int, n_pages: int) -> None:
    fy = FOOTER_MM
    p.hline(LEFT_MM, RIGHT_MM, fy, RULE, 0.25)
    p.text(
        LEFT_MM,
        fy + 0.8,
        WIDTH_MM * 0.8,
        4.0,
        "Sagittal-plane angles from body-worn inertial sensors; for review by a clinician "
        "alongside the full recording.",
        6.5,
        colour=MUTED,
    )
    p.text(
        LEFT_MM + WIDTH_MM * 0.8,
        fy + 0.8,
        WIDTH_MM * 0.2,
        4.0,
        f"page {page + 1} of {n_pages}",
        6.5,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )
