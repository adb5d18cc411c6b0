"""The report page's drawing kit: page size, colours, fonts, number formatting, axis ticks and
the millimetre painter :class:`Page` that every part of the page draws through.

Also :func:`ensure_gui_app`: fonts need a ``QGuiApplication``, so drawing makes one when there
is none (``gaitmon report`` runs headless on the offscreen platform, with no window).
"""

from __future__ import annotations

import math

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import (
    QColor,
    QFont,
    QFontMetricsF,
    QGuiApplication,
    QPaintDevice,
    QPainter,
    QPen,
)

from gaitmon.report import JointStat
from gaitmon.text import num

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
# the normal band: amber (not the session's blue, not the toe-off line's dark grey), its fill
# opaque enough to show a band 1-2 deg wide, opaque light edges and a solid mean line
NORM = QColor(208, 128, 0, 80)
NORM_MEAN = QColor("#d08000")
NORM_EDGE = QColor("#ebc483")
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


def fmt(v: float, decimals: int = 1) -> str:
    """A number with a true minus sign and no negative zero; a dash when there is none (NaN)."""
    return num(v, decimals, minus="−")


def fmt_pm(mean: float, sd: float, decimals: int = 1, unit: str = "") -> str:
    """The mean ± SD with its unit; the mean alone when there is no SD (fewer than 2 strides)."""
    u = f" {unit}" if unit else ""
    if not np.isfinite(mean):
        return "–"
    if not np.isfinite(sd):
        return f"{fmt(mean, decimals)}{u}"
    return f"{fmt(mean, decimals)} ± {fmt(sd, decimals)}{u}"


def fmt_stat(s: JointStat, decimals: int = 1, unit: str = "") -> str:
    """A per-stride figure as "mean ± SD unit"."""
    return fmt_pm(s.mean_deg, s.sd_deg, decimals, unit)


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


# word-wrapped text from the top left of its box
_WRAP = int(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop) | int(Qt.TextFlag.TextWordWrap)

class Page:
    """Draws on a painter in millimetres from the page's top left corner (``k`` px per mm)."""

    def __init__(self, painter: QPainter, device: QPaintDevice, px_per_mm: float) -> None:
        self.p = painter
        self.dev = device
        self.k = px_per_mm
        self.page = 0  # the page being drawn (0 = the first)
        self.n_pages = 1
        # every text drawn: (page, x, y, w, h) of its box in mm and the text (layout checks)
        self.boxes: list[tuple[int, float, float, float, float, str]] = []

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
        self.boxes.append((self.page, x, y, w, h, text))
        if elide:
            text = QFontMetricsF(font, self.dev).elidedText(
                text, Qt.TextElideMode.ElideRight, r.width()
            )
        self.p.drawText(r, int(align), text)

    def fitted(
        self,
        x: float,
        y: float,
        w: float,
        h: float,
        text: str,
        size_pt: float,
        *,
        min_pt: float = 6.5,
        bold: bool = False,
        colour: QColor = INK,
    ) -> None:
        """``text`` whole in a box of one line: at ``size_pt`` when it fits, else in a smaller
        type down to ``min_pt``, else word-wrapped at ``min_pt`` from the box's top (two short
        lines may run a little below it). Never elided: a header value cut short ("gaitmon-sim
        f…") says less than the file does."""
        width = self.mm(w)
        size = size_pt
        while size > min_pt and QFontMetricsF(self.font(size, bold), self.dev).horizontalAdvance(
            text
        ) > width:
            size = max(min_pt, size - 0.5)
        font = self.font(size, bold)
        if QFontMetricsF(font, self.dev).horizontalAdvance(text) <= width:
            self.text(x, y, w, h, text, size, bold=bold, colour=colour, elide=False)
            return
        top = max(0.0, (h - self.wrapped_height(w, text, size, bold=bold)) / 2)  # centred
        self.wrapped(x, y + top, w, text, size, bold=bold, colour=colour)

    def wrapped_height(self, w: float, text: str, size_pt: float, *, bold: bool = False) -> float:
        """The height (mm) :meth:`wrapped` uses for ``text`` in a column ``w`` mm wide."""
        fm = QFontMetricsF(self.font(size_pt, bold), self.dev)
        return fm.boundingRect(QRectF(0, 0, self.mm(w), 1e6), _WRAP, text).height() / self.k

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
        h = self.wrapped_height(w, text, size_pt, bold=bold)
        self.boxes.append((self.page, x, y, w, h, text))
        self.p.drawText(QRectF(self.mm(x), self.mm(y), self.mm(w), h * self.k + 1), _WRAP, text)
        return h

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
