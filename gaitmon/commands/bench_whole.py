"""``gaitmon bench --suite whole``: issue 28's goals, each whole command beside its reference.

What a user waits for is the whole command (imports, reading, arithmetic, writing), so every row
runs whole processes: the gaitmon side and its reference alternate for ``--repeat`` rounds (the
first of each pair swapped every round) and the medians, their ratio and the goal's verdict are
printed, with the load average at each row's start and end (the machine is shared). Figures:

* CPU: user + system seconds of the child process (``os.wait4``), interpreter start included;
* peak RSS: the child's own ``VmHWM``, measured by ``gaitmon bench --suite memory``'s children
  (:mod:`gaitmon.commands.bench_memory`; ``ru_maxrss`` of a child keeps its parent's peak across
  fork + exec on Linux), MB = 2**20 bytes as everywhere in gaitmon's figures;
* the live view's p95 sample-to-screen latency: ``benchmarks/bench_gui.py --load 2``, which
  alternates its own segments without and with two busy processes (source checkout only);
* batch pipeline + smoother: frames per CPU second of what ``process`` computes, in a child,
  beside the same pipeline with the paper's Kalman filter (``gaitmon bench``'s reference).

The rows' sessions are ``--suite memory``'s cached synthetic ones; ``--lengths SHORT,LONG,
LONGEST`` (default 1min,1h,8h) picks their lengths, so a test can run every row on a minute.

Child protocol: ``python -m gaitmon.commands.bench_whole pipeline SESSION both|paper`` prints one
JSON line.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from gaitmon.commands import user_environ
from gaitmon.commands.bench_offline import LENGTHS_H, _cache_dir, load_average

DEFAULT_LENGTHS = "1min,1h,8h"
PY = sys.executable
# the children compile gaitmon's byte code once and keep it, as after ``pip install``
# (as the user started gaitmon: the references run in it, and gaitmon's children set their own)
ENV = {k: v for k, v in user_environ().items() if k != "PYTHONDONTWRITEBYTECODE"}
VQF_SCRIPT = Path(__file__).with_name("bench_vqf.py")
BENCH_GUI = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_gui.py"


@dataclass(frozen=True)
class Row:
    """One goal of issue 28: what is measured, against what, and the goal's bound."""

    key: str  # --only
    measure: str  # {short}, {long}, {longest}: the session lengths
    reference: str
    unit: str
    goal: float
    on_ratio: bool = False  # the bound is on gaitmon / reference, else on gaitmon's figure
    more_is_better: bool = False

    def goal_text(self) -> str:
        op = ">=" if self.more_is_better else "<="
        return f"{op} {self.goal:g}x" if self.on_ratio else f"{op} {self.goal:g} {self.unit}"

    def met(self, mine: float, ref: float) -> bool:
        got = mine / ref if self.on_ratio else mine
        return got >= self.goal if self.more_is_better else got <= self.goal


ROWS: tuple[Row, ...] = (
    Row("process", "whole `gaitmon process`, {long}", "VQF online, whole process: read the "
        "file, 4 segments, write (python -P bench_vqf.py)", "CPU s", 1.0, on_ratio=True),
    Row("process_short", "whole `gaitmon process`, {short}", "python + numpy + h5py: read "
        "/raw/adc", "CPU s", 0.35),
    Row("info", "`gaitmon info`, {short}", "a bare h5py.File open", "CPU s", 1.2, on_ratio=True),
    Row("rss_process", "peak RSS, `gaitmon process`, {short}", "a bare h5py read of /raw/adc",
        "MB", 120.0),
    Row("rss_process_long", "peak RSS, `gaitmon process`, {longest}", "a bare h5py read of "
        "/raw/adc", "MB", 250.0),
    Row("rss_recover", "peak RSS, recovery (`info` on a killed recording), {longest}",
        "a bare h5py read of /raw/adc", "MB", 250.0),
    Row("rss_close", "peak RSS, recorder close, {longest}", "interpreter + numpy, scipy, h5py, "
        "gaitmon.io imported", "MB", 250.0),
    Row("rss_record", "peak RSS, `gaitmon record --simulate --speed max`, {longest}",
        "interpreter + numpy, scipy, h5py, gaitmon.io imported", "MB", 300.0),
    Row("live", "live p95 sample-to-screen, two busy processes", "the same window, no load "
        "(bench_gui.py --load 2)", "ms", 50.0),
    Row("first_run", "first run after an install: CPU to the first processed frame (empty "
        "numba cache)", "the same, warm cache", "CPU s", 0.5),
    Row("pipeline", "batch pipeline + smoother, {long}", "the same pipeline with the paper's "
        "Kalman filter", "M frames/CPU s", 1.2, more_is_better=True),
)
ROW_KEYS = tuple(r.key for r in ROWS)
# --suite memory's child task of each memory row: (gaitmon, reference, length)
MEMORY: dict[str, tuple[str, str, str]] = {
    "rss_process": ("process", "ref_raw", "short"),
    "rss_process_long": ("process", "ref_raw", "longest"),
    "rss_recover": ("recover", "ref_raw", "longest"),
    "rss_close": ("close", "ref_floor", "longest"),
    "rss_record": ("record", "ref_floor", "longest"),
}
FIRST_FRAME = (
    "import os, numpy as np\n"
    "from gaitmon.dsp.channels import ACC_X_IDX, DEFAULT_TABLE, N_CHANNELS\n"
    "from gaitmon.dsp.pipeline import Pipeline\n"
    "x = np.zeros((1, N_CHANNELS)); x[:, ACC_X_IDX] = 9.80665  # standing still\n"
    "Pipeline().process(DEFAULT_TABLE.to_counts(x))\n"
    "os._exit(0)  # the CPU to here: nothing a background thread would do after it\n"
)


def skipped(row: Row) -> str:
    """"" when ``row`` can run here, else the one line saying what to install."""
    found = importlib.util.find_spec
    if row.key == "process" and found("vqf") is None:
        return "skipped: pip install 'vqf>=2' (or '.[bench]'): the reference"
    if row.key == "live":
        if found("PySide6") is None or found("pyqtgraph") is None:
            return "skipped: pip install PySide6-Essentials pyqtgraph"
        if not BENCH_GUI.exists():
            return "skipped: needs gaitmon's source checkout (benchmarks/bench_gui.py)"
    return ""


def whole_cpu_s(cmd: list[str], env: dict[str, str] | None = None) -> float:
    """User + system CPU seconds of one whole process running ``cmd`` (it must succeed)."""
    with tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err, env=env or ENV)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            err.seek(0)
            tail = err.read().decode(errors="replace").strip()[-400:]
            raise RuntimeError(f"{' '.join(cmd[1:4])} ... failed ({proc.returncode}): {tail}")
    return usage.ru_utime + usage.ru_stime


class Context:
    """The sessions, the output folder and the knobs every measurement reads."""

    def __init__(self, lengths: dict[str, str], out: Path, gui_seconds: float) -> None:
        self.lengths = lengths  # short / long / longest -> a LENGTHS_H name
        self.out = out
        self.gui_seconds = gui_seconds
        self.warm_cache = _cache_dir() / "numba-warm"

    def session(self, which: str) -> Path:
        from gaitmon.commands.bench_memory import session

        return session(self.lengths[which])


def _gaitmon(*args: str) -> list[str]:
    return [PY, "-m", "gaitmon", *args]


def _process(ctx: Context, who: str, which: str) -> float:
    src, out = str(ctx.session(which)), ctx.out / f"{who}.h5"
    if who == "mine":
        cmd = _gaitmon("process", src, "-o", str(out), "--force", "--quiet")
    elif which == "long":
        cmd = [PY, "-P", str(VQF_SCRIPT), src, str(out)]
    else:
        cmd = [PY, "-c", f"import h5py, numpy; f = h5py.File({src!r}, 'r'); "
               "a = numpy.asarray(f['raw/adc'][()]); f.close()"]  # fmt: skip
    try:
        return whole_cpu_s(cmd)
    finally:
        out.unlink(missing_ok=True)


def _info(ctx: Context, who: str) -> float:
    src = str(ctx.session("short"))
    if who == "mine":
        return whole_cpu_s(_gaitmon("info", src))
    return whole_cpu_s([PY, "-c", f"import h5py; h5py.File({src!r}, 'r').close()"])


def _memory(ctx: Context, who: str, key: str) -> float:
    from gaitmon.commands.bench_memory import _run

    mine, ref, which = MEMORY[key]
    got = _run(mine if who == "mine" else ref, ctx.lengths[which], ctx.out)
    if key == "rss_record":  # the recording process's peak: recording or finishing
        return max(got["rss_mb"], got.get("recording_rss_mb", 0.0))
    return got["rss_mb"]


def _first_run(ctx: Context, who: str) -> float:
    if who == "ref":
        return whole_cpu_s([PY, "-c", FIRST_FRAME], dict(ENV, NUMBA_CACHE_DIR=str(ctx.warm_cache)))
    empty = Path(tempfile.mkdtemp(prefix="numba-", dir=ctx.out))
    try:
        return whole_cpu_s([PY, "-c", FIRST_FRAME], dict(ENV, NUMBA_CACHE_DIR=str(empty)))
    finally:
        shutil.rmtree(empty, ignore_errors=True)


def _pipeline(ctx: Context, who: str) -> float:
    cmd = [PY, "-m", "gaitmon.commands.bench_whole", "pipeline", str(ctx.session("long")),
           "both" if who == "mine" else "paper"]  # fmt: skip
    r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, check=False)
    if r.returncode != 0:
        raise RuntimeError(f"the pipeline child failed: {r.stderr.strip()[-400:]}")
    rate: float = json.loads(r.stdout.strip().splitlines()[-1])["m_frames_per_cpu_s"]
    return rate


MEASURE: dict[str, Callable[[Context, str], float]] = {
    "process": lambda ctx, who: _process(ctx, who, "long"),
    "process_short": lambda ctx, who: _process(ctx, who, "short"),
    "info": _info,
    **{k: (lambda ctx, who, k=k: _memory(ctx, who, k)) for k in MEMORY},  # type: ignore[misc]
    "first_run": _first_run,
    "pipeline": _pipeline,
}


def _live(ctx: Context, repeat: int) -> tuple[list[float], list[float]]:
    """bench_gui.py --load 2's p95 per segment: (with the load, without), alternated by it."""
    cmd = [PY, str(BENCH_GUI), "--load", "2", "--repeat", str(repeat), "--seconds",
           f"{ctx.gui_seconds:g}"]  # fmt: skip
    env = dict(ENV, QT_QPA_PLATFORM=os.environ.get("QT_QPA_PLATFORM", "offscreen"))
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    p95: dict[str, list[float]] = {"0": [], "2": []}
    # a segment that drew no sample says p95 nan: kept, so the median says it too
    for m in re.finditer(r"^\s+load (\d+)\s+GUI thread .*? p95\s+(\S+),", r.stdout, re.M):
        p95[m.group(1)].append(float(m.group(2)))
    if r.returncode != 0 or not p95["0"] or not p95["2"]:
        raise RuntimeError(f"bench_gui.py failed: {(r.stderr or r.stdout).strip()[-400:]}")
    return p95["2"], p95["0"]


@dataclass
class Result:
    row: Row
    measure: str
    skip: str = ""
    mine: float = float("nan")
    ref: float = float("nan")
    load: str = ""


def _measure_row(row: Row, ctx: Context, repeat: int) -> Result:
    measure = row.measure.format(**ctx.lengths)
    skip = skipped(row)
    if skip:
        print(f"  {row.key}: {skip}", flush=True)
        return Result(row, measure, skip)
    load0 = os.getloadavg()[0]
    if row.key == "live":
        mine, ref = _live(ctx, repeat)
    else:
        if row.key == "first_run":  # the warm cache: compiled once, before the rounds
            whole_cpu_s([PY, "-c", FIRST_FRAME], dict(ENV, NUMBA_CACHE_DIR=str(ctx.warm_cache)))
        mine, ref = [], []
        for i in range(repeat):
            for who in ("mine", "ref") if i % 2 == 0 else ("ref", "mine"):
                (mine if who == "mine" else ref).append(MEASURE[row.key](ctx, who))
            print(f"  {row.key:16s} round {i + 1}: gaitmon {mine[-1]:8.3f}  reference "
                  f"{ref[-1]:8.3f} {row.unit}  ({load_average()})", flush=True)
    load = f"{load0:.1f} -> {os.getloadavg()[0]:.1f}"
    res = Result(row, measure, "", statistics.median(mine), statistics.median(ref), load)
    each = ", ".join(f"{a:.3g} | {b:.3g}" for a, b in zip(mine, ref, strict=False))
    print(f"  {row.key:16s} median gaitmon {res.mine:.3f}, reference {res.ref:.3f} {row.unit} "
          f"(gaitmon | reference per round: {each})", flush=True)
    return res


def print_table(results: list[Result], repeat: int) -> None:
    print(f"\nmedians of {repeat} alternated round(s), whole processes; ratio = gaitmon / "
          "reference; MB = 2^20 bytes; load = 1-min load average at the row's start -> end")
    print("| measure | goal | gaitmon | reference | ratio | result | load |")
    print("|---|---|---|---|---|---|---|")
    for r in results:
        if r.skip:
            print(f"| {r.measure} | {r.row.goal_text()} | {r.skip} | – | – | – | – |")
            continue
        verdict = "pass" if r.row.met(r.mine, r.ref) else "FAIL"
        print(f"| {r.measure} | {r.row.goal_text()} | {r.mine:.3g} {r.row.unit} | "
              f"{r.ref:.3g} {r.row.unit}: {r.row.reference} | {r.mine / r.ref:.2f}x | "
              f"{verdict} | {r.load} |")


def _lengths(text: str) -> dict[str, str]:
    from gaitmon.errors import UserError

    names = [n.strip() for n in text.split(",")]
    if len(names) != 3 or any(n not in LENGTHS_H for n in names):
        raise UserError(f"--lengths for --suite whole is SHORT,LONG,LONGEST of "
                        f"{', '.join(LENGTHS_H)} (default {DEFAULT_LENGTHS}), got {text!r}")
    return dict(zip(("short", "long", "longest"), names, strict=True))


def suite(args: argparse.Namespace) -> int:
    from gaitmon.errors import UserError

    lengths = _lengths(args.lengths or DEFAULT_LENGTHS)
    repeat = 3 if args.repeat is None else args.repeat
    if repeat < 1:
        raise UserError("--repeat must be at least 1")
    wanted = [k for k in args.only.split(",") if k]
    unknown = [k for k in wanted if k not in ROW_KEYS]
    if unknown:
        raise UserError(f"unknown row {unknown[0]!r} for --only (choose from "
                        f"{', '.join(ROW_KEYS)})")
    rows = [r for r in ROWS if not wanted or r.key in wanted]
    print(f"gaitmon bench --suite whole: {', '.join(f'{k} {v}' for k, v in lengths.items())}; "
          f"{repeat} alternated round(s) ({os.cpu_count()} CPUs; {load_average()})", flush=True)
    with tempfile.TemporaryDirectory(prefix="gaitmon-bench-whole-") as d:
        ctx = Context(lengths, Path(d), args.gui_seconds)
        t0 = time.perf_counter()
        for r in rows:  # the sessions first, so no row's figures include writing one
            if r.key in ("process", "pipeline"):
                ctx.session("long")
            elif r.key in ("process_short", "info", "rss_process"):
                ctx.session("short")
            elif r.key in ("rss_process_long", "rss_recover"):
                ctx.session("longest")
            if r.key == "rss_recover":
                from gaitmon.commands.bench_memory import interrupted

                interrupted(lengths["longest"])
        print(f"  sessions ready in {time.perf_counter() - t0:.1f} s", flush=True)
        results = [_measure_row(r, ctx, repeat) for r in rows]
    print_table(results, repeat)
    print(f"at the end: {load_average()}")
    return 0


def pipeline_child(src: str, which: str) -> None:
    """M frames per CPU second of the pipeline + smoother (``both``, what ``process``
    computes) or the pipeline with the paper's filter (``paper``) over ``src``'s raw counts."""
    import h5py
    import numpy as np

    from gaitmon.commands.bench_passes import batch_loops, both, stream
    from gaitmon.dsp.pipeline import PipelineConfig

    with h5py.File(src, "r") as f:
        counts = f["raw/adc"][()]

    def run(x: np.ndarray) -> None:
        if which == "both":
            both(x)
        else:
            stream(x, PipelineConfig(tilt_method="paper"))

    with batch_loops():  # as `process` runs a long record
        run(counts[:2000])  # numba's cached loops loaded before the clock starts
        t0 = time.process_time()
        run(counts)
        cpu = time.process_time() - t0
    print(json.dumps({"m_frames_per_cpu_s": len(counts) / cpu / 1e6, "cpu_s": cpu}))


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "pipeline":
        pipeline_child(sys.argv[2], sys.argv[3])
    else:
        raise SystemExit("usage: python -m gaitmon.commands.bench_whole pipeline SESSION "
                         "both|paper  (the suite itself: gaitmon bench --suite whole)")
