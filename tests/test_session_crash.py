"""Real crashes: a recorder process killed with SIGKILL, and a write that fails at the OS level.

The recorder runs in a subprocess at real time (100 Hz, blocks of 1-3 samples of simulated ADC
counts) and announces each block after handing it to the writer. The parent kills it at a
seeded random moment, then opens the file (which recovers it) and checks every announced row
against the simulator's counts, exactly.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import h5py
import numpy as np
import pytest

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.finish import open_session
from gaitmon.io.journal import journal_path
from gaitmon.io.session import SessionError
from gaitmon.io.sim.sensors import simulate

N_MAX = 1000
CONFIG_ROW = 60  # settings change here (blocks are cut so a block starts at these rows)
CAL_ROW = 90
GAP_ROW = 40  # 3 frames lost before this row
CAL = Calibration(np.array([0.02, 0.01, -0.01, 0.03]), np.array([0.01, 0.0, 0.0, -0.01]))

RECORDER = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.finish import close_recording
    from gaitmon.io.session import SessionHeader, SessionWriter
    from gaitmon.io.sim.sensors import simulate

    path, seed = sys.argv[1], int(sys.argv[2])
    N_MAX, CONFIG_ROW, CAL_ROW, GAP_ROW = {N_MAX}, {CONFIG_ROW}, {CAL_ROW}, {GAP_ROW}
    CAL = Calibration(np.array([0.02, 0.01, -0.01, 0.03]), np.array([0.01, 0.0, 0.0, -0.01]))
    counts = simulate(N_MAX).counts
    seq = np.arange(N_MAX, dtype=np.int64) + 7
    seq[GAP_ROW:] += 3
    lost = np.zeros(N_MAX, dtype=np.int64)
    lost[GAP_ROW] = 3  # the pipeline is told, as the engine tells it
    rng = np.random.default_rng(seed)
    cfg1 = PipelineConfig(cutoff_hz=5.0)
    w = SessionWriter(path, SessionHeader("raw"))
    pipe = Pipeline()
    offset = 0
    wall = time.time() - time.monotonic()
    t0 = time.monotonic()
    i = 0
    while i < N_MAX:
        n = int(rng.integers(1, 4))
        # (a block also starts at every 50th row, where a marker is added)
        for cut in (CONFIG_ROW, CAL_ROW, GAP_ROW, 50 * (i // 50 + 1)):
            if i < cut < i + n:
                n = cut - i
        b = min(N_MAX, i + n)
        # real time: the block's last sample is due at t0 + b / 100
        time.sleep(max(0.0, t0 + b / 100.0 - time.monotonic()))
        if i == GAP_ROW:
            w.add_gap(3, 0.03, "frames lost")
        if i == CONFIG_ROW:
            w.log_config(cfg1)
            pipe = Pipeline(cfg1, pipe.calibration)
            offset = -i
        if i == CAL_ROW:
            w.log_calibration(CAL)
            pipe.set_calibration(CAL)
        if i % 50 == 0:
            w.add_marker(f"m{{i}}")
        now = time.monotonic()
        blk = SampleBlock(
            FrameKind.RAW, seq[i:b], np.full(b - i, now), wall, adc=counts[i:b]
        )
        w.append(blk, pipe.process(counts[i:b], lost[i:b]), event_offset=offset)
        i = b
        print("ROWS", i, time.monotonic(), flush=True)
    close_recording(w)
    print("DONE", flush=True)
    """
).format(N_MAX=N_MAX, CONFIG_ROW=CONFIG_ROW, CAL_ROW=CAL_ROW, GAP_ROW=GAP_ROW)


def _env() -> dict[str, str]:
    env = dict(os.environ)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _reference_gyro(n: int) -> np.ndarray:
    """The bias-corrected gyro rates of the first n rows (the calibration at CAL_ROW changes
    the bias; format 2 derives them from the counts and the logged calibrations)."""
    counts = simulate(N_MAX).counts[:n]
    pipe = Pipeline(PipelineConfig(cutoff_hz=5.0))
    parts = [Pipeline().process(counts[:CONFIG_ROW]).gyro_rad_s,
             pipe.process(counts[CONFIG_ROW:CAL_ROW]).gyro_rad_s]
    pipe.set_calibration(CAL)
    parts.append(pipe.process(counts[CAL_ROW:]).gyro_rad_s)
    return np.concatenate(parts).astype(np.float32)[:n]


def _reference_processed(n: int) -> tuple[np.ndarray, np.ndarray]:
    """joint_deg and heel strikes of the first n rows, computed here with hand-placed
    pipelines: settings change at CONFIG_ROW (fresh pipeline), calibration at CAL_ROW."""
    counts = simulate(N_MAX).counts[:n]
    lost = np.zeros(n, dtype=np.int64)
    lost[GAP_ROW:GAP_ROW + 1] = 3  # bridged: the 3 lost frames filled in
    cfg1 = PipelineConfig(cutoff_hz=5.0)
    p0 = Pipeline().process(counts[:CONFIG_ROW], lost[:CONFIG_ROW])
    pipe = Pipeline(cfg1)
    p1 = pipe.process(counts[CONFIG_ROW:CAL_ROW])
    pipe.set_calibration(CAL)
    p2 = pipe.process(counts[CAL_ROW:])
    joint = np.concatenate([p.joint_kalman_rad for p in (p0, p1, p2)])
    hs = np.concatenate(
        [p0.heel_strike_idx, p1.heel_strike_idx + CONFIG_ROW, p2.heel_strike_idx + CONFIG_ROW]
    )
    return np.degrees(joint).astype(np.float32)[:n], hs


@pytest.mark.timeout(120)
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_kill_9_loses_nothing_that_was_handed_over(assert_stored, tmp_path, seed):
    path = tmp_path / f"crash{seed}.h5"
    rng = np.random.default_rng(seed)
    kill_after_s = float(rng.uniform(0.15, 1.6))  # after the first announced block
    proc = subprocess.Popen(
        [sys.executable, "-c", RECORDER, str(path), str(seed)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
    )
    announced: list[tuple[int, float]] = []
    try:
        assert proc.stdout is not None
        first = proc.stdout.readline().split()
        assert first[:1] == ["ROWS"], [*first, proc.stderr.read() if proc.stderr else ""]
        announced.append((int(first[1]), float(first[2])))
        deadline = time.monotonic() + kill_after_s
        while time.monotonic() < deadline:
            line = proc.stdout.readline().split()
            assert line and line[0] == "ROWS", "recorder finished before the kill"
            announced.append((int(line[1]), float(line[2])))
        kill_time = time.monotonic()
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
        for line in proc.stdout.read().splitlines():  # printed before the kill landed
            parts = line.split()
            if parts and parts[0] == "ROWS":
                announced.append((int(parts[1]), float(parts[2])))
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
        if proc.stdout:
            proc.stdout.close()
        if proc.stderr:
            proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    assert journal_path(path).exists()

    must_have = max(n for n, t in announced if t <= kill_time - 0.1)
    all_announced = announced[-1][0]
    assert must_have > 0

    counts = simulate(N_MAX).counts
    seq = np.arange(N_MAX, dtype=np.int64) + 7
    seq[GAP_ROW:] += 3
    with open_session(path) as s:
        assert s.recovered and s.reprocessed
        n = s.n_samples
        assert n >= must_have
        # everything announced was in the OS before the kill, so all of it survives
        assert n >= all_announced
        assert np.array_equal(s.read("raw/adc"), counts[:n])
        assert np.array_equal(s.read("timeline/seq"), seq[:n])
        joint, hs = _reference_processed(n)
        s.use_angles("live")  # the causal filter's, rebuilt by replay
        assert_stored(s.read("processed/joint_deg"), joint, "processed/joint_deg")
        assert np.array_equal(s.read("processed/gyro_rad_s"), _reference_gyro(n))
        assert np.array_equal(s.heel_strike_idx, hs)
        if n > GAP_ROW:
            assert s.gaps[0].sample_idx == GAP_ROW and s.gaps[0].n_lost == 3
        # (a marker is written just before its row's block: killed in between, it is kept, for
        # the row after the last)
        assert [m.label for m in s.markers] == [f"m{i}" for i in range(0, n + 1, 50)][
            : len(s.markers)
        ]
        assert len(s.markers) >= (n - 1) // 50
        if n > CONFIG_ROW:
            assert s.config_changes[0][0] == CONFIG_ROW
        if n > CAL_ROW:
            assert s.calibration_changes[0][0] == CAL_ROW
    assert not journal_path(path).exists()
    with h5py.File(path, "r") as f:  # plain h5py, after recovery
        assert f["raw/adc"].shape == (n, 14)
        assert np.array_equal(f["raw/adc"][:], counts[:n])
        assert bool(f.attrs["recovered"]) is True


FULL_DISK = textwrap.dedent(
    """
    import json, resource, signal, sys
    import numpy as np
    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionError, SessionHeader, SessionWriter
    from gaitmon.io.sim.sensors import simulate

    path, limit, flush_s = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    if len(sys.argv) > 4:
        # the HDF5 side fails first: a compressed file (format 2) grows slower than its
        # journal, so under one size limit the journal always fills first; this makes the
        # HDF5 write of the third chunk fail as a full disk does (EFBIG)
        import errno
        import gaitmon.io.session.h5file as h5f
        _orig = h5f._append_low_level
        def _full(dsid, start, data):
            if start + len(data) > int(sys.argv[4]):
                raise OSError(errno.EFBIG, "File too large")
            return _orig(dsid, start, data)
        h5f._append_low_level = _full
    counts = simulate(20000).counts
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes past the limit fail with EFBIG
    w = SessionWriter(path, SessionHeader("raw"), flush_interval_s=flush_s)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    pipe = Pipeline()
    out = {"error": None}
    try:
        for i in range(0, 20000, 8):
            blk = SampleBlock(FrameKind.RAW, np.arange(i, i + 8), np.zeros(8), 0.0,
                              adc=counts[i:i + 8])
            w.append(blk, pipe.process(counts[i:i + 8]))
    except SessionError as e:
        out["error"] = str(e)
        out["rows"] = w.rows
        try:
            w.add_marker("after")
        except SessionError as e2:
            out["again"] = str(e2)
        w.close()  # only releases the files
    print(json.dumps(out), flush=True)
    """
)


@pytest.mark.timeout(60)
@pytest.mark.parametrize(
    ("flush_s", "limit", "full_file"),
    # which file hits the limit first: HDF5 (its third chunk write fails), or the journal
    # (a real size limit) when HDF5 is never flushed
    [(0.02, 20_000_000, "h5"), (1e9, 600_000, "journal")],
)
def test_write_error_stops_cleanly_and_keeps_everything_before(tmp_path, flush_s, limit, full_file):
    path = tmp_path / "full.h5"
    r = subprocess.run(
        [sys.executable, "-c", FULL_DISK, str(path), str(limit), str(flush_s),
         *(["8192"] if full_file == "h5" else [])],
        capture_output=True,
        text=True,
        env=_env(),
        timeout=240,
    )
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout.strip().splitlines()[-1])
    msg = out["error"]
    assert msg is not None, "the writer never failed"
    assert "\n" not in msg
    assert msg.startswith("disk full or write error while recording full.h5: File too large")
    rows = out["rows"]
    assert f"everything up to row {rows} " in msg
    assert out["again"] == msg  # the writer stays dead, with the same story
    journal_size = journal_path(path).stat().st_size
    if full_file == "journal":
        assert journal_size > limit - 200  # cut inside the last record
    else:
        assert journal_size < limit
    assert rows > 4096

    if full_file == "h5":
        _check_recovery_refused_while_still_full(path)
    counts = simulate(20000).counts
    with open_session(path) as s:
        assert s.recovered
        assert s.n_samples == rows  # exactly the rows the message promised
        assert np.array_equal(s.read("raw/adc"), counts[:rows])
        assert np.array_equal(s.read("timeline/seq"), np.arange(rows))


def _check_recovery_refused_while_still_full(path):
    recover = textwrap.dedent(
        """
        import resource, signal, sys
        from gaitmon.finish import recover_session
        from gaitmon.io.session import SessionError
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (200000, 200000))
        try:
            recover_session(sys.argv[1])
        except SessionError as e:
            print("ERR", e, flush=True)
        """
    )
    r = subprocess.run(
        [sys.executable, "-c", recover, str(path)],
        capture_output=True,
        text=True,
        env=_env(),
        timeout=240,
    )
    name = path.name
    # (the OS's words, or HDF5's translated: it can fail inside a compressed chunk write)
    assert r.stdout.startswith(f"ERR cannot recover {name}: "), r.stdout + r.stderr
    assert "File too large" in r.stdout or "file size limit is reached" in r.stdout, r.stdout
    assert "journal is kept" in r.stdout
    assert journal_path(path).exists()
    assert not path.with_name(name + ".recovering").exists()


def test_session_error_is_the_one_type_to_catch():
    assert issubclass(SessionError, Exception)
    assert not issubclass(SessionError, OSError)  # the engine catches exactly this
