"""How fast ``gaitmon batch`` reprocesses a study: local with 1 and 2 workers, Dask with 2.

    python benchmarks/bench_batch.py              # 200 sessions of 10 minutes (~2.8 GB)
    python benchmarks/bench_batch.py --n 40       # smaller

Sessions are simulated walks (``--distinct`` different ones, copied to N files: the cost of a
session does not depend on which walk it is). Each configuration reprocesses all N into a fresh
folder with new settings (cut-off 5 Hz), and the three runs' CSVs must be the same bytes. It
prints sessions/s, the scaling ratio against one worker, the per-session cost split (read /
compute / write) and what a 10,000-session study would take. The Dask run needs
``pip install 'gaitmon[dask]'``. The study is on this machine's disk and mostly in its page
cache (written just before): on a cluster the read comes from a shared file system instead.
"""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from gaitmon.batch import OK, Outcome, run_batch
from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.finish import open_session
from gaitmon.finish.replay import replay_pipeline
from gaitmon.finish.reprocess import REPLAY_CHUNK_ROWS
from gaitmon.finish.smoothed import smoothed_angles
from gaitmon.io.device import SampleBlock
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
from gaitmon.io.session.rows import lost_before_from_gaps
from gaitmon.io.sim import GaitConfig, GaitModel
from gaitmon.io.sim.sensors import realistic_sensors, simulate
from gaitmon.reprocessing import Reprocessing

FS = 100.0
SETTINGS = Reprocessing.of({"cutoff_hz": 5.0})
STUDY = 10_000  # sessions in the study the README extrapolates to


def write_walk(path: Path, seed: int, n: int) -> None:
    counts = simulate(n, GaitModel(GaitConfig(seed=seed)), realistic_sensors(seed)).counts
    header = SessionHeader("raw", FS, meta=SessionMeta(patient_id=f"BENCH-{seed}"),
                           config=PipelineConfig(), calibration=Calibration.identity())  # fmt: skip
    w = SessionWriter(path, header)
    seq = np.arange(n, dtype=np.int64)
    w.append(SampleBlock(FrameKind.RAW, seq, 10.0 + seq / FS, 1.7e9,
                         lost_before=np.zeros(n, np.int64), adc=counts),
             Pipeline(PipelineConfig()).process(counts))  # fmt: skip
    w.close()


def make_study(root: Path, n: int, distinct: int, minutes: float) -> Path:
    walks = root / "walks"
    walks.mkdir(parents=True)
    samples = int(minutes * 60 * FS)
    for k in range(distinct):
        write_walk(walks / f"w{k}.h5", 500 + k, samples)
    study = root / "study"
    for i in range(n):
        dst = study / f"site-{i % 4}" / f"s{i:05d}.h5"
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(walks / f"w{i % distinct}.h5", dst)
    return study


def task_wall(o: Outcome) -> float:
    return o.timing["read_s"] + o.timing["rewrite_s"] + o.timing["analyse_s"]


def compute_only(path: Path) -> tuple[float, float]:
    """(read, compute) CPU seconds of one session: opening it and reading what a reprocessing
    reads, then the pipeline replay and the zero-lag smoother in memory (no writing). CPU
    time, not wall: on a shared machine the wall time measures the other users as well."""
    config = SETTINGS.apply(PipelineConfig())
    t0 = time.thread_time()
    with open_session(path) as s:
        adc, n = s.read("raw/adc"), s.n_samples
        cal, log, table = s.calibration, list(s.calibration_changes), s.header.table
        lost = lost_before_from_gaps(s.gaps, n)
        s.read("timeline/t_s")
    t1 = time.thread_time()
    for _ in replay_pipeline(adc, config, cal, log, table=table, lost_before=lost,
                             chunk_rows=REPLAY_CHUNK_ROWS):  # fmt: skip
        pass
    smoothed_angles(adc, table, cal, log, lost, config.fs_hz)
    return t1 - t0, time.thread_time() - t1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=200, help="sessions (default 200)")
    ap.add_argument("--minutes", type=float, default=10.0, help="each session (default 10)")
    ap.add_argument("--distinct", type=int, default=8, help="different walks (default 8)")
    ap.add_argument("--workdir", help="folder for the study and outputs (default: a temp one)")
    ap.add_argument("--no-dask", action="store_true", help="skip the Dask run")
    args = ap.parse_args()
    root = Path(args.workdir or tempfile.mkdtemp(prefix="gaitmon-bench-batch-"))
    root.mkdir(parents=True, exist_ok=True)
    try:
        return _bench(root, args)
    finally:
        if not args.workdir:
            shutil.rmtree(root, ignore_errors=True)


def _bench(root: Path, args: argparse.Namespace) -> int:
    n = args.n
    t = time.perf_counter()
    study = make_study(root, n, min(args.distinct, n), args.minutes)
    size_mb = sum(p.stat().st_size for p in study.rglob("*.h5")) / 1e6
    print(f"study: {n} sessions of {args.minutes:g} min ({size_mb / n:.1f} MB each, "
          f"{size_mb / 1e3:.2f} GB), made in {time.perf_counter() - t:.0f} s; "
          f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}")  # fmt: skip

    runs: dict[str, tuple[float, tuple[Outcome, ...]]] = {}
    csvs: dict[str, bytes] = {}

    def one(name: str, **kw: object) -> None:
        out = root / f"out-{name.replace(' ', '-')}"
        result = run_batch(study, out, SETTINGS, **kw)  # type: ignore[arg-type]
        assert result.count(OK) == n, [o.reason for o in result.outcomes if o.status != OK]
        runs[name] = (result.elapsed_s, result.outcomes)
        csvs[name] = (out / "summary.csv").read_bytes() + (out / "strides.csv").read_bytes()
        task_s = statistics.mean(task_wall(o) for o in result.outcomes)
        cpu_s = statistics.mean(o.timing["cpu_s"] for o in result.outcomes)
        print(f"  {name:<18} {result.elapsed_s:7.1f} s  {n / result.elapsed_s:6.2f} sessions/s"
              f"  {task_s:6.3f} s ({cpu_s:.3f} s CPU)  (load {os.getloadavg()[0]:.1f})",
              flush=True)  # fmt: skip
        shutil.rmtree(out)

    print("run                  wall      speed            each task: wall (CPU)")
    one("local, 1 worker", jobs=1)
    one("local, 2 workers", jobs=2)
    if not args.no_dask:
        try:
            import dask
            from distributed import LocalCluster
        except ImportError:
            print("  dask: not installed (pip install 'gaitmon[dask]'); skipped")
        else:
            t = time.perf_counter()
            # the nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers, which turns off
            # glibc's adaptive mmap threshold: every large numpy array is then mmap'd and
            # faulted in afresh, ~2x the CPU per session (see README, "Batch reprocessing")
            dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None})
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                              dashboard_address=":0",
                              silence_logs=logging.CRITICAL) as cluster:  # fmt: skip
                started = time.perf_counter() - t
                one("dask, 2 workers", dask=cluster.scheduler_address)
            print(f"  (the LocalCluster took {started:.1f} s to start, not counted)")
    base = runs["local, 1 worker"][0]
    for name, (wall, _) in runs.items():
        if name != "local, 1 worker":
            print(f"scaling {name} / 1 worker: {base / wall:.2f}x")
    same = len(set(csvs.values())) == 1
    print(f"CSVs identical across the runs: {'yes' if same else 'NO'}")

    # per-session cost, from the one-worker run (no contention between our own workers)
    outcomes = runs["local, 1 worker"][1]
    per = statistics.mean(task_wall(o) for o in outcomes)
    cpu = statistics.mean(o.timing["cpu_s"] for o in outcomes)
    parts = {k: statistics.mean(o.timing[k] for o in outcomes)
             for k in ("read_s", "rewrite_s", "analyse_s")}  # fmt: skip
    print(f"per session (1 worker): {per:.3f} s wall in the task (open {parts['read_s']:.3f} + "
          f"rewrite {parts['rewrite_s']:.3f} + analyse {parts['analyse_s']:.3f}), {cpu:.3f} s "
          f"CPU; outside the tasks {base / n - per:.3f} s")  # fmt: skip
    walks = sorted((root / "walks").glob("*.h5"))
    compute_only(walks[0])  # warm: the first call pays for imports
    split = [compute_only(p) for p in walks for _ in range(2)]
    read_c = statistics.median(r for r, _ in split)
    compute_c = statistics.median(c for _, c in split)
    write_c = max(0.0, cpu - read_c - compute_c)
    print(f"  CPU split: read {read_c:.3f} s ({100 * read_c / cpu:.0f} %), compute "
          f"{compute_c:.3f} s ({100 * compute_c / cpu:.0f} %: pipeline replay + smoother), "
          f"write and the rest {write_c:.3f} s ({100 * write_c / cpu:.0f} %: copying the file, "
          f"writing the new series, reading them back for the analysis)")  # fmt: skip
    mb = size_mb / n
    print(f"  I/O per session: {mb:.1f} MB read + {mb:.1f} MB written (the copy) + the new "
          f"series; at {cpu:.2f} CPU-s per session one core moves {2 * mb / cpu:.0f} MB/s")
    for name, (wall, _) in runs.items():
        print(f"  {STUDY:,} sessions at the {name} speed: {STUDY * wall / n / 3600:.1f} h")
    for cores in (2, 64):
        print(f"  {STUDY:,} sessions on {cores} free cores at {cpu:.2f} CPU-s each (storage "
              f"keeping up: {cores * 2 * mb / cpu:.0f} MB/s): "
              f"{STUDY * cpu / cores / 60:.0f} min")  # fmt: skip
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
