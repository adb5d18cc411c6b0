"""Issue 25 in the real live window: nothing on the Gait panel older than its data.

- the current stride's line in the gait-cycle plots is cleared when a gap breaks its stride (a
  cut link) and never drawn from samples older than the gap;
- while recording, the panel counts the recording's strides (as the file will have them), and
  its cadence and speed are marked stale when no stride has completed for a while or the link
  is down;
- a one-leg window opened after a two-leg session shows its Gait panel (the two layouts do not
  share the remembered dock state)."""

import numpy as np
from PySide6.QtCore import Qt

from gaitmon.analysis import analyse_session
from gaitmon.finish import open_session
from gaitmon.io.sim.bilateral import BilateralConfig
from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.live.pair import PairSource
from gaitmon.ui.live import MainWindow

WAIT_MS = 60_000


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


DECIDED_WITHIN_S = 1.0  # a heel strike is in the file's events once this much follows it


def strides_shown(win):
    return int(win.gait_panel.values["strides"].text())


def test_while_recording_the_panel_counts_the_recordings_strides_and_marks_stale_figures(
    qtbot, ui_settings, tmp_path, no_leaked_threads
):
    win = one_leg(qtbot, ui_settings, speed=8.0)
    panel = win.gait_panel
    try:
        qtbot.waitUntil(lambda: win.engine.snapshot().gait.n_strides >= 8, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: panel.values["strides"].text() not in ("", "—"))
        assert panel.strides_name.text() == "Strides (since connect)"
        assert panel.stale_text() == "" and panel.values["cadence"].isEnabled()
        target = tmp_path / "walk.h5"
        win.act_record.trigger()
        dlg = win.recording_part.session_dialog
        dlg.path.setText(str(target))
        dlg.path.textEdited.emit(str(target))
        qtbot.mouseClick(dlg.buttons.buttons()[0], Qt.MouseButton.LeftButton)
        assert win.recording
        qtbot.waitUntil(lambda: panel.strides_name.text() == "Strides (this recording)")
        qtbot.waitUntil(lambda: strides_shown(win) >= 5, timeout=WAIT_MS)
        since_connect = win.engine.snapshot().gait.n_strides
        row0 = panel.recording_start.start_idx
        assert row0 is not None
        # the panel's count is the engine's strides from the recording's first row on
        shown = strides_shown(win)
        assert shown < since_connect - 5  # not the connection's count
        win.act_record.trigger()  # stop
        qtbot.waitUntil(lambda: not win.saving, timeout=WAIT_MS)
        snap = win.engine.snapshot()
        live = snap.gait.stride_start_idx
        with open_session(target) as s:
            rows = s.n_samples
            an = analyse_session(s)
            file_starts = np.array([r.stride.start_idx for r in an.rows]) + row0
        # the file's strides are the live ones that lie in it: the same opening heel strikes
        # (within 2 samples: the file's detector starts afresh at row 0), one for one
        # A live stride that ends near the file's end may be missing from the file: its
        # closing heel strike is decided a little after it, from rows the live engine read
        # after Stop. One that ended a second before the file's end is in it.
        in_file = live[(live >= row0) & (live < row0 + rows)]
        ends = np.append(live[1:], np.iinfo(np.int64).max)  # a stride closes at the next start
        settled = live[(live >= row0) & (ends < row0 + rows - round(DECIDED_WITHIN_S * 100))]
        assert len(file_starts) >= 5
        assert len(settled) <= len(file_starts) <= len(in_file)
        k = len(file_starts)
        assert np.abs(in_file[:k] - file_starts).max() <= 2
        assert len(file_starts) - 1 <= shown + 3  # shown a moment before Stop
        assert panel.strides_name.text() == "Strides (since connect)"  # recording over
        # a cut link: cadence and speed are greyed and said to be stale while no data comes
        win.device_part.cut_simulated_link(2.0)
        qtbot.waitUntil(lambda: panel.stale_text().startswith("⚠ stale: no data for"),
                        timeout=WAIT_MS)  # fmt: skip
        assert "last stride" in panel.stale_text()
        assert not panel.values["cadence"].isEnabled() and not panel.values["speed"].isEnabled()
        qtbot.waitUntil(lambda: win.status.state_text == "Connected", timeout=WAIT_MS)
        # walking on: new strides, fresh figures again
        n = win.engine.snapshot().gait.n_strides
        qtbot.waitUntil(lambda: win.engine.snapshot().gait.n_strides >= n + 4, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: panel.stale_text() == "", timeout=WAIT_MS)
        assert panel.values["cadence"].isEnabled()
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


def test_a_standing_subject_leaves_no_current_stride_and_stale_figures(
    qtbot, ui_settings, no_leaked_threads
):
    win = one_leg(qtbot, ui_settings, speed=8.0)
    panel = win.gait_panel
    try:
        qtbot.waitUntil(lambda: win.engine.snapshot().gait.n_strides >= 3, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: min(current_points(win)) > 5, timeout=WAIT_MS)
        win.device_part.set_simulated_standing(True)  # Device ▸ Simulator ▸ Stand still
        qtbot.waitUntil(lambda: panel.stale_text().startswith("⚠ stale: last stride"),
                        timeout=WAIT_MS)  # fmt: skip
        assert win.conn.unit.standing
        assert not panel.values["cadence"].isEnabled()
        # no heel strike for 2 mean strides: no stride is in progress, no line for one
        qtbot.waitUntil(lambda: max(current_points(win)) == 0, timeout=WAIT_MS)
        win.device_part.set_simulated_standing(False)
        qtbot.waitUntil(lambda: min(current_points(win)) > 5, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: panel.stale_text() == "", timeout=WAIT_MS)
    finally:
        win.close()
