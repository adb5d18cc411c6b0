"""PNG / SVG export of any plot, and the context-menu action the review window attaches.

``export_plot(target, path)`` writes what a plot shows through pyqtgraph's own exporters
(ImageExporter for PNG, SVGExporter for SVG), so the file matches the screen: same traces,
colours and axes. ``target`` may be a PlotItem, a PlotWidget, a GraphicsLayoutWidget (the whole
layout: every plot in it) or any item in a scene.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pyqtgraph as pg
import pyqtgraph.exporters as pg_exporters
from PySide6.QtGui import QAction
from PySide6.QtWidgets import QFileDialog, QMenu, QMessageBox, QWidget

FORMATS: dict[str, str] = {".png": "PNG image (*.png)", ".svg": "SVG vector image (*.svg)"}
DEFAULT_PNG_WIDTH_PX = 1600  # wide enough for a slide or a printed page


def _close_paths_explicitly(node: object) -> None:
    """Rewrite each 'Z' in the SVG paths under ``node`` as a line back to the subpath start.

    Why: Qt 6.11's QSvgGenerator closes paths with a bare 'Z' token, which pyqtgraph 0.14's
    SVGExporter cannot parse (it expects every token to be 'x,y'); the explicit line draws the
    same outline and fills the same area.
    """
    for el in node.getElementsByTagName("path"):  # type: ignore[attr-defined]
        d = el.getAttribute("d")
        if "Z" not in d and "z" not in d:
            continue
        out: list[str] = []
        start = ""
        for tok in d.split():
            if tok in ("Z", "z"):
                if start:
                    out.append("L" + start)
                continue
            if tok[0] in "Mm":
                start = tok[1:]
            out.append(tok)
        el.setAttribute("d", " ".join(out))


def _patch_svg_exporter() -> None:
    # the package re-exports the class under the module's name, so the module is looked up in
    # sys.modules after a plain import
    import pyqtgraph.exporters.SVGExporter  # noqa: F401

    module = sys.modules["pyqtgraph.exporters.SVGExporter"]
    original = getattr(module, "correctCoordinates", None)
    if original is None or getattr(original, "_gaitmon_patched", False):
        return

    def correct_coordinates(node: Any, defs: Any, item: Any, options: Any = None) -> Any:
        _close_paths_explicitly(node)
        return original(node, defs, item, options)

    correct_coordinates._gaitmon_patched = True  # type: ignore[attr-defined]
    module.__dict__["correctCoordinates"] = correct_coordinates


class PlotExportError(Exception):
    """The plot could not be written; the message is one line."""


def _export_item(target: object) -> object:
    """What pyqtgraph's exporters accept: a GraphicsItem or a GraphicsScene."""
    if isinstance(target, pg.PlotWidget):
        return target.getPlotItem()
    if isinstance(target, pg.GraphicsView):  # GraphicsLayoutWidget and friends: whole scene
        return target.scene()
    if isinstance(target, pg.GraphicsItem | pg.GraphicsScene):
        return target
    raise PlotExportError(f"cannot export a {type(target).__name__}; give a plot or plot widget")


def export_plot(
    target: object, path: str | os.PathLike[str], *, width_px: int | None = None
) -> Path:
    """Write ``target`` to ``path`` as PNG or SVG (from the extension); returns the path.

    ``width_px`` sets the PNG width (height follows the aspect ratio); default
    ``DEFAULT_PNG_WIDTH_PX``. Raises :class:`PlotExportError` for an unknown extension or a
    failed write.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in FORMATS:
        raise PlotExportError(f"{path.name}: choose a .png or .svg file name")
    if not path.parent.is_dir():
        raise PlotExportError(f"folder {path.parent} does not exist")
    item = _export_item(target)
    if ext == ".png":
        exporter = pg_exporters.ImageExporter(item)
        # pyqtgraph keeps width and height linked by the aspect ratio; set the width only
        exporter.parameters()["width"] = int(width_px or DEFAULT_PNG_WIDTH_PX)
    else:
        _patch_svg_exporter()
        exporter = pg_exporters.SVGExporter(item)
    try:
        exporter.export(str(path))
    except OSError as exc:
        raise PlotExportError(f"cannot write {path}: {exc.strerror or exc}") from None
    if not path.exists() or path.stat().st_size == 0:
        raise PlotExportError(f"cannot write {path}")
    return path


def ask_and_export(
    target: object, parent: QWidget | None = None, suggested_name: str = "plot.png"
) -> Path | None:
    """Ask for a file name (PNG or SVG) and export; errors are shown in one-line dialogs."""
    path, chosen = QFileDialog.getSaveFileName(
        parent, "Save plot as image", suggested_name, ";;".join(FORMATS.values())
    )
    if not path:
        return None
    p = Path(path)
    if p.suffix.lower() not in FORMATS:  # the user typed no extension: take the chosen filter
        p = p.with_suffix(".svg" if "svg" in chosen.lower() else ".png")
    try:
        return export_plot(target, p)
    except PlotExportError as exc:
        QMessageBox.warning(parent, "Plot not saved", str(exc))
        return None


def make_export_action(
    target: object | Callable[[], object],
    parent: QWidget,
    *,
    text: str = "Save plot as PNG / SVG…",
    suggested_name: str = "plot.png",
) -> QAction:
    """A QAction that exports ``target`` (or what a callable returns at trigger time)."""
    action = QAction(text, parent)

    def trigger() -> None:
        t = target() if callable(target) else target
        ask_and_export(t, parent, suggested_name)

    action.triggered.connect(trigger)
    return action


def attach_export_action(
    plot: pg.PlotItem | pg.PlotWidget, parent: QWidget, suggested_name: str = "plot.png"
) -> QAction:
    """Add the export action to the plot's right-click (ViewBox) menu; returns the action."""
    item = plot.getPlotItem() if isinstance(plot, pg.PlotWidget) else plot
    action = make_export_action(item, parent, suggested_name=suggested_name)
    menu: QMenu | None = item.getViewBox().menu
    if menu is not None:
        menu.addSeparator()
        menu.addAction(action)
    return action
