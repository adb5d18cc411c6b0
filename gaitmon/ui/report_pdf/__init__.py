"""The one-page clinical report drawn with Qt's own PDF support (QPdfWriter + QPainter).

Content comes from :mod:`gaitmon.report` (Qt-free); this module only lays it out on an A4 page:
header, the three cycle plots (drawn here with QPainter as vector paths, so they stay sharp at
any zoom and need no widget), summary, stride statistics, gaps and losses, settings and
conventions. :func:`paint_report` draws on any paint device, so the same code writes the PDF
(:func:`write_report_pdf`) and a PNG preview (:func:`write_report_png`).

Needs a ``QGuiApplication`` (fonts); :func:`ensure_gui_app` makes one when there is none, so
``gaitmon report`` runs headless on the offscreen platform with no window.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from PySide6.QtCore import QMarginsF, QPointF, QRectF, QSizeF, Qt
from PySide6.QtGui import (
    QBrush,
    QColor,
    QFont,
    QFontMetricsF,
    QGuiApplication,
    QImage,
    QImageWriter,
    QPageLayout,
    QPageSize,
    QPaintDevice,
    QPainter,
    QPainterPath,
    QPdfWriter,
    QPen,
)

from gaitmon.analysis import FIRST, GAP, LAST, USER
from gaitmon.report import JOINT_AXIS_LABELS, JOINT_TITLES, JointStat, ReportData

ToPixels = Callable[[float, float], QPointF]  # plot coordinates -> page point

PAGE_W_MM, PAGE_H_MM = 210.0, 297.0
MARGIN_MM = 14.0
FONT_FAMILIES = ["Helvetica Neue", "Helvetica", "Arial", "Liberation Sans", "DejaVu Sans"]

INK = QColor("#1b1f24")
MUTED = QColor("#5b6470")
RULE = QColor("#c9ced6")
ACCENT = QColor("#1f4e8c")
GRID = QColor("#e6e9ee")
MEAN = QColor("#1f5fd6")
BAND = QColor(31, 95, 214, 60)
# Strokes are opaque on purpose: Qt's PDF engine turns every semi-transparent stroke into a
# filled outline (to avoid overlap artefacts), which made the page ~30x larger (1.1 MB).
STRIDE = QColor("#c3ccd9")
NORM = QColor(120, 120, 120, 60)
TOE_OFF = QColor("#444a52")
SHADE = QColor("#f3f5f8")

_app: QGuiApplication | None = None


def ensure_gui_app() -> QGuiApplication:
    """The running QGuiApplication, or a new one (headless callers: set QT_QPA_PLATFORM)."""
    global _app
    app = QGuiApplication.instance()
    if app is None:
        _app = QGuiApplication([])
        app = _app
    return app  # type: ignore[return-value]


# --------------------------------------------------------------------------------------------
# number formatting


def _f(v: float, decimals: int = 1) -> str:
    return "–" if not np.isfinite(v) else f"{v:.{decimals}f}".replace("-", "−")


def _pm(mean: float, sd: float, decimals: int = 1, unit: str = "") -> str:
    u = f" {unit}" if unit else ""
    if not np.isfinite(mean):
        return "–"
    if not np.isfinite(sd):
        return f"{_f(mean, decimals)}{u}"
    return f"{_f(mean, decimals)} ± {_f(sd, decimals)}{u}"


def _stat(s: JointStat, decimals: int = 1, unit: str = "") -> str:
    return _pm(s.mean_deg, s.sd_deg, decimals, unit)


def _cut(text: str, n: int) -> str:
    return text if len(text) <= n else text[: n - 1].rstrip() + "…"


def nice_ticks(lo: float, hi: float, target: int = 5) -> np.ndarray:
    """Round tick values (1, 2, 5 x 10^k steps) covering [lo, hi]."""
    span = max(hi - lo, 1e-9)
    raw = span / target
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw)
    first = math.ceil(lo / step - 1e-9) * step
    return np.arange(first, hi + step * 1e-6, step)


# --------------------------------------------------------------------------------------------
# the page painter: millimetres in, device pixels out


class _Page:
    def __init__(self, painter: QPainter, device: QPaintDevice, px_per_mm: float) -> None:
        self.p = painter
        self.dev = device
        self.k = px_per_mm

    def mm(self, v: float) -> float:
        return v * self.k

    def rect(self, x: float, y: float, w: float, h: float) -> QRectF:
        return QRectF(self.mm(x), self.mm(y), self.mm(w), self.mm(h))

    def font(self, size_pt: float, bold: bool = False, italic: bool = False) -> QFont:
        f = QFont()
        f.setFamilies(FONT_FAMILIES)
        f.setPointSizeF(size_pt)
        f.setBold(bold)
        f.setItalic(italic)
        # no ligatures: "ﬂexion" would not be found when searching or copying the PDF's text
        if hasattr(QFont, "Tag"):  # Qt >= 6.6
            f.setFeature(QFont.Tag("liga"), 0)
        return f

    def pen(
        self, colour: QColor, width_mm: float = 0.2, style: Qt.PenStyle = Qt.PenStyle.SolidLine
    ) -> QPen:
        pen = QPen(colour)
        pen.setWidthF(self.mm(width_mm))
        pen.setStyle(style)
        pen.setCapStyle(Qt.PenCapStyle.FlatCap)
        pen.setJoinStyle(Qt.PenJoinStyle.RoundJoin)
        return pen

    def text(
        self,
        x: float,
        y: float,
        w: float,
        h: float,
        text: str,
        size_pt: float = 8.0,
        *,
        bold: bool = False,
        italic: bool = False,
        colour: QColor = INK,
        align: Qt.AlignmentFlag = Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter,
        elide: bool = True,
    ) -> None:
        font = self.font(size_pt, bold, italic)
        self.p.setFont(font)
        self.p.setPen(colour)
        r = self.rect(x, y, w, h)
        if elide:
            text = QFontMetricsF(font, self.dev).elidedText(
                text, Qt.TextElideMode.ElideRight, r.width()
            )
        self.p.drawText(r, int(align), text)

    def wrapped(
        self,
        x: float,
        y: float,
        w: float,
        text: str,
        size_pt: float = 7.5,
        *,
        bold: bool = False,
        colour: QColor = INK,
    ) -> float:
        """Word-wrapped text from (x, y); returns the height used in mm."""
        font = self.font(size_pt, bold)
        self.p.setFont(font)
        self.p.setPen(colour)
        flags = int(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop) | int(
            Qt.TextFlag.TextWordWrap
        )
        fm = QFontMetricsF(font, self.dev)
        br = fm.boundingRect(QRectF(0, 0, self.mm(w), 1e6), flags, text)
        r = QRectF(self.mm(x), self.mm(y), self.mm(w), br.height() + 1)
        self.p.drawText(r, flags, text)
        return br.height() / self.k

    def hline(
        self, x0: float, x1: float, y: float, colour: QColor = RULE, width_mm: float = 0.2
    ) -> None:
        self.p.setPen(self.pen(colour, width_mm))
        self.p.drawLine(QPointF(self.mm(x0), self.mm(y)), QPointF(self.mm(x1), self.mm(y)))

    def fill(self, x: float, y: float, w: float, h: float, colour: QColor) -> None:
        self.p.fillRect(self.rect(x, y, w, h), colour)

    def section(self, x: float, y: float, w: float, title: str) -> float:
        """A section heading with a rule under it; returns the y below it."""
        self.text(x, y, w, 5.0, title.upper(), 7.5, bold=True, colour=ACCENT)
        self.hline(x, x + w, y + 5.2, ACCENT, 0.3)
        return y + 6.6


# --------------------------------------------------------------------------------------------
# the cycle plot


def _path(p: _Page, xs: np.ndarray, ys: np.ndarray, to_px: ToPixels) -> QPainterPath:
    path = QPainterPath()
    started = False
    for x, y in zip(xs, ys, strict=True):
        if not np.isfinite(y):
            started = False
            continue
        pt = to_px(x, y)
        if started:
            path.lineTo(pt)
        else:
            path.moveTo(pt)
            started = True
    return path


def _band(xs: np.ndarray, lo: np.ndarray, hi: np.ndarray, to_px: ToPixels) -> QPainterPath:
    ok = np.isfinite(lo) & np.isfinite(hi)
    path = QPainterPath()
    if ok.sum() < 2:
        return path
    xs, lo, hi = xs[ok], lo[ok], hi[ok]
    path.moveTo(to_px(xs[0], hi[0]))
    for x, y in zip(xs[1:], hi[1:], strict=True):
        path.lineTo(to_px(x, y))
    for x, y in zip(xs[::-1], lo[::-1], strict=True):
        path.lineTo(to_px(x, y))
    path.closeSubpath()
    return path


def _y_range(data: ReportData, j: int) -> tuple[float, float]:
    parts = [data.cycles_deg[:, :, j].ravel()]
    mean, sd = data.mean_deg[:, j], data.sd_deg[:, j]
    parts += [mean - np.nan_to_num(sd), mean + np.nan_to_num(sd)]
    if data.normative is not None and np.all(np.isfinite(data.normative.mean_deg[:, j])):
        nm, ns = data.normative.mean_deg[:, j], data.normative.sd_deg[:, j]
        parts += [nm - ns, nm + ns]
    v = np.concatenate(parts)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return (-10.0, 10.0)
    lo, hi = float(v.min()), float(v.max())
    pad = max(0.08 * (hi - lo), 2.0)
    return lo - pad, hi + pad


def draw_cycle_plot(
    p: _Page, data: ReportData, j: int, x: float, y: float, w: float, h: float
) -> None:
    """One joint's cycle plot in the box (x, y, w, h) mm, axes and labels included."""
    left, bottom, top = 12.5, 9.0, 6.0
    px, py, pw, ph = x + left, y + top, w - left - 1.5, h - top - bottom
    n = data.n_included
    p.text(x + left, y, pw * 0.5, 5.0, JOINT_TITLES[j], 9.5, bold=True)
    p.text(
        x + left + pw * 0.5,
        y,
        pw * 0.5,
        5.0,
        f"n = {n}",
        7.0,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )
    lo, hi = _y_range(data, j)
    ticks = nice_ticks(lo, hi, 5)
    lo, hi = min(lo, float(ticks[0])), max(hi, float(ticks[-1]))

    def to_px(cx: float, cy: float) -> QPointF:
        return QPointF(p.mm(px + pw * cx / 100.0), p.mm(py + ph * (hi - cy) / (hi - lo)))

    painter = p.p
    p.fill(px, py, pw, ph, QColor("#ffffff"))
    # grid and tick labels
    for t in ticks:
        yy = py + ph * (hi - t) / (hi - lo)
        p.hline(
            px,
            px + pw,
            yy,
            QColor("#9aa3ad") if abs(t) < 1e-9 else GRID,
            0.25 if abs(t) < 1e-9 else 0.15,
        )
        p.text(
            x + 4.0,
            yy - 2.0,
            left - 5.0,
            4.0,
            _f(float(t), 0),
            6.5,
            colour=MUTED,
            align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
        )
    for c in range(0, 101, 20):
        xx = px + pw * c / 100.0
        painter.setPen(p.pen(GRID, 0.15))
        painter.drawLine(QPointF(p.mm(xx), p.mm(py)), QPointF(p.mm(xx), p.mm(py + ph)))
        p.text(
            xx - 5.0,
            py + ph + 0.6,
            10.0,
            3.6,
            str(c),
            6.5,
            colour=MUTED,
            align=Qt.AlignmentFlag.AlignHCenter | Qt.AlignmentFlag.AlignTop,
        )
    p.text(
        px,
        py + ph + 4.4,
        pw,
        4.0,
        "gait cycle (%)",
        7.0,
        colour=INK,
        align=Qt.AlignmentFlag.AlignHCenter | Qt.AlignmentFlag.AlignTop,
    )
    # y label, rotated
    painter.save()
    painter.translate(p.mm(x + 1.0), p.mm(py + ph / 2))
    painter.rotate(-90)
    painter.setFont(p.font(7.0))
    painter.setPen(INK)
    painter.drawText(
        QRectF(-p.mm(ph / 2 + 5), 0, p.mm(ph + 10), p.mm(3.8)),
        int(Qt.AlignmentFlag.AlignCenter),
        JOINT_AXIS_LABELS[j],
    )
    painter.restore()

    painter.save()
    painter.setClipRect(p.rect(px, py, pw, ph))
    painter.setRenderHint(QPainter.RenderHint.Antialiasing, True)
    xs = np.linspace(0.0, 100.0, data.mean_deg.shape[0])
    painter.setBrush(Qt.BrushStyle.NoBrush)
    if data.normative is not None and np.all(np.isfinite(data.normative.mean_deg[:, j])):
        nm, ns = data.normative.mean_deg[:, j], data.normative.sd_deg[:, j]
        nx = data.normative.cycle_pct
        painter.fillPath(_band(nx, nm - ns, nm + ns, to_px), QBrush(NORM))
        painter.setPen(p.pen(QColor("#7a7a7a"), 0.2, Qt.PenStyle.DashLine))
        painter.drawPath(_path(p, nx, nm, to_px))
    painter.setPen(p.pen(STRIDE, 0.12))
    strides = QPainterPath()  # one path for all strides: one PDF drawing operation, not n
    for k in range(n):
        strides.addPath(_path(p, xs, data.cycles_deg[k, :, j], to_px))
    painter.drawPath(strides)
    if n:
        mean, sd = data.mean_deg[:, j], data.sd_deg[:, j]
        painter.fillPath(_band(xs, mean - sd, mean + sd, to_px), QBrush(BAND))
        painter.setPen(p.pen(MEAN, 0.45))
        painter.drawPath(_path(p, xs, mean, to_px))
    if np.isfinite(data.toe_off_pct):
        xx = p.mm(px + pw * data.toe_off_pct / 100.0)
        painter.setPen(p.pen(TOE_OFF, 0.25, Qt.PenStyle.DashLine))
        painter.drawLine(QPointF(xx, p.mm(py)), QPointF(xx, p.mm(py + ph)))
    painter.restore()
    if np.isfinite(data.toe_off_pct):
        tx = px + pw * data.toe_off_pct / 100.0
        p.text(tx + 0.8, py + 0.3, 14.0, 3.4, "toe off", 6.0, colour=TOE_OFF)
    if not n:
        p.text(
            px,
            py,
            pw,
            ph,
            "no strides to show",
            8.0,
            italic=True,
            colour=MUTED,
            align=Qt.AlignmentFlag.AlignCenter,
        )
    painter.setPen(p.pen(QColor("#8a939e"), 0.2))
    painter.setBrush(Qt.BrushStyle.NoBrush)
    painter.drawRect(p.rect(px, py, pw, ph))


# --------------------------------------------------------------------------------------------
# the page


def _kv_rows(
    p: _Page,
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
    p: _Page,
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
    p = _Page(painter, device, device.width() / PAGE_W_MM)
    painter.setRenderHint(QPainter.RenderHint.TextAntialiasing, True)
    painter.fillRect(p.rect(0, 0, PAGE_W_MM, PAGE_H_MM), QColor("#ffffff"))
    x0, x1 = MARGIN_MM, PAGE_W_MM - MARGIN_MM
    w = x1 - x0
    h = data.header

    # -- title
    y = 11.0
    p.text(x0, y, w * 0.6, 8.0, "Gait analysis report", 16.0, bold=True, colour=ACCENT)
    p.text(
        x0 + w * 0.5,
        y + 0.6,
        w * 0.5,
        4.0,
        "wearable sagittal gait unit · one leg",
        7.5,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )
    p.text(
        x0 + w * 0.5,
        y + 4.2,
        w * 0.5,
        4.0,
        f"{data.software} · report {data.generated_utc}",
        7.0,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )
    y += 9.5
    p.hline(x0, x1, y, ACCENT, 0.6)
    y += 2.5

    # -- header grid (identifier only, never a name)
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
    col_w = w / 3
    p.fill(x0, y, w, 3 * 8.6 + 1.0, SHADE)
    for k, (label, value) in enumerate(cells):
        cx = x0 + (k % 3) * col_w + 2.0
        cy = y + 0.8 + (k // 3) * 8.6
        p.text(cx, cy, col_w - 4.0, 3.4, label, 6.0, bold=True, colour=MUTED)
        big = k in (0, 1)
        p.text(cx, cy + 3.4, col_w - 4.0, 4.6, value, 10.0 if big else 8.0, bold=big)
    y += 3 * 8.6 + 1.0 + 4.0

    # -- cycle plots
    y = p.section(x0, y, w, "Joint kinematics over the gait cycle")
    n = data.n_included
    sub = (
        f"Mean ± 1 SD of {n} included strides (blue band), individual strides faint; dashed "
        f"line: mean toe off at {_f(data.toe_off_pct)} % of the cycle."
        if n
        else "No included strides: nothing to average."
    )
    if data.normative is not None:
        sub += f" Grey band: reference ± 1 SD ({data.normative.label})."
    y += p.wrapped(x0, y, w, sub, 7.5, colour=MUTED) + 1.2
    gap = 5.0
    pw = (w - 2 * gap) / 3
    ph = 74.0
    for j in range(3):
        draw_cycle_plot(p, data, j, x0 + j * (pw + gap), y, pw, ph)
    y += ph + 5.0

    # -- summary | stride statistics
    colw = (w - 8.0) / 2
    xa, xb = x0, x0 + colw + 8.0
    ya = p.section(xa, y, colw, "Summary")
    yb = p.section(xb, y, colw, "Stride statistics (deg, mean ± SD)")
    s = data.summary
    n_all = len(data.rows)
    cv = f" (CV {_f(s.stride_time_cv_pct)} %)" if np.isfinite(s.stride_time_cv_pct) else ""
    summary_rows = [
        ("Strides analysed", f"{s.n_strides} of {n_all} ({n_all - s.n_strides} excluded)"),
        ("Stride time", _pm(s.stride_time_mean_s, s.stride_time_sd_s, 2, "s") + cv),
        (
            "Cadence (derived)",
            f"{_f(s.cadence_derived_steps_per_min, 0)} steps/min (from stride time)",
        ),
        ("Stance / swing", f"{_f(s.stance_pct_mean)} % / {_f(s.swing_pct_mean)} % of the cycle"),
        ("Stance time", _stat(data.stance_time, 2, "s")),
        ("Swing time", _stat(data.swing_time, 2, "s")),
    ]
    ya = _kv_rows(p, xa, ya, colw, summary_rows, label_w=29.0)
    header = ("Joint", "ROM", "Maximum", "Minimum")
    widths = (colw * 0.22, colw * 0.26, colw * 0.26, colw * 0.26)
    table_rows = [
        (JOINT_TITLES[j], _stat(data.rom[j]), _stat(data.peak[j]), _stat(data.trough[j]))
        for j in range(3)
    ]
    yb = _table(p, xb, yb, widths, header, table_rows)
    yb += 1.0
    yb = _kv_rows(
        p,
        xb,
        yb,
        colw,
        [("Peak knee flexion in swing", _stat(data.knee_peak_swing, 1, "deg"))],
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
    y = max(ya, yb) + 5.0

    # -- gaps, losses and exclusions
    y = p.section(x0, y, w, "Data quality: gaps, losses and exclusions")
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
    y = _kv_rows(p, x0, y, w, rows, label_w=29.0) + 5.0

    # -- settings and conventions
    y = p.section(x0, y, w, "Settings and conventions in force")
    for label, value in data.settings:
        p.text(x0 + 1.2, y, 29.0, 4.0, label, 7.5, colour=MUTED)
        y += max(4.0, p.wrapped(x0 + 30.2, y + 0.35, w - 31.4, value, 7.5)) + 0.6
    for k, line in enumerate(data.conventions):
        p.text(x0 + 1.2, y, 29.0, 4.0, "Conventions" if k == 0 else "", 7.5, colour=MUTED)
        y += max(4.0, p.wrapped(x0 + 30.2, y + 0.35, w - 31.4, line, 7.5)) + 0.6
    if data.normative is not None:
        nb = data.normative
        p.text(x0 + 1.2, y, 29.0, 4.0, "Reference band", 7.5, colour=MUTED)
        ref = f"{nb.label}; source: {_cut(nb.source, 420)}; licence: {_cut(nb.licence, 120)}"
        y += max(4.0, p.wrapped(x0 + 30.2, y + 0.35, w - 31.4, ref, 7.5)) + 0.6

    # -- footer, and the clinician's comments in the space left above it
    fy = PAGE_H_MM - 12.0
    y += 4.0
    if fy - 4.0 - y >= 16.0:
        y = p.section(x0, y, w, "Clinician's comments")
        painter.setPen(p.pen(RULE, 0.2))
        painter.setBrush(Qt.BrushStyle.NoBrush)
        painter.drawRect(p.rect(x0, y, w, fy - 4.0 - y))
        p.text(
            x0 + w - 62.0,
            fy - 10.0,
            60.0,
            4.0,
            "signature / date: ____________________",
            7.0,
            colour=MUTED,
            align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
        )
    p.hline(x0, x1, fy, RULE, 0.25)
    p.text(
        x0,
        fy + 0.8,
        w * 0.8,
        4.0,
        "Sagittal-plane angles from body-worn inertial sensors; for review by a clinician "
        "alongside the full recording.",
        6.5,
        colour=MUTED,
    )
    p.text(
        x0 + w * 0.8,
        fy + 0.8,
        w * 0.2,
        4.0,
        "page 1 of 1",
        6.5,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )


# --------------------------------------------------------------------------------------------
# writers


def _tmp_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def write_report_pdf(data: ReportData, path: str | os.PathLike[str], *, dpi: int = 600) -> Path:
    """Write the one-page A4 PDF (atomically: a temporary file renamed at the end)."""
    ensure_gui_app()
    path = Path(path)
    tmp = _tmp_path(path)
    writer = QPdfWriter(str(tmp))
    writer.setResolution(dpi)
    writer.setPageLayout(
        QPageLayout(
            QPageSize(QPageSize.PageSizeId.A4),
            QPageLayout.Orientation.Portrait,
            QMarginsF(0, 0, 0, 0),
            QPageLayout.Unit.Millimeter,
        )
    )
    writer.setCreator(data.software)
    writer.setTitle(
        "Gait analysis report"
        + (
            f" {data.header.patient_id}"
            if data.header.patient_id and not data.header.deidentified
            else ""
        )
    )
    painter = QPainter()
    if not painter.begin(writer):
        tmp.unlink(missing_ok=True)
        raise OSError(f"cannot write {path}")
    try:
        paint_report(painter, writer, data)
    finally:
        painter.end()
    del writer
    if not tmp.exists() or tmp.stat().st_size == 0:
        tmp.unlink(missing_ok=True)
        raise OSError(f"cannot write {path}")
    os.replace(tmp, path)
    return path


def render_report_image(data: ReportData, dpi: float = 150.0) -> QImage:
    """The page as an image (for a preview, or the README)."""
    ensure_gui_app()
    size = QSizeF(PAGE_W_MM / 25.4 * dpi, PAGE_H_MM / 25.4 * dpi)
    img = QImage(round(size.width()), round(size.height()), QImage.Format.Format_RGB32)
    dpm = round(dpi / 0.0254)
    img.setDotsPerMeterX(dpm)
    img.setDotsPerMeterY(dpm)
    img.fill(QColor("#ffffff"))
    painter = QPainter(img)
    try:
        painter.setRenderHint(QPainter.RenderHint.Antialiasing, True)
        paint_report(painter, img, data)
    finally:
        painter.end()
    return img


def write_report_png(data: ReportData, path: str | os.PathLike[str], *, dpi: float = 150.0) -> Path:
    path = Path(path)
    tmp = _tmp_path(path)
    # QImageWriter: QImage.save's format argument is typed as bytes but only takes a str
    if not QImageWriter(str(tmp), b"PNG").write(render_report_image(data, dpi)):
        tmp.unlink(missing_ok=True)
        raise OSError(f"cannot write {path}")
    os.replace(tmp, path)
    return path
