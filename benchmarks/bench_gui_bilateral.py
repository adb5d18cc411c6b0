"""GUI-thread cost of the live window's update tick: one leg against both legs, in one run.

Opens the real window twice in one process, first with the simulated unit (one leg), then with
the simulated pair (both legs), each on pseudo-terminals through the real serial code at 100 Hz
in real time, and times the window's ~30 Hz update after a warm-up: for one leg the drawing of
each frame the engine thread prepared (``_show_frame``: hand the arrays to the curves, paint,
status; every third also the gait panel), for both legs the tick (pull the snapshots, draw,
paint): wall time and GUI-thread CPU time (``time.thread_time``) per update, median and p95,
and the GUI thread's share of one core.

    QT_QPA_PLATFORM=offscreen python benchmarks/bench_gui_bilateral.py [--seconds 15]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QSettings

from gaitmon.io.sim.bilateral import BilateralConfig
from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.live.pair import PairSource
from gaitmon.ui.app import make_application
from gaitmon.ui.live import MainWindow


def measure(app: object, win: MainWindow, ready: object, seconds: float) -> dict[str, float]:
    deadline = time.monotonic() + 60.0
    while not ready() and time.monotonic() < deadline:  # type: ignore[operator]
        app.processEvents()  # type: ignore[attr-defined]
        time.sleep(0.01)
    # one leg: the engine thread prepares the frames and the window draws each in
    # _show_frame (its tick then only says "frames come"); both legs: the tick draws
    timed_calls: dict[str, tuple[list[float], list[float]]] = {"tick": ([], []), "frame": ([], [])}

    def timer(kind: str, fn: Callable[[], None]) -> Callable[[], None]:
        walls, cpus = timed_calls[kind]

        def timed() -> None:
            w0, c0 = time.perf_counter(), time.thread_time()
            fn()
            cpus.append(time.thread_time() - c0)
            walls.append(time.perf_counter() - w0)

        return timed

    win.timer.timeout.disconnect()
    win.timer.timeout.connect(timer("tick", win._tick))
    win.view_part.frame_signal.ready.disconnect()
    win.view_part.frame_signal.ready.connect(timer("frame", win._show_frame))
    warm = time.monotonic() + 3.0
    while time.monotonic() < warm:
        app.processEvents()  # type: ignore[attr-defined]
        time.sleep(0.002)
    for lists in timed_calls.values():
        for v in lists:
            v.clear()
    c0, t0 = time.thread_time(), time.monotonic()
    end = t0 + seconds
    while time.monotonic() < end:
        app.processEvents()  # type: ignore[attr-defined]
        time.sleep(0.002)
    share = (time.thread_time() - c0) / (time.monotonic() - t0)
    win.close()
    walls, cpus = timed_calls["frame" if timed_calls["frame"][0] else "tick"]

    def pct(v: list[float], q: float) -> float:
        return sorted(v)[min(len(v) - 1, int(q * len(v)))] * 1e3

    return {
        "updates/s": len(walls) / seconds,
        "wall ms p50": statistics.median(walls) * 1e3,
        "wall ms p95": pct(walls, 0.95),
        "cpu ms p50": statistics.median(cpus) * 1e3,
        "cpu ms p95": pct(cpus, 0.95),
        "GUI thread % of a core": share * 100,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=15.0)
    args = ap.parse_args()
    app = make_application("bench")
    tmp = Path(tempfile.mkdtemp(prefix="gaitmon-bench-"))
    results = {}
    settings = QSettings(str(tmp / "one.ini"), QSettings.Format.IniFormat)
    one = MainWindow(settings, sim=SimConfig(standing_s=1.0), autoconnect=SIMULATED_PORT,
                     mode="raw", confirm_close=False)  # fmt: skip
    one.resize(1400, 860)
    one.show()
    results["one leg"] = measure(
        app, one, lambda: one.engine is not None and one.engine.samples_total > 300, args.seconds
    )
    cfg = BilateralConfig(standing_s=1.0, asymmetry="hemiparetic")
    settings = QSettings(str(tmp / "both.ini"), QSettings.Format.IniFormat)
    both = MainWindow(settings, pair_sim=cfg, pair=PairSource(sim=cfg), mode="raw",
                      confirm_close=False)  # fmt: skip
    both.resize(1400, 860)
    both.show()
    results["both legs"] = measure(
        app, both,
        lambda: both.pair is not None
        and min(e.samples_total for e in both.pair.engines.values()) > 300,
        args.seconds,
    )  # fmt: skip
    keys = list(next(iter(results.values())))
    print(f"{'':10s}" + "".join(f"{k:>24s}" for k in keys))
    for name, r in results.items():
        print(f"{name:10s}" + "".join(f"{r[k]:24.1f}" for k in keys))
    return 0


if __name__ == "__main__":
    sys.exit(main())
