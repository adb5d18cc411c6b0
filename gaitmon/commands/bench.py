"""``gaitmon bench``: measure the signal pipeline's speed and print the figures.

Figures, not pass/fail: machines are shared and noisy. Alternatives are measured side by side in
the same run so that their ratio means something even when the absolute numbers wander.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from gaitmon.commands.bench_passes import batch_loops, both, smooth, stream
from gaitmon.errors import UserError

ALL_LENGTHS = "1min,10min,1h,8h"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--hours", type=float, default=8.0, help="length of the synthetic record (default 8 h)"
    )
    p.add_argument("--repeat", type=int, default=None,
                   help="best of N runs (default 3; --suite memory: 1)")
    p.add_argument(
        "--suite",
        choices=("pipeline", "offline", "size", "memory", "whole"),
        default="pipeline",
        help="pipeline: the signal chain (default); offline: info, export and report cost over "
        "1 min .. 8 h sessions beside references (medians of --repeat runs); size: session "
        "file size and write cost, format 1 beside format 2; memory: peak RSS of the review "
        "window, process, recovery, info, report and the recorder's close beside references; "
        "whole: issue 28's goals, each whole command and its reference alternated",
    )
    p.add_argument(
        "--lengths",
        default=None,
        help="session lengths for --suite offline, size and memory (1min, 10min, 20min, 1h, 2h, "
        "8h; default 1min,10min,1h,8h; "
        "memory: 1h,8h and one run unless --lengths / --repeat are given; "
        "whole: SHORT,LONG,LONGEST, default 1min,1h,8h)",
    )
    p.add_argument(
        "--only",
        default="",
        help="--suite offline: comma-separated of info, csv, mat, c3d, report (each with its "
        "reference); --suite memory: of its tasks (ref_floor, ref_raw, review, process, "
        "recover, info, report, close, record); --suite whole: of its rows (process, "
        "process_short, info, rss_process, rss_process_long, rss_recover, rss_close, "
        "rss_record, live, first_run, pipeline); default: all",
    )
    p.add_argument("--gui-seconds", type=float, default=10.0,
                   help="--suite whole: measured seconds per segment of the live row "
                   "(benchmarks/bench_gui.py --seconds)")


def _best_of(fn: Callable[[], object], repeat: int) -> float:
    """The shortest wall time (s) of ``repeat`` calls; the result of ``fn`` is discarded."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _record(n: int) -> np.ndarray:
    """Realistic counts from the simulated unit: one simulated hour (or less), tiled."""
    from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
    from gaitmon.io.sim.sensors import simulate

    base = min(n, 360_000)
    counts = simulate(base, GaitModel(GaitConfig(seed=1)), SensorConfig(seed=1)).counts
    reps = -(-n // base)
    return np.tile(counts, (reps, 1))[:n]


def run(args: argparse.Namespace) -> int:
    if args.suite == "memory":
        from gaitmon.commands.bench_memory import suite as memory_suite

        # (an explicit --lengths 1min,10min,1h,8h or --repeat 3 is what it says: the defaults
        # are told apart by None)
        lengths = args.lengths or "1h,8h"
        return memory_suite(lengths.split(","), 1 if args.repeat is None else args.repeat,
                            set(filter(None, args.only.split(","))))  # fmt: skip
    args.repeat = 3 if args.repeat is None else args.repeat
    if args.suite == "offline":
        from gaitmon.commands.bench_offline import suite

        return suite((args.lengths or ALL_LENGTHS).split(","), args.repeat, only=args.only)
    if args.suite == "size":
        from gaitmon.commands.bench_size import suite as size_suite

        return size_suite((args.lengths or ALL_LENGTHS).split(","), args.repeat)
    if args.suite == "whole":
        from gaitmon.commands.bench_whole import suite as whole_suite

        return whole_suite(args)
    # stream's and smooth's modules, imported before the clock starts
    import gaitmon.finish.reprocess
    import gaitmon.finish.smoothed  # noqa: F401
    from gaitmon.dsp.kalman import TiltKalman
    from gaitmon.dsp.pipeline import Pipeline, PipelineConfig

    if not 0 < args.hours <= 24:
        raise UserError(f"--hours must be above 0 and at most 24, got {args.hours}")
    if args.repeat < 1:
        raise UserError("--repeat must be at least 1")
    fs = 100.0
    n = int(args.hours * 3600 * fs)
    print(f"gaitmon bench: synthetic record of {args.hours:g} h = {n:,} frames at {fs:g} Hz")
    t0 = time.perf_counter()
    counts = _record(n)
    print(f"  simulated the record in {time.perf_counter() - t0:.2f} s")

    def rate(t: float) -> str:
        return f"{t:6.2f} s = {n / t / 1e6:5.2f} M frames/s ({t / args.hours:5.2f} s per hour)"

    # long batch work runs numba's compiled loops once its cache is ready (gaitmon.dsp.kernels;
    # here compiled or loaded before the timing, by the best-of runs' first)
    with batch_loops() as form:
        print(f"  batch loops: {form} (gaitmon.dsp.kernels); live ticks: interpreted")
        t_paper = _best_of(lambda: stream(counts, PipelineConfig(tilt_method="paper")),
                           args.repeat)  # fmt: skip
        t_pipe = _best_of(lambda: stream(counts), args.repeat)
        t_smooth = _best_of(lambda: smooth(counts, fs=fs), args.repeat)
        t_both = _best_of(lambda: both(counts), args.repeat)
    print(f"batch  pipeline, gait-aware filter (default):  {rate(t_pipe)}")
    print(f"       reference: the paper's Kalman filter:   {rate(t_paper)}  "
          f"(x{t_pipe / t_paper:.2f})")  # fmt: skip
    print(f"batch  RTS smoother alone, 4 segments:         {rate(t_smooth)}")
    print(f"batch  both, what `gaitmon process` computes:  {rate(t_both)}  target >= 1.00 M")
    print(f"       (the pipeline's filter is the smoother's first pass: {rate(t_pipe + t_smooth)}"
          f" if run twice)")  # fmt: skip

    # live: one 10 ms tick (1 frame), after warm-up; live blocks run the interpreted loops
    p = Pipeline()
    ticks = []
    from gaitmon.dsp import kernels

    with kernels.use("python"):
        p.process(counts[:5000])
        for i in range(5000, 8000):
            t0 = time.perf_counter()
            p.process(counts[i : i + 1])
            ticks.append(time.perf_counter() - t0)
    tick = np.array(ticks) * 1e6
    print(
        f"live   one 10 ms tick (1 frame): median {np.median(tick):6.0f} us, "
        f"p99 {np.percentile(tick, 99):6.0f} us  (target well under 1000 us)"
    )

    # the Kalman filter alone: steady-state lfilter path vs the paper's step-by-step loop
    rng = np.random.default_rng(0)
    m = min(n, 200_000)
    tt = np.arange(m) / fs
    z = 0.5 * np.sin(2 * np.pi * 0.9 * tt)[:, None] + 0.05 * rng.standard_normal((m, 4))
    w = np.gradient(z, 1 / fs, axis=0) + 0.03
    fast = _best_of(lambda: TiltKalman().process(z, w), args.repeat)
    loop_n = 20_000

    def loop() -> None:
        TiltKalman(fast_path=False).process(z[:loop_n], w[:loop_n])

    slow = _best_of(loop, 1) * (m / loop_n)
    print(
        f"kalman 4 segments x {m:,}: steady-state path {m / fast / 1e6:6.2f} M frames/s, "
        f"per-sample loop {m / slow / 1e6:6.3f} M frames/s  (x{slow / fast:.0f})"
    )
    return 0
