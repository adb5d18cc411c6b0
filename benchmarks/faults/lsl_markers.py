"""Fault rows: LSL markers and control words from another process (issue 26).

``gaitmon record`` runs in a child process; this process is the other program on the
computer, sending through real pylsl outlets:

* hostile labels: NUL, ANSI escapes, line breaks, a bidi override, bytes that are not UTF-8,
  1 MB labels and spreadsheet formulas;
* a flood: tens of thousands of markers as fast as liblsl takes them, 1 MB labels among them;
* a second control stream of the same name (an impostor) sending "stop".

Goals: 0 tracebacks, the recording complete with 0 frames lost to the markers, ``info`` and
``export --format csv`` exit 0, no raw control byte in any output, every formula cell
neutralised, and every marker accounted for (recorded + stamped outside + dropped = sent),
the gaitmon process's peak memory bounded.
"""

from __future__ import annotations

import argparse
import csv
import re
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

from faults.common import GAITMON, Row, env

FORMULAS = ['=HYPERLINK("http://example.invalid/x","click")', "+cmd|' /C calc'!A0",
            "-2+3+cmd|' /C calc'!A0", "@SUM(1+1)*cmd|' /C calc'!A0"]  # fmt: skip
HOSTILE: list[Any] = [
    "a\x00b", "\x00", "\x1b[31mred\x1b[0m", "\x1b]0;title\x07", "\x1b[2J", "line\nbreak\r",
    "abc\u202edcba", b"\xff\xfe\xfd not utf-8", "M" * 1_000_000, "\x00" * 1_000_000,
    "\x1b" * 1_000_000, *FORMULAS,
]  # fmt: skip


def _pylsl() -> Any:
    import pylsl  # the optional extra gaitmon[lsl]

    return pylsl


def _start(cmd: list[str], cwd: Path, until: str) -> tuple[subprocess.Popen[str], list[str]]:
    proc = subprocess.Popen([*GAITMON, *cmd], stderr=subprocess.PIPE, text=True, env=env(),
                            cwd=cwd)  # fmt: skip
    err: list[str] = []
    assert proc.stderr is not None
    for line in proc.stderr:
        err.append(line)
        if until in line:
            break
    return proc, err


def _finish(proc: subprocess.Popen[str], err: list[str], timeout_s: float = 300) -> str:
    try:
        err.append(proc.communicate(timeout=timeout_s)[1])
    except subprocess.TimeoutExpired:
        proc.kill()
        err.append(proc.communicate()[1] + "\nHANG: killed")
    return "".join(err)


def _peak_rss_mb(pid: int) -> float:
    try:
        text = Path(f"/proc/{pid}/status").read_text(encoding="ascii")
    except OSError:
        return float("nan")
    m = re.search(r"VmHWM:\s+(\d+) kB", text)
    return int(m[1]) / 1024 if m else float("nan")


def _accounted(text: str) -> tuple[int, int, int, int]:
    """recorded, received, outside, dropped, from the command's markers line."""
    lines = [ln for ln in text.splitlines() if "markers from LSL stream" in ln]
    if not lines:
        return 0, 0, 0, 0
    m = re.search(r"(\d[\d,]*) of (\d[\d,]*) markers", lines[-1])
    outside = re.search(r"; (\d[\d,]*) stamped outside", lines[-1])
    dropped = re.search(r"; (\d[\d,]*) dropped", lines[-1])

    def n(x: Any) -> int:
        return int(x.replace(",", "")) if x else 0

    return (n(m and m[1]), n(m and m[2]), n(outside and outside[1]), n(dropped and dropped[1]))


def _checked_outputs(out: Path, folder: Path) -> tuple[bool, str]:
    """info and csv export of ``out``: both exit 0, no traceback, no raw control byte, every
    formula cell neutralised."""
    info = subprocess.run([*GAITMON, "info", str(out)], capture_output=True, text=True,
                          env=env(), cwd=folder, timeout=300, check=False)  # fmt: skip
    csv_path = folder / "out.csv"
    exp = subprocess.run([*GAITMON, "export", str(out), "--format", "csv", "-o", str(csv_path),
                          "--force"], capture_output=True, text=True, env=env(), cwd=folder,
                         timeout=300, check=False)  # fmt: skip
    texts = info.stdout + info.stderr + exp.stdout + exp.stderr
    problems = []
    from gaitmon.finish import open_session

    with open_session(out) as s:
        if not s.complete or s.problems:
            problems.append(f"file not complete ({'; '.join(s.problems)})")
    if info.returncode or exp.returncode:
        problems.append(f"info {info.returncode}, export {exp.returncode}")
    if "Traceback" in texts:
        problems.append("traceback")
    if "\x1b" in info.stdout or "\x00" in info.stdout:
        problems.append("control byte in info")
    live = 0
    if csv_path.exists():
        data = csv_path.read_bytes()
        if b"\x1b" in data or b"\x00" in data:
            problems.append("control byte in csv")
        with open(csv_path, newline="", encoding="utf-8") as f:
            cells = [r[-1] for r in csv.reader(f) if r][1:]
        live = sum(1 for c in cells if c[:1] in ("=", "+", "@") or
                   (c[:1] == "-" and not _number(c)))  # fmt: skip
        if live:
            problems.append(f"{live} live formula cells")
    return not problems, "; ".join(problems)


def _number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _hostile_or_flood(quick: bool, flood: bool) -> Row:
    pylsl = _pylsl()
    name = f"gaitmon-fault-{'flood' if flood else 'hostile'}-{time.monotonic_ns()}"
    outlet = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, "string", name))
    duration_s = 8 if quick else 20
    with tempfile.TemporaryDirectory(prefix="gaitmon-fault-lsl-") as tmp:
        folder = Path(tmp)
        out = folder / "m.h5"
        proc, err = _start(["record", "--simulate", "--duration", str(duration_s), "-o",
                            str(out), "--lsl-markers", name, "--lsl-timeout", "30"], folder,
                           "recording ")  # fmt: skip
        sent = 0
        peak = float("nan")
        try:
            if not outlet.wait_for_consumers(30.0):
                raise RuntimeError("gaitmon never connected to the marker stream")
            time.sleep(1.5)
            if flood:
                n = 20_000 if quick else 100_000
                big = "B" * 1_000_000
                t_end = time.monotonic() + duration_s - 4
                while sent < n and time.monotonic() < t_end:
                    chunk = [[big if (sent + i) % 1000 == 0 else f"flood {sent + i}"]
                             for i in range(500)]  # fmt: skip
                    outlet.push_chunk(chunk)
                    sent += len(chunk)
                    peak = _peak_rss_mb(proc.pid)
            else:
                for rounds in range(3 if quick else 10):
                    for label in HOSTILE:
                        outlet.push_sample([label])
                        sent += 1
                    time.sleep(0.3)
                    if rounds == 0:
                        peak = _peak_rss_mb(proc.pid)
            time.sleep(1.0)
            peak = max(peak, _peak_rss_mb(proc.pid))
        finally:
            text = _finish(proc, err)
        recorded, received, outside, dropped = _accounted(text)
        with_file = out.exists()
        ok_out, why = _checked_outputs(out, folder) if with_file else (False, "no file")
    lost = re.search(r"; (\d[\d,]*) frames lost", text)
    frames_lost = int(lost[1].replace(",", "")) if lost else -1
    tracebacks = text.count("Traceback")
    # gaitmon accounts for every sample it receives; liblsl's own inlet buffer (36,000 samples)
    # may drop the oldest of a flood it could not hand over in time, uncounted (LSL samples
    # carry no sequence number): shown as a figure, the goal is gaitmon's own accounting
    accounted = recorded + outside + dropped == received <= sent
    if not flood:
        accounted = accounted and received == sent
    ok = (proc.returncode == 0 and tracebacks == 0 and ok_out and accounted
          and frames_lost == 0 and "HANG" not in text)  # fmt: skip
    what = "flood" if flood else "hostile labels"
    fig = (f"{sent:,} sent: {recorded:,} recorded + {outside} outside + {dropped:,} dropped "
           f"= {received:,} received ({sent - received:,} lost inside liblsl, uncounted); "
           f"exit {proc.returncode}, {tracebacks} tracebacks, "
           f"{frames_lost} frames lost, peak RSS {peak:.0f} MB; info+csv "
           f"{'ok' if ok_out else why}")  # fmt: skip
    goal = ("0 tracebacks, file complete, 0 frames lost, info/csv clean, "
            "recorded + outside + dropped = received" + ("" if flood else " = sent"))
    return Row(f"LSL markers from another process: {what}", goal, fig, ok)


def _impostor(quick: bool) -> Row:
    """Two control streams of one name: refused without a source id; with one, the
    impostor's stop changes nothing."""
    pylsl = _pylsl()
    name = f"gaitmon-fault-ctl-{time.monotonic_ns()}"
    real = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, "string", "ctl-real"))
    fake = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, "string", "ctl-fake"))
    with tempfile.TemporaryDirectory(prefix="gaitmon-fault-lsl-") as tmp:
        folder = Path(tmp)
        refused = subprocess.run([*GAITMON, "record", "--simulate", "--duration", "5", "-o",
                                  str(folder / "a.h5"), "--lsl-control", name,
                                  "--lsl-timeout", "10"], capture_output=True, text=True,
                                 env=env(), cwd=folder, timeout=120, check=False)  # fmt: skip
        one_line = len([ln for ln in refused.stderr.splitlines() if ln.strip()]) == 1
        out = folder / "b.h5"
        proc, err = _start(["record", "--simulate", "--duration", "60", "-o", str(out),
                            "--lsl-control", name, "--lsl-control-source-id", "ctl-real",
                            "--lsl-timeout", "20"], folder, "waiting for 'start'")  # fmt: skip
        try:
            real.wait_for_consumers(20.0)
            real.push_sample(["start"])
            time.sleep(1.0)
            for word in ("stop", "STOP", " stop "):
                fake.push_sample([word])
            real.push_sample(["stop\x00"])
            real.push_sample(["stop\n"])
            time.sleep(2.0)
            survived = proc.poll() is None
            real.push_sample(["stop"])
        finally:
            text = _finish(proc, err, 120)
    ok = (refused.returncode == 2 and one_line and survived and proc.returncode == 0
          and "Traceback" not in text + refused.stderr)  # fmt: skip
    fig = (f"same name, no source id: exit {refused.returncode} "
           f"({'one line' if one_line else 'not one line'}); with --lsl-control-source-id: "
           f"impostor's 3 stops and 'stop\\x00', 'stop\\n' ignored: "
           f"{'yes' if survived else 'NO'}, real stop: exit {proc.returncode}")
    return Row("LSL control stream: an impostor of the same name",
               "refused without a source id; with one, only its stop stops", fig, ok)


def row_lsl(args: argparse.Namespace) -> list[Row]:
    try:
        _pylsl()
    except (ImportError, OSError, RuntimeError) as exc:
        return [Row("LSL markers from another process", "(needs pylsl)",
                    f"skipped: {exc}", True)]  # fmt: skip
    return [_hostile_or_flood(args.quick, flood=False), _hostile_or_flood(args.quick, flood=True),
            _impostor(args.quick)]  # fmt: skip


ROWS = {"lsl": row_lsl}
