"""Issue 25, one number everywhere: the live Gait panel's strides are the recording's.

A link cut that begins inside a stride leaves, in the file, a stride across the cut (its heel
strike and toe off on one side, its closing heel strike on the other) which ``info``, review and
the report list as excluded, "crosses a gap". The live panel made its strides with the
pipeline's tracker, which forgets the open stride at the cut: it counted one stride fewer
("Strides (this recording)" 26 against the file's 27 in the walk-through). The live strides are
now made from the engine's events by the file's function, and the one stride rule
(``analysis.stride_exclusion``) gives each the file's reason.

The cut is placed by the simulated unit's fault (``FaultConfig.link_drops``, in the unit's own
time) inside the stance of a known stride (the simulator's truth), so the case is the same on
any machine. References: the recorded file read back by ``analysis.analyse_session``.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import wait_for
from PySide6.QtCore import QSettings

from gaitmon.analysis import FIRST, GAP, LAST, analyse_session
from gaitmon.engine import Engine
from gaitmon.engine.live_gait import RecordingStart
from gaitmon.finish import open_session
from gaitmon.io.device import Device
from gaitmon.io.sim import FaultConfig, GaitConfig, GaitModel, SimulatedUnit
from gaitmon.io.transport import InProcessTransport

FS = 100.0
CUT_S = 3.0


def cut_in_stance(gait: GaitConfig, k: int = 12) -> float:
    """A device time 0.2 s before the ``k``-th true toe off: the stride open when the cut
    begins has its closing heel strike after the cut (the file keeps it, "crosses a gap")."""
    _hs, to = GaitModel(gait).events(0, 4000)
    return float(to[k]) / FS - 0.2


def file_rows(path: Path) -> list[tuple[int, str]]:
    """(opening heel strike row, exclusion reason) of every stride of the file."""
    with open_session(path) as s:
        return [(r.stride.start_idx, r.excluded) for r in analyse_session(s).rows]


def test_live_strides_and_their_reasons_are_the_recordings_across_a_cut(tmp_path):
    gait = GaitConfig(seed=5, standing_s=2.0, stride_cv=0.005)
    faults = FaultConfig(seed=5, link_drops=((cut_in_stance(gait), CUT_S),))
    # the unit's clock starts when the engine first asks (not at its creation, which a busy
    # machine's first imports may leave seconds behind)
    unit = SimulatedUnit(gait, faults=faults, speed=10.0, start_on_request=True)
    eng = Engine(Device(InProcessTransport(unit)), "raw", transport_label="simulated")
    start = RecordingStart()
    eng.add_listener(start)
    path = tmp_path / "walk.h5"
    with eng:
        wait_for(lambda: eng.samples_total >= 200, what="samples")
        eng.start_recording(path)
        wait_for(lambda: eng.samples_total >= 3000, what="the walk after the cut")
        gait_now = eng.snapshot(0.1).gait
        n_live = start.strides(gait_now)
        row0 = start.start_idx
        with eng._lock:  # what the live means left out, and why
            live_excluded = {s.start_idx: why for s, why in eng._gait.excluded}
        eng.stop_recording()
    assert row0 is not None and n_live is not None
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
def cut_unit(monkeypatch):
    """The window's simulated unit (``SimConfig``) with a cut inside a stride's stance."""
    from gaitmon.io.sim.config import SimConfig

    config = SimConfig(standing_s=2.0, speed=5.0, stride_cv=0.005, seed=5)
    # the 20th stride (~24 s of the unit's clock, ~5 s of wall time from the unit's start): the
    # recording must have started before it, however long a busy machine takes to connect (at
    # the 12th, 3 s of wall time, it once had not)
    at = cut_in_stance(config.gait_config(), k=20)

    def faults(self: SimConfig) -> FaultConfig:
        return FaultConfig(seed=self.seed, link_drops=((at, CUT_S),))

    monkeypatch.setattr(SimConfig, "fault_config", faults)
    return config


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
        qtbot.waitUntil(lambda: win.engine.samples_total >= 3800, timeout=120_000)
        win.conn.unit.stand_still()  # the subject stops: the count is final before Stop
        qtbot.waitUntil(lambda: panel.stale_text().startswith("⚠ stale: last stride"),
                        timeout=60_000)  # fmt: skip
        shown = int(panel.values["strides"].text())
        assert not win.conn.engine.stop_recording().error
    finally:
        win.close()
    reasons = [why for _, why in file_rows(path)]
    assert reasons.count(GAP) == 1, reasons
    assert shown == len(reasons), (shown, reasons)
