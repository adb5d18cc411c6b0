"""The clinical report drawn with Qt's own PDF support (QPdfWriter + QPainter).

Content comes from :mod:`gaitmon.report` (Qt-free); this package only lays it out on A4 pages:
header, the three cycle plots (drawn with QPainter as vector paths, so they stay sharp at any
zoom and need no widget), summary, stride statistics, session notes, gaps, losses and excluded
ranges, markers, settings and conventions. A normal session fits one page; long notes or many
markers, gaps or exclusions continue on further pages, never cut short. :func:`paint_report`
draws on any paint device, so the same code writes the PDF (:func:`write_report_pdf`, every
page) and a PNG preview (:func:`write_report_png`, the first page).

This module owns the writers (PDF, image, PNG; files written atomically). The pages are drawn
by ``sheet`` (the sections), ``flow`` (wrapped lines, rows and tables as blocks, and the
pagination), ``cycle_plot`` (one joint's cycle plot) and ``page`` (colours, fonts, number
formatting, ticks, the millimetre painter, :func:`ensure_gui_app`).

Needs a ``QGuiApplication`` (fonts); :func:`ensure_gui_app` makes one when there is none, so
``gaitmon report`` runs headless on the offscreen platform with no window.
"""

from __future__ import annotations

import os
from pathlib import Path

from PySide6.QtCore import QMarginsF, QSizeF
from PySide6.QtGui import QColor, QImage, QImageWriter, QPageLayout, QPageSize, QPainter, QPdfWriter

from gaitmon.report import ReportData
from gaitmon.ui.report_pdf.cycle_plot import draw_cycle_plot
from gaitmon.ui.report_pdf.page import PAGE_H_MM, PAGE_W_MM, ensure_gui_app, nice_ticks
from gaitmon.ui.report_pdf.sheet import paint_report

__all__ = [
    "draw_cycle_plot",
    "ensure_gui_app",
    "nice_ticks",
    "paint_report",
    "render_report_image",
    "write_report_pdf",
    "write_report_png",
]


def _tmp_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def write_report_pdf(data: ReportData, path: str | os.PathLike[str], *, dpi: int = 600) -> Path:
    """Write the A4 PDF (atomically: a temporary file renamed at the end)."""
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
        paint_report(painter, writer, data, new_page=writer.newPage)
    finally:
        painter.end()
    del writer
    if not tmp.exists() or tmp.stat().st_size == 0:
        tmp.unlink(missing_ok=True)
        raise OSError(f"cannot write {path}")
    os.replace(tmp, path)
    return path


def render_report_image(data: ReportData, dpi: float = 150.0) -> QImage:
    """The first page as an image (for a preview, or the README)."""
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
    """Write the page as a PNG image (atomically, like the PDF)."""
    path = Path(path)
    tmp = _tmp_path(path)
    # QImageWriter: QImage.save's format argument is typed as bytes but only takes a str
    if not QImageWriter(str(tmp), b"PNG").write(render_report_image(data, dpi)):
        tmp.unlink(missing_ok=True)
        raise OSError(f"cannot write {path}")
    os.replace(tmp, path)
    return path
