"""Fault rows of issue 26 (items 8 and 11): damaged files of both legs, crashed recordings and
folders of damaged sessions, through every command that reads a session.

* ``damaged2`` - each damaged variant of a recording of both legs (the combined file: bytes cut,
  flipped and zeroed, groups, datasets and attributes removed; a crashed recording's
  ``.L/.R.partial`` parts and journals damaged) and of a crashed one-unit recording (its
  journal gone, only its journal, ...), each given to ``info``, ``export`` (every format),
  ``report``, ``process``, ``compare`` (beside a good session) and ``batch`` (a folder holding
  it). Counted: tracebacks, hangs, ``.partial``/``.recovering`` files a command left behind,
  and sessions a batch gave no row.
* ``folders`` - ``batch`` over whole folders (the one-unit damaged corpus, the two-leg corpus,
  crashed recordings, sessions that exist only as a journal or as parts), ``compare`` of
  sessions that exist only as a journal or as parts, and ``import`` of damaged XDF files.

Goal: 0 tracebacks, 0 hangs, 0 leftover partial files, every session of a folder a row.

    python benchmarks/fault_suite.py --only damaged2,folders [--quick]
"""

from __future__ import annotations

import argparse
import collections
import importlib.util
import json
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

from faults.common import GAITMON, ROOT, Row, env

HANG_S = 120.0
LEFTOVER = (".partial", ".recovering", ".combining")

WORKER = textwrap.dedent("""
    # runs each command in-process, one JSON line per command
    import contextlib, csv, io, json, shutil, sys, traceback
    from pathlib import Path
    from gaitmon.cli import main
    LEFTOVER = (".partial", ".recovering", ".combining")
    for job in json.loads(sys.stdin.read()):
        work = Path(job["work"])
        shutil.rmtree(work, ignore_errors=True)
        inp = work / "in"
        inp.mkdir(parents=True)
        for src in job["inputs"]:  # each input session with its journal and parts
            s = Path(src)
            for p in s.parent.glob(s.name + "*"):
                if p.name == s.name or p.name[len(s.name)] == ".":
                    shutil.copyfile(p, inp / p.name)
        before = {p.name for p in work.rglob("*")}
        argv = [a.replace("{W}", str(work)).replace("{IN}", str(inp)) for a in job["argv"]]
        err = io.StringIO()
        tb = ""
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                code = main(argv)
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else 1
            except BaseException:
                code = -1
                tb = traceback.format_exc(limit=-3)
        text = err.getvalue()
        if "Traceback" in text:
            tb = tb or text[-400:]
        left = sorted(str(p.relative_to(work)) for p in work.rglob("*")
                      if p.name not in before and p.name.endswith(LEFTOVER))
        rows = None
        summary = work / "out" / "summary.csv"
        if summary.exists():
            with summary.open(encoding="utf-8") as f:
                rows = [r["session"] for r in csv.DictReader(f)]
        lines = [x for x in text.splitlines() if x.strip()]
        print(json.dumps({"id": job["id"], "code": code, "tb": tb, "lines": len(lines),
                          "last": lines[-1][:200] if lines else "", "left": left,
                          "rows": rows}), flush=True)
""")


def _corpus_module() -> ModuleType:
    path = ROOT / "benchmarks" / "damaged_corpus.py"
    spec = importlib.util.spec_from_file_location("damaged_corpus", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules["damaged_corpus"] = mod
    spec.loader.exec_module(mod)
    return mod


def run_jobs(jobs: list[dict[str, Any]], hang_s: float = HANG_S) -> dict[int, dict[str, Any]]:
    """Every job in a worker process (restarted after a hang, which is recorded as one)."""
    results: dict[int, dict[str, Any]] = {}
    todo = list(jobs)
    while todo:
        proc = subprocess.Popen(
            [sys.executable, "-c", WORKER], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL, text=True, env=env(),
        )  # fmt: skip
        assert proc.stdin is not None and proc.stdout is not None
        proc.stdin.write(json.dumps(todo))
        proc.stdin.close()
        fd = proc.stdout.fileno()
        pending = b""
        last = time.monotonic()
        while True:
            ready, _, _ = select.select([fd], [], [], 1.0)
            if ready:
                chunk = os.read(fd, 1 << 16)
                if not chunk:
                    break
                pending += chunk
                *done, pending = pending.split(b"\n")
                for line in done:
                    r = json.loads(line)
                    results[r["id"]] = r
                    last = time.monotonic()
            elif time.monotonic() - last > hang_s:
                break
        proc.kill()
        proc.wait()
        left = [j for j in todo if j["id"] not in results]
        if left:  # the first one not answered hung (or killed the worker)
            results[left[0]["id"]] = {"id": left[0]["id"], "code": None, "tb": "hang",
                                      "lines": 0, "last": "", "left": [], "rows": None}
            left = left[1:]
        todo = left
    return results


def _record(argv: Sequence[str], quiet_fail: str) -> None:
    res = subprocess.run([*GAITMON, *argv], capture_output=True, text=True, env=env(),
                         timeout=300)  # fmt: skip
    if res.returncode != 0:
        raise RuntimeError(f"{quiet_fail}: {res.stderr.strip()[-200:]}")


def _killed(argv: Sequence[str], ready: Callable[[], bool]) -> None:
    """``gaitmon record argv`` killed with SIGKILL a second after ``ready()``."""
    proc = subprocess.Popen([*GAITMON, *argv], env=env(), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)  # fmt: skip
    try:
        deadline = time.monotonic() + 90.0
        while not ready():
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("the recording to kill ended or never started")
            time.sleep(0.1)
        time.sleep(1.0)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)


def _big(p: Path, n: int = 60_000) -> bool:
    return p.exists() and p.stat().st_size > n


def sources(d: Path) -> dict[str, Path]:
    """The recordings the corpora damage: a complete one of both legs and of one unit, and a
    recording of each killed with -9."""
    sim = ["--standing-s", "2", "--patient", "P1", "-q"]
    out = {"both": d / "both.h5", "one": d / "one.h5"}
    _record(["record", "--simulate-bilateral", "--duration", "12", "--speed", "10", "-o",
             str(out["both"]), *sim], "recording both legs failed")  # fmt: skip
    _record(["record", "--simulate", "--duration", "12", "--speed", "20", "-o",
             str(out["one"]), *sim], "recording one unit failed")  # fmt: skip
    killed2 = d / "killed2"
    killed2.mkdir()
    k2 = killed2 / "k2.h5"
    _killed(["record", "--simulate-bilateral", "--duration", "600", "--speed", "4", "-o",
             str(k2), *sim],
            lambda: all(_big(Path(f"{k2}.{s}.partial")) for s in "LR"))  # fmt: skip
    killed1 = d / "killed1"
    killed1.mkdir()
    k1 = killed1 / "k1.h5"
    _killed(["record", "--simulate", "--duration", "600", "--speed", "8", "-o", str(k1), *sim],
            lambda: _big(k1))
    out["killed2"], out["killed1"] = k2, k1
    return out


def commands(good: str) -> dict[str, list[str]]:
    """Every command that reads a session, on the session ``{IN}/NAME`` (``NAME`` replaced)."""
    from gaitmon.export import FORMATS

    cmds = {"info": ["info", "{IN}/NAME"],
            "report": ["report", "{IN}/NAME", "-o", "{W}/r.pdf", "-q"],
            "process": ["process", "{IN}/NAME", "-o", "{W}/p.h5", "-q"],
            "compare": ["compare", "{IN}/NAME", f"{{IN}}/{good}", "-o", "{W}/c.pdf", "-q"],
            "batch": ["batch", "{IN}", "-o", "{W}/out", "--jobs", "1", "-q"]}  # fmt: skip
    for fmt, spec in FORMATS.items():
        cmds[f"export-{fmt}"] = ["export", "{IN}/NAME", "--format", fmt, "-q", "-o",
                                 "{W}/out" + spec.suffix]  # fmt: skip
    return cmds


def _missing(job: dict[str, Any], result: dict[str, Any]) -> list[str]:
    return sorted(set(job["expect_rows"]) - set(result["rows"] or []))


def _summarise(name: str, jobs: list[dict[str, Any]], results: dict[int, dict[str, Any]],
               n_files: int, extra: str = "") -> Row:  # fmt: skip
    hangs = [j for j in jobs if results[j["id"]]["tb"] == "hang"]
    tbs = [j for j in jobs if results[j["id"]]["tb"] and results[j["id"]]["tb"] != "hang"]
    left = [(j, results[j["id"]]["left"]) for j in jobs if results[j["id"]]["left"]]
    no_row = [j for j in jobs if j.get("expect_rows") is not None
              and results[j["id"]]["tb"] != "hang"
              and sorted(results[j["id"]]["rows"] or []) != sorted(j["expect_rows"])]
    # a session left as its journal or parts exists: no command may say it does not
    gone = [j for j in jobs if "does not exist" in results[j["id"]]["last"]]
    by_cmd = collections.Counter(j["cmd"] for j in tbs)
    fig = (f"{n_files} sessions, {len(jobs)} runs: {len(hangs)} hangs, {len(tbs)} tracebacks"
           + (f" ({dict(by_cmd)}; e.g. {tbs[0]['cmd']} on {tbs[0]['what']}: "
              f"{results[tbs[0]['id']]['tb'].strip().splitlines()[-1][:120]})" if tbs else "")
           + f", {len(left)} runs left partial files"
           + (f" (e.g. {left[0][0]['cmd']} on {left[0][0]['what']}: {left[0][1][:2]})"
              if left else "")
           + f", {len(no_row)} batches missing a session's row"
           + (f" (e.g. {no_row[0]['what']}: no row for "
              f"{_missing(no_row[0], results[no_row[0]['id']])[:3]})" if no_row else "")
           + f", {len(gone)} runs said a session left as its journal or parts does not exist"
           + (f" (e.g. {gone[0]['cmd']} on {gone[0]['what']})" if gone else "")
           + extra)  # fmt: skip
    ok = not (hangs or tbs or left or no_row or gone)
    return Row(name, "0 tracebacks, 0 hangs, 0 partial files left, a batch row per session, "
               "no recoverable session called missing", fig, ok)  # fmt: skip


def row_damaged2(args: argparse.Namespace) -> list[Row]:
    mod = _corpus_module()
    quick = bool(getattr(args, "quick", False))
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        src = sources(d)
        combined = mod.make_bilateral_corpus(src["both"], d / "bi", seed=26)
        parts = mod.make_parts_corpus(src["killed2"].parent, src["killed2"].name, d / "parts",
                                      seed=26)  # fmt: skip
        crashed = mod.make_crashed_corpus(src["killed1"], d / "crashed")
        chosen = (combined[::4] if quick else combined) + parts + crashed
        good = d / "good" / "good.h5"
        good.parent.mkdir()
        shutil.copyfile(src["one"], good)
        jobs = []
        for path, what in chosen:
            for cmd, argv in commands(good.name).items():
                inputs = [str(path)] + ([str(good)] if cmd == "compare" else [])
                expect = [path.name] if cmd == "batch" else None
                jobs.append({"id": len(jobs), "inputs": inputs, "work": str(d / "w"),
                             "argv": [a.replace("NAME", path.name) for a in argv],
                             "cmd": cmd, "what": f"{path.name} ({what})",
                             "expect_rows": expect})  # fmt: skip
        results = run_jobs(jobs)
    mode = " (quick: a quarter of the combined-file variants)" if quick else ""
    return [_summarise(f"damaged files of both legs and crashed recordings x every command{mode}",
                       jobs, results, len(chosen))]  # fmt: skip


def _xdf_variants(out: Path) -> list[tuple[Path, str]]:
    src = ROOT / "docs" / "example-walk.xdf"
    data = src.read_bytes()
    out.mkdir(parents=True, exist_ok=True)
    found = []
    for k, (what, b) in enumerate([
        ("cut at 40 %", data[: int(len(data) * 0.4)]),
        ("cut at 95 %", data[: int(len(data) * 0.95)]),
        ("4 KiB zeroed in the middle", data[: len(data) // 2] + bytes(4096)
         + data[len(data) // 2 + 4096:]),
        ("byte 12 inverted", data[:12] + bytes([data[12] ^ 0xFF]) + data[13:]),
        ("the header only", data[:64]),
    ]):  # fmt: skip
        p = out / f"x{k}.xdf"
        p.write_bytes(b)
        found.append((p, f"XDF {what}"))
    return found


def row_folders(args: argparse.Namespace) -> list[Row]:
    mod = _corpus_module()
    quick = bool(getattr(args, "quick", False))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        src = sources(d)
        one = mod.make_corpus(src["one"], d / "one", seed=26)
        both = mod.make_bilateral_corpus(src["both"], d / "bi", seed=26)
        parts = mod.make_parts_corpus(src["killed2"].parent, src["killed2"].name, d / "parts",
                                      seed=26)  # fmt: skip
        crashed = mod.make_crashed_corpus(src["killed1"], d / "crashed")
        if quick:
            one, both = one[::3], both[::3]
        folders = {"one-unit damaged corpus": one, "both-legs damaged corpus": both,
                   "crashed both legs (parts)": parts, "crashed one unit": crashed}  # fmt: skip
        jobs = []
        for what, variants in folders.items():
            jobs.append({"id": len(jobs), "inputs": [str(p) for p, _ in variants],
                         "work": str(d / "w"), "cmd": "batch", "what": what,
                         "argv": ["batch", "{IN}", "-o", "{W}/out", "--jobs", "1", "-q"],
                         "expect_rows": sorted({p.name for p, _ in variants})})  # fmt: skip
        good = d / "good" / "good.h5"
        good.parent.mkdir()
        shutil.copyfile(src["one"], good)
        for p, what in [v for v in crashed if "journal" in v[0].name or v[0].name == "crashed.h5"]:
            jobs.append({"id": len(jobs), "inputs": [str(p), str(good)], "work": str(d / "w"),
                         "cmd": "compare", "what": f"{p.name} ({what})",
                         "argv": ["compare", f"{{IN}}/{p.name}", "{IN}/good.h5", "-o",
                                  "{W}/c.pdf", "-q"]})  # fmt: skip
        xdfs = _xdf_variants(d / "xdf")
        for p, what in xdfs:
            for extra in ([], ["--partial"]):
                jobs.append({"id": len(jobs), "inputs": [str(p)], "work": str(d / "w"),
                             "cmd": "import", "what": f"{what} {' '.join(extra)}",
                             "argv": ["import", f"{{IN}}/{p.name}", "-o", "{W}/i.h5", "-q",
                                      *extra]})  # fmt: skip
        results = run_jobs(jobs)
        n = sum(len(v) for v in folders.values())
        batch_jobs = [j for j in jobs if j["cmd"] == "batch"]
        per_folder = "; ".join(
            f"{j['what']}: {len(results[j['id']]['rows'] or [])} rows of {len(j['expect_rows'])}"
            for j in batch_jobs)  # fmt: skip
        rows.append(_summarise("batch over damaged folders, compare of recoverable sessions, "
                               "import of damaged XDF" + (" (quick: a third of the corpora)"
                                                          if quick else ""),
                               jobs, results, n + len(xdfs), f"; {per_folder}"))  # fmt: skip
    return rows


ROWS: dict[str, Callable[[argparse.Namespace], list[Row]]] = {
    "damaged2": row_damaged2,
    "folders": row_folders,
}


def main() -> None:  # the rows alone, without the rest of the suite
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--only", default="damaged2,folders")
    a = ap.parse_args()
    for name in a.only.split(","):
        for r in ROWS[name](a):
            print(r.line())


if __name__ == "__main__":
    main()
