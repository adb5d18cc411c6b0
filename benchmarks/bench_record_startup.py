"""How long after launch a recording's file exists (issue 12, defect 7), before and after.

    gaitmon record --simulate --duration 30 -o FILE      launch -> FILE and FILE.journal exist

Until the file exists, a crash loses everything already received. The figure is wall seconds
from ``Popen`` to both paths existing (polled every 2 ms), as a median over ``--runs`` runs,
for this checkout ("after") and, with ``--before DIR``, for another checkout of gaitmon (e.g.
the main branch: "before"), interleaved in the same run. Also printed: launch -> first row
recorded (the first ``ROWS`` status line), and the unit's sequence number of the file's first
row: the frames it sent before the recording began, all lost had the process died then (the
simulated unit spends its first 3 numbers answering the start-up commands).

Run: python benchmarks/bench_record_startup.py [--runs 7] [--speed 20] [--before /work/main]
(prints figures; no assertions: timings do not belong in pass/fail tests).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def one_run(checkout: Path, out: Path, speed: str) -> tuple[float, float, int]:
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    journal = out.with_name(out.name + ".journal")
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "gaitmon", "record", "--simulate", "--duration", "30",
         "-o", str(out), "--quiet", "--status-lines", "--speed", speed],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, text=True,
    )  # fmt: skip
    t_file = float("nan")
    try:
        while proc.poll() is None:
            if out.exists() and journal.exists():
                t_file = time.perf_counter() - t0
                break
            time.sleep(0.002)
        assert proc.stdout is not None
        line = proc.stdout.readline()  # the first "ROWS n t" line: a row was recorded
        t_row = time.perf_counter() - t0 if line.startswith("ROWS") else float("nan")
    finally:
        proc.terminate()  # SIGTERM: the recording stops cleanly
        proc.wait(timeout=60)
    import h5py

    with h5py.File(out, "r") as f:
        seq = f["timeline/seq"]
        first_seq = int(seq[0]) if seq.shape[0] else -1
    return t_file, t_row, first_seq


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--speed", default="20",
                    help="simulator time factor (default 20: start-up windows show as frames)")
    ap.add_argument("--before", type=Path, default=None,
                    help="another gaitmon checkout to compare with (e.g. /work/main)")
    a = ap.parse_args()
    checkouts = {"after": HERE}
    if a.before is not None:
        checkouts = {"before": a.before.resolve(), **checkouts}
    results: dict[str, list[tuple[float, float, int]]] = {k: [] for k in checkouts}
    with tempfile.TemporaryDirectory() as d:
        for i in range(a.runs):
            for name, checkout in checkouts.items():  # interleaved: the same load for both
                results[name].append(one_run(checkout, Path(d) / f"{name}{i}.h5", a.speed))
    load = os.getloadavg()[0]
    print(f"launch -> file + journal exist (median of {a.runs}, simulator x{a.speed}, "
          f"load {load:.1f}):")
    for name, runs in results.items():
        files = [f for f, _, _ in runs]
        rows = [r for _, r, _ in runs]
        seqs = [s for _, _, s in runs]
        print(f"  {name:6s}  file {statistics.median(files):6.3f} s (max {max(files):.3f}); "
              f"first row recorded {statistics.median(rows):6.3f} s; first row's sequence "
              f"number {statistics.median(seqs):.0f} (max {max(seqs)})")
    if "before" in results:
        b = statistics.median(f for f, _, _ in results["before"])
        c = statistics.median(f for f, _, _ in results["after"])
        print(f"  file exists {b - c:+.3f} s earlier after the change (ratio {c / b:.2f})")


if __name__ == "__main__":
    main()
