"""The headless engine driven by the simulated unit over the in-process transport."""

import math
import time

import numpy as np
import pytest
from helpers import HeldClock, make_engine, wait_for

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import EngineError, Mode, RingBuffer
from gaitmon.io.device import Device
from gaitmon.io.sim import FaultConfig, GaitConfig, SimulatedUnit
from gaitmon.io.transport import InProcessTransport


def test_ring_buffer_returns_the_latest_samples_in_order():
    rb = RingBuffer(10)
    for start in range(0, 25, 4):  # blocks of 4 wrap around a capacity of 10
        t = np.arange(start, start + 4, dtype=float)
        rb.append({"t_s": t, "host_time_s": t, "joint_kalman_deg": np.stack([t, t, t], 1)})
    got = rb.latest(7)
    np.testing.assert_array_equal(got["t_s"], np.arange(21, 28))
    np.testing.assert_array_equal(got["joint_kalman_deg"][:, 2], np.arange(21, 28))
    assert np.isnan(got["tilt_acc_deg"]).all()  # series not supplied read as NaN
    assert len(rb.latest(100)["t_s"]) == 10
    big = np.arange(100, 130, dtype=float)  # a block larger than the ring keeps its tail
    rb.append({"t_s": big, "host_time_s": big})
    np.testing.assert_array_equal(rb.latest(10)["t_s"], big[-10:])


def test_raw_mode_streams_processes_and_finds_strides():
    unit, eng = make_engine()
    with eng:
        wait_for(lambda: eng.samples_total >= 3000, what="3000 samples")
        snap = eng.snapshot(10.0)
    s = snap.series
    assert len(s["t_s"]) == 1000  # 10 s window at 100 Hz
    assert np.all(np.diff(s["t_s"]) > 0)
    assert not np.isnan(s["joint_kalman_deg"]).any()
    assert snap.link is not None and snap.link.decoder.frames_lost == 0
    assert snap.link.decoder.crc_failures == 0
    # 27 s of walking at 110 steps/min ~ 24 strides; the panel counts them as they complete.
    # The engine's row 0 is the first sample streamed: the unit's clock runs from its start,
    # and what it produced before START_STREAM (a first call that loads the filters' compiled
    # loop can take a few tenths of a second, several hundred samples at speed 20) is not sent
    first = int(unit.frame_log()[1][0])
    hs_true = unit.truth(first, first + eng.samples_total).heel_strike_idx
    assert abs(snap.gait.n_strides - (len(hs_true) - 1)) <= 2
    assert snap.gait.cadence_derived_steps_per_min == pytest.approx(110.0, rel=0.08)
    assert snap.gait.cycles_deg.shape[1:] == (101, 3)
    knee_peak = snap.gait.cycles_deg[:, :, 1].max(axis=1)
    assert np.all((knee_peak > 45) & (knee_peak < 80))


@pytest.mark.parametrize("mode", ["tilt", "joint"])
def test_device_angle_modes_show_the_units_own_angles(mode):
    _, eng = make_engine(mode)
    with eng:
        wait_for(lambda: eng.samples_total >= 1500, what="1500 samples")
        snap = eng.snapshot(5.0)
    s = snap.series
    assert not np.isnan(s["joint_kalman_deg"]).any()
    assert np.isnan(s["tilt_gyro_deg"]).all()  # the unit does not send gyro tilt
    if mode == "tilt":
        assert not np.isnan(s["tilt_kalman_deg"]).any()
    else:
        assert set(np.unique(s["phase"])) <= {0.0, 1.0, 2.0, 3.0}
        assert snap.gait.n_strides >= 5


def test_lost_frames_are_located_exactly_by_the_device():
    faults = FaultConfig(seed=4, loss_pct=3.0, corrupt_pct=2.0, burst_pct=0.2)
    # as fast as it is read: how many frames are lost is the faults' doing, never the machine's
    # (at 50x real time a reader late by seconds let the unit's output queue overflow)
    unit = SimulatedUnit(GaitConfig(seed=4), faults=faults, speed=math.inf)
    dev = Device(InProcessTransport(unit))
    lost = []
    seqs = []
    with dev:
        dev.select_kind(Mode.RAW.frame_kind)
        dev.start_stream()
        deadline = time.monotonic() + 20
        while sum(len(s) for s in seqs) < 4000 and time.monotonic() < deadline:
            b = dev.read_block(0.1)
            if b is not None:
                lost.append(b.lost_before)
                seqs.append(b.seq)
        dev.stop_stream()
        time.sleep(0.2)
        while (b := dev.read_block(0.1)) is not None:  # drain what came before the stop
            lost.append(b.lost_before)
            seqs.append(b.seq)
        stats = dev.stats
    lost_all = np.concatenate(lost)
    seq = np.concatenate(seqs)
    broken = [e.frame_no for e in (*unit.ledger.dropped, *unit.ledger.corrupted)]
    assert len(broken) > 100  # faults were really injected
    # every frame the unit broke before our last data frame is counted where it was missing
    # (one broken just before the STOP acknowledgement has no sample after it to carry it)
    assert lost_all.sum() == sum(1 for f in broken if f < seq[-1])
    assert lost_all.sum() <= stats.decoder.frames_lost
    # a data-sequence gap is exactly the missing frames where lost_before says so
    gaps = np.diff(seq) - 1
    np.testing.assert_array_equal(gaps, lost_all[1:])


def test_zero_refuses_while_walking_and_accepts_standing():
    # the unit's time stands still until it streams, then at 3.2 s (of 4 s standing) until the
    # zero is taken
    clock = HeldClock(hold_s=0.0)
    _unit, eng = make_engine(speed=5.0, standing_s=4.0, clock=clock)
    with eng:
        clock.hold(3.2 / 5.0)
        wait_for(lambda: eng.samples_total >= 300, what="standing data")
        cal = eng.zero()
        clock.release()
        assert np.max(np.abs(np.degrees(cal.tilt_offset_rad))) < 15
        wait_for(lambda: eng.samples_total >= 1200, what="walking")
        with pytest.raises(EngineError, match="moving"):
            eng.zero()
        snap = eng.snapshot(1.0)
    assert snap.calibrated


def test_settings_apply_live_and_bad_ones_are_refused():
    _, eng = make_engine()
    with eng:
        wait_for(lambda: eng.samples_total >= 500, what="data")
        eng.apply_config(PipelineConfig(cutoff_hz=2.0))
        wait_for(lambda: eng.config.cutoff_hz == 2.0, what="new config")
        with pytest.raises(EngineError, match="sample rate"):
            eng.apply_config(PipelineConfig(fs_hz=200.0))
        n = eng.samples_total
        wait_for(lambda: eng.samples_total > n + 200, what="data after the change")
    with pytest.raises(ValueError, match="Nyquist"):
        PipelineConfig(cutoff_hz=70.0)


def test_the_engine_streams_without_waiting_for_numba(tmp_path):
    """Issue 28: no compile on the critical path. Engine.start after an install (an empty
    numba cache) imports no numba: its blocks run the interpreted loops, and numba's cache is
    filled by a background process meanwhile (the old code compiled in Engine.start, before
    connecting). In a fresh interpreter (this one may have loaded numba already)."""
    import os
    import subprocess
    import sys

    code = """
import sys, time
from gaitmon.dsp import kernel_cache
from gaitmon.engine import Engine
from gaitmon.io.device import Device
from gaitmon.io.sim import SimulatedUnit
from gaitmon.io.transport import InProcessTransport

eng = Engine(Device(InProcessTransport(SimulatedUnit())), "raw", transport_label="simulated")
eng.start()
deadline = time.monotonic() + 60
while eng.samples_total < 300 and time.monotonic() < deadline:
    time.sleep(0.01)
eng.stop()
print(eng.samples_total >= 300, "numba" in sys.modules, kernel_cache.wait_fill(240),
      kernel_cache.cache_ready())
"""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                       env=env)  # fmt: skip
    assert r.returncode == 0, r.stderr
    # streamed, with no numba in the process; the background filler compiled into the cache
    assert r.stdout.split() == ["True", "False", "0", "True"], r.stdout
