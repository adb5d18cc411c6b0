"""Markers and control words from another process that gaitmon must not trust (issue 26):
NUL bytes, ANSI escapes, bytes that are not UTF-8, a 1 MB label, a spreadsheet formula, a
flood; two control streams of the same name; and the interfaces LSL listens on.

``gaitmon record`` runs in its own process and the senders are real pylsl outlets in this
one: the recording must finish complete, ``info`` and ``export`` must read it, every marker
must be accounted for (recorded, stamped outside, or dropped and counted), and no label may
reach a file, a terminal or a spreadsheet as anything but text.
"""

from __future__ import annotations

import csv
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pylsl = pytest.importorskip("pylsl")

from gaitmon.finish import open_session  # noqa: E402
from gaitmon.text import MAX_LABEL_CHARS, TRUNCATED  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MEGABYTE_LABEL = "M" * 1_000_000
FORMULA = '=HYPERLINK("http://example.invalid/x","click")'
FLOOD = 3000  # sent at once: more than the stream's burst (1,000)


def _unique(prefix: str) -> str:
    return f"{prefix}-{os.getpid()}-{time.monotonic_ns()}"


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def _gaitmon(*args: str, cwd: Path, timeout_s: float = 120) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, "-m", "gaitmon", *args]
    return subprocess.run(cmd, capture_output=True, text=True, env=_env(), cwd=cwd,
                          timeout=timeout_s, check=False)  # fmt: skip


def _start(cmd: list[str], cwd: Path, until: str) -> tuple[subprocess.Popen[str], list[str]]:
    """``gaitmon`` in its own process, read until a line of its standard error holds ``until``."""
    proc = subprocess.Popen([sys.executable, "-m", "gaitmon", *cmd], stderr=subprocess.PIPE,
                            text=True, env=_env(), cwd=cwd)  # fmt: skip
    err: list[str] = []
    assert proc.stderr is not None
    for line in proc.stderr:
        err.append(line)
        if until in line:
            break
    return proc, err


def _finish(proc: subprocess.Popen[str], err: list[str], timeout_s: float = 120.0) -> str:
    try:
        err.append(proc.communicate(timeout=timeout_s)[1])
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return "".join(err)


def _accounted(line: str) -> tuple[int, int, int, int]:
    """recorded, received, stamped outside (before or after the recording), dropped: from the
    command's markers line."""
    m = re.search(r"(\d[\d,]*) of (\d[\d,]*) markers from LSL stream", line)
    assert m, line

    def n(pattern: str) -> int:
        found = re.search(rf"[:,] (\d[\d,]*) {pattern}", line)
        return int(found[1].replace(",", "")) if found else 0

    outside = n("stamped before") + n("stamped or sent after")
    return int(m[1].replace(",", "")), int(m[2].replace(",", "")), outside, n("dropped")


def test_hostile_markers_from_another_process_leave_a_complete_readable_recording(tmp_path):
    name = _unique("gaitmon-test-hostile")
    outlet = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, "string", name))
    out = tmp_path / "hostile.h5"
    proc, err = _start(["record", "--simulate", "--duration", "6", "-o", str(out),
                        "--lsl-markers", name, "--lsl-timeout", "20"], tmp_path,
                       "recording ")  # fmt: skip
    try:
        assert outlet.wait_for_consumers(20.0), "".join(err)
        time.sleep(2.0)  # recording by now
        labels = ["a\x00b", "\x1b[31mred\x1b[0m", MEGABYTE_LABEL, FORMULA, "tab\there", "ok"]
        now = pylsl.local_clock()
        for i, label in enumerate(labels):  # each on a row of its own (5 rows apart)
            outlet.push_sample([label], now - 1.0 + 0.05 * i)
        time.sleep(0.5)  # pulled apart from what follows
        outlet.push_sample([b"\xff\xfe not utf-8"])  # pylsl itself would raise decoding it
        time.sleep(0.5)
        outlet.push_chunk([[f"flood {i}"] for i in range(FLOOD)])
        sent = len(labels) + 1 + FLOOD
    finally:
        text = _finish(proc, err)
    assert proc.returncode == 0, text
    assert "Traceback" not in text and "internal error" not in text
    last = [ln for ln in text.splitlines() if "markers from LSL stream" in ln][-1]
    # every marker accounted for: recorded + outside + dropped = received = sent
    recorded, received, outside, dropped = _accounted(last)
    assert received == sent, last
    assert recorded + outside + dropped == sent, last
    # the flood was cut to the stream's budget: a burst of 1,000, then 100 a second (the
    # recording lasts 6 s)
    assert dropped > 0 and recorded <= 1000 + 100 * 6, last
    with open_session(out) as s:
        assert s.complete and not s.problems
        got = [m.label for m in s.markers]
    assert len(got) == recorded
    assert "a\\x00b" in got
    assert "\\x1b[31mred\\x1b[0m" in got
    assert FORMULA in got and "tab\\x09here" in got and "ok" in got
    assert "\ufffd\ufffd not utf-8" in got  # replaced, not the chunk lost
    big = [g for g in got if g.startswith("MMM")]
    assert big == ["M" * (MAX_LABEL_CHARS - len(TRUNCATED)) + TRUNCATED]
    assert all(len(g) <= MAX_LABEL_CHARS and g.isprintable() for g in got)

    info = _gaitmon("info", str(out), cwd=tmp_path)
    assert info.returncode == 0, info.stderr
    assert "Traceback" not in info.stderr + info.stdout
    assert "\x1b" not in info.stdout and "\x00" not in info.stdout
    assert not list(tmp_path.glob("*.recovering"))

    exported = _gaitmon("export", str(out), "--format", "csv", "-o", str(tmp_path / "h.csv"),
                        cwd=tmp_path)  # fmt: skip
    assert exported.returncode == 0, exported.stderr
    data = (tmp_path / "h.csv").read_bytes()
    assert b"\x1b" not in data and b"\x00" not in data
    with open(tmp_path / "h.csv", newline="", encoding="utf-8") as f:
        cells = [row[-1] for row in csv.reader(f) if row and row[-1]]
    formula_cells = [c for c in cells if "HYPERLINK" in c]
    assert formula_cells and all(c.startswith("'=") for c in formula_cells), formula_cells
    assert not any(c.startswith(("=", "+", "@")) for c in cells[1:])


def test_the_control_stream_is_the_one_with_the_source_id_given(tmp_path):
    """Two senders use the control stream's name: without a source id the command refuses
    (naming both); with one, the impostor's "stop" (and its "start") change nothing."""
    name = _unique("gaitmon-test-ctl")
    real = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, "string", "lab-real"))
    fake = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, "string", "lab-fake"))
    refused = _gaitmon("record", "--simulate", "--duration", "5", "-o", str(tmp_path / "a.h5"),
                       "--lsl-control", name, "--lsl-timeout", "10", cwd=tmp_path)  # fmt: skip
    assert refused.returncode == 2
    lines = [ln for ln in refused.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, refused.stderr
    assert "2 LSL streams are named" in lines[0] and "--lsl-control-source-id" in lines[0]
    assert "'lab-real'" in lines[0] and "'lab-fake'" in lines[0]
    assert not (tmp_path / "a.h5").exists()

    out = tmp_path / "b.h5"
    proc, err = _start(["record", "--simulate", "--duration", "60", "-o", str(out),
                        "--lsl-control", name, "--lsl-control-source-id", "lab-real",
                        "--lsl-timeout", "20"], tmp_path, "waiting for 'start'")  # fmt: skip
    try:
        assert real.wait_for_consumers(20.0), "".join(err)
        fake.push_sample(["start"])  # not the stream chosen: nothing starts
        time.sleep(1.0)
        assert proc.poll() is None
        real.push_sample(["start"])
        time.sleep(1.0)
        fake.push_sample(["stop"])
        real.push_sample(["stop\n"])  # not the word: a line break is no space
        real.push_sample(["stop\x00"])
        time.sleep(1.5)
        assert proc.poll() is None, "stopped by the impostor or by a word that is not 'stop'"
        real.push_sample([" STOP "])
        text = _finish(proc, err, 60.0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, text
    with open_session(out) as s:
        assert s.complete
        assert s.stop_reason == f"remote: 'stop' on LSL stream {name!r}"
        assert s.duration_s > 2.0  # the impostor's stop at 1 s after the start did nothing


def _sockets(pid: int) -> list[tuple[str, str, int]]:
    """The process's own sockets (from /proc): (kind, local address, local port)."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    out = []
    for kind in ("tcp", "tcp6", "udp", "udp6"):
        with open(f"/proc/{pid}/net/{kind}", encoding="ascii") as f:
            for line in f.read().splitlines()[1:]:
                cols = line.split()
                if cols[9] in inodes and (not kind.startswith("tcp") or cols[3] == "0A"):
                    addr, port = cols[1].split(":")
                    out.append((kind, addr, int(port, 16)))
    return out


LOOPBACK = "0100007F"  # 127.0.0.1 as /proc/net writes it (little-endian hex)
ANY = "00000000"
MULTICAST_PORT = 16571  # liblsl's discovery port


@pytest.mark.skipif(not Path("/proc/self/net/tcp").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("scope", [None, "site"])
def test_lsl_answers_discovery_on_loopback_only_unless_asked(tmp_path, scope):
    """``record --lsl`` by default: liblsl answers discovery on 127.0.0.1 only and opens no
    IPv6 socket, and a program on this computer still finds the streams; ``--lsl-scope
    site`` opens discovery to the network (every interface), as liblsl does by default."""
    out = tmp_path / "s.h5"
    extra = [] if scope is None else ["--lsl-scope", scope]
    proc, err = _start(["record", "--simulate", "--duration", "120", "--lsl", "-o", str(out),
                        *extra], tmp_path, "streaming to LSL as")  # fmt: skip
    try:
        assert proc.poll() is None, "".join(err)
        deadline = time.monotonic() + 20
        found: list[str] = []
        while not found and time.monotonic() < deadline:
            found = [s.name() for s in pylsl.resolve_streams(1.0)
                     if s.name() == "gaitmon sim angles" and s.hostname()]  # fmt: skip
        socks = _sockets(proc.pid)
    finally:
        proc.send_signal(signal.SIGINT)
        text = _finish(proc, err)
    assert found, "a program on this computer must still find the streams"
    discovery = [(k, a) for k, a, p in socks if k.startswith("udp") and p == MULTICAST_PORT]
    assert discovery, socks
    if scope is None:
        assert set(discovery) == {("udp", LOOPBACK)}, socks
        assert not [s for s in socks if s[0].endswith("6")], socks  # no IPv6 socket at all
    else:
        assert ("udp", ANY) in discovery, socks
    assert "Traceback" not in text


# A session left by the old code: a NUL marker in its journal (which HDF5 could not store)
_OLD_CRASH = """
import os, sys
import numpy as np
sys.path.insert(0, {tests!r})
from conftest import write_simulated_session  # noqa: F401  (the same simulated counts)
import gaitmon.io.session.writer as writer_module
from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.io.device import SampleBlock
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session import SessionHeader, SessionWriter
from gaitmon.io.sim import GaitConfig, GaitModel
from gaitmon.io.sim.sensors import simulate

writer_module.clean_label = str  # the old code: labels stored as sent
counts = simulate(600, GaitModel(GaitConfig(seed=3))).counts
w = SessionWriter({path!r}, SessionHeader("raw", 100.0, config=PipelineConfig(),
                                           calibration=Calibration.identity()))
w.flush_interval_s = 1e9  # no timed flush: on a busy machine one fell after the marker
pipe = Pipeline(PipelineConfig())
for i in range(0, 600, 50):
    seq = np.arange(i, i + 50, dtype=np.int64)
    w.append(SampleBlock(FrameKind.RAW, seq, seq / 100.0, 1.7e9,
                         lost_before=np.zeros(50, np.int64), adc=counts[i:i + 50]),
             pipe.process(counts[i:i + 50]))
    if i == 200:
        w.add_marker("a\\x00b")
        w.add_marker("\\x1b[2J" + "x" * 5000)
w._journal.sync()
os._exit(9)  # as a crash (kill -9): no close, the journal is what is left
"""


def test_a_journal_with_a_nul_marker_from_the_old_code_is_recovered(tmp_path):
    path = tmp_path / "nul.h5"
    code = _OLD_CRASH.format(tests=str(ROOT / "tests"), path=str(path))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=_env(), cwd=tmp_path, timeout=120, check=False)  # fmt: skip
    assert done.returncode == 9, done.stderr
    info = _gaitmon("info", str(path), cwd=tmp_path)
    assert info.returncode == 0, info.stderr
    assert "Traceback" not in info.stdout + info.stderr
    assert "\x1b" not in info.stdout + info.stderr
    assert not list(tmp_path.glob("*.recovering")), list(tmp_path.iterdir())
    with open_session(path) as s:
        labels = [m.label for m in s.markers]
        assert s.n_samples == 600
    assert labels[0] == "a\\x00b"
    assert labels[1].startswith("\\x1b[2Jxxx") and labels[1].endswith(TRUNCATED)
    assert len(labels[1]) == MAX_LABEL_CHARS
