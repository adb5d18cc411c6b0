"""Markers given a host time that are not recorded say why (issue 27): "8 of 9 markers
recorded" left the ninth, sent half a second after the recording stopped, unexplained (it
waited for an engine thread that had gone, counted nowhere)."""

from __future__ import annotations

import os
import time

import pytest

from gaitmon.finish import open_session
from tests.test_engine_markers import _engine, _wait


def test_each_marker_not_recorded_is_counted_with_its_reason(tmp_path):
    out = tmp_path / "reasons.h5"
    eng = _engine()
    with eng:
        _wait(lambda: eng.samples_total >= 150)  # 1.5 s streamed before the recording
        t_rec = time.monotonic()
        eng.start_recording(out)
        _wait(lambda: eng.recording.rows >= 100)
        now = time.monotonic()
        eng.add_marker("streamed, not recorded", host_time_s=t_rec - 1.0)
        eng.add_marker("before any data", host_time_s=t_rec - 100.0)
        eng.add_marker("recorded", host_time_s=now - 0.2)
        eng.add_marker("after the end", host_time_s=now + 100.0)  # waits for its sample
        _wait(lambda: eng.timed_markers.recorded + eng.timed_markers.outside == 3)
        eng.stop_recording()
        at_stop = eng.timed_markers
        eng.add_marker("while streaming on", host_time_s=time.monotonic())
        _wait(lambda: eng.timed_markers.waiting == 0)
    eng.add_marker("after the unit stopped", host_time_s=time.monotonic())
    counts = eng.timed_markers
    # every marker accounted for: none waits for an engine thread that has gone
    assert (counts.recorded, counts.outside, counts.waiting) == (1, 5, 0)
    assert (at_stop.recorded, at_stop.before, at_stop.after, at_stop.waiting) == (1, 2, 1, 0)
    assert (counts.before, counts.after) == (2, 3)
    with open_session(out) as s:
        assert [m.label for m in s.markers] == ["recorded"]


def test_the_markers_line_says_why_each_one_was_not_recorded(tmp_path):
    """A real LSL outlet: one marker stamped before the recording, one on it, one sent once
    the recording (and the unit) had stopped; the command's line accounts for all three."""
    pylsl = pytest.importorskip("pylsl")
    from gaitmon.commands.record_lsl import LslInputs, start_markers, summary
    from gaitmon.lsl.inlet import MarkerBudget, MarkerInlet, resolve_marker_stream

    name = f"gaitmon-test-reasons-{os.getpid()}-{time.monotonic_ns()}"
    outlet = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, "string", name))
    info = resolve_marker_stream(pylsl, name, 10.0, "--lsl-markers")
    inputs = LslInputs(markers=MarkerInlet(pylsl, info, open_timeout_s=10.0,
                                           budget=MarkerBudget()))  # fmt: skip
    inlet = inputs.markers
    assert inlet is not None
    out = tmp_path / "lsl.h5"
    eng = _engine()
    try:
        with eng:
            start_markers(inputs, eng)
            assert outlet.wait_for_consumers(10.0)
            _wait(lambda: eng.samples_total >= 150)
            at_start = pylsl.local_clock()
            eng.start_recording(out)
            _wait(lambda: eng.recording.rows >= 100)
            outlet.push_sample(["before"], at_start - 1.0)
            outlet.push_sample(["on a row"], pylsl.local_clock() - 0.3)
            _wait(lambda: eng.timed_markers.recorded + eng.timed_markers.outside == 2)
            eng.stop_recording()
        outlet.push_sample(["half a second after the stop"])
        _wait(lambda: inlet.received == 3)
        line = summary(inputs, eng)
    finally:
        inputs.close()
    assert line == (
        f"1 of 3 markers from LSL stream {name!r} recorded; not recorded: 1 stamped before the "
        "recording started, 1 stamped or sent after the recording stopped"
    )
    with open_session(out) as s:
        assert [m.label for m in s.markers] == ["on a row"]
