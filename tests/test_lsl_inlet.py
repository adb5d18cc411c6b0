"""The LSL marker inlet and remote start/stop, with real pylsl outlets in the test and the
simulated unit in real time (the sample clock must be the host's for a timestamp to mean a
row).

The expected row of a marker is computed from the file alone: the simulator sends sample n when
``time.monotonic()`` reaches t0 + n / fs, so a row's sample was taken at its ``timeline/t_s``
plus one constant, and the smallest ``host_time_s - t_s`` of the file (the frames read
soonest) is that constant. On Linux pylsl's clock is ``time.monotonic()``'s; the test measures
the offset between them all the same.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

pylsl = pytest.importorskip("pylsl")

from gaitmon.cli import main  # noqa: E402
from gaitmon.finish import open_session  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FS_HZ = 100.0


def _unique(prefix: str) -> str:
    """Stream names no other test (or process on this machine) uses."""
    return f"{prefix}-{os.getpid()}-{time.monotonic_ns()}"


def _marker_outlet(name: str, fmt: str = "string") -> pylsl.StreamOutlet:
    return pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, fmt, name))


def _lsl_to_monotonic() -> float:
    best = None
    for _ in range(20):
        t0 = time.monotonic()
        lsl = pylsl.local_clock()
        t1 = time.monotonic()
        if best is None or t1 - t0 < best[0]:
            best = (t1 - t0, (t0 + t1) / 2 - lsl)
    return best[1]


def _expected_row(path: Path, lsl_stamp_s: float, offset_s: float) -> tuple[int, np.ndarray]:
    """The row whose sample was taken at ``lsl_stamp_s`` (pylsl's clock), from the file's own
    timeline columns; and the file's t_s."""
    with open_session(path) as s:
        host = np.asarray(s.read("timeline/host_time_s"))
        t = np.asarray(s.read("timeline/t_s"))
    taken = t + np.min(host - t)  # when each row's sample was taken, on the host clock
    return int(np.argmin(np.abs(taken - (lsl_stamp_s + offset_s)))), t


def _wait(cond, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not cond():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_markers_from_an_lsl_outlet_land_on_the_row_sampled_at_their_timestamp(tmp_path):
    from gaitmon.engine import Engine
    from gaitmon.io.device import Device
    from gaitmon.io.session import SessionMeta
    from gaitmon.io.sim import GaitConfig, SimulatedUnit
    from gaitmon.io.sim.pty import PtySimulator
    from gaitmon.io.transport import SerialTransport
    from gaitmon.lsl.inlet import MarkerInlet, resolve_marker_stream

    name = _unique("gaitmon-test-triggers")
    outlet = _marker_outlet(name)
    info = resolve_marker_stream(pylsl, name, 10.0, "--lsl-markers")
    inlet = MarkerInlet(pylsl, info, open_timeout_s=10.0)
    out = tmp_path / "m.h5"
    offset_s = _lsl_to_monotonic()
    unit = SimulatedUnit(GaitConfig(seed=5, standing_s=1.0), speed=1.0)
    stamps: dict[str, float] = {}
    try:
        with PtySimulator(unit) as sim:
            eng = Engine(Device(SerialTransport(str(sim.link_path))), "raw", transport_label="pty")
            with eng:
                inlet.start(lambda label, t: eng.add_marker(label, host_time_s=t))
                assert outlet.wait_for_consumers(10.0)
                eng.start_recording(out, SessionMeta(patient_id="L1"))
                _wait(lambda: eng.recording.rows >= 250)  # 2.5 s recorded
                now = pylsl.local_clock()
                stamps = {
                    "one second ago": now - 1.0,  # arrives 1 s after its samples
                    "just now": now,
                    "soon": now + 0.4,  # arrives 40 rows before its sample exists
                    "before the recording": now - 2.5 - 3.0,
                    "trigger 12": now - 0.25,
                }
                for label, ts in stamps.items():
                    outlet.push_sample([label], ts)
                _wait(lambda: eng.timed_markers.recorded + eng.timed_markers.outside == 5)
                counts = eng.timed_markers
                eng.stop_recording()
    finally:
        inlet.close()
    assert not [t.name for t in threading.enumerate() if t.name.startswith("gaitmon-")]
    assert (counts.recorded, counts.outside, counts.waiting) == (4, 1, 0)
    assert inlet.received == 5 and not inlet.error
    with open_session(out) as s:
        got = {m.label: m for m in s.markers}
    assert set(got) == set(stamps) - {"before the recording"}
    for label, m in got.items():
        expected, t = _expected_row(out, stamps[label], offset_s)
        assert abs(m.sample_idx - expected) <= 1, (label, m.sample_idx, expected)
        assert m.t_s == pytest.approx(t[m.sample_idx])  # the table's time is that row's time
    assert got["one second ago"].sample_idx < got["trigger 12"].sample_idx < got["soon"].sample_idx


def test_an_unknown_stream_name_is_one_line_and_exit_2(tmp_path, capfd):
    out = tmp_path / "x.h5"
    rc = main(["record", "--simulate", "--duration", "1", "-o", str(out),
               "--lsl-markers", _unique("no-such-stream"), "--lsl-timeout", "0.3"])  # fmt: skip
    err = capfd.readouterr().err
    assert rc == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "no LSL stream named 'no-such-stream-" in lines[0] and "--lsl-timeout" in lines[0]
    assert "Traceback" not in err
    assert not out.exists()  # nothing was started


def test_a_regular_stream_is_not_taken_for_a_marker_stream(tmp_path, capfd):
    name = _unique("gaitmon-test-eeg")
    keep = pylsl.StreamOutlet(pylsl.StreamInfo(name, "EEG", 2, 250.0, "float32", name))
    rc = main(["record", "--simulate", "--duration", "1", "-o", str(tmp_path / "x.h5"),
               "--lsl-control", name, "--lsl-timeout", "5"])  # fmt: skip
    del keep
    err = capfd.readouterr().err
    assert rc == 2
    assert "is a regular 250 Hz stream, not a marker stream" in err
    assert "Traceback" not in err


def test_without_pylsl_the_options_say_how_to_install_it(tmp_path, capfd, monkeypatch):
    monkeypatch.setitem(sys.modules, "pylsl", None)  # "import pylsl" raises ImportError
    rc = main(["record", "--simulate", "--duration", "1", "-o", str(tmp_path / "x.h5"),
               "--lsl-control", "LabControl"])  # fmt: skip
    err = capfd.readouterr().err
    assert rc == 2
    assert "install gaitmon[lsl]" in err and len(err.strip().splitlines()) == 1


def test_the_same_start_and_stop_word_is_refused(tmp_path, capfd):
    words = ["--lsl-start-word", "Go", "--lsl-stop-word", " go "]
    rc = main(["record", "--simulate", "--duration", "1", "-o", str(tmp_path / "x.h5"),
               "--lsl-control", "X", *words])  # fmt: skip
    assert rc == 2
    assert "the LSL start and stop words are the same" in capfd.readouterr().err


def test_a_recording_without_lsl_options_never_loads_pylsl(tmp_path):
    code = (
        "import sys; from gaitmon.cli import main; "
        f"rc = main(['record', '--simulate', '--speed', 'max', '--duration', '0.5', '-q', "
        f"'-o', {str(tmp_path / 'p.h5')!r}]); "
        "print(rc, 'pylsl' in sys.modules)"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=120, check=False)  # fmt: skip
    assert done.stdout.split() == ["0", "False"], done.stderr


def test_remote_start_and_stop_from_an_lsl_marker_stream(tmp_path):
    """``gaitmon record --lsl-control`` in its own process: the unit streams while it waits,
    "start" starts the recording, "stop" ends it with a complete file, and a trigger from a
    second stream lands on its row."""
    control = _unique("gaitmon-test-control")
    triggers = _unique("gaitmon-test-stim")
    ctl, stim = _marker_outlet(control), _marker_outlet(triggers, "int32")
    out = tmp_path / "remote.h5"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "gaitmon", "record", "--simulate", "--duration", "60",
           "-o", str(out), "--lsl-control", control, "--lsl-markers", triggers,
           "--lsl-start-word", "Begin", "--lsl-timeout", "20"]  # fmt: skip
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path)
    err: list[str] = []
    try:
        assert proc.stderr is not None
        for line in proc.stderr:  # the unit streams before the start word is sent
            err.append(line)
            if "waiting for 'Begin'" in line:
                break
        assert ctl.wait_for_consumers(20.0) and stim.wait_for_consumers(20.0), "".join(err)
        offset_s = _lsl_to_monotonic()
        time.sleep(0.5)
        ctl.push_sample(["stop"])  # a stop before the start is ignored
        ctl.push_sample(["something else"])
        start = pylsl.local_clock()
        ctl.push_sample(["BEGIN"], start)  # words match whatever their case
        time.sleep(1.5)
        trigger = pylsl.local_clock() - 0.5
        stim.push_sample([12], trigger)
        time.sleep(1.0)
        stop = pylsl.local_clock()
        ctl.push_sample([" stop "], stop)
        rest = proc.communicate(timeout=60)[1]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    err.append(rest)
    text = "".join(err)
    assert proc.returncode == 0, text
    assert "Traceback" not in text
    assert "1 of 1 markers from LSL stream" in text
    with open_session(out) as s:
        assert s.complete and not s.problems
        assert s.stop_reason == f"remote: 'stop' on LSL stream {control!r}"
        n, duration_s, markers = s.n_samples, s.duration_s, list(s.markers)
    expected_s = stop - start
    # the recording begins and ends with the block after each word arrives (a few ms on one
    # computer; a block or two of the unit's 10 ms samples, more on a busy machine)
    assert abs(duration_s - expected_s) <= 0.2, (duration_s, expected_s)
    assert abs(n / FS_HZ - expected_s) <= 0.2
    assert [m.label for m in markers] == ["12"]
    row, _ = _expected_row(out, trigger, offset_s)
    assert abs(markers[0].sample_idx - row) <= 1, (markers[0].sample_idx, row)


def test_ctrl_c_while_waiting_for_the_start_word_records_nothing(tmp_path):
    import signal

    control = _unique("gaitmon-test-idle")
    ctl = _marker_outlet(control)
    out = tmp_path / "never.h5"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "gaitmon", "record", "--simulate", "--duration", "60",
           "-o", str(out), "--lsl-control", control, "--lsl-timeout", "20"]  # fmt: skip
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path)
    try:
        assert proc.stderr is not None
        for line in proc.stderr:
            if "waiting for 'start'" in line:
                break
        ctl.push_sample(["stop"])  # not the start word: still waiting
        time.sleep(0.5)
        assert proc.poll() is None
        proc.send_signal(signal.SIGINT)
        rest = proc.communicate(timeout=60)[1]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 2
    lines = [ln for ln in rest.splitlines() if ln.strip()]
    assert lines == [
        f"gaitmon record: error: stopped before 'start' arrived on {control!r}; nothing was "
        "recorded"
    ]
    assert not out.exists()
