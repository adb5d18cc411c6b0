"""``gaitmon bench --suite memory``: peak RSS of the long-session work, beside references.

Each measurement runs in a fresh Python process and reports that process's own peak resident
memory (``VmHWM``; see :func:`gaitmon.commands.bench_offline._peak_rss_mb`), on the synthetic
raw sessions of ``gaitmon bench --suite offline`` (8 h = 2.88 M frames, written in the current
format by the recorder itself). What is measured:

* ``review``: the review window (offscreen) opening the session, to its first painted view and
  the stride analysis shown; then ``review, live + back``: View ▸ Angles ▸ Live and back to
  Smoothed, each to its analysis (the window then has analysed both angle sources);
* ``process``: ``gaitmon process FILE -o NEW`` (the pipeline replayed, the smoother, the overview);
* ``recover``: ``gaitmon info`` on a recording killed (SIGKILL) before its close: the journal is
  replayed into a new file (the pipeline, the smoother, the overview), then the file is read;
* ``info`` and ``report``: ``gaitmon info`` and ``gaitmon report`` (the stride analysis);
* ``close``: :meth:`SessionWriter.close` of the recording (the smoother, ``/overview``, whatever
  else close computes): the freed memory is returned to the system (``malloc_trim``) and the
  peak counter reset just before the close, so the figure is the close's peak over what the
  process holds then (given beside it);
* ``record``: the real path, ``gaitmon record --simulate --speed max --duration L`` run by the
  command's own code in the child: its peak while recording, then (the peak counter reset
  where the command stops its engines, ``EngineGroup.stop``: the same Stop as the live
  window's, the recorder's close with ``/smoothed`` and ``/strides``, then the simulator's
  ``/truth``) its peak while finishing. Issue 26: ``close`` above reported 316 MB for 8 h
  while ``record`` peaked at 919 MB finishing 1 h (the simulator's truth, then computed whole);

and the references, in the same run:

* ``floor``: the interpreter with numpy, scipy, h5py and gaitmon's session reader imported;
* ``h5py raw``: a bare h5py read of the whole ``/raw/adc`` (the raw counts, the truth).

Child protocol: ``python -m gaitmon.commands.bench_memory TASK SRC OUTDIR`` prints one JSON line.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from gaitmon.commands.bench_offline import LENGTHS_H, _cache_dir, _peak_rss_mb, load_average

GOAL_MB = 400.0
# (task, what the line says); "ref_" tasks are the references
TASKS: tuple[tuple[str, str], ...] = (
    ("ref_floor", "ref: interpreter + numpy, scipy, h5py, gaitmon.io imported"),
    ("ref_raw", "ref: bare h5py read of /raw/adc"),
    ("review", "review window: first view + stride analysis"),
    ("process", "gaitmon process"),
    ("recover", "recovery (gaitmon info on a killed recording)"),
    ("info", "gaitmon info"),
    ("report", "gaitmon report (PDF)"),
    ("close", "recorder close (smoother + overview)"),
    ("record", "gaitmon record --simulate --speed max: finishing (from its Stop)"),
)


def _reset_peak() -> bool:
    """Reset this process's peak RSS counter (Linux >= 4.0); False where it cannot."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def _trim() -> None:
    import contextlib
    import ctypes
    import gc

    gc.collect()
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6").malloc_trim(0)


def _rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def session(name: str) -> Path:
    """The cached synthetic session ``name``, keyed by the format version only (the content
    does not change with the code: memory figures need not rebuild it on every edit)."""
    from gaitmon.commands.bench_offline import write_session
    from gaitmon.io.session import FORMAT_VERSION

    path = _cache_dir() / f"mem-{name}-v{FORMAT_VERSION}.h5"
    if not path.exists():
        write_session(path, LENGTHS_H[name])
    return path


def interrupted(name: str) -> Path:
    """A recording of ``name`` killed (SIGKILL) before its close: the HDF5 file and its
    journal, cached (copy both before recovering)."""
    from gaitmon.io.journal import journal_path
    from gaitmon.io.session import FORMAT_VERSION

    path = _cache_dir() / f"mem-killed-{name}-v{FORMAT_VERSION}.h5"
    if path.exists() and journal_path(path).exists():
        return path
    r = subprocess.run([sys.executable, "-m", "gaitmon.commands.bench_memory", "_killed", name,
                        str(path)], capture_output=True, text=True, check=False)  # fmt: skip
    if r.returncode != -signal.SIGKILL or not journal_path(path).exists():
        raise RuntimeError(f"making the killed recording failed: {r.stderr.strip()[-300:]}")
    return path


def _record_killed(name: str, out: str) -> None:
    from gaitmon.commands.bench_offline import append_synthetic, bench_header
    from gaitmon.io.journal import journal_path
    from gaitmon.io.session import SessionWriter

    path = Path(out)
    for p in (path, journal_path(path)):
        p.unlink(missing_ok=True)
    w = SessionWriter(path, bench_header())
    append_synthetic(w, LENGTHS_H[name])
    w.flush()
    os.kill(os.getpid(), signal.SIGKILL)


# ---- one measurement, in its own process ----


def _review(src: Path, out: Path) -> dict[str, float]:
    from gaitmon.ui.review.measure import review_memory

    return review_memory(src, out, _peak_rss_mb)


def _close(name: str, out: Path) -> dict[str, float]:
    from gaitmon.commands.bench_offline import append_synthetic, bench_header
    from gaitmon.finish.closing import close_recording
    from gaitmon.io.session import SessionWriter

    path = out / "closing.h5"
    w = SessionWriter(path, bench_header(), overwrite=True)
    append_synthetic(w, LENGTHS_H[name])
    w.flush()
    recording = _peak_rss_mb()
    _trim()  # the simulator's and the pipeline's freed memory back to the system
    before = _rss_mb()
    if not _reset_peak():
        raise RuntimeError("cannot reset the peak RSS counter (/proc/self/clear_refs)")
    t0 = time.process_time()
    close_recording(w)
    cpu = time.process_time() - t0
    rss = _peak_rss_mb()
    path.unlink()
    return {"cpu_s": cpu, "rss_mb": rss, "recording_rss_mb": recording, "before_close_mb": before}


def record_phases(seconds: float, path: Path, extra: tuple[str, ...] = ()) -> dict[str, object]:
    """``gaitmon record --simulate --speed max --duration SECONDS -o PATH`` run by the
    command's own code in this process: its exit status and stderr lines, its peak RSS while
    recording (``recording_rss_mb``, to the command's Stop) and from the Stop on (``rss_mb``:
    the peak counter is reset where the command stops its engines, ``EngineGroup.stop``), and
    the CPU seconds of finishing. Also the fault suite's soak (benchmarks/faults/recorder.py)."""
    import contextlib
    import io

    from gaitmon.commands import record, run_command
    from gaitmon.engine.pair import EngineGroup

    phases: dict[str, float] = {}
    stop = EngineGroup.stop

    def stop_here(self: EngineGroup, *a: object, **kw: object) -> object:
        if "recording_rss_mb" not in phases:  # the first stop ends the recording
            phases["recording_rss_mb"] = _peak_rss_mb()
            phases["at_stop_mb"] = _rss_mb()
            if not _reset_peak():
                raise RuntimeError("cannot reset the peak RSS counter (/proc/self/clear_refs)")
            phases["t0"] = time.process_time()
        return stop(self, *a, **kw)  # type: ignore[arg-type]

    EngineGroup.stop = stop_here  # type: ignore[method-assign,assignment]
    argv = ["--simulate", "--speed", "max", "--duration", f"{seconds:g}", "-o", str(path),
            "--force", "--quiet", *extra]  # fmt: skip
    try:
        with contextlib.redirect_stderr(io.StringIO()) as err:
            rc = run_command(record.add_arguments, record.run, argv)
    finally:
        EngineGroup.stop = stop  # type: ignore[method-assign]
    cpu = time.process_time() - phases.pop("t0", time.process_time())
    rss = _peak_rss_mb()
    return {"rc": rc, "stderr": err.getvalue().strip().splitlines(), "cpu_s": cpu,
            "rss_mb": rss, **phases}  # fmt: skip


def _record(name: str, out: Path) -> dict[str, float]:
    """``record_phases`` of ``name``: the finishing peak beside the recording's."""
    path = out / "recorded.h5"
    got = record_phases(LENGTHS_H[name] * 3600.0, path)
    if got["rc"] != 0:
        raise RuntimeError(f"gaitmon record failed: {got['stderr']}")
    path.unlink()
    res = {k: float(v) for k, v in got.items() if isinstance(v, (int, float)) and k != "rc"}
    res["over_recording_mb"] = res["rss_mb"] - res["recording_rss_mb"]
    return res


def _task(task: str, name: str, out: Path) -> dict[str, float]:
    import contextlib
    import io

    if task == "ref_floor":
        import h5py
        import numpy  # noqa: F401
        import scipy.signal  # noqa: F401

        import gaitmon.io.session  # noqa: F401

        return {"cpu_s": time.process_time(), "rss_mb": _peak_rss_mb()}
    if task == "close":
        return _close(name, out)
    if task == "record":
        return _record(name, out)
    if task == "recover":
        from gaitmon.io.journal import journal_path

        killed = interrupted(name)
        src = out / "killed.h5"
        shutil.copyfile(killed, src)
        shutil.copyfile(journal_path(killed), journal_path(src))
    else:
        src = session(name)
    t0 = time.process_time()
    if task == "ref_raw":
        import h5py

        with h5py.File(src, "r") as f:
            adc = f["raw/adc"][()]
        assert adc.shape[0] > 0
    elif task == "review":
        return _review(src, out)
    elif task in ("process", "recover", "info", "report"):
        from gaitmon.commands import info, process, report, run_command

        command = {"process": process, "report": report}.get(task, info)
        argv = {"process": [str(src), "-o", str(out / "new.h5"), "--force", "--quiet"],
                "report": [str(src), "-o", str(out / "r.pdf"), "--force"]}.get(
                    task, [str(src)])  # fmt: skip
        with contextlib.redirect_stdout(io.StringIO()):
            if run_command(command.add_arguments, command.run, argv) != 0:
                raise SystemExit(1)
        if task == "recover" and journal_path(src).exists():
            raise RuntimeError("the recording was not recovered")
    else:
        raise SystemExit(f"unknown task {task}")
    cpu = time.process_time() - t0
    for p in [*out.glob("*.h5"), *out.glob("*.pdf")]:
        p.unlink()
    return {"cpu_s": cpu, "rss_mb": _peak_rss_mb()}


def child(task: str, name: str, outdir: str) -> None:
    print(json.dumps(_task(task, name, Path(outdir))))


def _run(task: str, name: str, outdir: Path) -> dict[str, float]:
    from gaitmon.commands import user_environ  # (the references run as the user would run them)

    env = dict(user_environ(), QT_QPA_PLATFORM=os.environ.get("QT_QPA_PLATFORM", "offscreen"))
    r = subprocess.run([sys.executable, "-m", "gaitmon.commands.bench_memory", task, name,
                        str(outdir)], capture_output=True, text=True, env=env, check=False)
    if r.returncode != 0:
        raise RuntimeError(f"{task} on {name} failed: {r.stderr.strip()[-400:]}")
    out: dict[str, float] = json.loads(r.stdout.strip().splitlines()[-1])
    return out


def suite(lengths: list[str], repeat: int, only: set[str] | None = None) -> int:
    from gaitmon.errors import UserError

    bad = [n for n in lengths if n not in LENGTHS_H]
    if bad:
        raise UserError(f"unknown length {bad[0]!r} (choose from {', '.join(LENGTHS_H)})")
    if repeat < 1:
        raise UserError("--repeat must be at least 1")
    tasks = [(t, label) for t, label in TASKS if not only or t in only]
    print(f"gaitmon bench --suite memory: {', '.join(lengths)}; peak RSS (VmHWM) of a fresh "
          f"process per run, median of {repeat} ({os.cpu_count()} CPUs; {load_average()})",
          flush=True)  # fmt: skip
    res: dict[tuple[str, str], dict[str, float]] = {}
    with tempfile.TemporaryDirectory(prefix="gaitmon-bench-mem-") as d:
        outdir = Path(d)
        for name in lengths:
            t0 = time.perf_counter()
            if any(t not in ("ref_floor", "close", "record") for t, _ in tasks):
                session(name)
            if any(t == "recover" for t, _ in tasks):
                interrupted(name)
            print(f"  sessions {name} ready in {time.perf_counter() - t0:.1f} s", flush=True)
            for task, _ in tasks:
                runs = [_run(task, name, outdir) for _ in range(repeat)]
                m = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
                res[(task, name)] = m
                extra = "".join(f"  {k} {v:.0f}" for k, v in m.items()
                                if k not in ("cpu_s", "rss_mb"))  # fmt: skip
                each = ", ".join(f"{r['rss_mb']:.0f}" for r in runs)
                print(f"    {name:5s} {task:10s} peak RSS {m['rss_mb']:6.0f} MB  "
                      f"{m['cpu_s']:6.2f} CPU s{extra}  (runs: {each})", flush=True)
    per_h = "1h" in lengths and "8h" in lengths
    print(f"\npeak RSS, MB (2^20 bytes), median of {repeat} fresh process(es); goal <= "
          f"{GOAL_MB:.0f} MB" + ("; per h = (8 h - 1 h) / 7, the growth per hour of session"
                                 if per_h else ""))  # fmt: skip
    print("| what | " + " | ".join(lengths) + (" | per h |" if per_h else " |"))
    print("|---|" + "---|" * (len(lengths) + per_h))

    def row(label: str, key: str, task: str) -> None:
        cells = [f"{res[(task, n)][key]:.0f}" for n in lengths]
        if per_h:
            cells.append(f"{(res[(task, '8h')][key] - res[(task, '1h')][key]) / 7:+.1f}")
        print(f"| {label} | " + " | ".join(cells) + " |")

    for task, label in tasks:
        row(label, "rss_mb", task)
        if task == "review":
            row("review window: then View ▸ Angles ▸ Live and back", "both_rss_mb", task)
        if task == "close":
            row("  (its process just before the close: the writer, the bench's simulator)",
                "before_close_mb", task)
        if task == "record":
            row("  (the same process while recording: its peak to the Stop)",
                "recording_rss_mb", task)
            row("  finishing over recording (goal: flat with the length)", "over_recording_mb",
                task)
    print(f"at the end: {load_average()}")
    return 0


def main(argv: list[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else "")
    ap.add_argument("--lengths", default="1h,8h")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--only", default="", help="comma-separated tasks: " +
                    ", ".join(t for t, _ in TASKS))  # fmt: skip
    args = ap.parse_args(argv)
    return suite(args.lengths.split(","), args.repeat, set(filter(None, args.only.split(","))))


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "_killed":
        _record_killed(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 4 and not sys.argv[1].startswith("-"):
        child(*sys.argv[1:])
    else:
        raise SystemExit(main())
