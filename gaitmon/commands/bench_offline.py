"""``gaitmon bench --suite offline``: export and report cost against session length.

Each figure is the median of ``--repeat`` runs, each in a fresh Python process (so its peak
memory is its own), over synthetic sessions of 1 min, 10 min, 1 h and 8 h, printed beside a
reference measured in the same run on the same data:

* CSV export vs pyarrow's ``write_csv`` of the same columns (read from the same session: the
  series' columns, the event and gap columns and the marker labels; pyarrow writes its own
  float text, shortest round-trip, so its file is ~20 % smaller than the fixed decimals);
  without pyarrow (``pip install '.[bench]'``) the CSV row runs alone and says so;
* MAT export vs ``scipy.io.savemat`` of the same arrays;
* ``info``, C3D export and the PDF report, against their own 1-minute figure (the fixed cost).

The sessions are written in the current format (2); every line shows the command's peak RSS.

"per h" is the growth per hour of session, (8 h - 1 h) / 7. The sessions are written directly
(simulated counts -> Pipeline -> SessionWriter; one simulated hour tiled) and cached under the
temp folder, keyed by the session-format source, so a changed format rebuilds them.

Child protocol: ``python -m gaitmon.commands.bench_offline TASK SRC OUTDIR`` prints one JSON
line {"cpu_s", "rss_mb", "bytes"}.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

LENGTHS_H: dict[str, float] = {"1min": 1 / 60, "10min": 1 / 6, "20min": 1 / 3, "1h": 1.0,
                              "2h": 2.0, "8h": 8.0}
# (task, reference task or "" for none, what the line says)
ROWS: tuple[tuple[str, str, str], ...] = (
    ("info", "", "info"),
    ("csv", "csv_pyarrow", "CSV export | pyarrow write_csv"),
    ("mat", "mat_savemat", "MAT export | scipy savemat"),
    ("c3d", "", "C3D export"),
    ("report", "", "PDF report"),
)
FS_HZ = 100.0


def _cache_dir() -> Path:
    d = Path(tempfile.gettempdir()) / f"gaitmon-bench-{os.getuid()}"
    d.mkdir(parents=True, exist_ok=True)
    return d


def _format_key() -> str:
    """A hash of the session package's source: a changed file format rebuilds the sessions."""
    import gaitmon.io.session as sess

    h = hashlib.sha256()
    for p in sorted(Path(sess.__file__).parent.glob("*.py")):
        h.update(p.read_bytes())
    return h.hexdigest()[:12]


def write_session(path: Path, hours: float) -> int:
    """A raw session of ``hours`` written directly (seconds for 8 hours, not 8 hours)."""
    from gaitmon.finish.closing import close_recording
    from gaitmon.io.session import SessionWriter

    # one temporary name per process: two benchmarks (sharing the cache) may build the same one
    tmp = path.with_suffix(f".{os.getpid()}.tmp.h5")
    w = SessionWriter(tmp, bench_header())
    try:
        n = append_synthetic(w, hours)
    except BaseException:
        w.close(stop_reason="error")
        raise
    close_recording(w)
    tmp.replace(path)
    return n


def bench_header() -> Any:
    from gaitmon.io.session import SessionHeader, SessionMeta

    return SessionHeader(mode="raw", meta=SessionMeta(patient_id="BENCH-1", side="R"))


def append_synthetic(w: Any, hours: float, block: int = 60_000) -> int:
    """Append ``hours`` of the synthetic raw session (one simulated hour tiled, through the
    pipeline) to the open :class:`SessionWriter` ``w``, a marker every hour; the rows."""
    import numpy as np

    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
    from gaitmon.io.sim.sensors import simulate

    n = round(hours * 3600 * FS_HZ)
    base = simulate(min(n, 360_000), GaitModel(GaitConfig(seed=1)), SensorConfig(seed=1)).counts
    pipe = Pipeline()
    for a in range(0, n, block):
        b = min(n, a + block)
        idx = np.arange(a, b)
        counts = base[idx % len(base)]
        blk = SampleBlock(FrameKind.RAW, idx.astype(np.int64), 1000.0 + idx / FS_HZ, 1.7e9,
                          lost_before=np.zeros(b - a, np.int64), adc=counts)
        w.append(blk, pipe.process(counts))
        if a % 360_000 == 0:
            w.add_marker(f"hour {a // 360_000}")
    return n


def session_file(name: str) -> Path:
    """The cached synthetic session ``name`` (a key of LENGTHS_H), written if missing."""
    path = _cache_dir() / f"{name}-{_format_key()}.h5"
    if not path.exists():
        write_session(path, LENGTHS_H[name])
    return path


# ---- one measurement, in its own process ----


def _all_columns(src_path: Path) -> tuple[list[str], list[Any], dict[int, str]]:
    """Every column of the CSV export: its names, the arrays of all but the last (the
    series' columns, then heel_strike, toe_off and gap_lost_frames as int64) and the last,
    the marker labels, as {row: text} (an empty cell on every other row)."""
    import numpy as np

    from gaitmon.export.writers.csv import CSV_EXTRA_COLUMNS, MARKER_PLACEHOLDER, _csv_columns
    from gaitmon.export.writers.source import gaps, markers, open_source
    from gaitmon.io.deidentify import Scrubber

    names: list[str] = []
    arrays: list[Any] = []
    with open_source(src_path) as src:
        for s in _csv_columns(src):
            a = src.read(s.path).reshape(src.n, -1)
            for i, c in enumerate(s.columns):
                names.append(c)
                arrays.append(a[:, i])
        scrub = Scrubber(src.group_attrs("session"), False)
        n = src.n
        for kind in ("heel_strike", "toe_off"):
            col = np.zeros(n, np.int64)
            col[src.events(kind)] = 1
            arrays.append(col)
        lost = np.zeros(n, np.int64)
        for g in gaps(src, scrub):
            if g["sample_idx"] < n:
                lost[g["sample_idx"]] += g["n_lost"]
        arrays.append(lost)
        labels: dict[int, list[str]] = {}
        for mk in markers(src, scrub):
            labels.setdefault(mk["sample_idx"], []).append(
                mk["label"].strip() or MARKER_PLACEHOLDER)
    names += list(CSV_EXTRA_COLUMNS)
    return names, arrays, {r: " | ".join(labels[r]) for r in sorted(labels)}


def _pyarrow_table(src_path: Path) -> Any:
    """The CSV export's columns (:func:`_all_columns`) as a pyarrow table: numbers as read,
    the marker column a dictionary of its labels (null, i.e. an empty cell, elsewhere)."""
    import numpy as np
    import pyarrow as pa  # type: ignore[import-untyped,import-not-found,unused-ignore]

    names, arrays, marked = _all_columns(src_path)
    idx = np.full(len(arrays[0]), -1, np.int32)
    idx[list(marked)] = np.arange(len(marked), dtype=np.int32)
    marker = pa.DictionaryArray.from_arrays(pa.array(idx, mask=idx < 0),
                                            pa.array(list(marked.values()), pa.string()))
    cols = [pa.array(a) for a in arrays]
    del arrays
    return pa.Table.from_arrays([*cols, marker], names=names)


def pyarrow_missing() -> str:
    """"" when pyarrow (the CSV row's reference) can be imported, else the one line to print."""
    import importlib.util

    if importlib.util.find_spec("pyarrow") is not None:
        return ""
    return ("pyarrow is not installed: the CSV row runs without its reference "
            "(pip install '.[bench]' to measure pyarrow's write_csv beside it)")


def _task(task: str, src: Path, out: Path) -> list[Path]:
    if task in ("csv", "mat", "c3d"):
        from gaitmon.export import export_session

        return list(export_session(src, task, out / f"x.{task}", force=True).paths)
    if task == "csv_pyarrow":
        # the reference only: pyarrow is not a dependency of gaitmon (pip install '.[bench]')
        import pyarrow.csv as pacsv  # type: ignore[import-untyped,import-not-found,unused-ignore]

        pacsv.write_csv(_pyarrow_table(src), out / "ref.csv")
        return [out / "ref.csv"]
    if task == "mat_savemat":
        from scipy.io import savemat

        from gaitmon.export.writers.source import open_source

        with open_source(src) as s:
            mats = {x.key: s.read(x.path) for x in s.series}
        savemat(out / "ref.mat", {"session": mats}, format="5", oned_as="column",
                do_compression=False)
        return [out / "ref.mat"]
    if task == "info":
        import contextlib
        import io

        from gaitmon.commands import info, run_command

        with contextlib.redirect_stdout(io.StringIO()):
            if run_command(info.add_arguments, info.run, [str(src)]) != 0:
                raise SystemExit(1)
        return []
    if task == "report":
        from gaitmon.commands import report, run_command

        if run_command(report.add_arguments, report.run,
                       [str(src), "-o", str(out / "r.pdf"), "--force"]) != 0:
            raise SystemExit(1)
        return [out / "r.pdf"]
    raise SystemExit(f"unknown task {task}")


def _peak_rss_mb() -> float:
    """This process's peak RSS. VmHWM, not getrusage: on Linux ru_maxrss keeps the parent's
    peak across fork + exec, so every child would report the bench runner's memory."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def child(task: str, src: str, outdir: str) -> None:
    t0 = time.process_time()
    paths = _task(task, Path(src), Path(outdir))
    cpu = time.process_time() - t0
    size = sum(p.stat().st_size for p in paths)
    for p in paths:
        p.unlink()
    rss = _peak_rss_mb()
    print(json.dumps({"cpu_s": cpu, "rss_mb": rss, "bytes": size, "files": len(paths)}))


def _run(task: str, src: Path, outdir: Path) -> dict[str, float]:
    from gaitmon.commands import user_environ  # (the references run as the user would run them)

    env = dict(user_environ(), QT_QPA_PLATFORM=os.environ.get("QT_QPA_PLATFORM", "offscreen"))
    r = subprocess.run([sys.executable, "-m", "gaitmon.commands.bench_offline", task, str(src),
                        str(outdir)], capture_output=True, text=True, env=env, check=False)
    if r.returncode != 0:
        raise RuntimeError(f"{task} on {src.name} failed: {r.stderr.strip()[-300:]}")
    out: dict[str, float] = json.loads(r.stdout.strip().splitlines()[-1])
    return out


def _median(runs: list[dict[str, float]]) -> dict[str, float]:
    return {k: statistics.median(r[k] for r in runs) for k in runs[0]}


def run_suite(lengths: list[str], repeat: int, skip: set[str]) -> dict[str, dict[str, Any]]:
    """{task: {length: median figures}} for every task and its reference."""
    results: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="gaitmon-bench-out-") as d:
        outdir = Path(d)
        for name in lengths:
            t0 = time.perf_counter()
            src = session_file(name)
            print(f"  session {name}: {src.stat().st_size / 2**20:.0f} MB "
                  f"(ready in {time.perf_counter() - t0:.1f} s)", flush=True)
            for task, ref, _ in ROWS:
                for t in (task, ref):
                    if not t or t in skip:
                        continue
                    runs = [_run(t, src, outdir) for _ in range(repeat)]
                    m = results.setdefault(t, {})[name] = _median(runs)
                    each = ", ".join(f"{r['cpu_s']:.2f}" for r in runs)
                    print(f"    {t:12s} {m['cpu_s']:7.2f} CPU s  peak RSS {m['rss_mb']:5.0f} MB"
                          f"  (runs: {each})", flush=True)
    return results


def print_table(results: dict[str, dict[str, Any]], lengths: list[str], repeat: int) -> None:
    print(f"\nmedian CPU s of {repeat} runs (fresh process each); ratio = export / reference; "
          "per h = (8 h - 1 h) / 7")
    head = "| what | " + " | ".join(lengths) + " | per h | peak RSS (longest) | output (longest) |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for task, ref, label in ROWS:
        for t in (task, ref):
            if t not in results:
                continue
            r = results[t]
            cells = [f"{r[n]['cpu_s']:.2f}" if n in r else "–" for n in lengths]
            if t == task and ref in results:
                cells = [
                    f"{r[n]['cpu_s']:.2f} ({r[n]['cpu_s'] / results[ref][n]['cpu_s']:.2f}×)"
                    if n in r and n in results[ref] else c
                    for n, c in zip(lengths, cells, strict=True)
                ]
            per_h = (f"{(r['8h']['cpu_s'] - r['1h']['cpu_s']) / 7:.2f}"
                     if "8h" in r and "1h" in r else "–")
            last = [n for n in lengths if n in r][-1]
            name = label.split(" | ")[0] if t == task else "  ref: " + label.split(" | ")[-1]
            print(f"| {name} | " + " | ".join(cells) + f" | {per_h} | "
                  f"{r[last]['rss_mb']:.0f} MB | {r[last]['bytes'] / 2**20:.1f} MB "
                  f"in {int(r[last]['files'])} file(s) |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else "")
    ap.add_argument("--lengths", default=",".join(LENGTHS_H),
                    help="comma-separated of " + ", ".join(LENGTHS_H))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--skip", default="", help="comma-separated tasks to leave out")
    args = ap.parse_args(argv)
    return suite(args.lengths.split(","), args.repeat, set(filter(None, args.skip.split(","))))


def suite(lengths: list[str], repeat: int, skip: set[str] | None = None, only: str = "") -> int:
    """``only``: comma-separated tasks of ROWS to run (each with its reference), "" for all."""
    from gaitmon.errors import UserError

    bad = [n for n in lengths if n not in LENGTHS_H]
    if bad:
        raise UserError(f"unknown length {bad[0]!r} (choose from {', '.join(LENGTHS_H)})")
    tasks = [t for t, _, _ in ROWS]
    wanted = [t for t in only.split(",") if t]
    unknown = [t for t in wanted if t not in tasks]
    if unknown:
        raise UserError(f"unknown task {unknown[0]!r} for --only (choose from {', '.join(tasks)})")
    if repeat < 1:
        raise UserError("--repeat must be at least 1")
    skip = set(skip or ())
    if "csv_pyarrow" not in skip and (not wanted or "csv" in wanted) and pyarrow_missing():
        print(pyarrow_missing(), flush=True)
        skip.add("csv_pyarrow")
    if wanted:
        skip |= {x for t, ref, _ in ROWS if t not in wanted for x in (t, ref) if x}
    print(f"gaitmon bench --suite offline: {', '.join(lengths)}; {repeat} runs each "
          f"({os.cpu_count()} CPUs; {load_average()})", flush=True)
    results = run_suite(lengths, repeat, skip)
    print_table(results, lengths, repeat)
    print(f"at the end: {load_average()}")
    return 0


def load_average() -> str:
    """The machine's load average (1, 5, 15 min), to print beside figures of a shared machine."""
    try:
        one, five, fifteen = os.getloadavg()
    except OSError:
        return "load average unknown"
    return f"load average {one:.2f}, {five:.2f}, {fifteen:.2f}"


if __name__ == "__main__":
    if len(sys.argv) == 4 and not sys.argv[1].startswith("-"):
        child(*sys.argv[1:])
    else:
        raise SystemExit(main())
