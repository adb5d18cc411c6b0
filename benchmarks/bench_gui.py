"""Live-monitor speed: GUI-thread CPU, redraw rate and port-to-screen latency of every sample.

Runs the real window against the simulated unit served on a pseudo-terminal by a child process
(100 Hz, real time), which the window opens by its path as it would a unit's serial port: the
same path as hardware (pty -> pyserial -> decoder -> engine -> snapshot -> plots), with no
simulator thread in the window's process. Measures, after a warm-up:

* latency of EVERY sample drawn, from its bytes arriving at the serial port to the end of the
  first paint that shows it. "Arriving" is the simulator's ``os.write`` of the frame's last
  byte to the pty master (timestamped just before the write, so never late; CLOCK_MONOTONIC is
  shared by the processes); the child decodes its own copy of the written byte stream to know
  which write completed which data frame, and the n-th data frame is the engine's sample n.
  The live plot logs, per paint, the newest sample index it shows and when the paint ended:
  sample n is drawn at the first paint whose newest index is >= n. p50 / p95 / max over all
  samples written in the measured time (a sample not drawn by the end counts as drawn at the
  end: none is left out);
* the part of it before the transport's read (port -> read, ``host_time_s``), for comparison;
* GUI thread CPU in % of one core (``time.thread_time`` of the main thread; the engine, device
  and simulator threads are in "whole process");
* redraw rate: paints of the live plot widget per second.

``--load N`` runs N busy processes (``while True: pass``) beside the window. Each measured
segment with the load is preceded by a reference segment of the same window without it (same
process, same run); ``--repeat`` pairs are measured and the medians and the ratios printed.

Goal (issue 14, 100 Hz input, default view, two busy processes): p95 <= 50 ms, >= 29 fps,
GUI thread <= 25 % of one core.

    QT_QPA_PLATFORM=offscreen python benchmarks/bench_gui.py --load 2      # load 0 and 2
    DISPLAY=:94 QT_QPA_PLATFORM=xcb python benchmarks/bench_gui.py --load 2  # a real X server
    python benchmarks/bench_gui.py --seconds 20 --window 30 --raw-dock
    python benchmarks/bench_gui.py --variants   # also pen width 2 / antialiased, same run
    python benchmarks/bench_gui.py --load 2 --scene-paint  # also the whole scene painted
"""

from __future__ import annotations

import argparse
import os
import statistics
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

import gaitmon.io.sim.pty as sim_pty
from gaitmon.io.decoder import FrameDecoder
from gaitmon.io.protocol import JointFrame, RawFrame, TiltFrame
from gaitmon.io.sim.config import SimConfig, serve_on_pty
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.ui.live import MainWindow


def _spin(app: QApplication, seconds: float) -> None:
    """Run the real event loop for ``seconds``."""
    loop = QEventLoop()  # app.quit() would close the window (Qt 6)
    QTimer.singleShot(round(seconds * 1000), loop.quit)
    loop.exec()


def serve(link_path: str) -> int:
    """The child process: serve the simulated unit on a pty at ``link_path``, log every write
    to the port, and answer "dump FILE" on stdin with the write time of each data frame so
    far (``np.save``), in the order written."""
    writes: list[tuple[float, bytes]] = []
    served: list[sim_pty.PtySimulator] = []

    class _Os:  # the pty module's ``os``, with its writes timestamped
        def __getattr__(self, name: str) -> object:
            return getattr(os, name)

        @staticmethod
        def write(fd: int, data: bytes | bytearray) -> int:
            t = time.monotonic()
            n = os.write(fd, data)
            if served and fd == served[0]._master:  # not the wake-up pipe
                writes.append((t, bytes(data[:n])))
            return n

    sim_pty.os = _Os()  # type: ignore[assignment]
    sim = serve_on_pty(SimConfig(standing_s=1.0), link_path)
    served.append(sim)
    print("ready", flush=True)
    dec = FrameDecoder()
    times: list[float] = []
    done = 0
    for line in sys.stdin:
        cmd, _, arg = line.strip().partition(" ")
        if cmd != "dump":
            break
        upto = len(writes)
        for t, data in writes[done:upto]:
            times.extend(
                t for f in dec.feed(data) if isinstance(f, RawFrame | TiltFrame | JointFrame)
            )
        done = upto
        np.save(arg, np.array(times))
        print("ok", flush=True)
    sim.stop()
    return 0


class _Unit:
    """The child process serving the unit, and the arrival times it logged."""

    def __init__(self, tmp: str) -> None:
        self.link_path = os.path.join(tmp, "ttyGAIT0")
        self._dump = os.path.join(tmp, "written.npy")
        self.proc = subprocess.Popen(
            [sys.executable, __file__, "--serve", self.link_path],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert self.proc.stdout is not None
        if self.proc.stdout.readline().strip() != "ready":
            raise RuntimeError("the simulated unit did not start")

    def frame_times(self) -> np.ndarray:
        """Arrival (write) time of each data frame so far: frame n = engine sample n."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(f"dump {self._dump}\n")
        self.proc.stdin.flush()
        self.proc.stdout.readline()
        return np.load(self._dump)

    def stop(self) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.close()
        self.proc.wait(10)


class _PaintLog:
    """(newest engine sample index shown, paint end) of every paint of a plot widget that
    showed new data: the widget's class is swapped for a subclass that logs around the real
    paint."""

    def __init__(self, widget: object) -> None:
        self.log: list[tuple[float, float]] = []
        log = self.log
        base = type(widget)

        def paintEvent(self: object, ev: object) -> None:
            shown = self._shown_idx  # type: ignore[attr-defined]
            base.paintEvent(self, ev)  # type: ignore[arg-type]
            if shown is not None:
                log.append((shown, time.monotonic()))

        widget.__class__ = type(base.__name__, (base,), {"paintEvent": paintEvent})


def drawn_at(idx: np.ndarray, log: list[tuple[float, float]], end_s: float) -> np.ndarray:
    """For each engine sample index, the end of the first paint showing it (a paint shows
    every sample up to its newest); ``end_s`` for samples no paint showed."""
    out = np.full(len(idx), end_s)
    if not log:
        return out
    shown = np.fmax.accumulate(np.array([a for a, _ in log]))  # NaN: no sample shown yet
    shown = np.nan_to_num(shown, nan=-1.0)
    ends = np.array([b for _, b in log])
    k = np.searchsorted(shown, idx, "left")
    ok = k < len(shown)
    out[ok] = ends[k[ok]]
    return out


def frames_before(written: np.ndarray, eng_idx: np.ndarray, host_s: np.ndarray) -> int:
    """How many data frames were written before the engine's sample 0 (frames the device
    dropped while connecting on a busy machine): the largest shift k for which no sample
    is read before it was written (host >= written[idx + k]). Without it every sample was
    timed against a frame written k frames earlier (a standing 2-3 s "latency" in some runs
    on a loaded machine)."""
    eng_idx = eng_idx.astype(np.int64)
    lo, hi = 0, len(written) - 1 - (int(eng_idx.max()) if len(eng_idx) else 0)
    if hi < 0 or not len(eng_idx) or (host_s - written[eng_idx]).min() < 0:
        return 0
    while lo < hi:  # host - written[idx + k] falls with k: the last k where it stays >= 0
        k = (lo + hi + 1) // 2
        if (host_s - written[eng_idx + k]).min() >= 0:
            lo = k
        else:
            hi = k - 1
    return lo


def _pct(a: np.ndarray, q: float) -> float:
    return float(np.percentile(a, q)) if len(a) else float("nan")


def measure(
    app: QApplication, win: MainWindow, unit: _Unit, seconds: float, load: int
) -> dict[str, float]:
    live = win.live
    paints = getattr(live, "_paint_log", None)
    if paints is None:
        paints = live._paint_log = _PaintLog(live)  # type: ignore[attr-defined]
    busy = _busy(load)
    try:
        _spin(app, 1.0 if load else 0.2)  # let the busy processes start
        paints.log.clear()
        paints0 = live.paints
        samples0 = win.engine.samples_total
        wall0, gui0, proc0 = time.monotonic(), time.thread_time(), time.process_time()
        loadavg0 = os.getloadavg()[0]
        _spin(app, seconds)
        wall1 = time.monotonic()
        wall = wall1 - wall0
        gui = time.thread_time() - gui0
        proc = time.process_time() - proc0
        fps = (live.paints - paints0) / wall
        samples1 = win.engine.samples_total
        _spin(app, 0.5)  # let the last samples of the segment be drawn
    finally:
        for p in busy:
            p.kill()
            p.wait()
    end = time.monotonic()
    written = unit.frame_times()
    # engine sample index n = the (n + k)-th data frame written: no frame is lost on the pty,
    # but the k written before the engine's sample 0 (frames_before)
    snap = win.engine.snapshot(min(55.0, seconds + 5.0)).series
    eng_idx, host = snap["idx"], snap["host_time_s"]
    real = np.isfinite(eng_idx) & (eng_idx < len(written))
    k = frames_before(written, eng_idx[real], host[real])
    idx = np.arange(samples0, samples1)
    idx = idx[idx + k < len(written)]
    t_port = written[idx + k]
    lat = (drawn_at(idx, paints.log, end) - t_port) * 1000.0
    have = np.isfinite(eng_idx) & (eng_idx >= samples0) & (eng_idx < samples0 + len(idx))
    read = (host[have] - written[eng_idx[have].astype(np.int64) + k]) * 1000.0
    return {
        "gui_cpu_pct": 100.0 * gui / wall,
        "gui_ms_per_frame": 1000.0 * gui / max(1, live.paints - paints0),
        "process_cpu_pct": 100.0 * proc / wall,
        "fps": fps,
        "p50_ms": _pct(lat, 50),
        "p95_ms": _pct(lat, 95),
        "max_ms": float(lat.max()) if len(lat) else float("nan"),
        "n": float(len(lat)),
        "never_drawn": float(np.sum(drawn_at(idx, paints.log, np.inf) == np.inf)),
        "read_p95_ms": _pct(read, 95),
        "read_min_ms": float(read.min()) if len(read) else float("nan"),
        "input_hz": (samples1 - samples0) / wall,
        "loadavg": loadavg0,
        "frames_before": float(k),
    }


def _print_segment(label: str, r: dict[str, float]) -> None:
    print(
        f"  {label:22s} GUI thread {r['gui_cpu_pct']:5.1f} % "
        f"({r['gui_ms_per_frame']:4.1f} ms/frame) | process {r['process_cpu_pct']:5.1f}"
        f" % | {r['fps']:5.1f} fps | input {r['input_hz']:5.1f} Hz | port -> painted, all "
        f"{r['n']:.0f} samples: p50 {r['p50_ms']:5.1f}, p95 {r['p95_ms']:5.1f}, max "
        f"{r['max_ms']:6.1f} ms (port -> read p95 {r['read_p95_ms']:4.1f} ms) | "
        f"loadavg {r['loadavg']:.1f} | frames before sample 0: {r['frames_before']:.0f}",
        flush=True,
    )
    if r["never_drawn"]:
        print(f"  {'':22s} {r['never_drawn']:.0f} samples were never drawn", flush=True)
    if r["read_min_ms"] < 0:
        print("  the frame <-> sample mapping is off (read before written)", file=sys.stderr)


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
    win.recording_part.open_session_dialog()
    dlg = win.recording_part.session_dialog
    dlg.patient.setText("P017")
    dlg.side.setCurrentIndex(dlg.side.findData("R"))
    dlg.operator.setText("demo")
    dlg.accept()
    _spin(app, 2.5)
    win.marker_edit.setText("10 m walk: turn")
    win.recording_part.add_marker()
    _spin(app, 2.5)
    win.statusBar().clearMessage()
    _spin(app, 0.3)
    ok = win.grab().save(path)
    win.close()
    print(f"saved {path}" if ok else f"could not save {path}")
    return 0 if ok and not win.errors else 1


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="measured seconds per segment")
    ap.add_argument("--repeat", type=int, default=3, help="segments of each kind (medians)")
    ap.add_argument("--warmup", type=float, default=4.0, help="seconds before measuring")
    ap.add_argument("--window", type=float, default=10.0, choices=(5.0, 10.0, 30.0))
    ap.add_argument("--raw-dock", action="store_true", help="also show the raw-sensor plots")
    ap.add_argument("--mode", default="raw", choices=("raw", "tilt", "joint"))
    ap.add_argument("--variants", action="store_true", help="also pen width 2, antialiased")
    ap.add_argument("--load", type=int, default=0, help="busy processes beside the window")
    ap.add_argument(
        "--scene-paint",
        action="store_true",
        help="also the window painting its whole scene every frame (the code path before the "
        "layered painting), same run",
    )
    ap.add_argument(
        "--screenshot", metavar="PNG", help="instead: save the window with live data as PNG"
    )
    ap.add_argument("--serve", metavar="LINK", help=argparse.SUPPRESS)  # the child process
    args = ap.parse_args(argv)
    if args.serve:
        return serve(args.serve)
    if args.screenshot:
        return screenshot(args.screenshot)

    app = QApplication.instance() or QApplication(sys.argv[:1])
    tmp = tempfile.mkdtemp(prefix="gaitmon-bench-")
    unit = _Unit(tmp)
    try:
        return _run(app, args, tmp, unit)
    finally:
        unit.stop()


def _run(app: QApplication, args: argparse.Namespace, tmp: str, unit: _Unit) -> int:
    settings = QSettings(os.path.join(tmp, "bench.ini"), QSettings.Format.IniFormat)
    win = MainWindow(settings, autoconnect=unit.link_path, mode=args.mode, confirm_close=False)
    win.resize(1400, 860)
    win.show()
    win.view_part.set_window(args.window)
    if args.raw_dock:
        win.raw_dock.show()
    deadline = time.monotonic() + 60  # a busy machine starts the simulator slowly
    while win.engine is None and time.monotonic() < deadline:
        app.processEvents(QEventLoop.ProcessEventsFlag.AllEvents, 50)
    if win.engine is None:
        print(f"could not connect to the simulated unit: {win.errors}", file=sys.stderr)
        return 1
    _spin(app, args.warmup)
    print(
        f"platform={app.platformName()} window={args.window:g}s mode={args.mode} "
        f"raw_dock={args.raw_dock} cores={os.cpu_count()} size={win.width()}x{win.height()} "
        f"segments={args.repeat}x{args.seconds:g}s load={args.load} busy process(es), "
        f"load average before {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    loads = [0] if args.load == 0 else [0, args.load]
    # (name, busy processes, layered painting); the first is the reference of the ratios
    conditions = [(f"load {n}", n, True) for n in loads]
    if args.scene_paint:  # the previous code path: the whole scene painted every frame
        conditions += [(f"load {n}, scene paint", n, False) for n in loads]
    styles = [("pen 1, no antialias (shipped)", 1, False)]
    if args.variants:
        styles += [("pen 2, no antialias", 2, False), ("pen 1, antialias", 1, True)]
    keys = ("gui_cpu_pct", "gui_ms_per_frame", "fps", "p50_ms", "p95_ms", "max_ms")
    shorts = ("gui", "ms/frame", "fps", "p50", "p95", "max")
    for label, width, aa in styles:
        _restyle(win, width, aa)
        print(label)
        res: dict[str, list[dict[str, float]]] = {c[0]: [] for c in conditions}
        for _ in range(args.repeat):  # the reference and the others alternate
            for name, n, layered in conditions:
                win.live.layered = layered
                res[name].append(measure(app, win, unit, args.seconds, n))
                _print_segment(name, res[name][-1])
        win.live.layered = True
        med = {c: {k: statistics.median(r[k] for r in rs) for k in keys} for c, rs in res.items()}
        ref_name = conditions[0][0]
        for name, _n, _layered in conditions:
            m = med[name]
            ratio = ""
            if name != ref_name:
                ref = med[ref_name]
                ratio = f" | x {ref_name}: " + ", ".join(
                    f"{short} {m[k] / ref[k]:.2f}"
                    for k, short in zip(keys, shorts, strict=True)
                    if ref[k]
                )
            print(
                f"  MEDIAN {name}: GUI thread {m['gui_cpu_pct']:.1f} % of a core "
                f"({m['gui_ms_per_frame']:.1f} ms per frame), "
                f"{m['fps']:.1f} fps, port -> painted p50 / p95 / max {m['p50_ms']:.0f} / "
                f"{m['p95_ms']:.0f} / {m['max_ms']:.0f} ms{ratio}",
                flush=True,
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
