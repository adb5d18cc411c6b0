"""Issue 25 in the real live window: nothing on the Gait panel older than its data.

- the current stride's line in the gait-cycle plots is cleared when a gap breaks its stride (a
  cut link) and never drawn from samples older than the gap;
- while recording, the panel counts the recording's strides (as the file will have them), and
  its cadence and speed are marked stale when no stride has completed for a while or the link
  is down;
- a one-leg window opened after a two-leg session shows its Gait panel (the two layouts do not
  share the remembered dock state)."""

import numpy as np
import pytest
from PySide6.QtCore import QSettings

from gaitmon.io.sim.bilateral import BilateralConfig
from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.live.pair import PairSource
from gaitmon.ui.live import MainWindow

WAIT_MS = 60_000


@pytest.fixture
def ui_settings(tmp_path):
    path = tmp_path / "settings" / "gaitmon.ini"
    path.parent.mkdir()
    return QSettings(str(path), QSettings.Format.IniFormat)


def one_leg(qtbot, settings, *, speed=4.0, autoconnect=True):
    win = MainWindow(settings, sim=SimConfig(standing_s=1.0, speed=speed),
                     autoconnect=SIMULATED_PORT if autoconnect else None, mode="raw",
                     confirm_close=False)  # fmt: skip
    win.show()
    if autoconnect:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
    return win


def current_points(win):
    """Points of the current stride's line in the hip, knee and ankle cycle plots."""
    out = []
    for curve in win.gait_panel.cycles.current:
        x, _y = curve.getData()
        out.append(0 if x is None else len(x))
    return out


def test_a_cut_link_clears_the_current_stride_and_nothing_older_than_the_gap_returns(
    qtbot, ui_settings, no_leaked_threads
):
    win = one_leg(qtbot, ui_settings)
    try:
        panel = win.gait_panel
        qtbot.waitUntil(lambda: win.engine.snapshot().gait.n_strides >= 3, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: min(current_points(win)) > 5, timeout=WAIT_MS)
        win.device_part.cut_simulated_link(2.0)
        # while no data arrives the current stride is broken: its line goes
        qtbot.waitUntil(lambda: win.status.state_text.startswith("Reconnecting"), timeout=WAIT_MS)
        qtbot.waitUntil(lambda: max(current_points(win)) == 0, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: win.status.state_text == "Connected", timeout=WAIT_MS)
        at = win.engine.samples_total
        qtbot.waitUntil(lambda: win.engine.samples_total >= at + 50, timeout=WAIT_MS)
        # from now on every drawn current stride starts after the gap: the engine's snapshot
        # (the panel's source) never gives a current stride whose heel strike precedes it
        for _ in range(20):
            snap = win.engine.snapshot()
            s = snap.series
            lost = np.flatnonzero(s["lost"] > 0)
            g = snap.gait
            if len(lost) and len(g.current_pct):
                n = len(g.current_pct)
                start = len(s["t_s"]) - n
                assert start > lost[-1], "current stride drawn from samples before the gap"
            qtbot.wait(25)
        win.device_part.disconnect_device()
        qtbot.waitUntil(lambda: win.engine is None, timeout=WAIT_MS)
        assert max(current_points(win)) == 0  # nothing of the last connection stays drawn
    finally:
        win.close()


def test_a_one_leg_window_after_a_two_leg_session_shows_its_gait_panel(
    qtbot, ui_settings, no_leaked_threads
):
    pair = MainWindow(ui_settings, pair=PairSource(sim=BilateralConfig(standing_s=1.0)),
                      mode="raw", confirm_close=False)  # fmt: skip
    pair.show()
    qtbot.waitUntil(lambda: pair.pair is not None, timeout=WAIT_MS)
    assert pair.pair_part.view.isVisible() and not pair.gait_dock.isVisible()
    pair.close()
    assert pair.pair is None
    win = one_leg(qtbot, ui_settings, autoconnect=False)
    try:
        assert win.state_restored  # the layout was remembered...
        assert win.gait_dock.isVisible()  # ...as the one-leg window left it
        assert win.gait_dock.toggleViewAction().isChecked()
    finally:
        win.close()
