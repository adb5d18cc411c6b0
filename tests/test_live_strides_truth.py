"""Issue 25, one number everywhere: the live Gait panel's strides are the recording's.

A link cut that begins inside a stride leaves, in the file, a stride across the cut (its heel
strike and toe off on one side, its closing heel strike on the other) which ``info``, review and
the report list as excluded, "crosses a gap". The live panel made its strides with the
pipeline's tracker, which forgets the open stride at the cut: it counted one stride fewer
("Strides (this recording)" 26 against the file's 27 in the walk-through). The live strides are
now made from the engine's events by the file's function, and the one stride rule
(``analysis.stride_exclusion``) gives each the file's reason.

The cut is placed by the simulated unit's fault (``FaultConfig.link_drops``, in the unit's own
time) inside the stance of a known stride (the simulator's truth), a few seconds of the unit's
time after the recording has started, so the case is the same on any machine however late a busy
one starts recording. References: the recorded file read back by ``analysis.analyse_session``.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from helpers import wait_for
from PySide6.QtCore import QSettings

from gaitmon.analysis import FIRST, GAP, LAST, analyse_session
from gaitmon.engine import Engine
from gaitmon.engine.live_gait import RecordingStart
from gaitmon.finish import open_session
from gaitmon.io.device import Device
from gaitmon.io.sim import FaultConfig, GaitConfig, SimulatedUnit
from gaitmon.io.transport import InProcessTransport

FS = 100.0
CUT_S = 3.0


def cut_in_swing(unit: SimulatedUnit, lead_s: float = 4.0) -> float:
    """Schedule the link's cut (``CUT_S`` long) 0.1 s before the first true heel strike at least
    ``lead_s`` of the unit's time from now, and return its device time: the stride open when
    the cut begins has its heel strike and toe off before it and closes after it (the file
    keeps it, "crosses a gap").

    - A cut scheduled at a fixed time (the 12th, then the 20th stride from the unit's start)
      came before the recording's start when a busy machine was slow to start it (CI, twice).
    - Late in swing, not in stance: a cut 0.2 s before a toe off left the open stride's toe
      off to the first rows after the cut, and a reconnection that took 0.47 s of the unit's
      time (under load) lost it too; with no toe off the file has no stride across the cut."""
    while True:
        now = unit.device_time_s
        hs, _to, _ = unit.true_events(round(now * FS), round((now + 30.0) * FS))
        at = float(hs[hs / FS - 0.1 > now + lead_s][0]) / FS - 0.1
        unit.faults = replace(unit.faults, link_drops=((at, CUT_S),))
        if unit.device_time_s < at - 1.0:  # scheduled in time (else: the next stride's swing)
            return at


def assert_the_open_stride_toed_off_before_the_cut(path: Path) -> None:
    """The case's premise, in the file: one gap, and the last heel strike before it has its
    toe off before it too."""
    with open_session(path) as s:
        assert len(s.gaps) == 1, s.gaps
        gap_row = s.gaps[0].sample_idx
        hs = s.heel_strike_idx[s.heel_strike_idx < gap_row]
        to = s.toe_off_idx
        assert len(hs) and np.any((to > hs[-1]) & (to < gap_row)), (gap_row, hs, to)


def file_rows(path: Path) -> list[tuple[int, str]]:
    """(opening heel strike row, exclusion reason) of every stride of the file."""
    with open_session(path) as s:
        return [(r.stride.start_idx, r.excluded) for r in analyse_session(s).rows]


def test_live_strides_and_their_reasons_are_the_recordings_across_a_cut(tmp_path):
    gait = GaitConfig(seed=5, standing_s=2.0, stride_cv=0.005)
    unit = SimulatedUnit(gait, faults=FaultConfig(seed=5), speed=4.0, start_on_request=True)
    eng = Engine(Device(InProcessTransport(unit)), "raw", transport_label="simulated")
    start = RecordingStart()
    eng.add_listener(start)
    path = tmp_path / "walk.h5"
    with eng:
        wait_for(lambda: eng.samples_total >= 200, what="samples")
        eng.start_recording(path)
        at = cut_in_swing(unit)
        wait_for(lambda: eng.samples_total >= (at + 6.0) * FS, what="the walk after the cut")
        gait_now = eng.snapshot(0.1).gait
        n_live = start.strides(gait_now)
        row0 = start.start_idx
        with eng._lock:  # what the live means left out, and why
            live_excluded = {s.start_idx: why for s, why in eng._gait.excluded}
        eng.stop_recording()
    assert row0 is not None and n_live is not None
    assert_the_open_stride_toed_off_before_the_cut(path)
    rows = file_rows(path)
    reasons = [why for _, why in rows]
    assert reasons.count(GAP) == 1, reasons  # the case: a stride across the cut
    # the live count is the file's (its last stride closes before Stop; the file has no more)
    assert n_live == len(rows), (n_live, reasons)
    # every stride of the file is a live stride with the file's reason (the file's first and
    # last are such because the recording starts and ends there; live they are mid-walk)
    live_starts = [int(s) for s in gait_now.stride_start_idx if s >= row0]
    assert live_starts == [row0 + start_row for start_row, _ in rows]
    for start_row, why in rows:
        if why not in (FIRST, LAST):
            assert live_excluded.get(row0 + start_row, "") == why, (start_row, why)
    # live, the start-up stride is the first since connecting, by the same rule
    assert live_excluded.get(int(gait_now.stride_start_idx[0])) == FIRST


@pytest.fixture
def cut_unit():
    """The window's simulated unit (``SimConfig``); the test schedules the cut."""
    from gaitmon.io.sim.config import SimConfig

    return SimConfig(standing_s=2.0, speed=3.0, stride_cv=0.005, seed=5)


def test_the_gait_panel_counts_the_stride_across_a_cut(qtbot, tmp_path, cut_unit,
                                                       no_leaked_threads):  # fmt: skip
    from gaitmon.live.connection import SIMULATED_PORT
    from gaitmon.ui.live import MainWindow

    settings = QSettings(str(tmp_path / "gaitmon.ini"), QSettings.Format.IniFormat)
    win = MainWindow(settings, sim=cut_unit, autoconnect=SIMULATED_PORT, mode="raw",
                     confirm_close=False)  # fmt: skip
    win.show()
    path = tmp_path / "walk.h5"
    panel = win.gait_panel
    try:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=60_000)
        qtbot.waitUntil(lambda: win.engine.samples_total >= 100, timeout=60_000)
        win.conn.engine.start_recording(path)
        qtbot.waitUntil(lambda: panel.strides_name.text() == "Strides (this recording)",
                        timeout=60_000)  # fmt: skip
        at = cut_in_swing(win.conn.unit)
        qtbot.waitUntil(lambda: win.engine.samples_total >= (at + 6.0) * FS, timeout=120_000)
        win.conn.unit.stand_still()  # the subject stops: the count is final before Stop
        qtbot.waitUntil(lambda: panel.stale_text().startswith("⚠ stale: last stride"),
                        timeout=60_000)  # fmt: skip
        shown = int(panel.values["strides"].text())
        assert not win.conn.engine.stop_recording().error
    finally:
        win.close()
    assert_the_open_stride_toed_off_before_the_cut(path)
    reasons = [why for _, why in file_rows(path)]
    assert reasons.count(GAP) == 1, reasons
    assert shown == len(reasons), (shown, reasons)
