"""Review window on an 8-hour session: first view, pan/zoom frame times; naive plots beside it.

    .venv/bin/python benchmarks/bench_review.py [--hours 8] [--keep FILE] [--no-naive]

Builds a synthetic session by tiling the walking part of a 40-s simulator recording (so the
data and the events are real pipeline output) up to the requested length, written with h5py
in the layout of docs/file-format.md (chunks of 4096 rows). Then, offscreen:

* review window: time from ``open_file`` to the first painted view (overview + detail lanes),
  then to the stride analysis; pan and zoom steps, each timed from the range change to the
  repaint with the new data (p50/p95); View ▸ Angles ▸ Live and back to Smoothed, each timed
  from the click to the lanes and the stride analysis of those angles (the session stores its
  smoothed angles in ``/smoothed``, tiled like the rest, as every recording does);
* naive: 14 raw channels, every row handed to pyqtgraph (``PlotDataItem.setData``), first
  paint and pan frames;
* pyqtgraph clip-to-view + peak auto-downsampling of the same 14 channels.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gaitmon.io.session import CHUNK_ROWS  # noqa: E402


def build_session(path: Path, hours: float) -> int:
    """Tile a short simulator recording's walking part into an ``hours``-long session."""
    from gaitmon.cli import main as cli_main

    src = path.with_name("bench_review_template.h5")
    if not src.exists():
        cli_main(["record", "--simulate", "--duration", "40", "-o", str(src), "--speed", "max",
                  "--standing-s", "2", "--quiet"])  # fmt: skip
    n_target = int(hours * 3600 * 100)
    with h5py.File(src) as f:
        hs = f["events/heel_strike"][()]
        to = f["events/toe_off"][()]
        a, b = int(hs[1]), int(hs[-2])  # whole strides: the tile joins seamlessly in phase
        period = b - a
        reps = -(-n_target // period)
        n = reps * period
        with h5py.File(path, "w") as g:
            for k, v in f.attrs.items():
                g.attrs[k] = v
            for grp in ("session", "device", "config", "calibration", "link", "markers", "gaps"):
                f.copy(f[grp], g, name=grp)
            for name in [n for n in ("processed", "raw", "smoothed") if n in f]:
                g.create_group(name)
                for k, v in f[name].attrs.items():
                    g[name].attrs[k] = v
            g.create_group("timeline")
            g.create_group("events")
            for name in _per_sample(f):
                ds = f[name]
                tile = ds[a:b]
                out = g.create_dataset(name, shape=(n, *ds.shape[1:]), dtype=ds.dtype,
                                       chunks=(CHUNK_ROWS, *ds.shape[1:]),
                                       maxshape=(None, *ds.shape[1:]))  # fmt: skip
                block = np.concatenate([tile] * max(1, (1 << 20) // period))
                for s in range(0, n, len(block)):
                    e = min(n, s + len(block))
                    out[s:e] = block[: e - s]
            g["timeline/t_s"] = np.arange(n) / 100.0
            g["timeline/seq"] = np.arange(n, dtype=np.int64)
            g["timeline/host_time_s"] = np.arange(n) / 100.0
            for name, ev in (("heel_strike", hs), ("toe_off", to)):
                one = ev[(ev >= a) & (ev < b)] - a
                allv = (one[None, :] + period * np.arange(reps)[:, None]).ravel()
                g.create_dataset(f"events/{name}", data=allv.astype(np.int64), maxshape=(None,))
            g.attrs["n_samples"] = n
            g.attrs["duration_s"] = n / 100.0
    return n


def _per_sample(f: h5py.File) -> list[str]:
    out = []
    for grp in ("raw", "processed", "smoothed"):
        out += [f"{grp}/{k}" for k in f[grp]] if grp in f else []
    return out


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, round(q * (len(xs) - 1)))]


def bench_review(path: Path, app) -> dict[str, float]:
    from PySide6.QtCore import QSettings

    from gaitmon.ui.review.window import ReviewWindow

    tmp = tempfile.mkdtemp()
    win = ReviewWindow(QSettings(os.path.join(tmp, "s.ini"), QSettings.Format.IniFormat))
    win.resize(1600, 1000)
    win.show()
    app.processEvents()
    tl = win.timeline

    def wait(cond, timeout=120.0):
        t_end = time.perf_counter() + timeout
        while not cond():
            app.processEvents()
            if time.perf_counter() > t_end:
                raise TimeoutError
            time.sleep(0.0005)

    t0 = time.perf_counter()
    win.open_file(path)
    wait(lambda: tl.applied_requests > 0)
    tl.glw.viewport().repaint()
    first = time.perf_counter() - t0
    wait(lambda: win.analysis is not None)
    analysed = time.perf_counter() - t0
    n_strides = len(win.analysis.rows)

    def step(t_a: float, t_b: float) -> float:
        n0 = tl.applied_requests
        s = time.perf_counter()
        tl.set_view(t_a, t_b)
        app.processEvents()
        wait(lambda: tl.applied_requests > n0 and not tl.loader.busy)
        tl.glw.viewport().repaint()
        return time.perf_counter() - s

    pans = []
    x0 = 3600.0
    for _ in range(60):
        x0 += 3.0
        pans.append(step(x0, x0 + 30.0))
    zooms = []
    centre = 4 * 3600.0
    total = float(win.doc.t_s[-1])
    for w in [10, 30, 120, 600, 1800, 3600, 4 * 3600, total] * 3:
        zooms.append(step(max(0, centre - w / 2), min(total, centre + w / 2)))
    whole_pans = []
    for k in range(20):
        whole_pans.append(step(k * 60.0, k * 60.0 + 7200.0))
    switches = {}
    done: list[int] = []
    win.analysis_done.connect(lambda: done.append(1))
    for angles in ("live", "smoothed"):
        done.clear()
        s = time.perf_counter()
        win.act[f"angles_{angles}"].trigger()
        wait(lambda a=angles: win.doc.angle_source == a and bool(done)
             and (f"recorded/{a}", "processed/joint_deg") in tl.last_window)  # fmt: skip
        tl.glw.viewport().repaint()
        switches[angles] = time.perf_counter() - s
    win.close()
    return {
        "first_view_s": first,
        "analysis_s": analysed,
        "strides": n_strides,
        "pan_p50_ms": 1e3 * statistics.median(pans),
        "pan_p95_ms": 1e3 * pct(pans, 0.95),
        "zoom_p50_ms": 1e3 * statistics.median(zooms),
        "zoom_p95_ms": 1e3 * pct(zooms, 0.95),
        "pan2h_p50_ms": 1e3 * statistics.median(whole_pans),
        "pan2h_p95_ms": 1e3 * pct(whole_pans, 0.95),
        "to_live_s": switches["live"],
        "to_smoothed_s": switches["smoothed"],
    }


def bench_pyqtgraph(path: Path, app, clip: bool, n_pans: int) -> dict[str, float]:
    import pyqtgraph as pg

    t0 = time.perf_counter()
    with h5py.File(path) as f:
        adc = f["raw/adc"][()].astype(np.float64)
        t = f["timeline/t_s"][()]
    read_s = time.perf_counter() - t0
    w = pg.PlotWidget()
    w.resize(1600, 800)
    w.show()
    p = w.getPlotItem()
    if clip:
        p.setClipToView(True)
        p.setDownsampling(auto=True, mode="peak")
    for c in range(adc.shape[1]):
        p.plot(t, adc[:, c], pen=pg.intColor(c), skipFiniteCheck=True)
    w.viewport().repaint()
    app.processEvents()
    first = time.perf_counter() - t0
    frames = []
    x0 = 3600.0
    p.setXRange(x0, x0 + 30, padding=0)
    app.processEvents()
    for _ in range(n_pans):
        x0 += 3.0
        s = time.perf_counter()
        p.setXRange(x0, x0 + 30, padding=0)
        app.processEvents()
        w.viewport().repaint()
        frames.append(time.perf_counter() - s)
    wide = []
    for k in range(max(2, n_pans // 3)):
        s = time.perf_counter()
        p.setXRange(k * 60.0, k * 60.0 + 7200.0, padding=0)
        app.processEvents()
        w.viewport().repaint()
        wide.append(time.perf_counter() - s)
    w.close()
    return {
        "first_view_s": first,
        "read_s": read_s,
        "pan_p50_ms": 1e3 * statistics.median(frames),
        "pan_p95_ms": 1e3 * pct(frames, 0.95),
        "pan2h_p50_ms": 1e3 * statistics.median(wide),
        "pan2h_p95_ms": 1e3 * pct(wide, 0.95),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=8.0)
    ap.add_argument("--keep", type=Path, default=None, help="reuse / keep the session file here")
    ap.add_argument("--no-naive", action="store_true", help="skip the naive full plot")
    args = ap.parse_args()
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance() or QApplication([])
    tmpdir = Path(tempfile.mkdtemp(prefix="bench_review_"))
    path = args.keep or tmpdir / "session_8h.h5"
    if not path.exists():
        s = time.perf_counter()
        n = build_session(path, args.hours)
        print(f"built {path.name}: {n} rows ({n / 360000:.2f} h), "
              f"{path.stat().st_size / 1e6:.0f} MB in {time.perf_counter() - s:.1f} s")  # fmt: skip
    r = bench_review(path, app)
    print(f"\nreview window ({args.hours:g} h, offscreen, 1600x1000)")
    print(f"  first view            {r['first_view_s']:.2f} s   (stride analysis done at "
          f"{r['analysis_s']:.2f} s, {r['strides']} strides)")  # fmt: skip
    print(f"  pan 30-s view         p50 {r['pan_p50_ms']:.1f} ms  p95 {r['pan_p95_ms']:.1f} ms")
    print(f"  zoom 10 s .. 8 h      p50 {r['zoom_p50_ms']:.1f} ms  p95 {r['zoom_p95_ms']:.1f} ms")
    print(f"  pan 2-h view          p50 {r['pan2h_p50_ms']:.1f} ms  p95 {r['pan2h_p95_ms']:.1f} ms")
    print(f"  angles: to live       {r['to_live_s']:.2f} s   back to smoothed "
          f"{r['to_smoothed_s']:.2f} s   (lanes, overview and strides of those angles)")
    rows = [("clip-to-view + peak", bench_pyqtgraph(path, app, True, 30))]
    if not args.no_naive:
        rows.append(("naive full plot", bench_pyqtgraph(path, app, False, 5)))
    for label, q in rows:
        print(f"\npyqtgraph, 14 raw channels, {label}")
        print(f"  first view            {q['first_view_s']:.2f} s   (of which reading "
              f"{q['read_s']:.2f} s)")  # fmt: skip
        print(f"  pan 30-s view         p50 {q['pan_p50_ms']:.1f} ms  p95 {q['pan_p95_ms']:.1f} ms")
        print(f"  pan 2-h view          p50 {q['pan2h_p50_ms']:.1f} ms  "
              f"p95 {q['pan2h_p95_ms']:.1f} ms")  # fmt: skip
    if args.keep is None:
        for p in tmpdir.iterdir():
            p.unlink()
        tmpdir.rmdir()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
