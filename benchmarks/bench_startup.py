"""Start-up cost of the command line, side by side with its reference in the same run.

    gaitmon info FILE       vs  python -c "import h5py, numpy; h5py.File(FILE)"   (goal: <= 1.2x)
    gaitmon --help, --version, process --help   CPU seconds, beside a bare ``python -c pass``

Each command runs as a whole process, interleaved with its reference, ``--runs`` times; the
figures are CPU seconds (user + system of the child) and wall seconds, as medians, and the ratio
of the medians. A 1-minute simulated session is recorded first unless ``--file`` is given.
The children run without PYTHONDONTWRITEBYTECODE, so the warm-up run leaves the byte code a user
has after ``pip install .`` (which compiles it): otherwise every run recompiles gaitmon's source.
They run in the root folder, so ``python -m gaitmon`` imports the gaitmon on ``sys.path`` (the
installed one, or PYTHONPATH's), not a checkout the benchmark happens to be started from.

Run: python benchmarks/bench_startup.py [--runs 7] [--file walk.h5]
(prints figures; no assertions: timings do not belong in pass/fail tests).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PY = sys.executable
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def gaitmon(*args: str) -> list[str]:
    return [PY, "-m", "gaitmon", *args]


def run_once(cmd: list[str]) -> tuple[float, float]:
    """(CPU s, wall s) of one whole process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=ENV,
                   cwd=os.path.abspath(os.sep))  # fmt: skip
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall


def measure(cmds: dict[str, list[str]], runs: int) -> dict[str, tuple[float, float]]:
    """Median (CPU s, wall s) per command, the commands interleaved run by run."""
    cpu: dict[str, list[float]] = {k: [] for k in cmds}
    wall: dict[str, list[float]] = {k: [] for k in cmds}
    for cmd in cmds.values():  # warm the file cache and the bytecode once
        run_once(cmd)
    for _ in range(runs):
        for name, cmd in cmds.items():
            c, w = run_once(cmd)
            cpu[name].append(c)
            wall[name].append(w)
    return {k: (statistics.median(cpu[k]), statistics.median(wall[k])) for k in cmds}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--file", type=Path, help="a session file (default: record 1 min simulated)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = args.file
        if path is None:
            path = Path(tmp) / "one_minute.h5"
            subprocess.run(
                gaitmon("record", "--simulate", "--duration", "60", "--speed", "20", "--quiet",
                        "-o", str(path)),
                check=True, stdout=subprocess.DEVNULL,
            )  # fmt: skip
        ref = f"import h5py, numpy; h5py.File({str(path)!r})"
        res = measure(
            {
                "gaitmon info FILE": gaitmon("info", str(path)),
                "h5py.File(FILE)": [PY, "-c", ref],
                "gaitmon --help": gaitmon("--help"),
                "gaitmon --version": gaitmon("--version"),
                "gaitmon process --help": gaitmon("process", "--help"),
                "python -c pass": [PY, "-c", "pass"],
            },
            args.runs,
        )
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"start-up, medians of {args.runs} alternated runs ({os.cpu_count()} cores, load "
          f"average {load})")  # fmt: skip
    print(f"{'command':<24} {'CPU s':>7} {'wall s':>7}")
    for name, (c, w) in res.items():
        print(f"{name:<24} {c:7.3f} {w:7.3f}")
    info, h5 = res["gaitmon info FILE"], res["h5py.File(FILE)"]
    print(f"gaitmon info / h5py.File: {info[0] / h5[0]:.2f}x CPU, {info[1] / h5[1]:.2f}x wall "
          "(goal <= 1.2x CPU, issue 28)")  # fmt: skip
    bare = res["python -c pass"][0]
    for name in ("gaitmon --help", "gaitmon --version", "gaitmon process --help"):
        print(f"{name}: {res[name][0]:.3f} s CPU, {res[name][0] - bare:.3f} s above a bare "
              "interpreter")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
