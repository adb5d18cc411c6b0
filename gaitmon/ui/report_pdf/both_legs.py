"""The report renderer's two-leg section: the report of both legs of one session on A4 pages
(``gaitmon report FILE`` of a two-leg file, without ``--side``).

Page 1: the title and header, the three cycle plots with the left and right legs' mean ± SD
on the same axes (the one-leg report's plot, :func:`~gaitmon.ui.report_pdf.cycle_plot.
draw_cycles`, given two curve sets) and a legend, the symmetry table with the measured cadence
and each leg's stride counts, and each leg's summary side by side. Then, flowing onto further
pages as the one-leg report does: session notes, each leg's data quality (gaps, losses,
exclusions), markers, settings and conventions, the clinician's comments. Content from
:mod:`gaitmon.report` (Qt-free; its types in :mod:`gaitmon.report_content`); this module only
lays it out.

Left and right are the live view's orange and purple (``gaitmon.ui.theme.side_colours``, its
light theme): neither is one of the paper's trace colours (red, green, blue), and the pair stays
apart for the common colour vision deficiencies and in grey print (orange is the lighter).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from PySide6.QtGui import QColor, QImage, QPaintDevice, QPainter

from gaitmon.analysis import clearance_symmetry_text
from gaitmon.normative import CAVEAT
from gaitmon.report_content import (
    MAX_FAINT_PER_SIDE,
    SIDE_NAMES,
    TABLE_HEADER,
    BilateralReportData,
)
from gaitmon.text import duration_text
from gaitmon.ui.report_pdf import flow
from gaitmon.ui.report_pdf.cycle_plot import CurveStyle, draw_cycles
from gaitmon.ui.report_pdf.output import pdf_title, render_a4_image, write_a4_pdf, write_png
from gaitmon.ui.report_pdf.page import MUTED, PAGE_H_MM, PAGE_W_MM, Page, fmt
from gaitmon.ui.report_pdf.sheet import (
    CONTINUED_TOP_MM,
    FOOTER_MM,
    LEFT_MM,
    WIDTH_MM,
    comments_block,
    continued,
    data_quality,
    footer,
    header_grid,
    joint_statistics,
    kv_rows,
    markers,
    normal_legend,
    rom_note,
    session_notes,
    settings_and_conventions,
    summary_rows,
    table,
    title,
)
from gaitmon.ui.theme import side_colours

# the live view's left and right colours on paper (one definition: gaitmon.ui.theme)
LEFT_COLOUR = side_colours()["L"]
RIGHT_COLOUR = side_colours()["R"]
# darker shades of the same hues for text and thin dashed lines on white
LEFT_INK = LEFT_COLOUR.darker(130)
RIGHT_INK = RIGHT_COLOUR.darker(125)


def _tint(c: QColor, alpha: int) -> QColor:
    t = QColor(c)
    t.setAlpha(alpha)
    return t


def _mix_white(c: QColor, share: float) -> QColor:
    """An opaque tint (strokes stay opaque: see ``page.STRIDE``)."""
    return QColor(round(255 + (c.red() - 255) * share), round(255 + (c.green() - 255) * share),
                  round(255 + (c.blue() - 255) * share))  # fmt: skip


STYLES = {
    "L": CurveStyle(LEFT_COLOUR, _tint(LEFT_COLOUR, 70), _mix_white(LEFT_COLOUR, 0.35), LEFT_INK,
                    "L toe off"),
    "R": CurveStyle(RIGHT_COLOUR, _tint(RIGHT_COLOUR, 70), _mix_white(RIGHT_COLOUR, 0.35),
                    RIGHT_INK, "R toe off"),
}  # fmt: skip
INKS = {"L": LEFT_INK, "R": RIGHT_INK}
CAUTION = QColor("#a4261b")  # the caveats over the symmetry table (dark red: not a side's hue)


def paint_bilateral_report(
    painter: QPainter,
    device: QPaintDevice,
    data: BilateralReportData,
    new_page: Callable[[], object] | None = None,
) -> Page:
    """Draw the bilateral report on ``device`` (as :func:`~gaitmon.ui.report_pdf.sheet.
    paint_report`: every page with ``new_page``, else the first)."""
    p = Page(painter, device, device.width() / PAGE_W_MM)
    painter.setRenderHint(QPainter.RenderHint.TextAntialiasing, True)
    painter.fillRect(p.rect(0, 0, PAGE_W_MM, PAGE_H_MM), QColor("#ffffff"))
    y = title(p, data.software, data.generated_utc, "both legs")
    y = header_grid(p, _header_cells(data), y)
    # the caveats over the symmetry table take their room from the plots: page 1 keeps its end
    y = _cycle_plots(p, data, y, sum(_caveat_h(p, c) for c in data.caveats))
    y = _symmetry(p, data, y)
    y = _legs(p, data, y)
    left, right = data.left, data.right
    blocks = [*session_notes(p, left)]
    if right.session_notes != left.session_notes:
        blocks += session_notes(p, right)
    for s, d in (("L", left), ("R", right)):
        blocks += data_quality(p, d, f"Data quality, {SIDE_NAMES[s]} leg: gaps, losses and "
                               "exclusions")  # fmt: skip
    for s, d in (("L", left), ("R", right)):
        blocks += markers(p, d, f"Markers, {SIDE_NAMES[s]} unit")
    settings = [("Clocks", data.clocks)]
    if left.settings == right.settings:
        settings += [(f"{k} (both)" if k else k, v) for k, v in left.settings]
    else:
        for s, d in (("L", left), ("R", right)):
            settings += [(f"{k} ({s})", v) for k, v in d.settings]
    blocks += settings_and_conventions(p, left, settings, data.conventions)
    blocks.append(comments_block(p))
    pages = flow.paginate(blocks, y, CONTINUED_TOP_MM, FOOTER_MM - 3.0)
    flow.paint_pages(p, pages, new_page, lambda: continued(p, left.header),
                     lambda k, n: footer(p, k, n))  # fmt: skip
    return p


def _header_cells(data: BilateralReportData) -> list[tuple[str, str]]:
    h = data.left.header
    mode = {"raw": "raw sensors (PC pipeline)", "tilt": "the units' tilts",
            "joint": "the units' joint angles"}.get(h.mode, h.mode)  # fmt: skip
    frames = f"L {data.left.header.n_samples}, R {data.right.header.n_samples} frames"
    mode += f", {h.sample_rate_hz:g} Hz"
    return [
        ("PATIENT ID", h.patient_id or "not recorded"),
        ("SIDES MEASURED", "Left and right"),
        ("RECORDED", h.recorded_utc or "unknown"),
        ("OPERATOR", h.operator or "not recorded"),
        ("DURATION", f"{duration_text(data.duration_s)} ({frames})"),
        ("MODE", mode),
        ("DEVICES", data.units),
        ("FILE", data.file_name or ("withheld (de-identified)" if h.deidentified else "–")),
        ("RECORDING", data.state + (" · de-identified report" if h.deidentified else "")),
    ]


def _swatch(p: Page, x: float, y: float, colour: QColor, band: QColor) -> None:
    """A legend key: the band with its mean line through it (8 x 3 mm, centred on y)."""
    p.fill(x, y - 1.5, 8.0, 3.0, band)
    p.hline(x, x + 8.0, y, colour, 0.45)


def _caution(c: str) -> str:
    return f"Caution: {c}"


def _caveat_h(p: Page, c: str) -> float:
    return p.wrapped_height(WIDTH_MM, _caution(c), 7.5, bold=True) + 0.8


def _cycle_plots(p: Page, data: BilateralReportData, y: float, shorter_mm: float = 0.0) -> float:
    """The plots, ``shorter_mm`` less tall than usual (to make room below them)."""
    y = p.section(LEFT_MM, y, WIDTH_MM, "Joint kinematics over the gait cycle, left and right")
    nl, nr = data.curves[0].n, data.curves[1].n
    sub = (f"Mean ± 1 SD of each leg's included strides (left {nl}, right {nr}), up to "
           f"{MAX_FAINT_PER_SIDE} of each leg's strides drawn faint; dashed lines: each leg's "
           "mean toe off. Each cycle runs from a heel strike to the next of the same leg."
           )  # fmt: skip
    y += p.wrapped(LEFT_MM, y, WIDTH_MM, sub, 7.5, colour=MUTED) + 1.0
    # the legend
    x = LEFT_MM + 1.0
    for s, c in zip(("L", "R"), data.curves, strict=True):
        st = STYLES[s]
        _swatch(p, x, y + 2.0, st.mean, st.band)
        p.text(x + 9.5, y, 40.0, 4.0, f"{c.label.capitalize()} leg ({s})", 7.5,
               colour=INKS[s], bold=True)  # fmt: skip
        x += 40.0
    if data.normative is not None:
        normal_legend(p, x, y, data.normative.label)
    y += 5.0
    gap = 5.0
    pw = (WIDTH_MM - 2 * gap) / 3
    ph = (62.0 if data.normative is None else 58.0) - shorter_mm
    sets = [(c, STYLES[s]) for s, c in zip(("L", "R"), data.curves, strict=True)]
    for j in range(3):
        draw_cycles(p, sets, data.normative, j, LEFT_MM + j * (pw + gap), y, pw, ph,
                    f"n = L {nl} · R {nr}")  # fmt: skip
    y += ph + 3.0
    if data.normative is not None:
        nb = data.normative
        text = (f"Amber band and solid line: {nb.label}, mean ± 1 SD (source and licence: see "
                f"Settings). Caveat: {CAVEAT}.")  # fmt: skip
        y += p.wrapped(LEFT_MM, y - 1.0, WIDTH_MM, text, 7.0, colour=MUTED) + 1.0
    return y + 2.0


def _symmetry(p: Page, data: BilateralReportData, y: float) -> float:
    y = p.section(LEFT_MM, y, WIDTH_MM, "Steps, support and symmetry (both legs)")
    for c in data.caveats:  # what may make these figures misleading, before them
        p.wrapped(LEFT_MM, y, WIDTH_MM, _caution(c), 7.5, bold=True, colour=CAUTION)
        y += _caveat_h(p, c)
    widths = (46.0, 20.0, 20.0, 20.0, 20.0, 28.0, WIDTH_MM - 154.0)
    rows = [line.cells() for line in data.symmetry]
    y = table(p, LEFT_MM, y, widths, TABLE_HEADER, rows)
    y += 0.8
    facts = [
        ("Cadence (measured)", f"{fmt(data.cadence_steps_min, 0)} steps/min, from both legs' "
         "steps"),
        ("Strides counted", f"left {data.strides_text('L')}, right {data.strides_text('R')} "
         "(those included on their own leg, of all detected)"),
    ]  # fmt: skip
    ls, rs = data.left.spatial, data.right.spatial
    if ls is not None and rs is not None and (ls.foot_clearance_n or rs.foot_clearance_n):
        facts.append(("Foot clearance", clearance_symmetry_text(ls, rs)))
    y = kv_rows(p, LEFT_MM, y, WIDTH_MM, facts, label_w=34.0)
    y += 0.6
    note = ("Means over the strides counted; % = of each stride's time. SR = left / right (1 "
            "symmetric); SI = 2 |L − R| / (L + R) × 100 % (0 % symmetric). Step time X: from "
            "the other leg's heel strike to X's; initial double support of X is the other "
            "leg's terminal one.")  # fmt: skip
    for n in data.notes:
        note = f"{n} {note}"
    y += p.wrapped(LEFT_MM, y, WIDTH_MM, note, 6.5, colour=MUTED)
    return y + 4.0


def _legs(p: Page, data: BilateralReportData, y: float) -> float:
    """Each leg's usual summary and joint statistics, side by side."""
    colw = (WIDTH_MM - 8.0) / 2
    bottom = y
    for k, (s, d) in enumerate((("L", data.left), ("R", data.right))):
        x = LEFT_MM + k * (colw + 8.0)
        yy = p.section(x, y, colw, f"{SIDE_NAMES[s].capitalize()} leg ({s})")
        p.fill(x + colw - 9.0, y + 1.0, 8.0, 3.0, STYLES[s].mean)
        yy = kv_rows(p, x, yy, colw, summary_rows(d, derived_cadence=False), label_w=29.0,
                     row_h=4.5, size_pt=7.5)  # fmt: skip
        yy = joint_statistics(p, d, x, yy + 1.0, colw, note=False)
        bottom = max(bottom, yy)
    bottom += 0.6
    bottom += p.wrapped(LEFT_MM, bottom, WIDTH_MM, "Joint angles in deg, mean ± SD over the "
                        "leg's included strides. " + rom_note(data.normative), 6.5,
                        colour=MUTED)  # fmt: skip
    return bottom + 4.0


# --------------------------------------------------------------------------------------------
# writers


def write_bilateral_pdf(data: BilateralReportData, path: str | os.PathLike[str], *,
                        dpi: int = 600) -> Path:  # fmt: skip
    """Write the A4 PDF (atomically, as the one-leg report)."""
    h = data.left.header
    title = pdf_title("Gait analysis report, both legs", h.patient_id, h.deidentified)
    return write_a4_pdf(path, lambda painter, device, new_page: paint_bilateral_report(
        painter, device, data, new_page), creator=data.software, title=title, dpi=dpi,
        dated=not h.deidentified)  # fmt: skip


def render_bilateral_image(data: BilateralReportData, dpi: float = 150.0) -> QImage:
    """The first page as an image."""
    return render_a4_image(
        lambda painter, device, _: paint_bilateral_report(painter, device, data), dpi
    )


def write_bilateral_png(data: BilateralReportData, path: str | os.PathLike[str], *,
                        dpi: float = 150.0) -> Path:  # fmt: skip
    return write_png(path, render_bilateral_image(data, dpi))


__all__ = [
    "LEFT_COLOUR",
    "RIGHT_COLOUR",
    "STYLES",
    "paint_bilateral_report",
    "render_bilateral_image",
    "write_bilateral_pdf",
    "write_bilateral_png",
]
