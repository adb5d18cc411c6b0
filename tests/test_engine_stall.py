"""The engine's stall rule, headless (issue 25): ``Snapshot.stalled_s`` is the wall time without
a frame once it reaches a second while the unit streams, 0 otherwise; a stall whose backlog
arrives leaves a recording complete, with no gap invented.

The simulated unit (``SimulatedUnit.stall``) holds its frames for 8 s of its clock (2 s of wall
time at 4x) and then sends them all, through the real decoder.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import make_engine, wait_for

from gaitmon.engine.stream import STALL_AFTER_S, stalled_s
from gaitmon.finish import open_session
from gaitmon.io.session import SessionMeta


def test_the_rule():
    assert stalled_s(0.5, True) == 0.0  # frames a moment apart: no stall
    assert stalled_s(STALL_AFTER_S, True) == STALL_AFTER_S
    assert stalled_s(3.2, True) == 3.2
    assert stalled_s(3.2, False) == 0.0  # a unit not asked to stream is silent, not stalled


@pytest.mark.timeout(180)
def test_a_stall_is_seen_while_it_lasts_and_its_backlog_leaves_no_gap(tmp_path):
    stall_s = 8.0  # device seconds
    unit, eng = make_engine(speed=4.0, standing_s=2.0)
    out = tmp_path / "stalled.h5"
    seen: list[float] = []
    with eng:
        wait_for(lambda: eng.samples_total >= 100, what="data")
        assert eng.snapshot(0.05).stalled_s == 0.0  # streaming: not stalled
        eng.start_recording(out, SessionMeta(patient_id="S1"))
        wait_for(lambda: eng.recording.rows >= 100, what="recorded rows")
        unit.stall(stall_s)
        stall_at = unit.samples_produced

        def stalled_for_a_while() -> bool:
            seen.append(eng.snapshot(0.05).stalled_s)
            return seen[-1] >= 1.5

        wait_for(stalled_for_a_while, what="the stall seen for 1.5 s")
        held = eng.samples_total
        assert held <= stall_at  # nothing produced during the stall came yet
        end = stall_at + round(stall_s * unit.fs_hz)
        wait_for(lambda: eng.samples_total >= end + 100, what="the backlog")
        assert eng.snapshot(0.05).stalled_s == 0.0  # frames again: over
        status = eng.stop_recording()
    positive = [s for s in seen if s > 0]
    assert positive and min(positive) >= STALL_AFTER_S  # never a stall shorter than a second
    assert positive == sorted(positive)  # the time without data only grows while it lasts
    assert eng.device.stats.decoder.frames_lost == 0 and unit.ledger.dropped == []
    with open_session(out) as s:
        assert len(s.gaps) == 0  # the backlog arrived: the data is complete
        t = s.read("timeline/t_s")
        n = s.n_samples
    assert n == status.rows >= 100 + stall_s * unit.fs_hz
    assert np.allclose(np.diff(t), 1.0 / unit.fs_hz)  # one sample period apart, throughout
