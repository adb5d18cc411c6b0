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

from PySide6.QtGui import QImage

from gaitmon.report import ReportData
from gaitmon.ui.report_pdf.cycle_plot import draw_cycle_plot
from gaitmon.ui.report_pdf.output import pdf_title, render_a4_image, write_a4_pdf, write_png
from gaitmon.ui.report_pdf.page import ensure_gui_app, nice_ticks
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


def write_report_pdf(data: ReportData, path: str | os.PathLike[str], *, dpi: int = 600) -> Path:
    """Write the A4 PDF (atomically: a temporary file renamed at the end)."""
    h = data.header
    title = pdf_title("Gait analysis report", h.patient_id, h.deidentified)
    return write_a4_pdf(path, lambda painter, device, new_page: paint_report(
        painter, device, data, new_page), creator=data.software, title=title, dpi=dpi,
        dated=not h.deidentified)  # fmt: skip


def render_report_image(data: ReportData, dpi: float = 150.0) -> QImage:
    """The first page as an image (for a preview, or the README)."""
    return render_a4_image(lambda painter, device, _: paint_report(painter, device, data), dpi)


def write_report_png(data: ReportData, path: str | os.PathLike[str], *, dpi: float = 150.0) -> Path:
    """Write the page as a PNG image (atomically, like the PDF)."""
    return write_png(path, render_report_image(data, dpi))
