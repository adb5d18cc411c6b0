"""One joint's cycle plot on the report page: stride curves, mean ± SD band, the optional
reference band, toe off, axes and labels, drawn with QPainter as vector paths (sharp at any zoom
in the PDF, and no widget needed).

:func:`draw_cycles` draws one or more curve sets (:class:`gaitmon.report.CycleCurves`) on the
same axes, each in its :class:`CurveStyle`: the one-leg report draws one
(:func:`draw_cycle_plot`), the bilateral report the left and the right leg.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QBrush, QColor, QFontMetricsF, QPainter, QPainterPath

from gaitmon.analysis import evenly_chosen
from gaitmon.normative import NormativeBands
from gaitmon.report import JOINT_AXIS_LABELS, JOINT_TITLES, CycleCurves, ReportData
from gaitmon.ui.report_pdf.page import (
    BAND,
    GRID,
    INK,
    MEAN,
    MUTED,
    NORM,
    NORM_EDGE,
    NORM_MEAN,
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
    return evenly_chosen(n, limit)


@dataclass(frozen=True)
class CurveStyle:
    """How one curve set is drawn. Strokes are opaque (see ``page.STRIDE``); the band is a
    translucent fill."""

    mean: QColor
    band: QColor
    stride: QColor
    toe_off: QColor
    toe_off_label: str = "toe off"


ONE_LEG = CurveStyle(MEAN, BAND, STRIDE, TOE_OFF)


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


def _y_range(sets: Sequence[CycleCurves], normative: NormativeBands | None,
             j: int) -> tuple[float, float]:  # fmt: skip
    # the curves drawn (not the strides left undrawn) and the bands set the range
    parts = []
    for c in sets:
        mean, sd = c.mean_deg[:, j], np.nan_to_num(c.sd_deg[:, j])
        parts += [c.faint_deg[:, :, j].ravel(), mean - sd, mean + sd]
    if normative is not None and np.all(np.isfinite(normative.mean_deg[:, j])):
        nm, ns = normative.mean_deg[:, j], normative.sd_deg[:, j]
        parts += [nm - ns, nm + ns]
    v = np.concatenate(parts) if parts else np.empty(0)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return (-10.0, 10.0)
    lo, hi = float(v.min()), float(v.max())
    pad = max(0.08 * (hi - lo), 2.0)
    return lo - pad, hi + pad


def draw_cycle_plot(
    p: Page, data: ReportData, j: int, x: float, y: float, w: float, h: float
) -> None:
    """One joint's cycle plot of the one-leg report in the box (x, y, w, h) mm."""
    c = data.curves(MAX_FAINT_STRIDES)
    draw_cycles(p, [(c, ONE_LEG)], data.normative, j, x, y, w, h, f"n = {c.n}")


def draw_cycles(
    p: Page, sets: Sequence[tuple[CycleCurves, CurveStyle]], normative: NormativeBands | None,
    j: int, x: float, y: float, w: float, h: float, n_text: str,
) -> None:  # fmt: skip
    """Joint ``j``'s cycle plot in the box (x, y, w, h) mm, axes and labels included: every
    set's faint strides, then every set's band, then every mean over them all."""
    left, bottom, top = 12.5, 9.0, 6.0
    px, py, pw, ph = x + left, y + top, w - left - 1.5, h - top - bottom
    p.text(x + left, y, pw * 0.5, 5.0, JOINT_TITLES[j], 9.5, bold=True)
    p.text(
        x + left + pw * 0.5,
        y,
        pw * 0.5,
        5.0,
        n_text,
        7.0,
        colour=MUTED,
        align=Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter,
    )
    lo, hi = _y_range([c for c, _ in sets], normative, j)
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
    for pct in range(0, 101, 20):
        xx = px + pw * pct / 100.0
        painter.setPen(p.pen(GRID, 0.15))
        painter.drawLine(QPointF(p.mm(xx), p.mm(py)), QPointF(p.mm(xx), p.mm(py + ph)))
        p.text(
            xx - 5.0,
            py + ph + 0.6,
            10.0,
            3.6,
            str(pct),
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
    painter.setBrush(Qt.BrushStyle.NoBrush)
    if normative is not None and np.all(np.isfinite(normative.mean_deg[:, j])):
        nm, ns = normative.mean_deg[:, j], normative.sd_deg[:, j]
        nx = normative.cycle_pct
        painter.fillPath(band_path(nx, nm - ns, nm + ns, to_px), QBrush(NORM))
        painter.setPen(p.pen(NORM_EDGE, 0.15))
        painter.drawPath(line_path(nx, nm - ns, to_px))
        painter.drawPath(line_path(nx, nm + ns, to_px))
        painter.setPen(p.pen(NORM_MEAN, 0.35))  # solid: the toe-off line is the dashed one
        painter.drawPath(line_path(nx, nm, to_px))
    for c, style in sets:
        xs = np.linspace(0.0, 100.0, c.mean_deg.shape[0])
        painter.setPen(p.pen(style.stride, 0.12))
        strides = QPainterPath()  # one path for all strides: one PDF drawing operation, not n
        for k in range(len(c.faint_deg)):
            strides.addPath(line_path(xs, c.faint_deg[k, :, j], to_px))
        painter.drawPath(strides)
    for c, style in sets:
        if c.n:
            xs = np.linspace(0.0, 100.0, c.mean_deg.shape[0])
            mean, sd = c.mean_deg[:, j], c.sd_deg[:, j]
            painter.fillPath(band_path(xs, mean - sd, mean + sd, to_px), QBrush(style.band))
    for c, style in sets:
        if c.n:
            xs = np.linspace(0.0, 100.0, c.mean_deg.shape[0])
            painter.setPen(p.pen(style.mean, 0.45))
            painter.drawPath(line_path(xs, c.mean_deg[:, j], to_px))
        if np.isfinite(c.toe_off_pct):
            xx = p.mm(px + pw * c.toe_off_pct / 100.0)
            painter.setPen(p.pen(style.toe_off, 0.25, Qt.PenStyle.DashLine))
            painter.drawLine(QPointF(xx, p.mm(py)), QPointF(xx, p.mm(py + ph)))
    painter.restore()
    # the toe-off labels one under the other, each beside its line (left of it when another
    # line lies just to its right)
    shown = [(c, s) for c, s in sets if np.isfinite(c.toe_off_pct)]
    for k, (c, style) in enumerate(sorted(shown, key=lambda cs: cs[0].toe_off_pct)):
        tx = px + pw * c.toe_off_pct / 100.0
        lw = QFontMetricsF(p.font(6.0), p.dev).horizontalAdvance(style.toe_off_label) / p.k + 0.6
        lx = tx + 0.6 if k == len(shown) - 1 else tx - 0.6 - lw
        ly = py + 0.3 + 3.4 * k
        # a veil over the curves, so that a curve passing under the label leaves it legible
        p.fill(lx, ly + 0.2, lw, 3.0, QColor(255, 255, 255, 200))
        p.text(lx + 0.3, ly, lw, 3.4, style.toe_off_label, 6.0, colour=style.toe_off,
               elide=False)  # fmt: skip
    if not any(c.n for c, _ in sets):
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
