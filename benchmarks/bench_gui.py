"""Live-monitor speed: GUI-thread CPU, redraw rate and sample-to-screen latency.

Runs the real window against the simulated unit over a pseudo-terminal (100 Hz, real time, the
same path as hardware) and measures, after a warm-up:

* GUI thread CPU in % of one core (``time.thread_time`` of the main thread; the engine,
  device and simulator threads are reported separately as "whole process");
* redraw rate: paints of the live plot widget per second;
* latency of EVERY sample drawn: paint finished - the time the transport read the sample's
  bytes from the serial port (``host_time_s``, time.monotonic() at the read), for each sample
  at the first paint that shows it; p50 / p95 / max over all of them (and, as before, of the
  newest sample per paint only).

``--load N`` runs N busy processes (``while True: pass``) beside the window while measuring,
as a busy clinic laptop would.

Budget (100 Hz input, default view): GUI thread <= 25 % of one core, >= 29 fps, p95 <= 50 ms
(with two busy processes beside it).

    QT_QPA_PLATFORM=offscreen python benchmarks/bench_gui.py            # or under xvfb-run
    python benchmarks/bench_gui.py --load 2     # two busy processes on the machine
    python benchmarks/bench_gui.py --seconds 20 --window 30 --raw-dock
    python benchmarks/bench_gui.py --variants   # also pen width 2 / antialiased, same run
"""

from __future__ import annotations

import argparse
import os
import subprocess
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


class _PaintLog:
    """(newest host time shown, paint end) of every paint of the live plots that showed new
    data: the widget's class is swapped for a subclass that logs around the real paint."""

    def __init__(self, widget: object) -> None:
        self.log: list[tuple[float, float]] = []
        log = self.log
        base = type(widget)

        def paintEvent(self: object, ev: object) -> None:
            shown = self._shown_host_time_s  # type: ignore[attr-defined]
            base.paintEvent(self, ev)  # type: ignore[arg-type]
            if shown is not None:
                log.append((shown, time.monotonic()))

        widget.__class__ = type(base.__name__, (base,), {"paintEvent": paintEvent})


def _every_sample_latency_ms(host_s: np.ndarray, log: list[tuple[float, float]]) -> np.ndarray:
    """For each sample received (host read time h), the end of the first paint that showed it
    (the first whose newest sample is at or after h) minus h; samples after the last paint
    are not counted."""
    if not log:
        return np.zeros(0)
    shown = np.array([a for a, _ in log])
    ends = np.array([b for _, b in log])
    shown = np.maximum.accumulate(shown)  # a paint shows everything up to its newest sample
    k = np.searchsorted(shown, host_s, "left")
    ok = k < len(shown)
    return (ends[k[ok]] - host_s[ok]) * 1000.0


def measure(app: QApplication, win: MainWindow, seconds: float) -> dict[str, float]:
    live = win.live
    live.latencies_s.clear()
    paints = _PaintLog(live) if not isinstance(getattr(live, "_paint_log", None), _PaintLog) \
        else live._paint_log
    live._paint_log = paints  # type: ignore[attr-defined]
    paints.log.clear()
    paints0 = live.paints
    samples0 = win.engine.samples_total
    wall0, gui0, proc0 = time.monotonic(), time.thread_time(), time.process_time()
    _spin(app, seconds)
    wall = time.monotonic() - wall0
    gui = time.thread_time() - gui0
    proc = time.process_time() - proc0
    lat = np.array(live.latencies_s) * 1000.0
    host = np.asarray(win.engine.snapshot(min(55.0, seconds + 5.0)).series["host_time_s"])
    host = host[np.isfinite(host) & (host >= wall0)]
    every = _every_sample_latency_ms(host, paints.log)
    return {
        "gui_cpu_pct": 100.0 * gui / wall,
        "process_cpu_pct": 100.0 * proc / wall,
        "fps": (live.paints - paints0) / wall,
        "lat_p50_ms": float(np.percentile(lat, 50)) if len(lat) else float("nan"),
        "lat_p95_ms": float(np.percentile(lat, 95)) if len(lat) else float("nan"),
        "all_p50_ms": float(np.percentile(every, 50)) if len(every) else float("nan"),
        "all_p95_ms": float(np.percentile(every, 95)) if len(every) else float("nan"),
        "all_max_ms": float(every.max()) if len(every) else float("nan"),
        "all_n": float(len(every)),
        "input_hz": (win.engine.samples_total - samples0) / wall,
    }


def _busy(n: int) -> list[subprocess.Popen[bytes]]:
    """n processes that each keep one core busy (ended by the caller, by their pid)."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


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
    ap.add_argument("--load", type=int, default=0, help="busy processes beside the window")
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
    deadline = time.monotonic() + 60  # a busy machine starts the simulator slowly
    while win.engine is None and time.monotonic() < deadline:
        app.processEvents(QEventLoop.ProcessEventsFlag.AllEvents, 50)
    if win.engine is None:
        print("could not connect to the simulated unit", file=sys.stderr)
        return 1
    _spin(app, args.warmup)
    print(
        f"platform={app.platformName()} window={args.window:g}s mode={args.mode} "
        f"raw_dock={args.raw_dock} cores={os.cpu_count()} size={win.width()}x{win.height()} "
        f"load={args.load} busy process(es) + load average {os.getloadavg()[0]:.1f}"
    )
    runs = [("pen 1, no antialias (shipped)", 1, False)]
    if args.variants:
        runs += [("pen 2, no antialias", 2, False), ("pen 1, antialias", 1, True)]
    for label, width, aa in runs:
        _restyle(win, width, aa)
        busy = _busy(args.load)
        try:
            r = measure(app, win, args.seconds)
        finally:
            for p in busy:
                p.kill()
                p.wait()
        print(
            f"{label:30s} GUI thread {r['gui_cpu_pct']:5.1f} % of a core | whole process "
            f"{r['process_cpu_pct']:5.1f} % | redraw {r['fps']:5.1f} fps | input "
            f"{r['input_hz']:5.1f} Hz\n"
            f"{'':30s} serial read -> painted, every sample ({r['all_n']:.0f}): p50 "
            f"{r['all_p50_ms']:5.1f} ms, p95 {r['all_p95_ms']:5.1f} ms, max "
            f"{r['all_max_ms']:5.1f} ms | newest sample per paint: p50 {r['lat_p50_ms']:5.1f} "
            f"ms, p95 {r['lat_p95_ms']:5.1f} ms"
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
