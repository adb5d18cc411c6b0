"""One joint's cycle plot on the report page: stride curves, mean ± SD band, the optional
reference band, toe off, axes and labels, drawn with QPainter as vector paths (sharp at any zoom
in the PDF, and no widget needed).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QBrush, QColor, QPainter, QPainterPath

from gaitmon.report import JOINT_AXIS_LABELS, JOINT_TITLES, ReportData
from gaitmon.ui.report_pdf.page import (
    BAND,
    GRID,
    INK,
    MEAN,
    MUTED,
    NORM,
    STRIDE,
    TOE_OFF,
    Page,
    fmt,
    nice_ticks,
)

ToPixels = Callable[[float, float], QPointF]  # plot coordinates -> page point

# At most this many strides are drawn faint, evenly chosen across the session: the statistics
# (mean, SD, n) use every included stride, but drawing all 26 000 strides of an 8-hour session
# took 30 s of CPU and made a 52 MB PDF of lines no one can tell apart.
MAX_FAINT_STRIDES = 50


def faint_strides(n: int, limit: int = MAX_FAINT_STRIDES) -> np.ndarray:
    """Indices of the strides drawn faint: all of them up to ``limit``, else ``limit`` spread
    evenly from the first to the last."""
    if n <= limit:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, limit)).astype(np.int64))


def line_path(xs: np.ndarray, ys: np.ndarray, to_px: ToPixels) -> QPainterPath:
    """A polyline through the finite points, broken where a value is missing."""
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


def band_path(xs: np.ndarray, lo: np.ndarray, hi: np.ndarray, to_px: ToPixels) -> QPainterPath:
    """The closed area between ``lo`` and ``hi`` over their finite points."""
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
    # the curves drawn (not the strides left undrawn) and the band set the range
    parts = [data.cycles_deg[faint_strides(data.n_included), :, j].ravel()]
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
    p: Page, data: ReportData, j: int, x: float, y: float, w: float, h: float
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
            fmt(float(t), 0),
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
        painter.fillPath(band_path(nx, nm - ns, nm + ns, to_px), QBrush(NORM))
        painter.setPen(p.pen(QColor("#7a7a7a"), 0.2, Qt.PenStyle.DashLine))
        painter.drawPath(line_path(nx, nm, to_px))
    painter.setPen(p.pen(STRIDE, 0.12))
    strides = QPainterPath()  # one path for all strides: one PDF drawing operation, not n
    for k in faint_strides(n):
        strides.addPath(line_path(xs, data.cycles_deg[k, :, j], to_px))
    painter.drawPath(strides)
    if n:
        mean, sd = data.mean_deg[:, j], data.sd_deg[:, j]
        painter.fillPath(band_path(xs, mean - sd, mean + sd, to_px), QBrush(BAND))
        painter.setPen(p.pen(MEAN, 0.45))
        painter.drawPath(line_path(xs, mean, to_px))
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
