"""The comparison sheet: a :class:`gaitmon.compare.Comparison` on A4 pages (``gaitmon compare``).

Title and patient; the sessions (date, file, duration, angles, strides), each in its colour,
with its gaps and excluded strides; warnings (patient ids, dates, angle methods); the three
cycle plots with every session's mean ± SD band overlaid and a legend; the measures table, one
column per session and the changes from the baseline and from the previous session, each with
its minimal detectable change beside it and marked when beyond it (the one rule of
:mod:`gaitmon.compare`). Drawn with the report's kit (:class:`Page`,
the flow blocks and pagination), so it looks and paginates like the report: a table too long
for the page continues on the next one.
"""

from __future__ import annotations

import datetime as _dt
import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import (
    QBrush,
    QColor,
    QFontMetricsF,
    QImage,
    QPaintDevice,
    QPainter,
)

from gaitmon import __version__
from gaitmon.compare import (
    JOINTS,
    MEASURES,
    RULE_TEXT,
    Comparison,
    Measure,
    SessionResult,
)
from gaitmon.compare import change_text as _change_text
from gaitmon.dsp.channel_table import JOINT_TABLE
from gaitmon.text import duration_text
from gaitmon.ui.report_pdf import flow
from gaitmon.ui.report_pdf.cycle_plot import band_path, line_path
from gaitmon.ui.report_pdf.flow import Block
from gaitmon.ui.report_pdf.output import render_a4_image, write_a4_pdf, write_png
from gaitmon.ui.report_pdf.page import (
    ACCENT,
    GRID,
    INK,
    MARGIN_MM,
    MUTED,
    PAGE_H_MM,
    PAGE_W_MM,
    RULE,
    SHADE,
    Page,
    fmt,
    fmt_pm,
    nice_ticks,
)

LEFT_MM, RIGHT_MM = MARGIN_MM, PAGE_W_MM - MARGIN_MM
WIDTH_MM = RIGHT_MM - LEFT_MM
FOOTER_MM = PAGE_H_MM - 12.0
CONTINUED_TOP_MM = 22.0
# one colour per session, in date order (the review's Compare view uses the same)
SESSION_COLOURS: tuple[str, ...] = ("#1f5fd6", "#d1401f", "#2a9d3a", "#8e44ad", "#e08a00",
                                    "#138d90", "#8c564b", "#c2185b")  # fmt: skip
WARN = QColor("#a4261b")
BEYOND = QColor("#a4261b")
AXIS_LABELS = tuple(f"{j.label} (deg)" for j in JOINT_TABLE)  # hip flexion (deg), ...
# later sessions per measures table: one, so that a change and its MDC ("−21.3 (MDC 0.5) *")
# fit its column with the baseline, the session and the change from the previous one beside it
LATER_PER_TABLE = 1
MARK = "*"  # a change beyond its minimal detectable change (MDC95)


def session_colour(k: int, alpha: int = 255) -> QColor:
    c = QColor(SESSION_COLOURS[k % len(SESSION_COLOURS)])
    c.setAlpha(alpha)
    return c


def measure_label(m: Measure) -> str:
    return f"{m.label} ({m.unit})" if m.unit else m.label


def value_text(s: SessionResult, m: Measure) -> str:
    v = s.values[m.key]
    if m.key == "n_strides":
        return f"{v.n} of {s.n_strides_total}"
    return fmt_pm(v.mean, v.sd if m.judged else float("nan"), m.decimals)


def change_text(c: Comparison, k: int, m: Measure, since: int) -> tuple[str, bool]:
    """The change cell: signed Δ and its MDC95 beside it (``gaitmon.compare.change_text``), with
    the mark when beyond it, and whether it is."""
    ch = c.change(k, m.key, since)
    text = _change_text(ch, m)
    return (f"{text} {MARK}" if ch.beyond else text), bool(ch.beyond)


# --------------------------------------------------------------------------------------------
# drawing


def paint_comparison(
    painter: QPainter,
    device: QPaintDevice,
    c: Comparison,
    new_page: Callable[[], object] | None = None,
    generated_utc: str = "",
) -> Page:
    """Draw the comparison (every page when ``new_page`` is given, else the first only)."""
    p = Page(painter, device, device.width() / PAGE_W_MM)
    painter.setRenderHint(QPainter.RenderHint.TextAntialiasing, True)
    painter.fillRect(p.rect(0, 0, PAGE_W_MM, PAGE_H_MM), QColor("#ffffff"))
    y = _title(p, c, generated_utc)
    blocks = [
        *_sessions(p, c),
        *_warnings(p, c),
        *_plots(p, c),
        *_measures(p, c),
    ]
    pages = flow.paginate(blocks, y, CONTINUED_TOP_MM, FOOTER_MM - 3.0)
    flow.paint_pages(p, pages, new_page, lambda: _continued(p, c),
                     lambda k, n: _footer(p, k, n))
    return p


def _title(p: Page, c: Comparison, generated_utc: str) -> float:
    y = 11.0
    p.text(LEFT_MM, y, WIDTH_MM * 0.62, 8.0, "Gait comparison across sessions", 16.0, bold=True,
           colour=ACCENT)  # fmt: skip
    right = Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter
    p.text(LEFT_MM + WIDTH_MM * 0.5, y + 0.6, WIDTH_MM * 0.5, 4.0,
           "wearable sagittal gait unit · one leg", 7.5, colour=MUTED, align=right)  # fmt: skip
    p.text(LEFT_MM + WIDTH_MM * 0.5, y + 4.2, WIDTH_MM * 0.5, 4.0,
           f"gaitmon {__version__}" + (f" · {generated_utc}" if generated_utc else ""), 7.0,
           colour=MUTED,
           align=right)  # fmt: skip
    y += 9.5
    p.hline(LEFT_MM, RIGHT_MM, y, ACCENT, 0.6)
    y += 2.5
    p.fill(LEFT_MM, y, WIDTH_MM, 9.6, SHADE)
    cols = (("PATIENT ID", c.who), ("SESSIONS", f"{len(c.sessions)}, oldest first"),
            ("FROM … TO", f"{c.sessions[0].recorded_utc[:10]} … "
                          f"{c.sessions[-1].recorded_utc[:10]}"))  # fmt: skip
    w = WIDTH_MM / 3
    for k, (label, value) in enumerate(cols):
        p.text(LEFT_MM + k * w + 2.0, y + 0.8, w - 4.0, 3.4, label, 6.0, bold=True, colour=MUTED)
        p.text(LEFT_MM + k * w + 2.0, y + 4.2, w - 4.0, 4.6, value, 10.0 if k == 0 else 8.5,
               bold=k == 0)  # fmt: skip
    return y + 9.6 + 4.0


def _continued(p: Page, c: Comparison) -> None:
    p.text(LEFT_MM, 11.0, WIDTH_MM * 0.6, 6.0, "Gait comparison (continued)", 11.0, bold=True,
           colour=ACCENT)  # fmt: skip
    p.text(LEFT_MM + WIDTH_MM * 0.5, 11.5, WIDTH_MM * 0.5, 4.0,
           f"{c.who} · {len(c.sessions)} sessions", 7.5, colour=MUTED,
           align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)  # fmt: skip
    p.hline(LEFT_MM, RIGHT_MM, 18.0, ACCENT, 0.6)


def _swatch(p: Page, x: float, y: float, k: int, w: float = 5.0) -> None:
    p.fill(x, y + 1.2, w, 2.4, session_colour(k, 90))
    p.hline(x, x + w, y + 2.4, session_colour(k), 0.5)


def _sessions(p: Page, c: Comparison) -> list[Block]:
    """One row per session: colour, number, date, file, duration, angles, strides."""
    size = 7.5
    h = flow.line_height_mm(p, size)
    cols = (("", 8.0), ("#", 22.0), ("recorded", 33.0), ("file", 39.0), ("duration", 15.0),
            ("strides", 17.0), ("angles", WIDTH_MM - 134.0))  # fmt: skip
    right_cols = {4, 5}
    left = Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter
    right = Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter

    def header(p: Page, y: float) -> None:
        x = LEFT_MM
        for k, (title, w) in enumerate(cols):
            p.text(x + 1.2, y, w - 2.4, h, title, size - 0.5, bold=True, colour=MUTED,
                   align=right if k in right_cols else left)  # fmt: skip
            x += w
        p.hline(LEFT_MM, RIGHT_MM, y + h + 0.1, RULE, 0.25)

    blocks = [flow.heading(p, LEFT_MM, WIDTH_MM, "Sessions"), Block(h + 0.5, header, True)]
    for k, s in enumerate(c.sessions):
        role = " (baseline)" if k == 0 else ""
        cells = ("", f"{k + 1}{role}", s.recorded_utc or "unknown", s.file_name,
                 duration_text(s.duration_s), f"{s.n_included} of {s.n_strides_total}",
                 s.angle_method or s.mode)  # fmt: skip
        method_lines = flow.split_lines(p, cells[-1], cols[-1][1] - 2.4, size - 0.5)
        # its gaps and excluded strides, under the row from the "#" column to the right edge
        q_x = LEFT_MM + cols[0][1] + 1.2
        q_lines = flow.split_lines(p, s.quality.text(), RIGHT_MM - q_x - 1.2, size - 0.5)
        top_h = max(1, len(method_lines)) * h
        bh = top_h + len(q_lines) * h + 0.4

        def draw(p: Page, y: float, k: int = k, cells: Sequence[str] = cells,
                 lines: list[str] = method_lines, bh: float = bh, q_lines: list[str] = q_lines,
                 q_x: float = q_x, top_h: float = top_h) -> None:  # fmt: skip
            if k % 2 == 1:
                p.fill(LEFT_MM, y, WIDTH_MM, bh, SHADE)
            for i, ln in enumerate(q_lines):
                p.text(q_x, y + 0.2 + top_h + i * h, RIGHT_MM - q_x - 1.2, h, ln, size - 0.5,
                       colour=MUTED, elide=False)  # fmt: skip
            _swatch(p, LEFT_MM + 1.2, y + 0.2, k)
            x = LEFT_MM
            for j, ((_t, w), text) in enumerate(zip(cols, cells, strict=True)):
                if j == len(cols) - 1:
                    for i, ln in enumerate(lines):
                        p.text(x + 1.2, y + 0.2 + i * h, w - 2.4, h, ln, size - 0.5,
                               colour=MUTED, elide=False)  # fmt: skip
                elif j:
                    p.text(x + 1.2, y + 0.2, w - 2.4, h, text, size, bold=j == 1,
                           align=right if j in right_cols else left)  # fmt: skip
                x += w

        blocks.append(Block(bh, draw))
    blocks.append(flow.gap(2.0))
    return blocks


def _warnings(p: Page, c: Comparison) -> list[Block]:
    out: list[Block] = []
    for w in c.warnings:
        out += flow.paragraph(p, LEFT_MM + 1.2, WIDTH_MM - 2.4, f"⚠ {w}", 8.0, colour=WARN)
    if out:
        out.append(flow.gap(2.0))
    return out


def _plots(p: Page, c: Comparison) -> list[Block]:
    """The three overlaid cycle plots and their legend (kept together)."""
    sub = ("Mean ± 1 SD over each session's included strides, in the session's colour; the "
           "small marks at the top are each session's mean toe off.")  # fmt: skip
    gap, ph = 5.0, 70.0
    pw = (WIDTH_MM - 2 * gap) / 3
    head = flow.heading(p, LEFT_MM, WIDTH_MM, "Joint kinematics over the gait cycle")
    lines = flow.paragraph(p, LEFT_MM, WIDTH_MM, sub, 7.5, colour=MUTED, after_mm=1.0)
    for b in lines:
        b.keep_with_next = True

    def plots(p: Page, y: float) -> None:
        for j in range(3):
            draw_overlay(p, c, j, LEFT_MM + j * (pw + gap), y, pw, ph)

    legend = _legend(p, c)
    return [head, *lines, Block(ph + 1.0, plots, keep_with_next=True), *legend, flow.gap(2.0)]


def _legend(p: Page, c: Comparison) -> list[Block]:
    """Colour, number and label of every session, two to a line."""
    h = 4.6
    half = WIDTH_MM / 2
    blocks = []
    for k0 in range(0, len(c.sessions), 2):

        def draw(p: Page, y: float, k0: int = k0) -> None:
            for k in range(k0, min(k0 + 2, len(c.sessions))):
                x = LEFT_MM + (k - k0) * half
                _swatch(p, x + 12.5, y, k, 8.0)
                p.text(x + 22.0, y, half - 24.0, h, f"{k + 1} · {c.sessions[k].label}", 7.5)

        blocks.append(Block(h, draw))
    return blocks


def _y_range(c: Comparison, j: int) -> tuple[float, float]:
    parts = []
    for s in c.sessions:
        m, sd = s.mean_deg[:, j], np.nan_to_num(s.sd_deg[:, j])
        parts += [m - sd, m + sd]
    v = np.concatenate(parts)
    v = v[np.isfinite(v)]
    if not v.size:
        return -10.0, 10.0
    lo, hi = float(v.min()), float(v.max())
    pad = max(0.08 * (hi - lo), 2.0)
    return lo - pad, hi + pad


def draw_overlay(p: Page, c: Comparison, j: int, x: float, y: float, w: float, h: float) -> None:
    """Joint ``j``'s cycle plot with every session's mean ± SD in its colour."""
    left, bottom, top = 12.5, 9.0, 6.0
    px, py, pw, ph = x + left, y + top, w - left - 1.5, h - top - bottom
    p.text(x + left, y, pw, 5.0, JOINTS[j], 9.5, bold=True)
    lo, hi = _y_range(c, j)
    ticks = nice_ticks(lo, hi, 5)
    lo, hi = min(lo, float(ticks[0])), max(hi, float(ticks[-1]))

    def to_px(cx: float, cy: float) -> QPointF:
        return QPointF(p.mm(px + pw * cx / 100.0), p.mm(py + ph * (hi - cy) / (hi - lo)))

    painter = p.p
    right = Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter
    centre_top = Qt.AlignmentFlag.AlignHCenter | Qt.AlignmentFlag.AlignTop
    for t in ticks:
        yy = py + ph * (hi - t) / (hi - lo)
        zero = abs(t) < 1e-9
        p.hline(px, px + pw, yy, QColor("#9aa3ad") if zero else GRID, 0.25 if zero else 0.15)
        p.text(x + 4.0, yy - 2.0, left - 5.0, 4.0, fmt(float(t), 0), 6.5, colour=MUTED,
               align=right)  # fmt: skip
    for cpct in range(0, 101, 20):
        xx = px + pw * cpct / 100.0
        painter.setPen(p.pen(GRID, 0.15))
        painter.drawLine(QPointF(p.mm(xx), p.mm(py)), QPointF(p.mm(xx), p.mm(py + ph)))
        p.text(xx - 5.0, py + ph + 0.6, 10.0, 3.6, str(cpct), 6.5, colour=MUTED, align=centre_top)
    p.text(px, py + ph + 4.4, pw, 4.0, "gait cycle (%)", 7.0, align=centre_top)
    painter.save()
    painter.translate(p.mm(x + 1.0), p.mm(py + ph / 2))
    painter.rotate(-90)
    painter.setFont(p.font(7.0))
    painter.setPen(INK)
    painter.drawText(QRectF(-p.mm(ph / 2 + 5), 0, p.mm(ph + 10), p.mm(3.8)),
                     int(Qt.AlignmentFlag.AlignCenter), AXIS_LABELS[j])  # fmt: skip
    painter.restore()

    painter.save()
    painter.setClipRect(p.rect(px, py, pw, ph))
    painter.setRenderHint(QPainter.RenderHint.Antialiasing, True)
    painter.setBrush(Qt.BrushStyle.NoBrush)
    for k, s in enumerate(c.sessions):
        xs = np.linspace(0.0, 100.0, s.mean_deg.shape[0])
        m, sd = s.mean_deg[:, j], s.sd_deg[:, j]
        painter.fillPath(band_path(xs, m - sd, m + sd, to_px), QBrush(session_colour(k, 55)))
    for k, s in enumerate(c.sessions):  # the means over every band
        xs = np.linspace(0.0, 100.0, s.mean_deg.shape[0])
        painter.setPen(p.pen(session_colour(k), 0.45))
        painter.drawPath(line_path(xs, s.mean_deg[:, j], to_px))
        if np.isfinite(s.stance_pct):
            xx = p.mm(px + pw * s.stance_pct / 100.0)
            painter.setPen(p.pen(session_colour(k), 0.5))
            painter.drawLine(QPointF(xx, p.mm(py)), QPointF(xx, p.mm(py + 2.2)))
    painter.restore()
    painter.setPen(p.pen(QColor("#8a939e"), 0.2))
    painter.setBrush(Qt.BrushStyle.NoBrush)
    painter.drawRect(p.rect(px, py, pw, ph))


# a column of the measures table: (title, subtitle, session, since); since None: the
# session's values, else its change from session ``since``
Col = tuple[str, str, int, int | None]


def table_columns(c: Comparison, later: Sequence[int]) -> list[Col]:
    """The baseline's values, then each of ``later`` with its change columns."""
    cols: list[Col] = [("1 (baseline)", c.sessions[0].recorded_utc[:10], 0, None)]
    for k in later:
        cols.append((f"{k + 1}", c.sessions[k].recorded_utc[:10], k, None))
        cols.append((f"Δ {k + 1} − 1", "from baseline", k, 0))
        if k >= 2:
            cols.append((f"Δ {k + 1} − {k}", "from previous", k, k - 1))
    return cols


def _measures(p: Page, c: Comparison) -> list[Block]:
    """The measures table(s): a table for every LATER_PER_TABLE later sessions."""
    later = list(range(1, len(c.sessions)))
    groups = [later[i : i + LATER_PER_TABLE] for i in range(0, len(later), LATER_PER_TABLE)]
    blocks = [flow.heading(p, LEFT_MM, WIDTH_MM, "Measures (mean ± stride-to-stride SD) and "
                           "changes (minimal detectable change beside each)")]  # fmt: skip
    for g in groups:
        blocks += _measure_table(p, c, g)
        blocks.append(flow.gap(2.5))
    n_beyond = c.n_beyond()
    note = (f"{MARK} beyond its minimal detectable change. {RULE_TEXT} Changes are the later "
            "session's minus the earlier one's, with the MDC95 in brackets. Strides included, "
            "stride time CV: not judged. "
            "Cadence is derived (120 / mean stride time); ROM = maximum − minimum within each "
            "stride; maximum and minimum from the time-normalised stride. "
            f"{n_beyond} change{'s' if n_beyond != 1 else ''} from the baseline "
            f"{'are' if n_beyond != 1 else 'is'} beyond the MDC95.")  # fmt: skip
    blocks += flow.paragraph(p, LEFT_MM + 1.2, WIDTH_MM - 2.4, note, 7.0, colour=MUTED)
    return blocks


def _measure_table(p: Page, c: Comparison, later: Sequence[int]) -> list[Block]:
    size = 7.5
    h = flow.line_height_mm(p, size)
    label_w = 46.0
    cols = table_columns(c, later)
    cw = (WIDTH_MM - label_w) / len(cols)
    right = Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter
    left = Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter

    def header(p: Page, y: float) -> None:
        p.text(LEFT_MM + 1.2, y + h, label_w - 2.4, h, "measure (unit)", size - 0.5, bold=True,
               colour=MUTED, align=left)  # fmt: skip
        for j, (t1, t2, k, since) in enumerate(cols):
            cx = LEFT_MM + label_w + j * cw
            if since is None:  # the session's colour just left of its title
                tw = QFontMetricsF(p.font(size - 0.5, True), p.dev).horizontalAdvance(t1) / p.k
                _swatch(p, cx + cw - 1.2 - tw - 5.5, y, k, 4.0)
            p.text(cx + 1.2, y, cw - 2.4, h, t1, size - 0.5, bold=True, colour=INK,
                   align=right)  # fmt: skip
            p.text(cx + 1.2, y + h, cw - 2.4, h, t2, size - 1.0, colour=MUTED, align=right)
        p.hline(LEFT_MM, RIGHT_MM, y + 2 * h + 0.1, RULE, 0.25)

    blocks = [Block(2 * h + 0.6, header, keep_with_next=True)]
    for r, m in enumerate(MEASURES):

        def draw(p: Page, y: float, m: Measure = m, r: int = r) -> None:
            if r % 2 == 1:
                p.fill(LEFT_MM, y, WIDTH_MM, h + 0.4, SHADE)
            p.text(LEFT_MM + 1.2, y + 0.2, label_w - 2.4, h, measure_label(m), size, align=left)
            for j, (_t1, _t2, k, since) in enumerate(cols):
                cx = LEFT_MM + label_w + j * cw
                if since is None:
                    p.text(cx + 1.2, y + 0.2, cw - 2.4, h, value_text(c.sessions[k], m),
                           size, align=right)  # fmt: skip
                else:
                    text, beyond = change_text(c, k, m, since)
                    p.text(cx + 1.2, y + 0.2, cw - 2.4, h, text, size, bold=beyond,
                           colour=BEYOND if beyond else MUTED, align=right)  # fmt: skip

        blocks.append(Block(h + 0.4, draw, keep_with_next=r < len(MEASURES) - 1))
    return blocks  # kept together: a table never continues without its header


def _footer(p: Page, page: int, n_pages: int) -> None:
    fy = FOOTER_MM
    p.hline(LEFT_MM, RIGHT_MM, fy, RULE, 0.25)
    p.text(LEFT_MM, fy + 0.8, WIDTH_MM * 0.8, 4.0,
           "Sagittal-plane angles from body-worn inertial sensors; for review by a clinician "
           "alongside the recordings and their reports.", 6.5, colour=MUTED)  # fmt: skip
    p.text(LEFT_MM + WIDTH_MM * 0.8, fy + 0.8, WIDTH_MM * 0.2, 4.0,
           f"page {page + 1} of {n_pages}", 6.5, colour=MUTED,
           align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)  # fmt: skip


# --------------------------------------------------------------------------------------------
# writers


def _now(c: Comparison) -> str:
    """When the comparison is drawn; "" de-identified (it would date the visit)."""
    return "" if c.deidentified else _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")


def write_comparison_pdf(c: Comparison, path: str | os.PathLike[str], *, dpi: int = 600) -> Path:
    """Write the A4 PDF atomically (a temporary file renamed at the end)."""
    who = c.patient_id if c.patient_id and not c.deidentified else ""
    now = _now(c)
    return write_a4_pdf(
        path,
        lambda painter, device, new_page: paint_comparison(painter, device, c, new_page=new_page,
                                                           generated_utc=now),
        creator=f"gaitmon {__version__}",
        title="Gait comparison" + (f" {who}" if who else ""),
        dpi=dpi,
        dated=not c.deidentified,
    )  # fmt: skip


def render_comparison_image(c: Comparison, dpi: float = 150.0) -> QImage:
    """The first page as an image."""
    now = _now(c)
    return render_a4_image(
        lambda painter, device, _: paint_comparison(painter, device, c, generated_utc=now), dpi
    )


def write_comparison_png(c: Comparison, path: str | os.PathLike[str]) -> Path:
    return write_png(path, render_comparison_image(c))
