"""Robustness of the recording path: nothing a patient's recording depends on may die silently.

Every test drives the real parts (the simulated unit over the in-process transport, the real
engine, recorder thread, session writer and HDF5 files) and checks the file against the
simulator's ground truth or an offline replay of the pipeline. Where a failure cannot be
provoked with the real parts (a bug raising inside the pipeline, a stalled disk, a transport
raising an unexpected exception), one method is wrapped to raise or wait; the code under test is
otherwise untouched.
"""

from __future__ import annotations

import contextlib
import functools
import threading
import time

import h5py
import numpy as np
import pytest
from helpers import StalledDisk, wait_for
from helpers import make_engine as _make_engine

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine
from gaitmon.finish import open_session, replay_pipeline
from gaitmon.io.device import Device
from gaitmon.io.journal import journal_path
from gaitmon.io.protocol import Command, FrameKind, encode_command
from gaitmon.io.session import SessionWriter
from gaitmon.io.sim import GaitConfig, SimulatedUnit
from gaitmon.io.sim.truth import attach_ground_truth, row_samples
from gaitmon.io.transport import InProcessTransport

pytestmark = pytest.mark.timeout(120)

FS = 100.0


make_engine = functools.partial(_make_engine, standing_s=1.0)


def recorder_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "gaitmon-recorder"]


def check_against_truth(out, unit, *, skip_after_gaps=30, skip_around=()):
    """The file's timeline and heel strikes against the simulator's truth; returns the rows'
    sample indices (the unit's own sample counter). True heel strikes just after a gap, or
    within 30 rows of a row in ``skip_around`` (a settings change: the new pipeline starts
    fresh there, so an event the old one had not yet confirmed is not found), are not
    required."""
    attach_ground_truth(out, unit)
    with open_session(out, recover=False) as s:
        assert s.complete and not s.recovered, s.problems
        seq = s.read("timeline/seq")
        t_s = s.read("timeline/t_s")
        gaps = s.gaps
        found = s.heel_strike_idx
    samples = row_samples(seq, unit)
    assert np.all(samples >= 0)  # every row is a data frame the unit really sent
    # the timeline is true: row time = the unit's sample time (lost frames included)
    np.testing.assert_allclose(t_s - t_s[0], (samples - samples[0]) / FS, atol=1e-9)
    # every missing frame is listed in /gaps, at the row where data resume
    missing = np.diff(samples) - 1
    jumps = np.flatnonzero(missing) + 1
    assert [g.sample_idx for g in gaps] == jumps.tolist()
    assert [g.n_lost for g in gaps] == missing[jumps - 1].tolist()
    with h5py.File(out, "r") as f:
        true = all_true = f["truth/heel_strike"][()]
    n = len(seq)
    true = true[(true > 20) & (true < n - 20)]
    # a heel strike right after a gap may have happened in the frames the file does not hold
    near_gap = np.zeros(n + 1, bool)
    for g in gaps:
        near_gap[g.sample_idx : g.sample_idx + skip_after_gaps] = True
        if g.n_lost > 5:
            # after a long gap the pipeline restarts (docs/gaps-and-time.md): a heel strike
            # whose confirmation (filter delay + minimum contact, 8 rows) fell in the gap is lost
            near_gap[max(0, g.sample_idx - 10) : g.sample_idx] = True
    for r in skip_around:
        near_gap[max(0, r - 30) : r + 30] = True
    true = true[~near_gap[true]]
    assert len(true) >= 5
    assert len(found) > 0
    nearest = np.abs(found[:, None] - true[None, :]).min(axis=0)
    where = (true[nearest > 2], found, [(g.sample_idx, g.n_lost) for g in gaps])
    assert np.all(nearest <= 2), where  # every true heel strike found within 20 ms
    # and every heel strike in the file sits on a true one's row (none moved by a gap)
    invented = np.abs(found[:, None] - all_true[None, :]).min(axis=1)
    assert np.all(invented <= 2), (found[invented > 2], all_true)
    return samples


# ------------------------------------------------------------------------------------------
# frames of the wrong kind (a unit that came back in its default frame kind)
# ------------------------------------------------------------------------------------------


def test_frames_of_another_kind_mid_recording_leave_a_gap_not_a_dead_recorder(tmp_path):
    unit, eng = make_engine(seed=11)
    out = tmp_path / "kinds.h5"
    with eng:
        wait_for(lambda: eng.samples_total >= 200, what="data")
        eng.start_recording(out)
        wait_for(lambda: eng.recording.rows >= 800, what="rows")
        # the unit switches to its own tilt frames (as after a reset into its default kind)
        unit.write(encode_command(Command.SELECT_KIND, int(FrameKind.TILT)))
        wait_for(lambda: (unit.frame_log()[2] == FrameKind.TILT).sum() >= 100, what="tilt")
        unit.write(encode_command(Command.SELECT_KIND, int(FrameKind.RAW)))
        raw_before = int((unit.frame_log()[2] == FrameKind.RAW).sum())
        rows = eng.recording.rows
        wait_for(lambda: eng.recording.rows >= rows + 800, what="rows after")
        # rows are written behind the unit: after a stall (a GC pause, a busy machine) those 800
        # rows may all be frames from before the tilt ones; the rows after them are in the file
        # once the engine has taken (and handed to the recorder) 800 frames sent after them
        wait_for(lambda: eng.samples_total >= raw_before + 800, what="frames after")
        status = eng.stop_recording()
    assert status.error == ""
    samples = check_against_truth(out, unit)
    _, sample_idx, kinds = unit.frame_log()
    tilt = sample_idx[kinds == FrameKind.TILT]
    inside = tilt[(tilt > samples[0]) & (tilt < samples[-1])]
    assert len(inside) >= 100
    with open_session(out) as s:  # the tilt frames are exactly the gap
        assert sum(g.n_lost for g in s.gaps) == len(inside)


# ------------------------------------------------------------------------------------------
# exceptions inside the recorder and the engine thread
# ------------------------------------------------------------------------------------------


def test_an_unexpected_writer_exception_is_reported_and_the_rows_are_kept(tmp_path, monkeypatch):
    _unit, eng = make_engine(seed=5)
    out = tmp_path / "bug.h5"

    def broken_add_marker(self, label, sample_idx=None):
        raise TypeError("injected writer bug")

    monkeypatch.setattr(SessionWriter, "add_marker", broken_add_marker)
    with eng:
        wait_for(lambda: eng.samples_total >= 100, what="data")
        eng.start_recording(out)
        wait_for(lambda: eng.recording.rows >= 300, what="rows")
        eng.add_marker("here")
        wait_for(lambda: eng.recording.error != "", timeout_s=10, what="the error")
        live = eng.recording
        assert not live.active and "injected writer bug" in live.error
        status = eng.stop_recording(timeout_s=10)
    assert "injected writer bug" in status.error
    assert not recorder_threads()
    assert journal_path(out).exists()  # the journal is the truth: kept for recovery
    with open_session(out) as s:  # recovered: every row handed over before the failure
        assert s.recovered and s.n_samples == status.rows >= 300
        assert np.all(np.diff(s.read("timeline/seq")) == 1)


def test_a_failed_final_close_does_not_hang_stop_or_leak_the_recorder(tmp_path):
    _unit, eng = make_engine(seed=6)
    out = tmp_path / "close.h5"
    with eng:
        wait_for(lambda: eng.samples_total >= 100, what="data")
        eng.start_recording(out)
        wait_for(lambda: eng.recording.rows >= 300, what="rows")
        # the journal's removal at the very end of the clean stop fails (OSError)
        journal_path(out).rename(tmp_path / "moved.journal")
        status = eng.stop_recording(timeout_s=5)
        alive = recorder_threads()
    assert "No such file" in status.error
    assert not alive  # the recorder thread ended with the failed stop
    with open_session(out, recover=False) as s:
        assert s.complete and s.n_samples == status.rows


def test_an_exception_inside_handle_is_survived_reported_and_logged_as_a_gap(tmp_path):
    unit, eng = make_engine(seed=7)
    out = tmp_path / "handle.h5"
    failed = threading.Event()
    with eng:
        wait_for(lambda: eng.samples_total >= 100, what="data")
        eng.start_recording(out)
        wait_for(lambda: eng.recording.rows >= 500, what="rows")
        real = eng._pipeline.process

        def process(adc, *rest):
            if not failed.is_set():
                failed.set()
                raise ValueError("malformed block (injected)")
            return real(adc, *rest)

        eng._pipeline.process = process
        wait_for(failed.is_set, what="the failure")
        n = eng.samples_total
        wait_for(lambda: eng.samples_total >= n + 800, what="data after the failure")
        snap = eng.snapshot(1.0)
        status = eng.stop_recording()
    assert eng.running is False  # stopped by us, not by the exception
    assert "malformed block" in snap.engine_error
    assert status.error == "" and status.rows >= 1000
    with open_session(out) as s:
        rebuilt = [r for r, _ in s.config_changes]
    samples = check_against_truth(out, unit, skip_around=rebuilt)
    with open_session(out) as s:
        gaps = s.gaps
        changes = s.config_changes
        adc = s.read("raw/adc")
        s.use_angles("live")  # what the live pipeline stored
        joint = s.read("processed/joint_deg")
        hs = s.heel_strike_idx
        cal = s.calibration
    assert len(gaps) == 1 and gaps[0].n_lost >= 1  # the failed block, nothing else
    assert np.sum(np.diff(samples) - 1) == gaps[0].n_lost
    # a fresh pipeline took over at the gap, and the file says so: a replay from the logged
    # settings gives the live series and events from there on
    assert [r for r, _ in changes] == [gaps[0].sample_idx]
    _check_replay_matches_from(adc, joint, hs, changes, cal, gaps[0].sample_idx)


def _check_replay_matches_from(adc, joint, hs, changes, cal, row):
    parts = list(replay_pipeline(adc, PipelineConfig(), cal, changes))
    ref = np.concatenate([p[1]["processed/joint_deg"] for p in parts])
    ref_hs = np.concatenate([p[2] for p in parts])
    # the file stores the tilts at 0.01 deg; a joint is the difference of two (format 2)
    np.testing.assert_allclose(joint[row:], ref[row:], atol=0.01 + 1e-4)
    live_after = hs[hs >= row + 10]
    ref_after = ref_hs[(ref_hs >= row + 10) & (ref_hs < len(adc) - 30)]
    assert len(ref_after) >= 3
    np.testing.assert_array_equal(live_after[: len(ref_after)], ref_after)


def test_settings_changed_mid_recording_keep_the_events_on_their_rows(tmp_path):
    unit, eng = make_engine(seed=9)
    out = tmp_path / "settings.h5"
    new = PipelineConfig(cutoff_hz=3.0, r=0.5)
    with eng:
        wait_for(lambda: eng.samples_total >= 300, what="data")
        eng.start_recording(out)
        wait_for(lambda: eng.recording.rows >= 600, what="rows")
        eng.apply_config(new)
        rows = eng.recording.rows
        wait_for(lambda: eng.recording.rows >= rows + 1200, what="rows after")
        status = eng.stop_recording()
    assert status.error == ""
    with open_session(out) as s:
        changes = s.config_changes
    check_against_truth(out, unit, skip_around=[r for r, _ in changes])
    with open_session(out) as s:
        adc = s.read("raw/adc")
        s.use_angles("live")  # what the live pipeline stored
        joint = s.read("processed/joint_deg")
        hs = s.heel_strike_idx
        cal = s.calibration
    assert len(changes) == 1 and changes[0][1] == new
    _check_replay_matches_from(adc, joint, hs, changes, cal, changes[0][0])


# ------------------------------------------------------------------------------------------
# races between the caller's thread and the engine thread
# ------------------------------------------------------------------------------------------


class _Pauser:
    """Wraps the engine's pipeline so the engine thread can be held inside ``_handle``."""

    def __init__(self, eng: Engine) -> None:
        self.real = eng._pipeline.process
        self.armed = threading.Event()
        self.inside = threading.Event()
        self.go = threading.Event()
        eng._pipeline.process = self

    def __call__(self, adc, *rest):
        out = self.real(adc, *rest)
        if self.armed.is_set():
            self.armed.clear()
            self.inside.set()
            self.go.wait(10)
        return out

    def hold(self) -> None:
        self.go.clear()
        self.inside.clear()
        self.armed.set()
        assert self.inside.wait(10)

    def release(self) -> None:
        self.go.set()


def test_start_recording_while_a_block_is_being_processed_keeps_events_on_their_rows(tmp_path):
    unit, eng = make_engine(seed=4)
    out = tmp_path / "race.h5"
    with eng:
        wait_for(lambda: eng.samples_total >= 300, what="data")
        pause = _Pauser(eng)
        pause.hold()
        time.sleep(0.3)  # frames pile up in the device: the next block is a long one
        pause.release()
        pause.hold()  # the engine thread is inside _handle with that long block
        eng.start_recording(out)
        pause.release()
        wait_for(lambda: eng.recording.rows >= 2000, what="rows")
        status = eng.stop_recording()
    assert status.error == ""
    check_against_truth(out, unit)


# ------------------------------------------------------------------------------------------
# a stalled disk: the recorder queue overflows, stop times out
# ------------------------------------------------------------------------------------------


def test_blocks_dropped_by_a_full_recorder_queue_are_gaps_in_a_true_timeline(tmp_path, monkeypatch):
    # the disk stalls in the middle of a recording (not before its first row: a recording
    # whose first blocks are refused simply starts later, which is not what is tested here)
    unit, eng = make_engine(seed=2, recorder_queue_blocks=3)
    out = tmp_path / "overflow.h5"
    with eng:
        wait_for(lambda: eng.samples_total >= 300, what="data")
        disk = StalledDisk(monkeypatch, after_rows=200)
        eng.start_recording(out)
        wait_for(disk.stalled.is_set, what="the stall")
        wait_for(lambda: eng.recording.dropped_blocks >= 20, what="dropped blocks")
        disk.go.set()
        rows = eng.recording.rows
        wait_for(lambda: eng.recording.rows >= rows + 1500, what="rows after")
        with eng._lock:
            rec = eng._recorder
        assert rec is not None
        status = eng.stop_recording()
    assert status.error == "" and status.dropped_blocks >= 20
    samples = check_against_truth(out, unit)
    missing = np.diff(samples) - 1
    gap_rows = np.flatnonzero(missing) + 1
    # The engine thread's own record of what it dropped (complete: the recording has stopped)
    # says exactly where the file's gaps are, however a loaded machine timed the drops (a queue
    # of 3 blocks is short: it may refuse blocks before the stall, or after it until the
    # recorder catches up). Adjacent dropped blocks are one gap; blocks dropped after the
    # file's last row leave no gap.
    rm = rec.row_map
    assert rm.record_offset is not None and rm.drop_starts
    expected: list[list[int]] = []  # [row, frames]
    dropped_before = 0
    for start, end in zip(rm.drop_starts, rm.drop_ends, strict=True):
        row = start - rm.record_offset - dropped_before
        if expected and expected[-1][0] == row:
            expected[-1][1] += end - start
        else:
            expected.append([row, end - start])
        dropped_before += end - start
    told = (rm.record_offset, rm.drop_starts[:3], rm.drop_ends[:3], len(rm.drop_starts),
            len(samples), status.rows, expected[:3])  # fmt: skip
    expected = [e for e in expected if e[0] < len(samples)]
    assert [[int(r), int(missing[r - 1])] for r in gap_rows] == expected, told
    assert sum(n for _r, n in expected) >= 20, told  # the stall's drops really are missing
    with open_session(out) as s:
        assert all(g.reason.startswith("frames lost") for g in s.gaps)


def test_stop_recording_that_times_out_says_so(tmp_path, monkeypatch):
    _unit, eng = make_engine(seed=1)
    out = tmp_path / "slow.h5"
    with eng:
        wait_for(lambda: eng.samples_total >= 100, what="data")
        disk = StalledDisk(monkeypatch)
        eng.start_recording(out)
        wait_for(disk.stalled.is_set, what="the stall")
        status = eng.stop_recording(timeout_s=0.3)
        assert status.error and "not finished" in status.error
        disk.go.set()
        with contextlib.suppress(AssertionError):
            wait_for(lambda: not recorder_threads(), timeout_s=20, what="the recorder")
    assert not recorder_threads()
    with open_session(out, recover=False) as s:  # it finished in the background
        assert s.complete


# ------------------------------------------------------------------------------------------
# the device's receive thread
# ------------------------------------------------------------------------------------------


class _FlakyUnit:
    """The simulated unit behind a link whose read() raises an unexpected exception once."""

    def __init__(self, unit: SimulatedUnit) -> None:
        self.unit = unit
        self.fail_next = threading.Event()

    def read(self):
        if self.fail_next.is_set():
            self.fail_next.clear()
            raise OSError(5, "Input/output error (injected)")
        return self.unit.read()

    def write(self, data):
        self.unit.write(data)

    def wait_readable(self, timeout_s):
        return self.unit.wait_readable(timeout_s)

    def close(self):
        self.unit.close()


def test_the_receive_thread_survives_an_unexpected_transport_exception_and_says_so():
    unit = SimulatedUnit(GaitConfig(seed=12, standing_s=1.0), speed=20.0)
    flaky = _FlakyUnit(unit)
    with Device(InProcessTransport(flaky)) as dev:
        dev.select_kind(FrameKind.RAW)
        dev.start_stream()
        got = 0
        while got < 200:
            b = dev.read_block(timeout_s=1.0)
            got += 0 if b is None else len(b)
        flaky.fail_next.set()
        wait_for(lambda: dev.stats.rx_errors >= 1, timeout_s=10, what="the error")
        seqs = []
        deadline = time.monotonic() + 10
        while sum(len(s) for s in seqs) < 300 and time.monotonic() < deadline:
            b = dev.read_block(timeout_s=0.5)
            if b is not None:
                seqs.append(b.seq)
        stats = dev.stats
    assert sum(len(s) for s in seqs) >= 300  # data kept coming after the exception
    assert stats.rx_errors == 1 and "injected" in stats.rx_error


# ------------------------------------------------------------------------------------------
# gaitmon record
# ------------------------------------------------------------------------------------------


def test_ctrl_c_while_zeroing_records_nothing(tmp_path):
    import os
    import signal
    import subprocess
    import sys

    out = tmp_path / "never.h5"
    # the subject walks from the start, so zeroing is refused and retried for up to 10 s
    proc = subprocess.Popen(
        [sys.executable, "-m", "gaitmon", "record", "--simulate", "--zero", "--standing-s", "0",
         "--duration", "30", "-o", str(out), "--quiet", "--status-lines"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        time.sleep(3.0)  # started and zeroing (the retries last 10 s)
        assert proc.poll() is None
        os.kill(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert "Traceback" not in err
    assert not out.exists() and not journal_path(out).exists()


def test_overwrite_refuses_a_file_that_is_being_recorded(tmp_path):
    from gaitmon.engine import EngineError

    # (two units at 5x, not the usual 20x: each unit's own pipeline and each engine's run the
    # interpreted loops live, and four of them at 20x outrun a busy 2-core machine)
    unit, eng = make_engine(seed=13, speed=5.0)
    _, other = make_engine(seed=14, speed=5.0)
    out = tmp_path / "live.h5"
    with eng, other:
        wait_for(lambda: eng.samples_total >= 300 and other.samples_total >= 100, what="data")
        eng.start_recording(out)
        wait_for(lambda: eng.recording.rows >= 300, what="rows")
        with pytest.raises(EngineError, match="being recorded"):
            other.start_recording(out, overwrite=True)
        rows = eng.recording.rows
        wait_for(lambda: eng.recording.rows >= rows + 500, what="rows after")
        status = eng.stop_recording()
    assert status.error == ""
    check_against_truth(out, unit)  # the live recording is whole and untouched
