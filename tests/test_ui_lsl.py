"""Device ▸ Stream to LSL in the live window: off by default, streams while connected when on
(a real pylsl inlet receives it), remembered, and one line when pylsl is missing."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from test_ui_window import WAIT_MS, make_window

pylsl = pytest.importorskip("pylsl")


def _our_stream(outlet):
    """Our outlet's stream among any of the same name on this machine (other runs)."""
    uid = outlet.get_info().uid()
    sid = outlet.get_info().source_id()
    for info in pylsl.resolve_byprop("source_id", sid, 0, 3.0):
        if info.uid() == uid:
            return info
    raise AssertionError(f"{sid} not found")


def test_stream_to_lsl_is_off_by_default_then_streams_and_is_remembered(
    qtbot, ui_settings, no_leaked_threads
):
    win = make_window(qtbot, ui_settings)
    try:
        assert not win.act_lsl.isChecked() and win.lsl_part.lsl_outlets is None
        assert not win.act_lsl_patient.isChecked()
        win.act_lsl.trigger()  # the user ticks Device ▸ Stream to LSL
        assert win.act_lsl.isChecked() and win.lsl_part.lsl_outlets is not None
        assert "Streaming to LSL: gaitmon sim angles" in win.statusBar().currentMessage()
        inlet = pylsl.StreamInlet(_our_stream(win.lsl_part.lsl_outlets.angles), recover=False)
        inlet.open_stream(timeout=5.0)
        got = []
        qtbot.waitUntil(lambda: got.extend(inlet.pull_chunk(timeout=0.0)[1]) or len(got) > 50,
                        timeout=WAIT_MS)  # fmt: skip
        assert np.all(np.diff(got) > 0)  # sample-clock stamps: strictly increasing
        labels = inlet.info().desc().child("channels").child("channel").child_value("label")
        assert labels == "hip_flexion"
        inlet.close_stream()
    finally:
        win.close()
    assert win.lsl_part.lsl_outlets is None  # disconnecting closed the outlets
    assert win.errors == []
    # remembered: the next window streams as soon as it is connected
    win2 = make_window(qtbot, ui_settings)
    try:
        assert win2.act_lsl.isChecked()
        qtbot.waitUntil(lambda: win2.lsl_part.lsl_outlets is not None, timeout=WAIT_MS)
        win2.act_lsl.trigger()  # off again
        assert win2.lsl_part.lsl_outlets is None and not win2.act_lsl.isChecked()
        assert ui_settings.value("lsl/enabled") in (False, "false")
    finally:
        win2.close()
    assert win2.errors == []


def test_without_pylsl_the_action_says_what_to_install(
    qtbot, ui_settings, no_leaked_threads, monkeypatch
):
    monkeypatch.setitem(sys.modules, "pylsl", None)
    win = make_window(qtbot, ui_settings, autoconnect=False)
    try:
        win.act_lsl.trigger()
        assert not win.act_lsl.isChecked() and win.lsl_part.lsl_outlets is None
        assert "install gaitmon[lsl]" in win.statusBar().currentMessage()
        assert win.errors == []
    finally:
        win.close()
