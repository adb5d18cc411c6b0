"""Markers stamped with a host time (engine/markers.py), without LSL: the sample clock fitted
to receive times, the runs of engine indices, and placing a marker on the right row of a
recording, also across lost frames and a full recorder queue."""

from __future__ import annotations

import numpy as np
import pytest

from gaitmon.engine.markers import RecentEnvelope, SampleIndex, TimedMarkers, file_rows
from gaitmon.engine.rows import RowMap

FS = 100.0


def _reads(n: int, t0: float, rate_ppm: float, seed: int, fs: float = FS):
    """Sample k is taken at t0 + k / fs * (1 + ppm) and read in bursts of 1-6 frames that
    share the time of the read, after 2-40 ms on the link: the receive times a Bluetooth link
    gives. Returns k, host receive time, the true instants."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    taken = t0 + k / fs * (1 + rate_ppm * 1e-6)
    host = np.empty(n)
    i = 0
    while i < n:
        j = min(n, i + int(rng.integers(1, 7)))
        host[i:j] = taken[j - 1] + rng.uniform(0.002, 0.040)  # read after the last arrived
        i = j
    return k, host, taken


def test_the_clock_finds_when_a_sample_was_taken_not_when_it_was_read():
    k, host, taken = _reads(3000, 1000.0, rate_ppm=80.0, seed=1)
    clock = RecentEnvelope(FS, window_s=30.0)
    for a in range(0, len(k), 7):  # blocks as the engine gets them
        clock.add(k[a : a + 7], host[a : a + 7])
    # instants inside the data: the fitted k is the true sample within half a row, where the
    # first sample read after the instant is often several rows late
    probes = np.random.default_rng(9).integers(100, 2990, 60)
    fitted = np.array([clock.k_at(taken[kk]) for kk in probes])
    naive = np.searchsorted(host, taken[probes])
    assert np.abs(fitted - probes).max() <= 0.5
    assert np.abs(naive - probes).max() >= 3
    # a little ahead of the data (a marker for a sample still on its way)
    assert clock.k_at(taken[2999] + 0.3) == pytest.approx(3029, abs=0.5)


def test_before_a_second_of_data_the_clock_uses_the_nominal_rate():
    clock = RecentEnvelope(FS)
    assert clock.k_at(5.0) is None
    clock.add(np.arange(10), 50.0 + np.arange(10) / FS + 0.004)  # all read 4 ms late
    # the quickest read stands for the instant of taking (the link's least delay is unknown)
    assert clock.k_at(50.054) == pytest.approx(5.0, abs=1e-6)


def test_the_index_maps_the_sample_clock_to_engine_indices_across_lost_frames():
    idx = SampleIndex()
    idx.add(0, np.arange(0, 50))  # k 0..49 -> engine 0..49
    idx.add(50, np.array([50, 51, 60, 61, 62]))  # 8 frames lost before k 60
    idx.add(55, np.arange(63, 70))  # contiguous with the run before
    assert idx.k_last == 69
    assert idx.index_at(10.2) == (10, 10)
    assert idx.index_at(51.4) == (51, 51)
    assert idx.index_at(53.0) == (51, 51)  # in the lost frames, nearer the run before
    assert idx.index_at(58.0) == (52, 60)  # nearer the run after
    assert idx.index_at(55.5) == (52, 60)  # the middle: the row the file logs the gap at
    assert idx.index_at(64.0) == (56, 64)
    assert idx.index_at(-0.4) == (0, 0)
    assert idx.index_at(-0.6) is None  # before the first sample


def test_indices_reused_after_a_failed_block_belong_to_the_newer_block():
    idx = SampleIndex()
    idx.add(0, np.arange(0, 20))
    idx.add(20, np.arange(20, 30))  # this block failed after it was noted ...
    idx.add(20, np.arange(30, 40))  # ... and the next one got its indices
    assert idx.index_at(35) == (25, 35)
    assert idx.index_at(25) in ((19, 19), (20, 30))  # its frames are a gap now


def test_markers_wait_for_their_sample_and_then_land_on_it():
    tm = TimedMarkers(FS)
    k, host, taken = _reads(400, 20.0, rate_ppm=0.0, seed=2)
    tm.add("soon", taken[350])  # arrives before its sample
    tm.add("past", taken[120])
    for a in range(0, 300, 10):
        tm.add_block(a, k[a : a + 10], host[a : a + 10])
    placed = tm.due()
    assert [(m.label, m.k) for m in placed] == [("past", 120)]  # "soon" still waits
    assert tm.pending == 1
    for a in range(300, 400, 10):
        tm.add_block(a, k[a : a + 10], host[a : a + 10])
    placed = tm.due()
    assert [m.label for m in placed] == ["soon"]
    assert abs(placed[0].k - 350) <= 1 and placed[0].idx == placed[0].k


def test_at_a_flush_a_marker_after_the_last_sample_is_outside():
    tm = TimedMarkers(FS)
    # 10 s of reads: enough for the envelope fit to place an instant at the end within a
    # fraction of a sample (over 2 s, 200 bursty reads, its slope is off by ~0.1 %)
    k, host, taken = _reads(1000, 20.0, rate_ppm=0.0, seed=3)
    tm.add_block(0, k, host)
    tm.add("on the last sample", taken[999] + 0.008)  # 0.8 of a sample after it
    tm.add("much later", taken[999] + 5.0)
    tm.add("long before", taken[0] - 5.0)
    assert [(m.label, m.idx) for m in tm.due()] == [("long before", None)]  # the others wait
    rest = tm.due(final=True)
    assert [(m.label, m.idx) for m in rest] == [("on the last sample", 999), ("much later", None)]
    assert tm.pending == 0


def test_file_rows_follow_the_recordings_row_map():
    from gaitmon.engine.markers import Placed

    rm = RowMap()
    rm.record_offset = 100  # row 0 is engine index 100
    rm.drop_starts, rm.drop_ends, rm.drop_cum = [300], [320], [20]  # 20 samples not in the file
    placed = [Placed("a", 150, 150), Placed("b", 99, 99), Placed("c", 50, 50),
              Placed("d", 310, 310), Placed("e", 330, 330), Placed("f", None, None)]  # fmt: skip
    assert file_rows(placed, rm) == [50, 0, None, None, 210, None]
    assert file_rows(placed, None) == [None] * 6


def _engine(faults=None):
    from gaitmon.engine import Engine
    from gaitmon.io.device import Device
    from gaitmon.io.sim import GaitConfig, SimulatedUnit
    from gaitmon.io.transport import InProcessTransport

    # real time: the simulator takes sample n at time.monotonic() = t0 + n / fs
    unit = SimulatedUnit(GaitConfig(seed=4, standing_s=1.0), faults=faults, speed=1.0)
    return Engine(Device(InProcessTransport(unit)), "raw", transport_label="simulated")


def _wait(cond, timeout_s=60.0):
    import time

    deadline = time.monotonic() + timeout_s
    while not cond():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def _taken(path):
    """When each row's sample was taken (host clock), from the file's timeline alone."""
    from gaitmon.finish import open_session

    with open_session(path) as s:
        host = np.asarray(s.read("timeline/host_time_s"))
        t = np.asarray(s.read("timeline/t_s"))
        markers = {m.label: m for m in s.markers}
        n_gaps = len(s.gaps)
    return t + np.min(host - t), t, markers, n_gaps


def test_markers_across_lost_frames_land_on_the_nearest_row_received(tmp_path):
    import time

    from gaitmon.io.sim import FaultConfig

    out = tmp_path / "lossy.h5"
    eng = _engine(FaultConfig(seed=2, burst_pct=2.0, burst_len_frames=8, loss_pct=2.0))
    with eng:
        eng.start_recording(out)
        _wait(lambda: eng.recording.rows >= 300)
        now = time.monotonic()
        instants = {f"m{i}": now - 2.0 + i * 0.0437 for i in range(40)}  # 1.7 s, every 4.37 rows
        for label, h in instants.items():
            eng.add_marker(label, host_time_s=h)
        _wait(lambda: eng.timed_markers.waiting == 0)
        eng.stop_recording()
    taken, t, markers, n_gaps = _taken(out)
    assert n_gaps >= 2  # the link really lost frames
    assert set(markers) == set(instants)
    for label, h in instants.items():
        expected = int(np.argmin(np.abs(taken - h)))
        assert abs(markers[label].sample_idx - expected) <= 1, label
        assert markers[label].t_s == t[markers[label].sample_idx]


def test_a_marker_waiting_when_the_recording_stops_is_still_recorded(tmp_path):
    import time

    out = tmp_path / "stop.h5"
    eng = _engine()
    with eng:
        eng.start_recording(out)
        _wait(lambda: eng.recording.rows >= 100)
        h = time.monotonic() - 0.2
        eng.add_marker("just before stop", host_time_s=h)
        eng.add_marker("after the end", host_time_s=time.monotonic() + 10.0)
        eng.stop_recording()  # straight away: the engine thread has not looked yet
        counts = eng.timed_markers
    taken, _t, markers, _gaps = _taken(out)
    assert list(markers) == ["just before stop"]
    assert abs(markers["just before stop"].sample_idx - int(np.argmin(np.abs(taken - h)))) <= 1
    assert (counts.recorded, counts.outside, counts.waiting) == (1, 1, 0)
