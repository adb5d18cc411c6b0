"""Live-monitor speed: GUI-thread CPU, redraw rate and sample-to-screen latency.

Runs the real window against the simulated unit over a pseudo-terminal (100 Hz, real time, the
same path as hardware) and measures, after a warm-up:

* GUI thread CPU in % of one core (``time.thread_time`` of the main thread; the engine,
  device and simulator threads are reported separately as "whole process");
* redraw rate: paints of the live plot widget per second;
* latency: paint finished - host receive time of the newest sample drawn, p50 / p95.

Budget (100 Hz input, default view): GUI thread <= 30 % of one core, >= 30 fps, p95 <= 50 ms.

    QT_QPA_PLATFORM=offscreen python benchmarks/bench_gui.py            # or under xvfb-run
    python benchmarks/bench_gui.py --seconds 20 --window 30 --raw-dock
    python benchmarks/bench_gui.py --variants   # also pen width 2 / antialiased, same run
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import threading
import time

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QEventLoop, QSettings, QTimer
from PySide6.QtWidgets import QApplication

from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.ui.live import MainWindow


def _spin(app: QApplication, seconds: float) -> None:
    """Run the real event loop for ``seconds``."""
    loop = QEventLoop()  # app.quit() would close the window (Qt 6)
    QTimer.singleShot(round(seconds * 1000), loop.quit)
    loop.exec()


def measure(app: QApplication, win: MainWindow, seconds: float) -> dict[str, float]:
    live = win.live
    live.latencies_s.clear()
    paints0 = live.paints
    samples0 = win.engine.samples_total
    wall0, gui0, proc0 = time.monotonic(), time.thread_time(), time.process_time()
    _spin(app, seconds)
    wall = time.monotonic() - wall0
    gui = time.thread_time() - gui0
    proc = time.process_time() - proc0
    lat = np.array(live.latencies_s) * 1000.0
    return {
        "gui_cpu_pct": 100.0 * gui / wall,
        "process_cpu_pct": 100.0 * proc / wall,
        "fps": (live.paints - paints0) / wall,
        "lat_p50_ms": float(np.percentile(lat, 50)) if len(lat) else float("nan"),
        "lat_p95_ms": float(np.percentile(lat, 95)) if len(lat) else float("nan"),
        "input_hz": (win.engine.samples_total - samples0) / wall,
    }


def _restyle(win: MainWindow, width: int, antialias: bool) -> None:
    for tr in win.live.curves:
        tr.pen = pg.mkPen(tr.pen.color(), width=width)
    for info in win.live.plots.values():
        info.traces.antialias = antialias


def screenshot(path: str) -> int:
    """The real window after ~14 s of simulated walking: zeroed, recording, one marker."""
    app = QApplication.instance() or QApplication(sys.argv[:1])
    tmp = tempfile.mkdtemp(prefix="gaitmon-shot-")
    settings = QSettings(os.path.join(tmp, "shot.ini"), QSettings.Format.IniFormat)
    settings.setValue("session/folder", tmp)
    sim = SimConfig(standing_s=2.5)
    win = MainWindow(settings, sim=sim, autoconnect=SIMULATED_PORT, confirm_close=False)
    win.resize(1440, 900)
    win.show()
    while win.engine is None:
        _spin(app, 0.1)
    while win.engine.samples_total < 190:  # standing still: zero the pose
        _spin(app, 0.05)
    win.zero()
    _spin(app, 9.0)
    win.open_session_dialog()
    dlg = win.session_dialog
    dlg.patient.setText("P017")
    dlg.side.setCurrentIndex(dlg.side.findData("R"))
    dlg.operator.setText("demo")
    dlg.accept()
    _spin(app, 2.5)
    win.marker_edit.setText("10 m walk: turn")
    win.add_marker()
    _spin(app, 2.5)
    win.statusBar().clearMessage()
    _spin(app, 0.3)
    ok = win.grab().save(path)
    win.close()
    print(f"saved {path}" if ok else f"could not save {path}")
    return 0 if ok and not win.errors else 1


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=15.0, help="measured seconds per run")
    ap.add_argument("--warmup", type=float, default=4.0, help="seconds before measuring")
    ap.add_argument("--window", type=float, default=10.0, choices=(5.0, 10.0, 30.0))
    ap.add_argument("--raw-dock", action="store_true", help="also show the raw-sensor plots")
    ap.add_argument("--mode", default="raw", choices=("raw", "tilt", "joint"))
    ap.add_argument("--variants", action="store_true", help="also pen width 2, antialiased")
    ap.add_argument(
        "--screenshot", metavar="PNG", help="instead: save the window with live data as PNG"
    )
    args = ap.parse_args(argv)
    if args.screenshot:
        return screenshot(args.screenshot)

    app = QApplication.instance() or QApplication(sys.argv[:1])
    tmp = tempfile.mkdtemp(prefix="gaitmon-bench-")
    settings = QSettings(os.path.join(tmp, "bench.ini"), QSettings.Format.IniFormat)
    sim = SimConfig(standing_s=1.0)
    win = MainWindow(
        settings, sim=sim, autoconnect=SIMULATED_PORT, mode=args.mode, confirm_close=False
    )
    win.resize(1400, 860)
    win.show()
    win.set_window(args.window)
    if args.raw_dock:
        win.raw_dock.show()
    deadline = time.monotonic() + 15
    while win.engine is None and time.monotonic() < deadline:
        app.processEvents(QEventLoop.ProcessEventsFlag.AllEvents, 50)
    if win.engine is None:
        print("could not connect to the simulated unit", file=sys.stderr)
        return 1
    _spin(app, args.warmup)
    print(
        f"platform={app.platformName()} window={args.window:g}s mode={args.mode} "
        f"raw_dock={args.raw_dock} cores={os.cpu_count()} size={win.width()}x{win.height()}"
    )
    runs = [("pen 1, no antialias (shipped)", 1, False)]
    if args.variants:
        runs += [("pen 2, no antialias", 2, False), ("pen 1, antialias", 1, True)]
    for label, width, aa in runs:
        _restyle(win, width, aa)
        r = measure(app, win, args.seconds)
        print(
            f"{label:30s} GUI thread {r['gui_cpu_pct']:5.1f} % of a core | whole process "
            f"{r['process_cpu_pct']:5.1f} % | redraw {r['fps']:5.1f} fps | latency p50 "
            f"{r['lat_p50_ms']:5.1f} ms, p95 {r['lat_p95_ms']:5.1f} ms | input "
            f"{r['input_hz']:5.1f} Hz"
        )
    if win.errors:
        print("window errors:", *win.errors[:3], sep="\n  ")
    win.close()
    left = [t.name for t in threading.enumerate() if t.name.startswith("gaitmon")]
    if left:
        print("threads still running:", left, file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
