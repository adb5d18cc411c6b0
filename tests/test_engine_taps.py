"""The engine's listener hook (gaitmon.engine.taps): what a listener gets, and what it costs
when nobody listens."""

from __future__ import annotations

import numpy as np
from helpers import make_engine, wait_for

import gaitmon.engine.taps as taps
from gaitmon.finish import open_session
from gaitmon.io.sim import FaultConfig


def test_listener_gets_every_sample_with_the_files_clock_and_events(tmp_path):
    """Lost frames (1 % at random) too: the listener's sample clock equals the file's t_s * fs
    on every row, its counter the file's seq, its heel strikes the file's (engine index =
    row: the recording starts with the first block)."""
    _unit, eng = make_engine(faults=FaultConfig(seed=2, loss_pct=1.0), standing_s=1.0)
    blocks = []
    eng.add_listener(blocks.append)
    out = tmp_path / "t.h5"
    eng.start(before_stream=lambda: eng.start_recording(out))
    try:
        wait_for(lambda: eng.samples_total >= 1500, what="samples")
        eng.add_marker("here")
        wait_for(lambda: eng.samples_total >= 1700, what="more samples")
        eng.stop_recording()
        wait_for(lambda: eng.samples_total >= 1800, what="after the recording")
    finally:
        eng.stop()
    data = [b for b in blocks if len(b)]
    assert blocks[-1].last and not len(blocks[-1])
    idx = np.concatenate([b.idx for b in data])
    assert np.array_equal(idx, np.arange(len(idx)))  # every sample, once, in order
    k = np.concatenate([b.k for b in data])
    seq = np.concatenate([b.seq for b in data])
    lost = np.concatenate([b.lost_before for b in data])
    assert lost.sum() > 0
    assert np.array_equal(np.diff(k), 1 + lost[1:])  # the clock counts the lost frames
    hs = np.concatenate([b.heel_strike_k for b in data])
    with open_session(out) as s:
        n = s.n_samples
        assert np.array_equal(seq[:n], s.read("timeline/seq"))
        assert np.array_equal(k[:n], np.rint(s.read("timeline/t_s") * 100).astype(np.int64))
        file_hs = k[np.asarray(s.heel_strike_idx)]
    assert len(file_hs) >= 5
    assert set(file_hs) <= set(hs)
    assert data[0].recording_started == str(out)
    assert sum(b.recording_stopped for b in blocks) == 1
    assert [m for b in data for m in b.markers] == ["here"]
    joint = np.concatenate([b.joint_deg for b in data])
    assert joint.shape == (len(idx), 3) and np.isfinite(joint).all()
    assert all(b.adc is not None and b.adc.shape == (len(b), 14) for b in data)


def test_a_failing_listener_does_not_stop_acquisition():
    _unit, eng = make_engine(standing_s=1.0)

    def broken(_out):
        raise ValueError("boom")

    eng.add_listener(broken)
    with eng:
        wait_for(lambda: eng.samples_total >= 300, what="samples")
        snap = eng.snapshot()
        eng.remove_listener(broken)
    assert "listener error: ValueError: boom" in snap.engine_error


def test_no_listener_builds_nothing(monkeypatch):
    """With nobody listening the engine makes no BlockOut at all (the hook costs one test)."""

    def refuse(*a, **k):
        raise AssertionError("a BlockOut was built with no listener")

    monkeypatch.setattr(taps, "BlockOut", refuse)
    _unit, eng = make_engine(standing_s=1.0)
    with eng:
        eng.add_marker("m")
        wait_for(lambda: eng.samples_total >= 300, what="samples")
        snap = eng.snapshot()
    assert snap.engine_errors == 0, snap.engine_error
