"""``gaitmon bench --suite size``: session file size and write cost, format 1 beside format 2.

For each session length (1 min, 10 min, 1 h, 8 h) the same synthetic raw session (simulated
counts, one simulated hour tiled, through the pipeline) is written twice by
:class:`gaitmon.io.session.SessionWriter`, once as format 1 (uncompressed float32) and once as
format 2 (the current format: quantised, derived, shuffle + gzip), in the same run, each in a
fresh process (so its peak memory is its own). Printed per length and format: file MB, bytes per
frame (file size / rows), the writer's append throughput (rows per CPU second, the pipeline
excluded: what the recorder thread spends; blocks of 100 rows, one flush per 1000 rows, where
live flushes every 100 ms), the close (the smoother and the overview, written once at the
end); then the growth per hour, (8 h - 1 h) / 7, beside the goal (8 hours in 150 MB, 52
bytes per frame).

Child protocol: ``python -m gaitmon.commands.bench_size LENGTH VERSION OUT`` prints one JSON line.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from gaitmon.commands.bench_offline import FS_HZ, LENGTHS_H, _peak_rss_mb

GOAL_BYTES_PER_FRAME = 52.0
GOAL_MB_8H = 150.0


def write_timed(path: Path, hours: float, version: int) -> dict[str, float]:
    """Write the synthetic session; the writer's CPU time measured apart from the pipeline."""
    import numpy as np

    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.finish.closing import close_recording
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
    from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
    from gaitmon.io.sim.sensors import simulate

    n = round(hours * 3600 * FS_HZ)
    base = simulate(min(n, 360_000), GaitModel(GaitConfig(seed=1)), SensorConfig(seed=1)).counts
    pipe = Pipeline()
    hdr = SessionHeader(mode="raw", meta=SessionMeta(patient_id="BENCH-1", side="R"))
    # blocks of 100 rows (live: 1-5), the file flushed and the journal synced every 1000 rows
    # (live: every 100 ms = 10 rows; an fsync per 10 rows of an 8-hour session would make
    # this benchmark take its hours in disk waits, and the sizes do not depend on it)
    block = 100
    flush_every = 1000
    append_cpu = 0.0
    w = SessionWriter(path, hdr, format_version=version, flush_interval_s=1e9)
    host = 1000.0
    for a in range(0, n, block):
        b = min(n, a + block)
        idx = np.arange(a, b)
        counts = base[idx % len(base)]
        # the host receives a block every ~30 ms, with jitter (as a real link does)
        host_t = host + (idx - a) // 3 * 0.03 + 0.001 * ((idx * 7919) % 13) / 13
        blk = SampleBlock(FrameKind.RAW, idx.astype(np.int64), host_t, 1.7e9,
                          lost_before=np.zeros(b - a, np.int64), adc=counts)
        proc = pipe.process(counts)
        t0 = time.process_time()
        w.append(blk, proc)
        if b % flush_every == 0:
            w.flush()
        append_cpu += time.process_time() - t0
        host += (b - a) / FS_HZ
    t0 = time.process_time()
    close_recording(w)
    close_cpu = time.process_time() - t0
    return {"rows": n, "append_cpu_s": append_cpu, "close_cpu_s": close_cpu}


def child(length: str, version: str, out: str) -> None:
    path = Path(out)
    r = write_timed(path, LENGTHS_H[length], int(version))
    r["bytes"] = path.stat().st_size
    r["rss_mb"] = _peak_rss_mb()
    path.unlink()
    print(json.dumps(r))


def _run(length: str, version: int, outdir: Path) -> dict[str, Any]:
    out = outdir / f"{length}-v{version}.h5"
    r = subprocess.run([sys.executable, "-m", "gaitmon.commands.bench_size", length,
                        str(version), str(out)], capture_output=True, text=True, check=False)
    if r.returncode != 0:
        raise RuntimeError(f"writing {length} format {version} failed: {r.stderr.strip()[-300:]}")
    got: dict[str, Any] = json.loads(r.stdout.strip().splitlines()[-1])
    return got


def suite(lengths: list[str], repeat: int) -> int:
    bad = [n for n in lengths if n not in LENGTHS_H]
    if bad:
        from gaitmon.errors import UserError

        raise UserError(f"unknown length {bad[0]!r} (choose from {', '.join(LENGTHS_H)})")
    print(f"gaitmon bench --suite size: {', '.join(lengths)}; format 1 vs 2, median of "
          f"{repeat} run(s) each, fresh process each ({os.cpu_count()} CPUs)", flush=True)
    res: dict[tuple[str, int], dict[str, float]] = {}
    with tempfile.TemporaryDirectory(prefix="gaitmon-bench-size-") as d:
        for name in lengths:
            for v in (1, 2):
                runs = [_run(name, v, Path(d)) for _ in range(repeat)]
                m = {k: statistics.median(float(r[k]) for r in runs) for k in runs[0]}
                res[(name, v)] = m
                print(f"  {name:5s} format {v}: {m['bytes'] / 2**20:8.1f} MB  "
                      f"{m['bytes'] / m['rows']:6.1f} B/frame  append "
                      f"{m['rows'] / max(m['append_cpu_s'], 1e-9) / 1e6:5.2f} M rows/CPU s  "
                      f"close {m['close_cpu_s']:6.2f} CPU s  (process peak RSS "
                      f"{m['rss_mb']:4.0f} MB, simulator included)",
                      flush=True)  # fmt: skip
    print("\n| session | format 1 MB | format 2 MB | ratio | format 1 B/frame | format 2 B/frame "
          "| append M rows/CPU s (1 / 2) | close CPU s (1 / 2) |")
    print("|---|---|---|---|---|---|---|---|")
    for name in lengths:
        a, b = res[(name, 1)], res[(name, 2)]
        rate_a = a["rows"] / a["append_cpu_s"] / 1e6
        rate_b = b["rows"] / b["append_cpu_s"] / 1e6
        print(f"| {name} | {a['bytes'] / 2**20:.1f} | {b['bytes'] / 2**20:.1f} | "
              f"{b['bytes'] / a['bytes']:.2f} | {a['bytes'] / a['rows']:.1f} | "
              f"{b['bytes'] / b['rows']:.1f} | {rate_a:.2f} / {rate_b:.2f} | "
              f"{a['close_cpu_s']:.1f} / {b['close_cpu_s']:.1f} |")  # fmt: skip
    if "1h" in lengths and "8h" in lengths:
        for v in (1, 2):
            a, b = res[("1h", v)], res[("8h", v)]
            per_h = (b["bytes"] - a["bytes"]) / 7
            rows_h = (b["rows"] - a["rows"]) / 7
            print(f"format {v}: {per_h / 2**20:.1f} MB per hour ({per_h / rows_h:.1f} B/frame "
                  f"of growth); 8 h = {b['bytes'] / 2**20:.0f} MB "
                  f"(goal <= {GOAL_MB_8H:.0f} MB, <= {GOAL_BYTES_PER_FRAME:.0f} B/frame)")
    return 0


if __name__ == "__main__":
    if len(sys.argv) == 4 and not sys.argv[1].startswith("-"):
        child(*sys.argv[1:])
    else:
        raise SystemExit(suite(sys.argv[1].split(",") if len(sys.argv) > 1 else list(LENGTHS_H),
                               1))  # fmt: skip
