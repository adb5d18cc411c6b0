"""Export time of an 8-hour raw-mode session, per format (CSV, MAT, C3D).

Records the session the way gaitmon does (simulated sensors -> Pipeline -> SessionWriter, one
simulated hour tiled), then times `export_session` for each format in a fresh process so each
peak memory figure (max RSS) is that format's own. Prints seconds, rows/s, output size, RSS.

Run: python benchmarks/bench_export.py [--hours 8] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

FS_HZ = 100.0


def record(path: Path, hours: float) -> int:
    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
    from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
    from gaitmon.io.sim.sensors import simulate

    n = int(hours * 3600 * FS_HZ)
    base = simulate(min(n, 360_000), GaitModel(GaitConfig(seed=1)), SensorConfig(seed=1)).counts
    pipe = Pipeline()
    hdr = SessionHeader(mode="raw", meta=SessionMeta(patient_id="BENCH-1", side="R"))
    block = 60_000  # 10 minutes per append: the writer's speed is not what is measured here
    with SessionWriter(path, hdr) as w:
        for a in range(0, n, block):
            b = min(n, a + block)
            idx = np.arange(a, b)
            counts = base[idx % len(base)]
            blk = SampleBlock(FrameKind.RAW, idx.astype(np.int64), 1000.0 + idx / FS_HZ, 1.7e9,
                              lost_before=np.zeros(b - a, np.int64), adc=counts)
            w.append(blk, pipe.process(counts))
            if a % (block * 6) == 0:
                w.add_marker(f"hour {a // 360_000}")
    return n


def one(src: str, fmt: str, out_dir: str) -> None:
    from gaitmon.io.export import export_session

    t0 = time.perf_counter()
    res = export_session(src, fmt, Path(out_dir) / f"bench.{fmt}", force=True)
    dt = time.perf_counter() - t0
    size = sum(p.stat().st_size for p in res.paths)
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"fmt": fmt, "s": dt, "rows": res.n_samples, "bytes": size,
                      "files": len(res.paths), "rss_mb": rss_mb}))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--hours", type=float, default=8.0)
    ap.add_argument("--formats", default="csv,mat,c3d")
    ap.add_argument("--keep", metavar="DIR", help="work in DIR and keep the files")
    ap.add_argument("--one", nargs=3, metavar=("SRC", "FMT", "OUTDIR"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        one(*args.one)
        return
    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="gaitmon-bench-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        src = work / "bench.h5"
        if src.exists():
            src.unlink()
        t0 = time.perf_counter()
        n = record(src, args.hours)
        print(f"bench_export: recorded {args.hours:g} h raw session = {n:,} rows, "
              f"{src.stat().st_size / 2**20:.0f} MB, in {time.perf_counter() - t0:.1f} s")
        for fmt in args.formats.split(","):
            r = subprocess.run([sys.executable, __file__, "--one", str(src), fmt, str(work)],
                               capture_output=True, text=True, check=False)
            if r.returncode != 0:
                print(f"  {fmt}: failed: {r.stderr.strip().splitlines()[-1:]}")
                continue
            d = json.loads(r.stdout.strip().splitlines()[-1])
            print(f"  {fmt:3s}: {d['s']:6.1f} s  {d['rows'] / d['s'] / 1e3:7.0f} k rows/s  "
                  f"{d['bytes'] / 2**20:7.0f} MB in {d['files']} file(s)  "
                  f"peak RSS {d['rss_mb']:.0f} MB")
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
