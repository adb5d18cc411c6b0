"""The desktop application both windows run in: QApplication, logging, icon, event loop.

The live monitor (:func:`gaitmon.ui.live.run`) and the review window
(:mod:`gaitmon.ui.review.window`) start through :func:`make_application` and
:func:`exec_until_closed`; each window's ``run`` lives with the window.
"""

from __future__ import annotations

import logging
import signal
import sys
from types import TracebackType

from pyqtgraph.util.garbage_collector import GarbageCollector
from PySide6.QtCore import QPointF, Qt, QTimer
from PySide6.QtGui import QColor, QGuiApplication, QIcon, QPainter, QPainterPath, QPen, QPixmap
from PySide6.QtWidgets import QApplication, QWidget

from gaitmon import logs
from gaitmon.ui import desktop

log = logging.getLogger("gaitmon.ui")


def draw_icon(size: int) -> QPixmap:
    """gaitmon's icon drawn at ``size`` px: a knee-angle trace on a disc. The shipped
    ``gaitmon/ui/desktop/gaitmon.png`` is this at 256 px (tests/test_desktop.py compares them)."""
    pm = QPixmap(size, size)
    pm.fill(Qt.GlobalColor.transparent)
    p = QPainter(pm)
    p.setRenderHint(QPainter.RenderHint.Antialiasing)
    p.setBrush(QColor("#1f5fd6"))
    p.setPen(Qt.PenStyle.NoPen)
    p.drawEllipse(0, 0, size, size)
    path = QPainterPath()
    pts = [(0.12, 0.62), (0.3, 0.58), (0.42, 0.66), (0.55, 0.3), (0.68, 0.22), (0.88, 0.6)]
    path.moveTo(QPointF(pts[0][0] * size, pts[0][1] * size))
    for x, y in pts[1:]:
        path.lineTo(QPointF(x * size, y * size))
    p.setPen(QPen(QColor("#3ddc5a"), max(1.5, size / 14)))
    p.setBrush(Qt.BrushStyle.NoBrush)
    p.drawPath(path)
    p.end()
    return pm


def app_icon() -> QIcon:
    """The windows' icon: the shipped file (the one the desktop entry names), drawn only if
    the file is missing or unreadable."""
    icon = QIcon(str(desktop.ICON_PNG))
    if icon.isNull() or not icon.availableSizes():
        icon = QIcon()
        for size in (16, 32, 64, 128, 256):
            icon.addPixmap(draw_icon(size))
    return icon


_gc: GarbageCollector | None = None  # one per process, made with the application


def make_application(program: str, logger: logging.Logger = log) -> QApplication:
    """The QApplication a gaitmon window runs in (the one already made, if any), set up.

    High-DPI pass-through scaling, the organisation and application names (they place
    ``QSettings``), the icon and desktop entry's name (:mod:`gaitmon.ui.desktop`), the log
    file (:mod:`gaitmon.logs`), and an excepthook: an exception escaping a Qt
    virtual (paint, event) is logged to ``logger`` with its traceback and printed as one line,
    ``PROGRAM: internal error: ...``. No application display name is set: Qt would append it
    to every window title ("gaitmon — live monitor — gaitmon").
    """
    QGuiApplication.setHighDpiScaleFactorRoundingPolicy(
        Qt.HighDpiScaleFactorRoundingPolicy.PassThrough
    )
    app = QApplication.instance() or QApplication(sys.argv[:1])
    assert isinstance(app, QApplication)
    app.setOrganizationName("gaitmon")
    app.setApplicationName("gaitmon")
    app.setWindowIcon(app_icon())
    # ties the windows to gaitmon.desktop (the taskbar's icon and name on Wayland and X11)
    QGuiApplication.setDesktopFileName(desktop.DESKTOP_ID)
    # the command line's log (gaitmon.logs) when it set one up, else the same file now
    log_path = logs.current_file() or logs.setup()

    def excepthook(kind: type[BaseException], exc: BaseException, tb: TracebackType | None) -> None:
        # an exception escaping a Qt virtual (paint, event) must not print a traceback
        logger.error("unhandled exception", exc_info=(kind, exc, tb))
        where = f" (details in {log_path})" if log_path else ""
        print(f"{program}: internal error: {exc}{where}", file=sys.stderr)

    sys.excepthook = excepthook
    # Garbage is collected on the GUI thread only (a timer, pyqtgraph's GarbageCollector):
    # left to Python, a collection runs on whichever thread allocates (engine, device,
    # recorder, workers), and PySide destroying QObjects of a cycle there can deadlock against
    # the GUI thread's destructors (seen in the test suite: both waiting on a Qt mutex and the
    # GIL, the whole process frozen).
    global _gc
    if _gc is None:
        _gc = GarbageCollector(interval=1.0)
    return app


def exec_until_closed(app: QApplication, win: QWidget) -> int:
    """Run the event loop; Ctrl-C / SIGTERM in the terminal close ``win`` cleanly."""
    # closing (not quitting) lets the window finish its work, e.g. complete a recording;
    # the timer lets the interpreter run its signal handlers while Qt's loop is waiting
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: win.close())
    wake = QTimer()
    wake.start(250)
    wake.timeout.connect(lambda: None)
    return int(app.exec())
