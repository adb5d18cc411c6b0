"""Issue 13 in the live window: which tilt filter makes the angles (shown, chosen from a menu,
applied live, remembered), and a force sensor dying while the subject walks (a persistent
banner within 5 strides, the gait panel counting on from the foot gyro, cleared on a new
connection). The simulated unit runs on a pseudo-terminal behind the real serial transport;
strides are counted from the simulator's truth, never from what the window computes."""


import numpy as np
import pytest
from PySide6.QtCore import QSettings

from gaitmon.dsp.calibration import ZERO_ESTIMATED, ZERO_UNIT
from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.ui.live import MainWindow

WAIT_MS = 30_000
PAPER = "Kalman (paper, seed 000)"
GAIT_AWARE = "gait-aware Kalman"


@pytest.fixture
def ini(tmp_path):
    return tmp_path / "settings" / "gaitmon.ini"


def open_window(qtbot, ini, sim=None, autoconnect=True, mode="raw"):
    settings = QSettings(str(ini), QSettings.Format.IniFormat)
    win = MainWindow(settings, sim=sim or SimConfig(standing_s=1.0),
                     autoconnect=SIMULATED_PORT if autoconnect else None, mode=mode,
                     confirm_close=False)  # fmt: skip
    win.show()
    if autoconnect:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
    return win


def close_window(win):
    win.close()
    assert win.conn is None
    assert win.errors == []


def menu_actions(win, *path):
    """The actions of a menu reached by its titles, as a user opens it."""
    menus = [a.menu() for a in win.menuBar().actions()]
    for title in path:
        menu = next(m for m in menus if m is not None and m.title().replace("&", "") == title)
        menus = [a.menu() for a in menu.actions()]
    return [a for a in menu.actions() if not a.isSeparator()]


def test_the_tilt_filter_is_shown_chosen_from_the_menu_applied_live_and_remembered(
    qtbot, ini, no_leaked_threads
):
    win = open_window(qtbot, ini)
    try:
        # shown where the angles are and in the status bar
        shown = f"angles: {GAIT_AWARE} · zero: {ZERO_ESTIMATED}"
        qtbot.waitUntil(lambda: win.status.method_label.full_text == shown, timeout=WAIT_MS)
        assert win.live.title_text(0) == f"Segment tilt · {GAIT_AWARE}"
        assert win.live.title_text(1) == f"Joint angles and foot contact · {GAIT_AWARE}"
        items = menu_actions(win, "Device", "Tilt filter")
        assert [a.text() for a in items] == ["Gait-aware Kalman (default)", PAPER]
        assert [a.isChecked() for a in items] == [True, False]
        # the user picks the paper's filter: the engine runs it, the window names it
        items[1].trigger()
        qtbot.waitUntil(lambda: win.engine.config.tilt_method == "paper", timeout=WAIT_MS)
        qtbot.waitUntil(lambda: win.live.title_text(1).endswith(f"· {PAPER}"),
                        timeout=WAIT_MS)  # fmt: skip
        assert win.live.title_text(0).endswith(f"· {PAPER}")
        assert win.status.method_label.full_text == f"angles: {PAPER} · zero: {ZERO_ESTIMATED}"
        assert [a.isChecked() for a in items] == [False, True]  # exclusive
        # the Settings dialog keeps the filter the menu chose
        win.act_settings.trigger()
        win.processing_part.settings_dialog.edits["cutoff_hz"].setText("3")
        win.processing_part.settings_dialog.accept()
        qtbot.waitUntil(lambda: win.engine.config.cutoff_hz == 3.0, timeout=WAIT_MS)
        assert win.engine.config.tilt_method == "paper"
    finally:
        close_window(win)
    assert QSettings(str(ini), QSettings.Format.IniFormat).value("pipeline/tilt_method") == "paper"
    # the next start remembers it, before and after connecting
    win = open_window(qtbot, ini, autoconnect=False)
    try:
        assert win.tilt_actions["paper"].isChecked()
        assert not win.tilt_actions["gait-aware"].isChecked()
        assert win.live.title_text(0).endswith(f"· {PAPER}")
        win.device_part.connect_device(SIMULATED_PORT)
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
        assert win.engine.config.tilt_method == "paper"
        assert win.engine.config.cutoff_hz == 3.0
    finally:
        close_window(win)


def test_in_the_units_joint_mode_the_window_names_the_units_own_filter(
    qtbot, ini, no_leaked_threads
):
    win = open_window(qtbot, ini, mode="joint")
    try:
        own = "the unit's own Kalman"
        shown = f"angles: {own} · zero: {ZERO_UNIT}"
        qtbot.waitUntil(lambda: win.status.method_label.full_text == shown, timeout=WAIT_MS)
        assert win.live.title_text(1) == f"Joint angles and foot contact · {own}"
        qtbot.waitUntil(lambda: win.gait_panel.events_label.text() != "", timeout=WAIT_MS)
        assert win.gait_panel.events_label.text() == "Gait events: the unit's foot contacts"
        # choosing the PC's filter is saved for "PC computes" and says so; the unit's stays
        win.tilt_actions["paper"].trigger()
        assert "takes effect when gaitmon computes" in win.statusBar().currentMessage()
        qtbot.wait(200)
        assert win.status.method_label.full_text == f"angles: {own} · zero: {ZERO_UNIT}"
    finally:
        close_window(win)


def true_strides(unit, a, b):
    """True heel strikes (one per stride) at the unit's sample indices (a, b]."""
    hs = unit.truth(0, b + 1).heel_strike_idx
    return int(np.sum((hs > a) & (hs <= b)))


def test_a_dying_heel_sensor_is_on_screen_within_5_strides_and_strides_go_on(
    qtbot, ini, no_leaked_threads
):
    win = open_window(qtbot, ini, SimConfig(standing_s=1.0, speed=2.0))
    try:
        unit = win.conn.unit
        qtbot.waitUntil(lambda: unit.samples_produced >= 900, timeout=WAIT_MS)  # 8 s walking
        qtbot.waitUntil(lambda: win.gait_panel.values["strides"].text() not in ("—", "0"),
                        timeout=WAIT_MS)  # fmt: skip
        assert win.gait_panel.events_label.text() == "Gait events: force sensors"
        assert not win.status.fsr_banner.isVisible()
        heel_dead = next(a for a in menu_actions(win, "Device", "Simulator")
                         if a.text() == "Heel sensor dead")  # fmt: skip
        before = unit.samples_produced  # the sensor dies at this sample or just after
        heel_dead.trigger()
        assert unit.foot_sensor_fault == (True, False)
        banner = win.status.fsr_banner
        qtbot.waitUntil(banner.isVisible, timeout=WAIT_MS)
        shown = unit.samples_produced  # the window showed it by this sample at the latest
        assert true_strides(unit, before, shown) <= 5
        assert "Heel force sensor never loads: gait events from the foot gyro" in banner.text()
        # the gait panel says so and goes on counting strides, from the gyro
        qtbot.waitUntil(lambda: "Gait events: foot gyro" in win.gait_panel.events_label.text(),
                        timeout=WAIT_MS)  # fmt: skip
        n0 = int(win.gait_panel.values["strides"].text())
        at = unit.samples_produced
        qtbot.waitUntil(lambda: true_strides(unit, at, unit.samples_produced) >= 5,
                        timeout=WAIT_MS)  # fmt: skip
        qtbot.waitUntil(lambda: int(win.gait_panel.values["strides"].text()) >= n0 + 3,
                        timeout=WAIT_MS)  # fmt: skip
        # still on screen: the banner stays for the connection
        assert banner.isVisible()
        # a new connection starts with working sensors and no banner
        win.disconnect_device()
        assert not banner.isVisible()
        win.device_part.connect_device(SIMULATED_PORT)
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: win.engine.samples_total >= 100, timeout=WAIT_MS)
        qtbot.wait(200)
        assert not banner.isVisible() and not heel_dead.isChecked()
        assert win.conn.unit.foot_sensor_fault == (False, False)
    finally:
        close_window(win)
