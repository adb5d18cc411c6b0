"""Fault-suite rows for hostile session files (issue 26, items 1 and 6).

``hostile``: every command (info, export in every format, report, process, compare, batch and
batch --deidentify) over every hostile variant of a real recorded session
(``benchmarks/hostile_corpus.py``: external storage, external links, a virtual dataset, counts
above the ADC, shapes of 10^12 rows, huge attributes), each a real ``gaitmon`` process with a
timeout. Counted: tracebacks (or a crash), hangs, and outside reads: the secret marker that only
the outside files hold in any output or exported file, or a command that succeeds on a file
whose data lie outside it. Goal 0/0/0.

``hostile-rss``: the peak memory of ``gaitmon info`` on a session with a huge text attribute
(400 MB; 100 MB with --quick) beside that of ``info`` on the session it was made from.
"""

from __future__ import annotations

import argparse
import csv
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py

from faults.common import GAITMON, ROOT, Row, env

sys.path.insert(0, str(ROOT / "benchmarks"))
from hostile_corpus import SECRET, make_hostile

HANG_S = 120.0
# variants whose data lie outside the file: a command that succeeds on them read outside
OUTSIDE = ("external_storage", "external_link_session", "external_link_adc", "virtual_adc")


def _record(path: Path) -> bool:
    r = subprocess.run(
        [*GAITMON, "record", "--simulate", "--duration", "12", "-o", str(path), "--speed", "20",
         "--standing-s", "2", "--quiet", "--patient", "P1"],
        capture_output=True, text=True, timeout=300, env=env(),
    )  # fmt: skip
    return r.returncode == 0


def _commands(f: Path, good: Path, w: Path) -> dict[str, list[str]]:
    out = {"info": ["info", str(f)]}
    for fmt in ("csv", "mat", "c3d", "bids", "strides"):
        out[f"export-{fmt}"] = ["export", str(f), "--format", fmt, "-q", "-o", str(w / "out")]
    out["report"] = ["report", str(f), "-o", str(w / "r.pdf"), "-q"]
    out["process"] = ["process", str(f), "-o", str(w / "p.h5"), "-q"]
    out["compare"] = ["compare", str(good), str(f), "-o", str(w / "c.pdf"), "-q"]
    out["batch"] = ["batch", str(w / "in"), "-o", str(w / "b"), "-q"]
    out["batch-deidentify"] = ["batch", str(w / "in"), "-o", str(w / "bd"), "-q", "--deidentify"]
    return out


def _secret_in(w: Path, *texts: str) -> bool:
    mark = SECRET.encode()
    if any(SECRET in t for t in texts):
        return True
    for p in w.rglob("*"):
        if p.is_file() and w / "in" not in p.parents and mark in p.read_bytes():
            return True
    return False


def _batch_status(out: Path) -> str:
    """The status of the one session of a batch's summary.csv ("" if there is none)."""
    try:
        with open(out / "summary.csv", newline="") as fh:
            rows = list(csv.DictReader(fh))
    except OSError:
        return ""
    return rows[0].get("status", "") if len(rows) == 1 else ""


def row_hostile(args: argparse.Namespace) -> list[Row]:
    goal = "0 tracebacks, 0 hangs, 0 outside reads"
    name = "hostile files x every command"
    with tempfile.TemporaryDirectory() as d:
        good = Path(d) / "walk.h5"
        if not _record(good):
            return [Row(name, goal, "NOT RUN: recording the source session failed", False)]
        variants = make_hostile(good, Path(d) / "corpus")
        tracebacks: list[str] = []
        hangs: list[str] = []
        outside: list[str] = []
        one_line = in_summary = runs = 0
        passed: list[str] = []
        for path, _what in variants:
            for cmd in _commands(path, good, Path(d)):
                w = Path(d) / "w"
                shutil.rmtree(w, ignore_errors=True)
                (w / "in").mkdir(parents=True)
                f = shutil.copy(path, w / "in" / path.name)
                argv = _commands(Path(f), good, w)[cmd]
                runs += 1
                what = f"{cmd} on {path.stem}"
                try:
                    r = subprocess.run([*GAITMON, *argv], capture_output=True, text=True,
                                       timeout=HANG_S, env=env(), cwd=w)  # fmt: skip
                except subprocess.TimeoutExpired:
                    hangs.append(what)
                    continue
                if "Traceback" in r.stderr or r.returncode not in (0, 1, 2):
                    tracebacks.append(f"{what} ({r.returncode})")
                single = not cmd.startswith("batch")
                if _secret_in(w, r.stdout, r.stderr) or (
                    single and r.returncode == 0 and path.stem in OUTSIDE
                ):
                    outside.append(what)
                lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
                if r.returncode == 2 and len(lines) == 1:
                    one_line += 1
                elif not single and _batch_status(Path(argv[3])) == "damaged":
                    in_summary += 1  # batch: the file is a row saying why, the batch goes on
                elif r.returncode == 0:
                    passed.append(what)
    fig = (
        f"{len(variants)} files x {runs // max(1, len(variants))} commands = {runs} runs: "
        f"{len(tracebacks)} tracebacks, {len(hangs)} hangs, {len(outside)} outside reads; "
        f"{one_line} refused in one line (exit 2), {in_summary} batch summary rows 'damaged' "
        f"with the reason, {len(passed)} exit 0"
    )
    notes = tracebacks[:3] + hangs[:3] + outside[:3]
    if notes:
        fig += " (" + "; ".join(notes) + ")"
    ok = not (tracebacks or hangs or outside)
    extra = sorted({p.split(" on ")[1] + ": " + p.split(" on ")[0] for p in passed})
    print("hostile: exit 0 for " + (", ".join(extra) or "none"), file=sys.stderr)
    return [Row(name, goal, fig, ok)]


# Runs a command and prints its peak RSS (KiB). A child of this suite would inherit the suite's
# own peak (Linux keeps a process's peak RSS across fork and exec, and the suite holds the
# 400 MB text it wrote), so the command runs as the grandchild of this small process.
_RSS_WRAPPER = (
    "import resource, subprocess, sys\n"
    "rc = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL"
    ").returncode\n"
    "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, rc)\n"
)


def _peak_rss_mb(argv: list[str]) -> tuple[float, int]:
    """(peak RSS in MB, exit status) of one gaitmon process."""
    r = subprocess.run([sys.executable, "-c", _RSS_WRAPPER, *GAITMON, *argv],
                       capture_output=True, text=True, timeout=HANG_S, env=env())  # fmt: skip
    kib, rc = r.stdout.split()
    return int(kib) / 1024.0, int(rc)


def row_hostile_rss(args: argparse.Namespace) -> list[Row]:
    size_mb = 100 if args.quick else 400
    name = f"info on a session with a {size_mb} MB text attribute"
    goal = "refused; peak RSS within 50 MB of info on the session it was made from"
    with tempfile.TemporaryDirectory() as d:
        good = Path(d) / "walk.h5"
        if not _record(good):
            return [Row(name, goal, "NOT RUN: recording the source session failed", False)]
        big = Path(d) / "big.h5"
        shutil.copyfile(good, big)
        with h5py.File(big, "r+") as f:
            f["session"].attrs["notes"] = "é" * (size_mb * 500_000)  # 2 bytes each in UTF-8
        base, rc0 = _peak_rss_mb(["info", str(good)])
        peak, rc = _peak_rss_mb(["info", str(big)])
    fig = f"exit {rc}, peak RSS {peak:.0f} MB (the session it was made from: {base:.0f} MB)"
    return [Row(name, goal, fig, rc == 2 and rc0 == 0 and peak <= base + 50)]


ROWS = {"hostile": row_hostile, "hostile-rss": row_hostile_rss}
