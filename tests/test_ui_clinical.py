"""Issue 15 §2 in the live window: the clinical view by default (the filter's joint angles,
large, with a compact foot-contact strip), the engineering view one remembered toggle away, and
the guided start (Connect → stand still, Zero → Record) driven by the real state, against the
simulated unit behind its pseudo-terminal."""

from __future__ import annotations

import pytest
from PySide6.QtCore import QSettings, Qt
from PySide6.QtWidgets import QToolBar, QToolButton

from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.ui.live import MainWindow
from gaitmon.ui.live.guide import CURRENT, DONE, WAITING

pytestmark = pytest.mark.timeout(120)
WAIT_MS = 15_000
TILTS = ("body", "thigh", "shank", "foot")
CLINICAL = ["hip", "knee", "ankle", "fsr"]
ENGINEERING_TRACES = (
    ("joint_acc_deg", 1, "acc"),
    ("joint_gyro_deg", 1, "gyro"),
    ("tilt_kalman_deg", 0, "kalman"),
    ("tilt_acc_deg", 2, "acc"),
)


def settings_at(tmp_path) -> QSettings:
    return QSettings(str(tmp_path / "gaitmon.ini"), QSettings.Format.IniFormat)


def open_window(qtbot, settings, sim: SimConfig, autoconnect: bool = True) -> MainWindow:
    win = MainWindow(
        settings, sim=sim, autoconnect=SIMULATED_PORT if autoconnect else None, mode="raw",
        confirm_close=False,
    )  # fmt: skip
    win.resize(1400, 860)
    win.show()
    if autoconnect:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
    return win


def points(win, series, col, method=""):
    return win.live.curve_points(series, col, method)


def toolbar_button(win, action) -> QToolButton:
    for tb in win.findChildren(QToolBar):
        b = tb.widgetForAction(action)
        if isinstance(b, QToolButton):
            return b
    raise AssertionError(f"{action.text()} is on no toolbar")


def test_default_is_the_clinical_view_and_the_engineering_toggle_is_remembered(qtbot, tmp_path):
    settings = settings_at(tmp_path)
    win = open_window(qtbot, settings, SimConfig(standing_s=0.5))
    try:
        green = ("joint_kalman_deg", 1, "kalman")
        qtbot.waitUntil(lambda: points(win, *green) >= 200, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: win.live.band_paths() != [], timeout=WAIT_MS)
        live = win.live
        assert not win.act_engineering.isChecked() and not live.engineering
        assert live.shown_plots() == CLINICAL
        # the chosen filter's joint angles only: no accelerometer, gyro or tilt traces drawn
        for trace in ENGINEERING_TRACES:
            assert points(win, *trace) == 0, trace
        assert not win.raw_dock.isVisible()
        assert not any(box.isVisible() for box in win.method_boxes.values())
        # the foot contacts stay visible, compact: sensors and phase shading in a short strip
        assert points(win, "fsr_counts", 0) > 100 and live.band_paths()
        knee, fsr = live.plots["knee"].plot, live.plots["fsr"].plot
        assert fsr.geometry().height() < 0.8 * knee.geometry().height()
        # large: the joint plots take the plot area's whole width (the tilt column is gone)
        assert knee.geometry().width() > 0.8 * live.width()

        # the toolbar's toggle (the same action as View ▸ Engineering view)
        qtbot.mouseClick(toolbar_button(win, win.act_engineering), Qt.MouseButton.LeftButton)
        assert win.act_engineering.isChecked() and live.engineering
        assert live.shown_plots() == [*TILTS, *CLINICAL]
        for trace in ENGINEERING_TRACES:
            qtbot.waitUntil(lambda t=trace: points(win, *t) > 100)
        assert win.raw_dock.isVisible()
        assert all(box.isVisible() for box in win.method_boxes.values())
        assert knee.geometry().width() < 0.6 * live.width()  # two columns now
    finally:
        win.close()
    assert win.errors == []
    assert settings_at(tmp_path).value("view/engineering") in (True, "true")

    win2 = open_window(qtbot, settings_at(tmp_path), SimConfig(), autoconnect=False)
    try:
        assert win2.act_engineering.isChecked() and win2.live.shown_plots() == [*TILTS, *CLINICAL]
        win2.act_engineering.trigger()  # View ▸ Engineering view off: clinical again
        assert win2.live.shown_plots() == CLINICAL and not win2.raw_dock.isVisible()
        # the methods chosen for the engineering view are kept for when it comes back
        assert all(win2.live.methods_on.values())
    finally:
        win2.close()
    assert win2.errors == []


def test_guided_start_follows_the_real_state_and_its_buttons_do_the_steps(qtbot, tmp_path):
    # the subject walks from the start: zeroing works only after Simulator ▸ Stand still
    win = open_window(qtbot, settings_at(tmp_path), SimConfig(standing_s=0.0, speed=2.0),
                      autoconnect=False)  # fmt: skip
    guide = win.guide
    connect, zero, record = guide.buttons
    try:
        assert guide.isVisible()
        assert guide.states == [CURRENT, WAITING, WAITING]
        assert connect.isEnabled() and not zero.isEnabled() and not record.isEnabled()
        assert "press Connect" in guide.hint_text
        win.port_combo.setCurrentIndex(win.port_combo.findData(SIMULATED_PORT))
        qtbot.mouseClick(connect, Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: guide.states == [DONE, CURRENT, WAITING], timeout=WAIT_MS)
        assert "stand upright and still" in guide.hint_text and "then press Zero" in guide.hint_text
        assert zero.isEnabled() and not connect.isEnabled() and not record.isEnabled()

        # Zero while the subject walks: refused by the engine, and the guide stays at Zero
        qtbot.waitUntil(lambda: win.engine.samples_total >= 200, timeout=WAIT_MS)
        qtbot.mouseClick(zero, Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: "Zero refused" in win.statusBar().currentMessage(), timeout=WAIT_MS)
        qtbot.wait(200)  # a few display ticks
        assert guide.states == [DONE, CURRENT, WAITING]

        win.device_part.set_simulated_standing(True)
        at = win.engine.samples_total
        qtbot.waitUntil(lambda: win.engine.samples_total >= at + 500, timeout=WAIT_MS)
        qtbot.waitUntil(zero.isEnabled, timeout=WAIT_MS)
        qtbot.mouseClick(zero, Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: "zeroed" in win.statusBar().currentMessage(), timeout=WAIT_MS)
        qtbot.waitUntil(lambda: guide.states == [DONE, DONE, CURRENT], timeout=WAIT_MS)
        assert win.last_snapshot is not None and win.last_snapshot.calibrated
        assert "press Record" in guide.hint_text and record.isEnabled()

        qtbot.mouseClick(record, Qt.MouseButton.LeftButton)  # the session dialog, as Ctrl+R
        dlg = win.recording_part.session_dialog
        assert dlg is not None and dlg.isVisible()
        dlg.patient.setText("P015")
        target = tmp_path / "guided.h5"
        dlg.path.setText(str(target))
        dlg.path.textEdited.emit(str(target))
        qtbot.mouseClick(dlg.buttons.buttons()[0], Qt.MouseButton.LeftButton)
        assert win.recording
        assert not guide.isVisible()  # collapsed: the plots get the room
        win.act_guide.trigger()  # Help ▸ Guided start brings it back, every step done
        assert guide.isVisible() and guide.states == [DONE, DONE, DONE]
        assert "Recording" in guide.hint_text
        win.recording_part.stop_recording()
        assert target.exists()
        win.disconnect_device()
        assert guide.states == [CURRENT, WAITING, WAITING]  # not connected: not zeroed either
    finally:
        win.close()
    assert win.errors == []


def test_a_theme_change_keeps_the_view_and_restyles_the_guide(qtbot, tmp_path):
    from PySide6.QtGui import QColor, QPalette
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance()
    old = app.palette()
    win = open_window(qtbot, settings_at(tmp_path), SimConfig(), autoconnect=False)
    try:
        assert win.live.shown_plots() == CLINICAL
        was_dark = win.colours.dark
        pal = QPalette(old)
        shade = QColor("#f0f0f0") if was_dark else QColor("#202020")
        pal.setColor(QPalette.ColorRole.Window, shade)
        pal.setColor(QPalette.ColorRole.Base, shade)
        app.setPalette(pal)
        qtbot.waitUntil(lambda: win.colours.dark != was_dark, timeout=WAIT_MS)
        # the plots were rebuilt in the new shades: still the clinical view, the guide restyled
        assert win.live.shown_plots() == CLINICAL and not win.live.engineering
        assert win.colours.ok in win.guide.buttons[0].styleSheet()
    finally:
        app.setPalette(old)
        win.close()
    assert win.errors == []
