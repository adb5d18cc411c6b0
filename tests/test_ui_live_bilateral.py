"""Both legs in the real live window: the simulated pair on two pseudo-terminals, reached through
the real SerialTransport and decoder, driven as a user does (Device menu, Record, Simulator ▸
Cut left leg's link). What is asserted is what is drawn and written; the references are the
engines' own snapshots, the simulator's configuration and the recorded file read back."""


import numpy as np
import pytest
from PySide6.QtCore import QPointF, QSettings, Qt
from test_truth_live_window import lines_across

from gaitmon.cli import main
from gaitmon.finish.bilateral import open_bilateral
from gaitmon.io.sim.bilateral import BilateralConfig
from gaitmon.live.pair import PairSource
from gaitmon.ui.live import MainWindow

WAIT_MS = 30_000
KNEE = 1


def open_window(qtbot, tmp_path, config, *, via_menu=False):
    settings = QSettings(str(tmp_path / "gaitmon.ini"), QSettings.Format.IniFormat)
    win = MainWindow(
        settings,
        pair_sim=config,
        pair=None if via_menu else PairSource(sim=config),
        mode="raw",
        confirm_close=False,
    )
    win.show()
    if via_menu:
        assert win._actions["pair_sim"].isEnabled()
        win._actions["pair_sim"].trigger()
    qtbot.waitUntil(lambda: win.pair is not None, timeout=WAIT_MS)
    return win


def close_window(win):
    win.close()
    assert win.pair is None and win.conn is None
    assert win.errors == []


def samples(win, side):
    return win.pair.engines[side].samples_total


def path_points(path):
    pts = np.array([(path.elementAt(i).x, path.elementAt(i).y)
                    for i in range(path.elementCount())])  # fmt: skip
    return pts[:, 0], pts[:, 1]


def test_both_legs_are_drawn_and_measured_from_their_own_engines(
    qtbot, tmp_path, no_leaked_threads
):
    config = BilateralConfig(standing_s=1.0, asymmetry="hemiparetic", affected="L", speed=2.0)
    win = open_window(qtbot, tmp_path, config, via_menu=True)
    try:
        view = win.pair_part.view
        assert view.isVisible() and not win.live.isVisible() and not win.gait_dock.isVisible()
        assert not win.phase_combo.isVisible()  # the one-leg legend says nothing here
        # walk until each leg's panel has its strides and the measures have both legs' steps
        qtbot.waitUntil(
            lambda: min(samples(win, "L"), samples(win, "R")) >= 2400, timeout=60_000
        )
        qtbot.waitUntil(lambda: view.values["symmetry"].text().startswith("SR 0."))
        win.view_part.set_paused(True)  # nothing is drawn any more: compare what is shown
        qtbot.wait(50)
        snaps = win.pair_part.snapshots
        plots = view.plots
        for side in ("L", "R"):
            for j in range(3):
                assert plots.curve_points(side, j) >= 500, (side, j)
        # the right leg's knee trace is the right engine's knee series, value for value
        knee_r = snaps["R"].series["joint_kalman_deg"][:, KNEE]
        x, y = path_points(plots.curve_path("R", KNEE))
        assert len(knee_r) <= 1400  # 10 s of the unit's clock: drawn without decimation
        np.testing.assert_allclose(y, knee_r[np.isfinite(knee_r)])
        np.testing.assert_allclose(np.diff(x), 0.01, atol=1e-6)  # at its samples' times
        _, y_left = path_points(plots.curve_path("L", KNEE))
        assert not np.array_equal(y_left[: len(y)], y[: len(y_left)])
        # both legs end "now" on the host clock (within a tick, the link and the pause)
        for side in ("L", "R"):
            right_edge = plots.curve_path(side, KNEE).boundingRect().right()
            assert -0.5 < right_edge <= 0.05, (side, right_edge)
        # the hemiparetic left knee swings less: its peak is lower than the right's
        assert np.nanmax(snaps["L"].series["joint_kalman_deg"][:, KNEE]) < 0.8 * np.nanmax(knee_r)
        # the measures: the step times' ratio and the measured cadence, as configured
        gait = win.pair_model.gait()
        step = gait.symmetry_of("step_s")
        assert step.ratio == pytest.approx(config.step_time_ratio, abs=0.03)
        assert gait.cadence_steps_min == pytest.approx(config.cadence_steps_min, abs=3.0)
        shown_sr = float(view.values["symmetry"].text().split()[1])  # "SR 0.85 · SI 16 %"
        # the measured ratio's 0.03 and the 2 decimals shown (a ratio 0.0275 off shows 0.03
        # off, which the float difference puts past abs=0.03 alone)
        assert shown_sr == pytest.approx(config.step_time_ratio, abs=0.03 + 0.005 + 1e-12)
        # each leg's gait panel shows its own engine's strides (the one-leg panel). It is
        # refreshed one piece a tick (~10 Hz), so it may lag the last tick's snapshot, never
        # lead it: on a loaded machine the ticks slow down, and it lagged by 2 strides at 2x
        for side in ("L", "R"):
            shown = int(view.panels[side].values["strides"].text())
            assert 0 <= snaps[side].gait.n_strides - shown <= 3, (side, shown)
            assert shown >= 5
        assert view.status["L"].state_text == view.status["R"].state_text == "Connected"
        assert "0 lost" in view.status["R"].health_label.text()
    finally:
        close_window(win)


def test_a_cut_on_the_left_leg_shows_there_and_the_right_leg_draws_on(
    qtbot, tmp_path, no_leaked_threads
):
    win = open_window(qtbot, tmp_path, BilateralConfig(standing_s=1.0, speed=2.0))
    try:
        view = win.pair_part.view
        plots = view.plots
        qtbot.waitUntil(lambda: min(samples(win, "L"), samples(win, "R")) >= 600, timeout=WAIT_MS)
        win._actions["cut_L"].trigger()
        qtbot.waitUntil(
            lambda: view.status["L"].state_text.startswith("Reconnecting"), timeout=WAIT_MS
        )
        qtbot.waitUntil(lambda: win.pair_part.snapshots["L"].last_data_age_s > 1.0, timeout=WAIT_MS)
        qtbot.wait(100)
        # the left leg: its time runs on, shaded red, its line stops; the right draws on
        assert plots.lost_path("L", "knee").contains(QPointF(-0.3, 30.0))
        assert plots.curve_path("L", KNEE).boundingRect().right() < -0.6
        assert plots.curve_path("R", KNEE).boundingRect().right() > -0.3
        assert plots.lost_path("R", "knee") is None
        assert plots.lost_label("L") == "left leg: no data" and plots.lost_label("R") == ""
        # in the contact strip, only the left row is red
        assert plots.lost_path("L", "contact").contains(QPointF(-0.3, 1.5))
        assert not plots.lost_path("L", "contact").contains(QPointF(-0.3, 0.5))
        assert view.status["R"].state_text == "Connected"
        # the window's link banner names the leg whose link is down, and only that one
        banner = win.status.link_banner.text()
        assert win.status.link_banner.isVisible() and banner.startswith("Left leg: ")
        assert "Right leg" not in banner
        qtbot.waitUntil(lambda: view.status["L"].state_text == "Connected", timeout=WAIT_MS)
        qtbot.waitUntil(lambda: not win.status.link_banner.isVisible())
        at = samples(win, "L")
        qtbot.waitUntil(lambda: samples(win, "L") >= at + 300, timeout=WAIT_MS)
        win.view_part.set_paused(True)
        qtbot.wait(50)
        snaps = win.pair_part.snapshots
        s = snaps["L"].series
        lost = np.flatnonzero(s["lost"] > 0)
        assert len(lost) >= 250  # >= ~1.3 s at 200 Hz went nowhere and are rows on screen
        now = win.pair_model.x_now("L")
        mid = (s["t_s"][lost[0]] + s["t_s"][lost[-1]]) / 2 - now
        assert lines_across(plots.curve_path("L", KNEE), mid) == 0  # broken across the gap
        assert plots.lost_path("L", "knee").contains(QPointF(mid, 30.0))
        # the right leg lost nothing, and its line runs through that time
        assert not (snaps["R"].series["lost"] > 0).any()
        assert win.pair.engines["R"].device.stats.decoder.frames_lost == 0
        assert lines_across(plots.curve_path("R", KNEE), mid) == 1
        assert win.pair.engines["L"].device.stats.reconnects >= 1
        assert win.pair.engines["R"].device.stats.reconnects == 0
    finally:
        close_window(win)


def test_record_both_legs_from_the_window_into_one_file(qtbot, tmp_path, no_leaked_threads):
    win = open_window(qtbot, tmp_path, BilateralConfig(standing_s=1.0, speed=2.0))
    target = tmp_path / "both.h5"
    try:
        qtbot.waitUntil(lambda: min(samples(win, "L"), samples(win, "R")) >= 100, timeout=WAIT_MS)
        assert not win.act_engineering.isEnabled()  # one leg's traces: not in this view
        old_view = win.pair_part.view
        win.pair_part.restyle()  # what a theme change does: a new view that draws on
        assert win.pair_part.view is not old_view and win.pair_part.view.isVisible()
        qtbot.waitUntil(lambda: win.pair_part.view.plots.curve_points("R", KNEE) > 100)
        win.act_record.trigger()
        dlg = win.recording_part.session_dialog
        assert dlg is not None and dlg.isVisible() and not dlg.side.isEnabled()
        dlg.patient.setText("P017")
        dlg.path.setText(str(target))
        dlg.path.textEdited.emit(str(target))
        qtbot.mouseClick(dlg.buttons.buttons()[0], Qt.MouseButton.LeftButton)
        assert win.recording and win.act_record.text() == "Stop"
        start = {s: samples(win, s) for s in ("L", "R")}
        qtbot.waitUntil(lambda: samples(win, "L") >= start["L"] + 200, timeout=WAIT_MS)
        win.marker_edit.setText("turn")
        win.act_marker.trigger()
        qtbot.waitUntil(
            lambda: min(samples(win, s) - start[s] for s in ("L", "R")) >= 500, timeout=WAIT_MS
        )
        qtbot.waitUntil(lambda: "REC both legs" in win.status.rec_label.full_text)
        assert not win.port_combo.isEnabled() and not win.mode_combo.isEnabled()
        win.act_record.trigger()  # stop: both parts finished and combined, on the worker
        assert not win.recording and win.act_record.text() == "Record"
        assert win.saving and not win.act_record.isEnabled()  # no new recording meanwhile
        qtbot.waitUntil(lambda: not win.saving, timeout=WAIT_MS)
        assert "Recording saved: both legs" in win.statusBar().currentMessage()
        assert target.exists() and not list(tmp_path.glob("both.h5.*.partial"))
        # acquisition goes on after the stop
        after = samples(win, "R")
        qtbot.waitUntil(lambda: samples(win, "R") >= after + 50, timeout=WAIT_MS)
        win.disconnect_device()
        # the one-leg window is back as it was
        assert win.pair is None and not win.pair_part.view.isVisible() and win.live.isVisible()
        assert win.gait_dock.isVisible() and win.phase_combo.isVisible()
        assert win.act_engineering.isEnabled()
        assert win._actions["pair_sim"].isEnabled()
    finally:
        close_window(win)
    with open_bilateral(target) as both:
        assert set(both.units) == {"L", "R"} and both.complete
        for side in ("L", "R"):
            unit = both.units[side]
            assert unit.meta.side == side and unit.meta.patient_id == "P017"
            assert unit.n_samples >= 500
            assert [m.label for m in unit.markers] == ["turn"]
            assert both.sync[side] is not None


def test_connect_two_units_by_their_ports_from_the_device_menu(
    qtbot, tmp_path, monkeypatch, no_leaked_threads
):
    """Device ▸ Connect two units: the ports picked are the two units' serial ports (here a
    simulated pair's pseudo-terminals, as ``gaitmon simulate --pty --bilateral`` serves them):
    first one port for both legs (refused in one line), then the left and the right one."""
    from PySide6.QtWidgets import QDialog

    from gaitmon.io.ports import PortInfo
    from gaitmon.io.sim.bilateral import serve_pair_on_ptys
    from gaitmon.ui.live import pair_part

    pty = serve_pair_on_ptys(BilateralConfig(standing_s=1.0, speed=2.0))
    left, right = (str(p) for p in pty.link_paths)
    ports = [PortInfo(right, "unit R", "n/a"), PortInfo(left, "unit L", "n/a")]
    monkeypatch.setattr(pair_part, "available_ports", lambda: ports)
    picks = iter([(right, right), (left, right)])  # first the same port twice: refused

    def exec_(dlg):
        lp, rp = next(picks)
        for side, path in (("L", lp), ("R", rp)):
            dlg.combos[side].setCurrentIndex(dlg.combos[side].findData(path))
        return QDialog.DialogCode.Accepted

    monkeypatch.setattr(pair_part.TwoPortsDialog, "exec", exec_)
    settings = QSettings(str(tmp_path / "gaitmon.ini"), QSettings.Format.IniFormat)
    win = MainWindow(settings, mode="raw", confirm_close=False)
    win.show()
    try:
        win._actions["pair_ports"].trigger()
        assert win.pair is None and "two different ports" in win.statusBar().currentMessage()
        win._actions["pair_ports"].trigger()
        qtbot.waitUntil(lambda: win.pair is not None, timeout=WAIT_MS)
        assert win.pair.source.ports == (left, right) and not win.pair.simulated
        # each engine reads its own unit: the left engine's unit is the left one (#1001)
        assert win.pair.engines["L"].identity.serial == 1001
        assert win.pair.engines["R"].identity.serial == 1002
        qtbot.waitUntil(lambda: min(samples(win, "L"), samples(win, "R")) >= 200, timeout=WAIT_MS)
        assert win.pair_part.view.plots.curve_points("L", KNEE) > 100
        assert not win._actions["cut_L"].isEnabled()  # real ports: no simulator to cut
        assert win.pair_part.view.status["L"].state_text == "Connected"
    finally:
        close_window(win)
        pty.stop()
        pty.sim.close()


def test_zero_both_legs_while_the_subject_stands(qtbot, tmp_path, no_leaked_threads):
    win = open_window(qtbot, tmp_path, BilateralConfig(standing_s=8.0))
    try:
        engines = win.pair.engines
        qtbot.waitUntil(lambda: min(samples(win, "L"), samples(win, "R")) >= 200, timeout=WAIT_MS)
        assert not any(e.snapshot(0.1).calibrated for e in engines.values())
        win.act_zero.trigger()
        qtbot.waitUntil(lambda: "zeroed on both legs" in win.statusBar().currentMessage(),
                        timeout=WAIT_MS)  # fmt: skip
        qtbot.waitUntil(lambda: all(e.snapshot(0.1).calibrated for e in engines.values()))
        qtbot.waitUntil(lambda: win.guide.state.zeroed)  # the step bar moves on to Record
        assert win.act_zero.isEnabled()
        # each leg says where its angles' zero comes from now (the status bar's wording)
        labels = [win.pair_part.view.status[s].method_label for s in ("L", "R")]
        qtbot.waitUntil(lambda: all(lb.text().endswith("zero: standing calibration")
                                    for lb in labels))  # fmt: skip
    finally:
        close_window(win)


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--asymmetry", "hemiparetic"], "only with --simulate-bilateral"),
        (["--simulate", "--simulate-bilateral"], "choose one"),
        (["--ports", "/dev/rfcomm0"], "two different ports"),
        (["--simulate-bilateral", "--speed", "max"], "--speed max"),
    ],
)
def test_the_both_legs_options_refuse_a_bad_combination_in_one_line(argv, says, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert says in err and len(err.strip().splitlines()) == 1
