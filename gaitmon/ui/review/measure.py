"""The review window's part of ``gaitmon bench --suite memory`` (only ``gaitmon.ui`` imports Qt):
open an 8-hour session as a clinician would and report what it cost."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any


def review_memory(
    src: Path, out: Path, peak_rss_mb: Callable[[], float]
) -> dict[str, float]:
    """Open ``src`` in a review window (settings under ``out``), wait for its first view and
    stride analysis, then switch to the live angles and back; CPU seconds and ``peak_rss_mb()``
    after the first view, and the peak after both angle sources were analysed."""
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication

    from gaitmon.ui.review.window import ReviewWindow

    app = QApplication.instance() or QApplication([])
    win = ReviewWindow(QSettings(str(out / "s.ini"), QSettings.Format.IniFormat))
    win.resize(1600, 1000)
    win.show()
    app.processEvents()
    tl = win.timeline

    def wait(cond: Any, timeout: float = 600.0) -> None:
        t_end = time.monotonic() + timeout
        while not cond():
            app.processEvents()
            if time.monotonic() > t_end:
                raise TimeoutError
            time.sleep(0.002)

    t0 = time.process_time()
    win.open_file(src)
    wait(lambda: tl.applied_requests > 0)
    tl.glw.viewport().repaint()
    wait(lambda: win.analysis is not None)
    first = {"cpu_s": time.process_time() - t0, "rss_mb": peak_rss_mb()}
    done: list[int] = []
    win.analysis_done.connect(lambda: done.append(1))
    for angles in ("live", "smoothed"):
        done.clear()
        win.act[f"angles_{angles}"].trigger()
        wait(lambda a=angles: win.doc is not None and win.doc.angle_source == a and bool(done))
    both = peak_rss_mb()
    errors = list(win.errors)
    win.close()
    if errors:
        raise RuntimeError(f"review window errors: {errors}")
    return {**first, "both_rss_mb": both}
