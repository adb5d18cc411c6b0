"""The fault-injection suite of issue 12: prints each figure beside its goal, PASS/FAIL per row.

    python benchmarks/fault_suite.py --quick          # smaller sizes, same rows (~4 min)
    python benchmarks/fault_suite.py                  # the full campaign (~55 min)
    python benchmarks/fault_suite.py --only decoder,linkcut

Rows (goal in the table):
  decoder    byte-level link faults on 5 seeds (gaitmon.io.sim.linkfaults, exact ledger),
             and the same streams fed in random chunks of 1 B .. 4 KiB (also --only chunking)
  linkcut    an Engine recording over a real pty (PtySimulator + SerialTransport) while the
             port vanishes for 1, 3 and 8 s
  kill9      `gaitmon record --simulate` killed with SIGKILL at random times, then `gaitmon info`
  diskfull   `gaitmon record` under RLIMIT_FSIZE (writes fail with EFBIG, as on a full disk),
             and an Engine under the same limit to see acquisition carry on
  damaged    info / export (every format) / report over the damaged-file corpus of
             benchmarks/damaged_corpus.py (branch `cli`; --corpus-module PATH to use another copy)
  soak       `gaitmon record --simulate` of >= 3 h of data at a raised speed, RSS sampled

More rows, one module each in benchmarks/faults/ (issue 26):
  hostile, hostile-rss     hostile session files (external storage and links, virtual
                           datasets, huge shapes and attributes) x every command (hostile.py)
  lsl                      LSL markers from another process: NUL, control characters, 1 MB
                           labels, formulas, a flood, an impostor control stream (lsl_markers.py)
  damaged2, folders        damaged two-leg files and crashed recordings x every command;
                           batch / compare / import over damaged folders (damaged_folders.py)
  diskfull_create, soak8h  a full disk at the file's creation; 8 h at --speed max beside a
                           busy process: every lost frame reported, finishing RSS (recorder.py)

A row that cannot run says why and counts as FAIL: nothing is hidden. Exit status 0 only when
every row passes. Nothing here is a pass/fail test of the test suite (that would put timings
in tests); the fast, timing-free parts live in tests/test_faults_decoder.py.
"""

from __future__ import annotations

import argparse
import collections
import functools
import importlib.util
import json
import math
import os
import re
import resource
import select
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
import traceback
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np
from faults.common import GAITMON, ROOT, Row
from faults.common import env as _env

FS_HZ = 100.0
ALIASES = {"chunking": "decoder"}  # the chunking rows are the decoder row's second half


# --- decoder and chunking -----------------------------------------------------------------------


def _naive_crc_failures(stream: bytes) -> int:
    """Header-valid complete candidates failing their CRC, at every sync offset."""
    import binascii

    from gaitmon.io import protocol as p

    n, count, pos = len(stream), 0, stream.find(p.FRAME_SYNC)
    while 0 <= pos <= n - 4:
        kind, length = stream[pos + 2], stream[pos + 3]
        end = pos + 8 + length
        if kind in p.PAYLOAD_LEN and length == p.PAYLOAD_LEN[kind] and end <= n:
            crc = int.from_bytes(stream[end - 2 : end], "little")
            count += binascii.crc_hqx(stream[pos + 2 : end - 2], 0xFFFF) != crc
        pos = stream.find(p.FRAME_SYNC, pos + 1)
    return count


def _swallowed(want: list, got: list) -> int:
    """Intact frames the decoder did not deliver (compared by their wire bytes)."""
    from gaitmon.io import protocol as p

    have = collections.Counter(p.encode_frame(f, validate=False) for f in got)
    need = collections.Counter(p.encode_frame(f, validate=False) for f in want)
    return sum((need - have).values())


def row_decoder(quick: bool) -> list[Row]:
    from gaitmon.io.decoder import FrameDecoder
    from gaitmon.io.sim.linkfaults import LinkFaultConfig, faulty_stream, last_byte_loss_stream

    n_frames = 8_000 if quick else 40_000
    seeds = range(5)
    events = exceptions = swallowed = equal = 0
    chunk_same = 0
    n_chunks = 0
    diffs: list[str] = []
    for seed in seeds:
        ledger = faulty_stream(n_frames, LinkFaultConfig(seed=seed), seq0=(seed * 13_001) % 65_536)
        events += ledger.n_events
        try:
            dec = FrameDecoder()
            got = dec.feed(ledger.stream)
        except Exception:  # the goal is 0 of these: count, do not stop
            exceptions += 1
            continue
        want = ledger.delivered()
        swallowed += _swallowed(want, got)
        stats = asdict(dec.stats)
        exp = ledger.expected_counters()
        exp["crc_failures"] = _naive_crc_failures(ledger.stream)
        bad = {k: (stats[k], v) for k, v in exp.items() if stats[k] != v}
        if not bad and got == want:
            equal += 1
        else:
            diffs.append(
                f"seed {seed}: " + ", ".join(f"{k} {a} vs {b}" for k, (a, b) in bad.items())
            )
        # chunking: random sizes, log-uniform over 1 B .. 4 KiB
        rng = np.random.default_rng(1000 + seed)
        try:
            cdec, cgot, at = FrameDecoder(), [], 0
            while at < len(ledger.stream):
                size = int(np.exp(rng.uniform(0.0, math.log(4096.0))))
                cgot += cdec.feed(ledger.stream[at : at + size])
                at += size
                n_chunks += 1
            chunk_same += cgot == got and cdec.stats == dec.stats
        except Exception:
            exceptions += 1
    # the pattern of defect 1, alone: every other frame loses its last byte
    n_last = 4_000 if quick else 20_000
    lb = last_byte_loss_stream(n_last, seed=7)
    lb_got = FrameDecoder().feed(lb.stream)
    lb_swallowed = _swallowed(lb.delivered(), lb_got)
    lb_completed = len(lb.intact()) - (n_last - lb.events["tail"])
    ok = exceptions == 0 and swallowed == 0 and lb_swallowed == 0 and equal == len(seeds)
    fig = (
        f"{events:,} events ({n_frames:,} frames x {len(seeds)} seeds): {exceptions} exceptions; "
        f"{swallowed} swallowed (+ {lb_swallowed} of {n_last // 2:,} frames after a lost last "
        f"byte, {lb_completed} of them completed by the next sync); counters = ledger in "
        f"{equal}/{len(seeds)} seeds" + (f" [{'; '.join(diffs)}]" if diffs else "")
    )
    goal1 = "0 exceptions; 0 good frames swallowed; counters equal the ledger in every seed"
    return [
        Row("decoder, >=10^4 corruption events, 5 seeds", goal1, fig, ok),
        Row(
            "random chunking 1 B-4 KiB",
            "identical output",
            f"identical frames and counters in {chunk_same}/{len(seeds)} seeds "
            f"({n_chunks:,} chunks)",
            chunk_same == len(seeds),
        ),
    ]


# --- link cut over a real pty -------------------------------------------------------------------


def _one_cut(outage_s: float, tmp: Path) -> dict[str, float | int | str]:
    from gaitmon.engine import Engine
    from gaitmon.finish import open_session
    from gaitmon.io.device import Device
    from gaitmon.io.sim import GaitConfig, SimulatedUnit
    from gaitmon.io.sim.pty import PtySimulator
    from gaitmon.io.transport import LinkState, SerialTransport

    out = tmp / f"cut{outage_s:g}.h5"
    unit = SimulatedUnit(GaitConfig(seed=5, standing_s=1.0), speed=1.0)
    with PtySimulator(unit) as sim:
        eng = Engine(Device(SerialTransport(str(sim.link_path))), "raw", transport_label="pty")
        with eng:
            deadline = time.monotonic() + 30
            eng.start_recording(out)
            while eng.recording.rows < 100 and time.monotonic() < deadline:
                time.sleep(0.01)
            sim.cut()  # the port vanishes, as an RFCOMM link does
            t_cut = time.monotonic()
            detect_s = math.inf
            while time.monotonic() - t_cut < outage_s:
                if math.isinf(detect_s) and eng.device.stats.transport.state != LinkState.CONNECTED:
                    detect_s = time.monotonic() - t_cut
                time.sleep(0.002)
            sim.restore()
            rows_at_restore = eng.recording.rows
            back = time.monotonic() + 20
            while eng.recording.rows < rows_at_restore + 100 and time.monotonic() < back:
                time.sleep(0.01)
            status = eng.stop_recording()
    files = sorted(p.name for p in tmp.glob(f"cut{outage_s:g}*.h5"))
    with open_session(out) as s:
        gaps = [g for g in s.gaps if g.n_lost >= 10]
        n = s.n_samples
        seq = s.read("timeline/seq")
    lost_s = sum(g.n_lost for g in gaps) / FS_HZ
    after = int(n - gaps[-1].sample_idx) if gaps else 0
    same_file = files == [out.name] and len(gaps) == 1 and after >= 100 and status.error == ""
    return {
        "detect_s": detect_s,
        "lost_s": lost_s,
        "same_file": int(same_file),
        "rows_after": after,
        "seq_ok": int(bool(np.all(np.diff(seq) >= 1))),
    }


def row_linkcut(quick: bool) -> list[Row]:
    outages = (1.0, 3.0, 8.0)
    res = []
    with tempfile.TemporaryDirectory() as d:
        for o in outages:
            res.append((o, _one_cut(o, Path(d))))
    ok = all(
        r["detect_s"] <= 0.1 and r["same_file"] and r["lost_s"] <= o + 0.5 and r["seq_ok"]
        for o, r in res
    )
    fig = "; ".join(
        f"{o:g} s: detected {float(r['detect_s']):.3f} s, "
        f"{'same file' if r['same_file'] else 'NOT the same file / no resume'}, "
        f"lost {float(r['lost_s']):.2f} s (outage + {float(r['lost_s']) - o:.2f} s)"
        for o, r in res
    )
    return [
        Row(
            "link cut 1/3/8 s over a real pty",
            "detected <= 0.1 s; same file; loss <= outage + 0.5 s",
            fig,
            ok,
        )
    ]


# --- kill -9 ----------------------------------------------------------------------------------


def _announced(lines: list[str], t_max: float) -> int:
    """Rows the recorder announced (`--status-lines`: "ROWS n t") at or before t_max."""
    rows = 0
    for line in lines:
        parts = line.split()
        if len(parts) == 3 and parts[0] == "ROWS" and float(parts[2]) <= t_max:
            rows = int(parts[1])
    return rows


def _one_kill(path: Path, seed: int, run_s: float) -> dict[str, float | int | str]:
    import h5py

    proc = subprocess.Popen(
        [*GAITMON, "record", "--simulate", "--duration", "120", "-o", str(path), "--quiet",
         "--status-lines", "--seed", str(seed)],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=_env(),
    )  # fmt: skip
    assert proc.stdout is not None
    fd, buf, start = proc.stdout.fileno(), b"", None
    give_up = time.monotonic() + 60
    while True:
        ready, _, _ = select.select([fd], [], [], 0.005)
        if ready:
            buf += os.read(fd, 1 << 16)
            if start is None and b"ROWS" in buf:
                start = time.monotonic()
        if start is not None and time.monotonic() - start >= run_s:
            break
        if proc.poll() is not None or time.monotonic() > give_up:
            proc.kill()
            proc.wait()
            return {"opened": 0, "loss_ms": math.inf, "why": "recorder did not start"}
    t_kill = time.monotonic()
    proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    buf += proc.stdout.read()
    proc.stdout.close()
    lines = buf.decode(errors="replace").splitlines()
    received = _announced(lines, t_kill)
    info = subprocess.run(
        [*GAITMON, "info", str(path)], capture_output=True, text=True, timeout=120, env=_env()
    )
    opened, rows = 0, 0
    why = ""
    if info.returncode != 0:
        why = f"info exit {info.returncode}: {info.stderr.strip()[-200:]}"
    else:
        try:
            with h5py.File(path, "r") as f:
                seq = f["timeline/seq"][()]
                rows = len(seq)
                opened = int(f["raw/adc"].shape[0] == rows and bool(np.all(np.diff(seq) >= 1)))
        except Exception as exc:
            why = f"h5py: {exc}"
    return {"opened": opened, "loss_ms": max(0, received - rows) / FS_HZ * 1000.0, "why": why}


def row_kill9(quick: bool) -> list[Row]:
    n = 5 if quick else 50
    rng = np.random.default_rng(9)
    res = []
    with tempfile.TemporaryDirectory() as d:
        for k in range(n):
            res.append(
                _one_kill(Path(d) / f"k{k}.h5", seed=k + 1, run_s=float(rng.uniform(0.3, 4.0)))
            )
    opened = sum(int(r["opened"]) for r in res)
    losses = [float(r["loss_ms"]) for r in res]
    whys = sorted({str(r["why"]) for r in res if r["why"]})
    fig = (
        f"{opened}/{n} open without manual repair; loss of received data: median "
        f"{np.median(losses):.0f} ms, max {max(losses):.0f} ms"
        + (f" [{'; '.join(whys)[:300]}]" if whys else "")
    )
    ok = opened == n and max(losses) <= 100.0
    return [
        Row(
            f"kill -9 x {n} at random times",
            f"{n}/{n} open without manual repair; loss <= 100 ms of received data",
            fig,
            ok,
        )
    ]


# --- disk full --------------------------------------------------------------------------------


def _limit_file_size(limit: int) -> Callable[[], None]:
    def pre() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes beyond it fail with EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return pre


ENGINE_DISK_FULL = textwrap.dedent("""
    import json, resource, signal, sys, time
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    from gaitmon.engine import Engine
    from gaitmon.io.device import Device
    from gaitmon.io.sim import GaitConfig, SimulatedUnit
    from gaitmon.io.transport import InProcessTransport
    unit = SimulatedUnit(GaitConfig(seed=1), speed=20.0)
    eng = Engine(Device(InProcessTransport(unit)), "raw")
    eng.start()
    time.sleep(0.3)
    resource.setrlimit(resource.RLIMIT_FSIZE, (400_000, 400_000))
    eng.start_recording(sys.argv[1])
    t0 = time.monotonic()
    while not eng.recording.error and time.monotonic() - t0 < 60:
        time.sleep(0.02)
    n1 = eng.samples_total
    time.sleep(0.5)
    n2 = eng.samples_total
    status = eng.stop_recording()
    eng.stop()
    print(json.dumps({"error": eng.recording.error, "before": n1, "after": n2,
                      "rows": status.rows}))
""")


def row_diskfull(quick: bool) -> list[Row]:
    from gaitmon.finish import open_session

    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "full.h5"
        res = subprocess.run(
            [*GAITMON, "record", "--simulate", "--duration", "120", "--speed", "10", "-o",
             str(out), "--quiet"],
            capture_output=True, text=True, timeout=180, env=_env(),
            preexec_fn=_limit_file_size(400_000),
        )  # fmt: skip
        text = (res.stderr + res.stdout).strip()
        lines = [ln for ln in text.splitlines() if ln.strip()]
        error_lines = [ln for ln in lines if re.search(r"disk|space|write error", ln, re.I)]
        tracebacks = "Traceback" in text
        stated = None
        for ln in lines:
            # "N rows|frames|samples" or "up to row N"
            m = re.search(r"(\d[\d,]*)\s+(?:rows|frames|samples)\b|\brows?\s+(\d[\d,]*)", ln)
            if m:
                stated = int((m.group(1) or m.group(2)).replace(",", ""))
        readable = -1
        why = ""
        try:
            with open_session(out) as s:
                readable = int(s.n_samples)
                lengths = {int(s.read(k).shape[0]) for k in ("timeline/seq", "raw/adc")}
                if lengths != {readable}:
                    why = f"dataset lengths {sorted(lengths)}"
        except Exception as exc:
            why = f"cannot read: {exc}"
        # the display goes on: an Engine under the same limit keeps acquiring after the error
        eng = subprocess.run(
            [sys.executable, "-c", ENGINE_DISK_FULL, str(Path(d) / "eng.h5")],
            capture_output=True,
            text=True,
            timeout=180,
            env=_env(),
        )
    try:
        r = json.loads(eng.stdout.strip().splitlines()[-1])
        goes_on = bool(r["error"]) and r["after"] > r["before"] + 200
        on_fig = f"{r['after'] - r['before']} samples acquired in the 0.5 s after the error"
    except (ValueError, IndexError, KeyError):
        goes_on, on_fig = False, f"engine run failed: {eng.stderr.strip()[-200:]}"
    one_line = len(error_lines) == 1 and not tracebacks
    same = stated is not None and stated == readable and not why
    fig = (
        f"exit {res.returncode}; {len(error_lines)} error line(s)"
        + (" + a traceback" if tracebacks else "")
        + f" ({error_lines[0][:90]!r}{' ...' if len(error_lines) > 1 else ''})" * bool(error_lines)
        + f"; stated {stated} rows, readable {readable}"
        + (f" ({why})" if why else "")
        + f"; {on_fig}"
    )
    return [
        Row(
            "disk full",
            "one clear line; stated rows = readable rows; display goes on",
            fig,
            one_line and same and goes_on,
        )
    ]


# --- damaged files ----------------------------------------------------------------------------

DAMAGED_WORKER = textwrap.dedent("""
    # runs each command in-process and reports one JSON line per command
    import contextlib, io, json, shutil, sys, traceback
    from pathlib import Path
    from gaitmon.cli import main
    jobs = json.loads(sys.stdin.read())
    for job in jobs:
        work = Path(job["work"])
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir(parents=True)
        src = Path(job["path"])
        f = work / src.name
        if src.exists():
            shutil.copyfile(src, f)
        j = src.with_name(src.name + ".journal")
        if j.exists():
            shutil.copyfile(j, f.with_name(f.name + ".journal"))
        argv = [a.replace("{F}", str(f)).replace("{W}", str(work)) for a in job["argv"]]
        err = io.StringIO()
        tb = ""
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                code = main(argv)
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else 1
            except BaseException:
                code = -1
                tb = traceback.format_exc(limit=2)
        text = err.getvalue()
        if "Traceback" in text:
            tb = tb or text[-300:]
        print(json.dumps({"id": job["id"], "code": code, "tb": tb,
                          "lines": len([x for x in text.splitlines() if x.strip()])}), flush=True)
""")


def _load_corpus_module(path: str | None) -> object | None:
    candidates = [Path(path)] if path else [ROOT / "benchmarks" / "damaged_corpus.py"]
    for c in candidates:
        if c.is_file():
            spec = importlib.util.spec_from_file_location("damaged_corpus", c)
            assert spec is not None and spec.loader is not None
            mod = importlib.util.module_from_spec(spec)
            sys.modules["damaged_corpus"] = mod
            spec.loader.exec_module(mod)
            return mod
    return None


def row_damaged(quick: bool, corpus_module: str | None) -> list[Row]:
    goal = "0 hangs, 0 tracebacks"
    name = ">=100 damaged files x info/export/report"
    mod = _load_corpus_module(corpus_module)
    if mod is None:
        return [
            Row(
                name,
                goal,
                "NOT RUN: benchmarks/damaged_corpus.py is not here (it comes "
                "with branch `cli`; or pass --corpus-module PATH)",
                False,
            )
        ]
    from gaitmon.cli import main
    from gaitmon.export import FORMATS

    hang_s = 120.0
    with tempfile.TemporaryDirectory() as d:
        src = Path(d) / "walk.h5"
        with open(os.devnull, "w") as null:
            import contextlib

            with contextlib.redirect_stderr(null):
                rc = main(["record", "--simulate", "--duration", "12", "-o", str(src),
                           "--speed", "20", "--standing-s", "2", "--quiet",
                           "--patient", "P1"])  # fmt: skip
        if rc != 0:
            return [Row(name, goal, f"NOT RUN: recording the source session failed ({rc})", False)]
        variants = mod.make_corpus(src, Path(d) / "corpus", seed=3)
        chosen = variants[::8] if quick else variants
        commands = {"info": ["info", "{F}"], "report": ["report", "{F}", "-o", "{W}/r.pdf", "-q"]}
        for fmt, spec in FORMATS.items():
            commands[f"export-{fmt}"] = ["export", "{F}", "--format", fmt, "-q", "-o",
                                         "{W}/out" + spec.suffix]  # fmt: skip
        jobs = [
            {"id": i, "path": str(v[0]), "work": str(Path(d) / "w"), "argv": argv, "cmd": c,
             "what": v[1]}
            for i, (v, (c, argv)) in enumerate(
                (v, ca) for v in chosen for ca in commands.items()
            )
        ]  # fmt: skip
        results: dict[int, dict] = {}
        hangs: list[str] = []
        todo = list(jobs)
        while todo:
            proc = subprocess.Popen(
                [sys.executable, "-c", DAMAGED_WORKER], stdin=subprocess.PIPE,
                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=_env(),
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
            if left:
                hung = left[0]
                hangs.append(f"{hung['cmd']} on {hung['what']}")
                results[hung["id"]] = {"id": hung["id"], "code": None, "tb": "hang", "lines": 0}
                left = left[1:]
            todo = left
    tbs = [
        (jobs[i]["cmd"], jobs[i]["what"])
        for i, r in results.items()
        if r["tb"] and r["tb"] != "hang"
    ]
    multi = collections.Counter(
        jobs[i]["cmd"] for i, r in results.items() if r["code"] not in (0, None) and r["lines"] > 1
    )
    by_cmd = collections.Counter(c for c, _ in tbs)
    fig = (
        f"{len(chosen)} files x {len(commands)} commands = {len(jobs)} runs: {len(hangs)} hangs, "
        f"{len(tbs)} tracebacks"
        + (f" ({dict(by_cmd)}; e.g. {tbs[0][0]} on {tbs[0][1]})" if tbs else "")
        + f"; failing runs with more than one stderr line: {dict(multi) or 0}"
    )
    return [Row(name, goal, fig, not hangs and not tbs)]


# --- soak -------------------------------------------------------------------------------------


def _rss_mb(pid: int) -> float | None:
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def row_soak(quick: bool, speed: float) -> list[Row]:
    from gaitmon.finish import open_session

    hours = 0.15 if quick else 3.0
    duration_s = hours * 3600
    samples: list[tuple[float, float]] = []  # (recorded hours, RSS MB)
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "soak.h5"
        # the unit runs in its own process on a pty, so the recorder's RSS is not the
        # simulator's (its frame log and ledger grow by design, ~6 MB per hour)
        sim = subprocess.Popen(
            [*GAITMON, "simulate", "--pty", "--speed", f"{speed:g}", "--link",
             str(Path(d) / "ttySOAK")],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=_env(), text=True,
        )  # fmt: skip
        assert sim.stdout is not None
        port = sim.stdout.readline().strip()
        proc = subprocess.Popen(
            [*GAITMON, "record", "--port", port, "--duration", f"{duration_s:g}",
             "-o", str(out), "--quiet", "--status-lines"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env(),
        )  # fmt: skip
        assert proc.stdout is not None and proc.stderr is not None
        fd = proc.stdout.fileno()
        rows, next_sample, pending = 0, 0.0, b""
        t0 = time.monotonic()
        limit_s = duration_s / speed * 3 + 120
        while proc.poll() is None and time.monotonic() - t0 < limit_s:
            ready, _, _ = select.select([fd], [], [], 0.2)
            if ready:
                chunk = os.read(fd, 1 << 20)
                pending += chunk
                *done, pending = pending.split(b"\n")
                for line in done[-1:]:
                    parts = line.split()
                    if len(parts) == 3 and parts[0] == b"ROWS":
                        rows = int(parts[1])
            if time.monotonic() >= next_sample:
                rss = _rss_mb(proc.pid)
                if rss is not None and rows:
                    samples.append((rows / FS_HZ / 3600.0, rss))
                next_sample = time.monotonic() + 1.0
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        sim.send_signal(signal.SIGINT)
        try:
            sim.wait(10)
        except subprocess.TimeoutExpired:
            sim.kill()
            sim.wait()
        err = proc.stderr.read().decode(errors="replace").strip()
        wall_s = time.monotonic() - t0
        try:
            with open_session(out) as s:
                seq = s.read("timeline/seq")
                n = len(seq)
                n_gaps = len(s.gaps)
                reasons = collections.Counter(g.reason.split(":")[0][:40] for g in s.gaps)
        except Exception as exc:
            return [Row("accelerated soak", "written = sent", f"file unreadable: {exc}", False)]
    # written = sent: every frame the unit numbered between the first and last row is in the file
    sent = int(seq[-1] - seq[0] + 1) if n else 0
    recorded_h = n / FS_HZ / 3600.0
    pts = [(h, m) for h, m in samples if h >= 0.1 * recorded_h]
    slope = float(np.polyfit(*zip(*pts, strict=True), 1)[0]) if len(pts) >= 5 else math.nan
    complete = n >= duration_s * FS_HZ
    last_err = err.splitlines()[-1][:120] if err else "no message"
    incomplete = "" if complete else f" (INCOMPLETE: {last_err})"
    fig = (
        f"{recorded_h:.2f} h of data in {wall_s:.0f} s (simulator on a pty at speed {speed:g}); "
        f"written {n:,} = sent "
        f"{sent:,}: {'yes' if n == sent else 'NO'}, {n_gaps} gaps"
        f"{' ' + str(dict(reasons)) if reasons else ''}"
        f"{incomplete}; "
        f"RSS {samples[0][1] if samples else math.nan:.0f} -> "
        f"{samples[-1][1] if samples else math.nan:.0f} MB, slope {slope:.2f} MB per recorded hour"
    )
    ok = complete and n == sent and n_gaps == 0 and slope <= 2.0
    return [
        Row(
            f"accelerated soak {hours:g} h of data" + (" (quick; goal is >= 3 h)" if quick else ""),
            "written = sent; RSS slope <= 2 MB per recorded hour",
            fig,
            ok,
        )
    ]


# --- main ------------------------------------------------------------------------------------


def _more_rows() -> dict[str, Callable[[argparse.Namespace], list[Row]]]:
    """The rows of every module in benchmarks/faults/ (each defines ROWS), by module name."""
    out: dict[str, Callable[[argparse.Namespace], list[Row]]] = {}
    for path in sorted((Path(__file__).parent / "faults").glob("*.py")):
        if path.stem in ("__init__", "common"):
            continue
        mod = importlib.import_module(f"faults.{path.stem}")
        out.update(mod.ROWS)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller sizes (~2-4 min)")
    more = _more_rows()
    ap.add_argument("--only", default="", help="comma-separated rows: " + ",".join(
        ["decoder", "linkcut", "kill9", "diskfull", "damaged", "soak", *more]))  # fmt: skip
    ap.add_argument("--corpus-module", default=None, help="path of a damaged_corpus.py")
    ap.add_argument("--soak-speed", type=float, default=12.0, help="simulator time factor")
    args = ap.parse_args()
    rows: dict[str, Callable[[], list[Row]]] = {
        "decoder": lambda: row_decoder(args.quick),
        "linkcut": lambda: row_linkcut(args.quick),
        "kill9": lambda: row_kill9(args.quick),
        "diskfull": lambda: row_diskfull(args.quick),
        "damaged": lambda: row_damaged(args.quick, args.corpus_module),
        "soak": lambda: row_soak(args.quick, args.soak_speed),
    }
    for name, fn in more.items():
        rows[name] = functools.partial(fn, args)
    asked = [ALIASES.get(r, r) for r in args.only.split(",") if r]
    unknown = [r for r in asked if r not in rows]
    if unknown:
        ap.error(f"no row named {', '.join(unknown)}; the rows are {', '.join(rows)}")
    only = list(dict.fromkeys(asked)) or list(rows)  # each row once, in the order asked
    table: list[Row] = []
    t_all = time.monotonic()
    for name in only:
        t0 = time.monotonic()
        try:
            got = rows[name]()
        except Exception as exc:  # a row that crashes is a FAIL with its reason, not a stop
            tb = traceback.format_exc(limit=3).strip().splitlines()[-1]
            got = [Row(name, "(see goal)", f"row crashed: {tb or exc}", False)]
        for r in got:
            table.append(r)
            print(f"[{time.monotonic() - t0:6.1f} s] {r.line()}", file=sys.stderr, flush=True)
    mode = "quick" if args.quick else "full"
    print(f"\ngaitmon fault-injection suite ({mode} mode, {time.monotonic() - t_all:.0f} s)\n")
    print("| test | goal | measured | result |")
    print("|---|---|---|---|")
    for r in table:
        print(r.line())
    return 0 if all(r.ok for r in table) else 1


if __name__ == "__main__":
    sys.exit(main())
