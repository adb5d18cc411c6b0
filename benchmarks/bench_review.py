"""Review window on an 8-hour session: first view, pan/zoom frame times; naive plots beside it.

    .venv/bin/python benchmarks/bench_review.py [--hours 8] [--keep DIR] [--formats 1,2]
        [--repeat 3] [--pyqtgraph] [--baseline OTHER_TREE]

Builds a synthetic session by tiling the walking part of a 40-s simulator recording (so the
data and the events are real pipeline output) up to the requested length, written with h5py
in the layout of docs/file-format.md (chunks of 4096 rows), once per session format (1:
uncompressed float32; 2: the current, compressed, with its /overview), and measures each in
fresh processes, alternating, side by side. Offscreen:

* review window: time from ``open_file`` to the first painted view (overview + detail lanes),
  then to the stride analysis; pan and zoom steps, each timed from the range change to the
  repaint with the new data (p50/p95); View ▸ Angles ▸ Live and back to Smoothed, each timed
  from the click to the lanes and the stride analysis of those angles (the session stores its
  smoothed angles in ``/smoothed``, tiled like the rest, as every recording does);
* the GUI thread's CPU time per pan step (``time.thread_time``: what the pans cost the GUI
  thread, much less swayed by other processes than the wall time);
* peak RSS of the process (the window with the session open);
* with ``--pyqtgraph``: naive (14 raw channels, every row handed to pyqtgraph) and pyqtgraph's
  clip-to-view + peak auto-downsampling of the same 14 channels.
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
# --baseline: the child runs another tree's gaitmon (this file's benchmark code)
sys.path.insert(0, os.environ.get("GAITMON_BENCH_CODE") or str(ROOT))

from gaitmon.io.session import CHUNK_ROWS, FORMAT_VERSION  # noqa: E402


def build_session(path: Path, hours: float, version: int = FORMAT_VERSION) -> int:
    """Tile a short simulator recording's walking part into an ``hours``-long session of
    format ``version``: 2 (the current one: the template's stored datasets tiled with their
    own dtype and filters, then its /overview computed as a closing recorder does) or 1
    (every series decoded and stored as float32, uncompressed, as format 1 did)."""
    from gaitmon.cli import main as cli_main
    from gaitmon.finish import open_session
    from gaitmon.io.session.codec import COMPRESSION
    from gaitmon.io.session.stored_overview import write_overview

    src = path.with_name("bench_review_template.h5")
    if not src.exists():
        cli_main(["record", "--simulate", "--duration", "40", "-o", str(src), "--speed", "max",
                  "--standing-s", "2", "--quiet"])  # fmt: skip
    n_target = int(hours * 3600 * 100)
    with h5py.File(src) as f, open_session(src) as sess:
        hs = f["events/heel_strike"][()]
        to = f["events/toe_off"][()]
        a, b = int(hs[1]), int(hs[-2])  # whole strides: the tile joins seamlessly in phase
        period = b - a
        reps = -(-n_target // period)
        n = reps * period
        tiles: dict[str, tuple[np.ndarray, dict]] = {}
        if version >= 2:
            for name in _per_sample(f):
                ds = f[name]
                filters = {"compression": ds.compression, "compression_opts":
                           ds.compression_opts, "shuffle": ds.shuffle}
                tiles[name] = (ds[a:b], filters)
        else:
            for name in sess.dataset_names:
                if name.startswith("timeline/"):
                    continue
                sess.use_angles("live")
                tiles[name] = (sess.read_range(a, b, [name])[name], {})
                if name in ("processed/tilt_deg", "processed/joint_deg"):
                    sess.use_angles("smoothed")
                    smooth = name.replace("processed/", "smoothed/")
                    tiles[smooth] = (sess.read_range(a, b, [name])[name], {})
        with h5py.File(path, "w") as g:
            for k, v in f.attrs.items():
                g.attrs[k] = v
            g.attrs["format_version"] = version
            for grp in ("session", "device", "config", "calibration", "link", "markers", "gaps"):
                f.copy(f[grp], g, name=grp)
            for name in [n for n in ("processed", "raw", "smoothed") if n in f]:
                g.create_group(name)
                for k, v in f[name].attrs.items():
                    g[name].attrs[k] = v
            g.create_group("timeline")
            g.create_group("events")
            for name, (tile, filters) in tiles.items():
                out = g.create_dataset(name, shape=(n, *tile.shape[1:]), dtype=tile.dtype,
                                       chunks=(CHUNK_ROWS, *tile.shape[1:]),
                                       maxshape=(None, *tile.shape[1:]), **filters)  # fmt: skip
                # 2**20 rows (whole chunks: a compressed chunk is written once) at a time
                for s in range(0, n, 1 << 20):
                    e = min(n, s + (1 << 20))
                    out[s:e] = tile[np.arange(s, e) % period]
            timeline = {"timeline/t_s": np.arange(n) / 100.0,
                        "timeline/seq": np.arange(n, dtype=np.int64),
                        "timeline/host_time_s": np.arange(n) / 100.0}
            for name, data in timeline.items():
                g.create_dataset(name, data=data, chunks=(CHUNK_ROWS,), maxshape=(None,),
                                 **(COMPRESSION if version >= 2 else {}))  # fmt: skip
            for name, ev in (("heel_strike", hs), ("toe_off", to)):
                one = ev[(ev >= a) & (ev < b)] - a
                allv = (one[None, :] + period * np.arange(reps)[:, None]).ravel()
                g.create_dataset(f"events/{name}", data=allv.astype(np.int64), maxshape=(None,))
            g.attrs["n_samples"] = n
            g.attrs["duration_s"] = n / 100.0
            if version >= 2:
                write_overview(g)
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

    # (like gaitmon.ui.review.measure's wait, on purpose not imported from it: with --baseline
    # this code drives an older tree's gaitmon, which may not have it)
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

    gui_cpu: list[float] = []

    def step(t_a: float, t_b: float) -> float:
        n0 = tl.applied_requests
        c = time.thread_time()  # the GUI thread's CPU (the view worker's is not counted)
        s = time.perf_counter()
        tl.set_view(t_a, t_b)
        app.processEvents()
        wait(lambda: tl.applied_requests > n0 and not tl.loader.busy)
        tl.glw.viewport().repaint()
        gui_cpu.append(time.thread_time() - c)
        return time.perf_counter() - s

    pans = []
    total = float(win.doc.t_s[-1])
    x0 = min(3600.0, total / 8)  # (the 8-h figures pan from hour 1, zoom around hour 4)
    for _ in range(60):
        x0 += 3.0
        pans.append(step(x0, x0 + 30.0))
    pan_cpu = gui_cpu[:]
    zooms = []
    centre = total / 2
    widths = [w for w in (10, 30, 120, 600, 1800, 3600, 4 * 3600) if w < total] + [total]
    for w in widths * 3:
        zooms.append(step(max(0, centre - w / 2), min(total, centre + w / 2)))
    whole_pans = []
    gui_cpu.clear()
    for k in range(20):
        wide = min(7200.0, total / 4)  # 2 h (of 8 h); a quarter of a shorter session
        whole_pans.append(step(k * wide / 120, k * wide / 120 + wide))
    pan2h_cpu = gui_cpu[:]
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
        "pan_cpu_p50_ms": 1e3 * statistics.median(pan_cpu),
        "pan_cpu_p95_ms": 1e3 * pct(pan_cpu, 0.95),
        "pan2h_cpu_p50_ms": 1e3 * statistics.median(pan2h_cpu),
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


def _child(path: Path) -> None:
    """One review run in this (fresh) process: its figures and peak RSS as one JSON line."""
    import json

    from PySide6.QtWidgets import QApplication

    app = QApplication.instance() or QApplication([])
    r = bench_review(path, app)
    with open("/proc/self/status") as f:
        rss = next((int(x.split()[1]) / 1024 for x in f if x.startswith("VmHWM:")), float("nan"))
    print(json.dumps({**r, "rss_mb": rss}), flush=True)


def _run_child(path: Path, code: Path | None = None) -> dict[str, float]:
    import json
    import subprocess

    env = dict(os.environ, GAITMON_BENCH_CODE=str(code or ROOT))
    r = subprocess.run([sys.executable, __file__, "--child", str(path)], capture_output=True,
                       text=True, check=False, env=env)  # fmt: skip
    if r.returncode != 0:
        raise RuntimeError(r.stderr[-2000:])
    out: dict[str, float] = json.loads(r.stdout.strip().splitlines()[-1])
    return out


ROWS = (
    ("first view (s)", "first_view_s", "{:.2f}"),
    ("stride analysis done (s)", "analysis_s", "{:.2f}"),
    ("pan 30-s view p50 (ms)", "pan_p50_ms", "{:.1f}"),
    ("pan 30-s view p95 (ms)", "pan_p95_ms", "{:.1f}"),
    ("pan 30-s view, GUI thread CPU p50 (ms)", "pan_cpu_p50_ms", "{:.1f}"),
    ("pan 30-s view, GUI thread CPU p95 (ms)", "pan_cpu_p95_ms", "{:.1f}"),
    ("zoom 10 s .. 8 h p50 (ms)", "zoom_p50_ms", "{:.1f}"),
    ("zoom 10 s .. 8 h p95 (ms)", "zoom_p95_ms", "{:.1f}"),
    ("pan 2-h view p50 (ms)", "pan2h_p50_ms", "{:.1f}"),
    ("pan 2-h view p95 (ms)", "pan2h_p95_ms", "{:.1f}"),
    ("pan 2-h view, GUI thread CPU p50 (ms)", "pan2h_cpu_p50_ms", "{:.1f}"),
    ("View > Angles > Live (s)", "to_live_s", "{:.2f}"),
    ("and back to Smoothed (s)", "to_smoothed_s", "{:.2f}"),
    ("peak RSS (MB)", "rss_mb", "{:.0f}"),
)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=8.0)
    ap.add_argument("--keep", type=Path, default=None,
                    help="a folder to reuse / keep the session files in")
    ap.add_argument("--formats", default="1,2",
                    help="session format versions compared side by side (default 1,2)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs per format, alternating, each in a fresh process (median)")
    ap.add_argument("--pyqtgraph", action="store_true",
                    help="also plot the 14 raw channels with pyqtgraph (clip-to-view and naive)")
    ap.add_argument("--baseline", type=Path, default=None,
                    help="another source tree (e.g. `git worktree add /tmp/base main`): its "
                    "gaitmon measured beside this one's, alternating, with a ratio column")
    ap.add_argument("--child", type=Path, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child is not None:
        _child(args.child)
        return 0
    formats = [int(v) for v in args.formats.split(",")]
    folder = args.keep or Path(tempfile.mkdtemp(prefix="bench_review_"))
    folder.mkdir(parents=True, exist_ok=True)
    paths = {}
    for v in formats:
        path = folder / f"session_{args.hours:g}h_format{v}.h5"
        if not path.exists():
            s = time.perf_counter()
            n = build_session(path, args.hours, v)
            print(f"built {path.name}: {n} rows ({n / 360000:.2f} h), "
                  f"{path.stat().st_size / 1e6:.0f} MB in {time.perf_counter() - s:.1f} s",
                  flush=True)  # fmt: skip
        paths[v] = path
    # columns: (format, code tree); with --baseline each format runs the other tree's gaitmon
    # then this one's, alternating, so their ratio is measured under the same load
    codes: list[Path | None] = [args.baseline, None] if args.baseline else [None]
    cols = [(v, c) for v in formats for c in codes]
    runs: dict[tuple[int, Path | None], list[dict[str, float]]] = {col: [] for col in cols}

    def name(col: tuple[int, Path | None]) -> str:
        v, c = col
        return f"format {v}" + ("" if not args.baseline else
                                f", {'baseline' if c else 'this tree'}")  # fmt: skip

    for k in range(args.repeat):
        for col in cols:
            r = _run_child(paths[col[0]], col[1])
            runs[col].append(r)
            print(f"  run {k + 1} {name(col)}: first view {r['first_view_s']:.2f} s, pan p50 / "
                  f"p95 {r['pan_p50_ms']:.0f} / {r['pan_p95_ms']:.0f} ms (GUI CPU p50 "
                  f"{r['pan_cpu_p50_ms']:.1f} ms), 2-h pan p95 {r['pan2h_p95_ms']:.0f} ms, "
                  f"RSS {r['rss_mb']:.0f} MB; load {os.getloadavg()[0]:.1f}",
                  flush=True)  # fmt: skip
    print(f"\nreview window, {args.hours:g} h session, offscreen 1600x1000, median of "
          f"{args.repeat} runs (fresh process each), {runs[cols[0]][0]['strides']:.0f} strides"
          + (f"; baseline: {args.baseline}" if args.baseline else ""))
    print("| | " + " | ".join(f"{name(c)} ({paths[c[0]].stat().st_size / 2**20:.0f} MB)"
                             for c in cols)
          + (" | ratio |" if args.baseline else " |"))  # fmt: skip
    print("|---|" + "---|" * (len(cols) + bool(args.baseline)))
    for label, key, fmt in ROWS:
        med = [statistics.median(r[key] for r in runs[c]) for c in cols]
        cells = [fmt.format(m) for m in med]
        if args.baseline:
            cells.append(f"{med[-1] / med[-2]:.2f}×" if med[-2] else "–")
        print(f"| {label} | " + " | ".join(cells) + " |")
    if args.pyqtgraph:
        from PySide6.QtWidgets import QApplication

        app = QApplication.instance() or QApplication([])
        path = paths[formats[-1]]
        for label, q in (("clip-to-view + peak", bench_pyqtgraph(path, app, True, 30)),
                         ("naive full plot", bench_pyqtgraph(path, app, False, 5))):
            print(f"\npyqtgraph, 14 raw channels, {label}")
            print(f"  first view            {q['first_view_s']:.2f} s   (of which reading "
                  f"{q['read_s']:.2f} s)")  # fmt: skip
            print(f"  pan 30-s view         p50 {q['pan_p50_ms']:.1f} ms  "
                  f"p95 {q['pan_p95_ms']:.1f} ms")  # fmt: skip
            print(f"  pan 2-h view          p50 {q['pan2h_p50_ms']:.1f} ms  "
                  f"p95 {q['pan2h_p95_ms']:.1f} ms")  # fmt: skip
    if args.keep is None:
        for p in folder.iterdir():
            p.unlink()
        folder.rmdir()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
