"""The report's content laid out on the A4 page: :func:`paint_report` and one function per
section of the page (title, header grid, cycle plots, summary and stride statistics, data
quality, settings and conventions, footer with the clinician's comments), with the key-value
rows and tables they are made of.

Each section draws from its top ``y`` (mm) across the text column and returns the ``y`` below
it, so the sections stack in order and the page stays one page.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor, QPaintDevice, QPainter

from gaitmon.analysis import FIRST, GAP, LAST, USER
from gaitmon.report import JOINT_TITLES, ReportData, ReportHeader
from gaitmon.ui.report_pdf.cycle_plot import MAX_FAINT_STRIDES, draw_cycle_plot
from gaitmon.ui.report_pdf.page import (
    ACCENT,
    MARGIN_MM,
    MUTED,
    PAGE_H_MM,
    PAGE_W_MM,
    RULE,
    SHADE,
    Page,
    cut,
    fmt,
    fmt_pm,
    fmt_stat,
)

# the text column every section spans
LEFT_MM, RIGHT_MM = MARGIN_MM, PAGE_W_MM - MARGIN_MM
WIDTH_MM = RIGHT_MM - LEFT_MM


def _kv_rows(
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


def _table(
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


def paint_report(painter: QPainter, device: QPaintDevice, data: ReportData) -> None:
    """Draw the whole A4 page on ``device`` (its full area is the page)."""
    p = Page(painter, device, device.width() / PAGE_W_MM)
    painter.setRenderHint(QPainter.RenderHint.TextAntialiasing, True)
    painter.fillRect(p.rect(0, 0, PAGE_W_MM, PAGE_H_MM), QColor("#ffffff"))
    y = _title(p, data)
    y = _header_grid(p, data.header, y)
    y = _cycle_plots(p, data, y)
    y = _summary_and_stride_statistics(p, data, y)
    y = _data_quality(p, data, y)
    y = _settings_and_conventions(p, data, y)
    _footer(p, y)


def _title(p: Page, data: ReportData) -> float:
    y = 11.0
    p.text(LEFT_MM, y, WIDTH_MM * 0.6, 8.0, "Gait analysis report", 16.0, bold=True, colour=ACCENT)
    p.text(
        LEFT_MM + WIDTH_MM * 0.5,
        y + 0.6,
        WIDTH_MM * 0.5,
        4.0,
        "wearable sagittal gait unit · one leg",
        7.5,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )
    p.text(
        LEFT_MM + WIDTH_MM * 0.5,
        y + 4.2,
        WIDTH_MM * 0.5,
        4.0,
        f"{data.software} · report {data.generated_utc}",
        7.0,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )
    y += 9.5
    p.hline(LEFT_MM, RIGHT_MM, y, ACCENT, 0.6)
    return y + 2.5


def _header_grid(p: Page, h: ReportHeader, y: float) -> float:
    """Who, when and how was recorded: the identifier only, never a name."""
    side = {"left": "Left", "right": "Right"}.get(h.side, "not recorded")
    cells = [
        ("PATIENT ID", h.patient_id or "not recorded"),
        ("SIDE MEASURED", side),
        ("RECORDED", h.recorded_utc or "unknown"),
        ("OPERATOR", h.operator or "not recorded"),
        ("DURATION", f"{h.duration_s:.1f} s ({h.n_samples} frames at {h.sample_rate_hz:g} Hz)"),
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
    col_w = WIDTH_MM / 3
    p.fill(LEFT_MM, y, WIDTH_MM, 3 * 8.6 + 1.0, SHADE)
    for k, (label, value) in enumerate(cells):
        cx = LEFT_MM + (k % 3) * col_w + 2.0
        cy = y + 0.8 + (k // 3) * 8.6
        p.text(cx, cy, col_w - 4.0, 3.4, label, 6.0, bold=True, colour=MUTED)
        big = k in (0, 1)
        p.text(cx, cy + 3.4, col_w - 4.0, 4.6, value, 10.0 if big else 8.0, bold=big)
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
        else "No included strides: nothing to average."
    )
    if data.normative is not None:
        sub += f" Grey band: reference ± 1 SD ({data.normative.label})."
    y += p.wrapped(LEFT_MM, y, WIDTH_MM, sub, 7.5, colour=MUTED) + 1.2
    gap = 5.0
    pw = (WIDTH_MM - 2 * gap) / 3
    ph = 74.0
    for j in range(3):
        draw_cycle_plot(p, data, j, LEFT_MM + j * (pw + gap), y, pw, ph)
    return y + (ph + 5.0)


def _summary_and_stride_statistics(p: Page, data: ReportData, y: float) -> float:
    """Two columns: the gait summary, and per-joint stride statistics."""
    colw = (WIDTH_MM - 8.0) / 2
    xa, xb = LEFT_MM, LEFT_MM + colw + 8.0
    ya = p.section(xa, y, colw, "Summary")
    yb = p.section(xb, y, colw, "Stride statistics (deg, mean ± SD)")
    s = data.summary
    n_all = len(data.rows)
    cv = f" (CV {fmt(s.stride_time_cv_pct)} %)" if np.isfinite(s.stride_time_cv_pct) else ""
    summary_rows = [
        ("Strides analysed", f"{s.n_strides} of {n_all} ({n_all - s.n_strides} excluded)"),
        ("Stride time", fmt_pm(s.stride_time_mean_s, s.stride_time_sd_s, 2, "s") + cv),
        (
            "Cadence (derived)",
            f"{fmt(s.cadence_derived_steps_per_min, 0)} steps/min (from stride time)",
        ),
        ("Stance / swing", f"{fmt(s.stance_pct_mean)} % / {fmt(s.swing_pct_mean)} % of the cycle"),
        ("Stance time", fmt_stat(data.stance_time, 2, "s")),
        ("Swing time", fmt_stat(data.swing_time, 2, "s")),
    ]
    ya = _kv_rows(p, xa, ya, colw, summary_rows, label_w=29.0)
    header = ("Joint", "ROM", "Maximum", "Minimum")
    widths = (colw * 0.22, colw * 0.26, colw * 0.26, colw * 0.26)
    table_rows = [
        (JOINT_TITLES[j], fmt_stat(data.rom[j]), fmt_stat(data.peak[j]), fmt_stat(data.trough[j]))
        for j in range(3)
    ]
    yb = _table(p, xb, yb, widths, header, table_rows)
    yb += 1.0
    yb = _kv_rows(
        p,
        xb,
        yb,
        colw,
        [("Peak knee flexion in swing", fmt_stat(data.knee_peak_swing, 1, "deg"))],
        label_w=40.0,
    )
    yb += 0.6
    yb += p.wrapped(
        xb,
        yb,
        colw,
        "ROM = maximum − minimum within each stride; maximum and "
        "minimum from the time-normalised stride.",
        6.5,
        colour=MUTED,
    )
    return max(ya, yb) + 5.0


def _data_quality(p: Page, data: ReportData, y: float) -> float:
    """Gaps, losses and exclusions."""
    y = p.section(LEFT_MM, y, WIDTH_MM, "Data quality: gaps, losses and exclusions")
    lo = data.losses
    link = (
        f"{lo.frames_lost} frames lost in {lo.n_gaps} gaps"
        + (f" (longest {lo.longest_gap_s:.2f} s)" if lo.n_gaps else "")
        + f"; {lo.outages} link outage{'s' if lo.outages != 1 else ''}"
        + (f" ({lo.outage_s:.1f} s in total)" if lo.outages else "")
        + f"; {lo.crc_failures} CRC failures; {lo.reconnects} reconnects"
    )
    if lo.queue_overflow_frames:
        link += f"; {lo.queue_overflow_frames} frames dropped by a full queue"
    names = {
        FIRST: "first stride (start-up)",
        LAST: "last stride (stopping)",
        GAP: "crosses a gap > 50 ms",
        USER: "in a range excluded by the user",
    }
    excl = ", ".join(f"{names.get(k, k)} {v}" for k, v in lo.excluded.items()) or "none"
    rows = [("Link", link), ("Strides excluded", excl)]
    if lo.excluded_ranges:
        rows.append(("Excluded ranges", f"{len(lo.excluded_ranges)} range(s) chosen in review"))
    notes = [*data.notes, *lo.problems]
    if len(notes) > 3:  # keep the page to one page whatever the reader found
        notes = [*notes[:2], f"and {len(notes) - 2} more (see gaitmon info)"]
    rows += [("Note", note) for note in notes]
    return _kv_rows(p, LEFT_MM, y, WIDTH_MM, rows, label_w=29.0) + 5.0


def _settings_and_conventions(p: Page, data: ReportData, y: float) -> float:
    y = p.section(LEFT_MM, y, WIDTH_MM, "Settings and conventions in force")
    for label, value in data.settings:
        p.text(LEFT_MM + 1.2, y, 29.0, 4.0, label, 7.5, colour=MUTED)
        y += max(4.0, p.wrapped(LEFT_MM + 30.2, y + 0.35, WIDTH_MM - 31.4, value, 7.5)) + 0.6
    for k, line in enumerate(data.conventions):
        p.text(LEFT_MM + 1.2, y, 29.0, 4.0, "Conventions" if k == 0 else "", 7.5, colour=MUTED)
        y += max(4.0, p.wrapped(LEFT_MM + 30.2, y + 0.35, WIDTH_MM - 31.4, line, 7.5)) + 0.6
    if data.normative is not None:
        nb = data.normative
        p.text(LEFT_MM + 1.2, y, 29.0, 4.0, "Reference band", 7.5, colour=MUTED)
        ref = f"{nb.label}; source: {cut(nb.source, 420)}; licence: {cut(nb.licence, 120)}"
        y += max(4.0, p.wrapped(LEFT_MM + 30.2, y + 0.35, WIDTH_MM - 31.4, ref, 7.5)) + 0.6
    return y


def _footer(p: Page, y: float) -> None:
    """The footer, and the clinician's comments in the space left above it."""
    painter = p.p
    fy = PAGE_H_MM - 12.0
    y += 4.0
    if fy - 4.0 - y >= 16.0:
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
        "page 1 of 1",
        6.5,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )
