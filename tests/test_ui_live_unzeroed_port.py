"""Issue 25, gaps a clinician stumbles over in the live window (the real window, pytest-qt):

* Record before a standing Zero asks first (Record anyway / Zero first / Cancel; both legs:
  which leg), and a recording without one says so in the guide bar, in the alert colour;
* the Unit field takes a typed port (a ``gaitmon simulate --pty`` path, a ``bt://`` address),
  refuses a wrong one in one line and remembers a good one;
* the hint after Zero on the simulator says how to make the subject walk.
"""

import math
import re

from PySide6.QtCore import QSettings, QTimer
from PySide6.QtWidgets import QMessageBox

from gaitmon.io.sim import GaitConfig, SimulatedUnit
from gaitmon.io.sim.bilateral import BilateralConfig
from gaitmon.io.sim.config import SimConfig
from gaitmon.io.sim.pty import PtySimulator
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.live.pair import PairSource
from gaitmon.ui.live import MainWindow

WAIT_MS = 30_000


def settings_in(tmp_path):
    return QSettings(str(tmp_path / "gaitmon.ini"), QSettings.Format.IniFormat)


def simulated_window(tmp_path, standing_s, *, confirm_unzeroed=True):
    """A shown one-leg window connecting to the simulated unit, whose subject stands
    ``standing_s`` first (0: walks from the start, so no Zero can happen behind a test)."""
    win = MainWindow(settings_in(tmp_path), sim=SimConfig(standing_s=standing_s), mode="raw",
                     autoconnect=SIMULATED_PORT, confirm_close=False,
                     confirm_unzeroed=confirm_unzeroed)  # fmt: skip
    win.show()
    return win


def answer_next_question(win, button_text, seen):
    """Click ``button_text`` in the unzeroed question once it is open (in its own exec loop);
    its text goes into ``seen`` (nothing when no question is asked)."""

    def click():
        box = getattr(win.recording_part, "unzeroed_box", None)
        if box is None:
            return
        seen.append(box.text())
        [button] = [b for b in box.buttons() if b.text().replace("&", "") == button_text]
        button.click()

    QTimer.singleShot(0, click)


def close(win):
    win.close()
    assert win.conn is None and win.pair is None
    assert win.errors == []


def test_record_before_zero_asks_and_a_recording_without_zero_says_so(
    qtbot, tmp_path, no_leaked_threads
):
    # the subject walks from the start: a Zero is refused, so nothing zeroes behind the test
    win = simulated_window(tmp_path, 0.0)
    try:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: win.engine.samples_total >= 50, timeout=WAIT_MS)
        assert not win.engine.snapshot(0.05).calibrated

        seen: list[str] = []
        answer_next_question(win, "Cancel", seen)
        win.act_record.trigger()
        assert len(seen) == 1
        assert seen[0].startswith("Record without a standing Zero? The angles will be relative "
                                  "to the sensor axes (zero: estimated)")  # fmt: skip
        assert not win.recording and win.recording_part.session_dialog is None

        answer_next_question(win, "Zero first", seen)
        win.act_record.trigger()
        assert len(seen) == 2
        assert win.recording_part.session_dialog is None
        assert win.statusBar().currentMessage().startswith("Zeroing")  # the Zero was started
        qtbot.waitUntil(lambda: "Zero refused" in win.statusBar().currentMessage(),
                        timeout=WAIT_MS)  # fmt: skip

        answer_next_question(win, "Record anyway", seen)
        win.act_record.trigger()
        assert len(seen) == 3
        dlg = win.recording_part.session_dialog
        assert dlg is not None and dlg.isVisible()
        target = tmp_path / "unzeroed.h5"
        dlg.path.setText(str(target))
        dlg.path.textEdited.emit(str(target))
        dlg.accept()
        assert win.recording
        # said where the angles are read: the guide bar stays, in the alert colour, and its
        # Zero step is still to do (not ticked)
        qtbot.waitUntil(lambda: win.guide.isVisible(), timeout=WAIT_MS)
        assert "Recording without a standing Zero" in win.guide.hint_text
        assert "sensor axes" in win.guide.hint_text
        assert win.colours.alert in win.guide.hint_label.styleSheet()
        assert not win.guide.buttons[1].text().startswith("✓")
        assert win.guide.buttons[1].isEnabled()
        win.act_record.trigger()  # stop
        assert not win.recording
    finally:
        close(win)


def test_a_zeroed_recording_is_not_asked_about_and_folds_the_guide(qtbot, tmp_path,
                                                                    no_leaked_threads):
    win = simulated_window(tmp_path, math.inf)
    try:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: win.engine.samples_total >= 200, timeout=WAIT_MS)
        win.act_zero.trigger()
        qtbot.waitUntil(lambda: win.guide.state.zeroed, timeout=WAIT_MS)
        seen: list[str] = []
        answer_next_question(win, "Cancel", seen)
        win.act_record.trigger()
        dlg = win.recording_part.session_dialog
        assert seen == [] and dlg is not None
        dlg.path.setText(str(tmp_path / "zeroed.h5"))
        dlg.accept()
        assert win.recording and not win.guide.isVisible()
        assert win.guide.hint_label.styleSheet() == ""
        win.act_record.trigger()
    finally:
        close(win)


def test_both_legs_are_asked_about_per_leg(qtbot, tmp_path, no_leaked_threads):
    config = BilateralConfig(standing_s=60.0, speed=1.0)  # both stand: a Zero is accepted
    win = MainWindow(settings_in(tmp_path), pair_sim=config, pair=PairSource(sim=config),
                     mode="raw", confirm_close=False, confirm_unzeroed=True)  # fmt: skip
    win.show()
    try:
        qtbot.waitUntil(lambda: win.pair is not None, timeout=WAIT_MS)
        engines = win.pair.engines
        qtbot.waitUntil(lambda: min(e.samples_total for e in engines.values()) >= 200,
                        timeout=WAIT_MS)  # fmt: skip
        seen: list[str] = []
        answer_next_question(win, "Cancel", seen)
        win.act_record.trigger()
        assert seen and seen[-1].startswith("Record without a standing Zero on both legs?")
        assert not win.recording

        engines["L"].zero()  # the left leg zeroed, the right one not
        qtbot.waitUntil(lambda: engines["L"].snapshot(0.05).calibrated, timeout=WAIT_MS)
        answer_next_question(win, "Cancel", seen)
        win.act_record.trigger()
        assert len(seen) == 2
        assert seen[-1].startswith("Record without a standing Zero on the right leg?")
        assert "(zero: estimated)" in seen[-1]
        assert not win.recording and win.recording_part.session_dialog is None
    finally:
        close(win)


def test_a_typed_pty_port_is_connected_and_remembered(qtbot, tmp_path, no_leaked_threads):
    settings = settings_in(tmp_path)
    unit = SimulatedUnit(GaitConfig(seed=3, standing_s=1.0), speed=2.0)
    with PtySimulator(unit) as sim:
        path = str(sim.link_path)
        win = MainWindow(settings, mode="raw", confirm_close=False)
        win.show()
        try:
            combo = win.port_combo
            assert combo.findData(path) < 0  # not listed: it can only be typed
            line = combo.lineEdit()
            assert line is not None, "the Unit field cannot be typed into"

            # a wrong one: one line saying what to type, nothing started
            missing = "/dev/gaitmon-no-such-port"
            for typed, said in ((missing, f"No port '{missing}'"),
                                ("bt://12:34", "is not a Bluetooth address")):  # fmt: skip
                line.clear()
                qtbot.keyClicks(line, typed)
                win.act_connect.trigger()
                message = win.statusBar().currentMessage()
                assert said in message and "\n" not in message
                assert win.conn is None and win.act_connect.text() == "Connect"

            line.clear()
            qtbot.keyClicks(line, path)
            win.act_connect.trigger()
            qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
            assert win.conn.port == path and not win.conn.simulated
            qtbot.waitUntil(lambda: win.engine.samples_total >= 100, timeout=WAIT_MS)
            assert unit.ledger.dropped == []
            win.act_connect.trigger()  # disconnect
            assert win.conn is None
            # remembered: listed now (after a refresh too) and chosen again next time
            win.act_refresh.trigger()
            idx = combo.findData(path)
            assert idx >= 0 and "recent" in combo.itemText(idx)
        finally:
            close(win)
        win2 = MainWindow(settings, mode="raw", confirm_close=False)
        try:
            assert win2.device_part.current_port() == path
        finally:
            close(win2)


def test_the_hint_after_zero_on_the_simulator_says_how_to_make_the_subject_walk(
    qtbot, tmp_path, no_leaked_threads
):
    # the subject stands until told to walk: the Zero is accepted
    win = simulated_window(tmp_path, math.inf, confirm_unzeroed=False)
    try:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: win.engine.samples_total >= 200, timeout=WAIT_MS)
        win.act_zero.trigger()
        qtbot.waitUntil(lambda: win.guide.state.zeroed, timeout=WAIT_MS)
        # the menu path as the menu bar names it
        sim_item = win.sim_menu.menuAction()
        device = next(a.menu() for a in win.menuBar().actions()
                      if a.menu() is not None and sim_item in a.menu().actions())  # fmt: skip
        walk = next(a for a in win.sim_menu.actions() if a.text().replace("&", "") == "Walk again")
        names = [m.replace("&", "") for m in (device.title(), win.sim_menu.title(), walk.text())]
        assert " ▸ ".join(names) in win.guide.hint_text
        assert win.guide.hint_text.startswith("Zeroed")
        walk.trigger()  # and the menu item does what the hint says
        unit = win.conn.unit
        qtbot.waitUntil(lambda: not unit.standing, timeout=WAIT_MS)
    finally:
        close(win)


def test_port_problem_in_one_line():
    from gaitmon.ui.live.device import port_problem

    assert port_problem(SIMULATED_PORT) == ""
    assert port_problem("bt://AA:BB:CC:DD:EE:FF/3") == ""
    assert "RFCOMM channel" in port_problem("bt://AA:BB:CC:DD:EE:FF/99")
    assert re.match(r"No port '/nonexistent/x'", port_problem("/nonexistent/x"))
    assert port_problem("/dev/null") == ""  # exists: tried (the connect says what it is)


def test_escape_records_nothing(qtbot, tmp_path, no_leaked_threads):
    """Escape (the box's Cancel) is the way out: nothing is recorded."""
    win = simulated_window(tmp_path, 0.0)
    try:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: win.engine.samples_total >= 20, timeout=WAIT_MS)

        def reject():
            box = win.recording_part.unzeroed_box
            if box is not None:
                assert box.escapeButton() is box.button(QMessageBox.StandardButton.Cancel)
                box.reject()

        QTimer.singleShot(0, reject)
        win.act_record.trigger()
        assert not win.recording and win.recording_part.session_dialog is None
    finally:
        close(win)


def test_the_guide_warns_while_recording_unzeroed_until_a_zero(qtbot):
    """The bar's transitions: closed by the user, it opens again for an unzeroed recording;
    a Zero while recording folds it; a zeroed recording folds it as before."""
    from PySide6.QtGui import QAction

    from gaitmon.ui.live.guide import GuideBar, GuideState
    from gaitmon.ui.theme import current_colours

    actions = (QAction("Connect"), QAction("Zero"), QAction("Record"))
    bar = GuideBar(current_colours(), actions)
    qtbot.addWidget(bar)
    bar.show()
    bar.show_state(GuideState(connected=True, simulated=True))
    bar.dismiss()  # the user closed it
    bar.show_state(GuideState(connected=True, recording=True, zero_source="estimated"))
    assert bar.isVisible() and bar.hint_text.startswith("Recording without a standing Zero")
    assert "Angles' zero" not in bar.hint_text  # said once, not twice
    assert bar.colours.alert in bar.hint_label.styleSheet()
    bar.show_state(GuideState(connected=True, recording=True, zeroed=True))
    assert not bar.isVisible() and bar.hint_label.styleSheet() == ""
    bar.show_state(GuideState(connected=True, zeroed=True))  # stopped
    bar.reopen()
    bar.show_state(GuideState(connected=True, zeroed=True, recording=True))
    assert not bar.isVisible()


def test_a_recording_that_cannot_start_says_so_where_it_stays(qtbot, tmp_path, no_leaked_threads):
    """Issue 25, words: a Record that cannot create its file (here its folder is a file) was
    said only in the status bar, gone after 30 s; it stays in the record banner, with the
    cause, until a recording starts."""
    win = simulated_window(tmp_path, math.inf, confirm_unzeroed=False)
    try:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: win.engine.samples_total >= 50, timeout=WAIT_MS)
        (tmp_path / "not_a_folder").write_text("")
        bad = tmp_path / "not_a_folder" / "walk.h5"
        assert not win.recording_part.start_recording(bad, patient_id="P1")
        assert not win.recording
        banner = win.status.record_banner
        assert banner.isVisibleTo(win)
        assert banner.text().startswith("Not recording: cannot create walk.h5")
        assert "Not a directory" in banner.text()
        win.statusBar().clearMessage()  # the status bar's line goes; the banner stays
        assert banner.isVisibleTo(win) and "walk.h5" in banner.text()
        good = tmp_path / "walk.h5"
        assert win.recording_part.start_recording(good, patient_id="P1")
        assert not banner.isVisibleTo(win)  # a recording that starts takes it away
        win.act_record.trigger()  # stop
        qtbot.waitUntil(lambda: not win.ctx.saving, timeout=WAIT_MS)
    finally:
        close(win)
