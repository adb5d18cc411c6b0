"""The live monitor window driven like a user would, against the simulated unit.

The simulated unit runs in this process behind a pseudo-terminal and is reached through the
real SerialTransport, exactly as the "Simulated device" entry does for a clinician. Every test
gets its own QSettings file, fails if the window caught an unexpected exception, and fails if
a gaitmon thread outlives it.
"""

import threading

import h5py
import numpy as np
import pytest
from PySide6.QtCore import Qt

from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.ui.live import MainWindow

WAIT_MS = 15_000


def make_window(qtbot, settings, *, standing_s=1.0, mode="raw", autoconnect=True):
    sim = SimConfig(standing_s=standing_s)
    # these tests look at every trace: the engineering view, as if chosen in an earlier run
    # (the default clinical view is tests/test_ui_clinical.py's)
    settings.setValue("view/engineering", True)
    win = MainWindow(
        settings,
        sim=sim,
        autoconnect=SIMULATED_PORT if autoconnect else None,
        mode=mode,
        confirm_close=False,
    )
    win.show()
    if autoconnect:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
    return win


@pytest.fixture
def window(qtbot, ui_settings, no_leaked_threads, request):
    opts = getattr(request, "param", {})
    win = make_window(qtbot, ui_settings, **opts)
    yield win
    win.close()
    assert win.conn is None
    assert win.errors == []


def samples(win):
    return win.engine.samples_total


# ------------------------------------------------------------------------------------------


def test_connect_shows_live_curves_and_a_clean_link(qtbot, window):
    win = window
    assert win.status.state_text == "Connected"
    assert not win.port_combo.isEnabled()  # the port cannot change under a live connection
    qtbot.waitUntil(lambda: samples(win) >= 300, timeout=WAIT_MS)
    qtbot.waitUntil(lambda: win.live.curve_points("joint_kalman_deg", 1, "kalman") >= 290)
    # the window shows every sample received so far (less than one window): compare with the
    # engine's count, allowing for the samples that arrived since the last 30 Hz frame
    n_curve = win.live.curve_points("joint_kalman_deg", 1, "kalman")
    assert 0 <= samples(win) - n_curve <= 25
    for series, col, method in (
        ("tilt_acc_deg", 0, "acc"),
        ("tilt_gyro_deg", 3, "gyro"),
        ("joint_acc_deg", 2, "acc"),
        ("fsr_counts", 0, ""),
        ("fsr_counts", 1, ""),
    ):
        assert win.live.curve_points(series, col, method) >= 250, series
    # health: the simulator dropped nothing (its ledger is the reference) and the bar says so
    assert win.conn.unit.ledger.dropped == [] and win.conn.unit.ledger.corrupted == []
    qtbot.waitUntil(lambda: "fps" in win.status.health_label.full_text)
    assert "0 lost · 0 CRC" in win.status.health_label.full_text  # (the window may show less)
    assert win.status.health_label.property("grade") == "ok"
    assert not win.status.link_banner.isVisible()
    assert int(win.status.samples_label.property("samples")) > 0


def test_record_two_seconds_with_a_marker(qtbot, window, tmp_path):
    win = window
    qtbot.waitUntil(lambda: samples(win) >= 50, timeout=WAIT_MS)
    win.act_record.trigger()
    dlg = win.recording_part.session_dialog
    assert dlg is not None and dlg.isVisible()
    assert dlg.path.text().endswith(".h5")  # a sensible default is offered
    dlg.patient.setText("P001")
    dlg.side.setCurrentIndex(dlg.side.findData("R"))
    dlg.operator.setText("op-a")
    dlg.notes.setPlainText("10 m walk")
    target = tmp_path / "walk.h5"
    dlg.path.setText(str(target))
    dlg.path.textEdited.emit(str(target))
    qtbot.mouseClick(dlg.buttons.buttons()[0], Qt.MouseButton.LeftButton)
    assert win.recording
    assert win.act_record.text() == "Stop"
    start = samples(win)
    qtbot.waitUntil(lambda: samples(win) >= start + 100, timeout=WAIT_MS)
    win.marker_edit.setText("turn")
    win.act_marker.trigger()
    assert win.marker_edit.text() == ""  # the label is used once
    qtbot.waitUntil(lambda: samples(win) >= start + 200, timeout=WAIT_MS)
    rec_label = win.status.rec_label
    qtbot.waitUntil(lambda: "REC" in rec_label.full_text and "walk.h5" in rec_label.full_text)
    win.act_record.trigger()  # stop
    assert not win.recording
    # the file is finished on the device worker, the window drawing on meanwhile
    qtbot.waitUntil(lambda: not win.saving, timeout=WAIT_MS)
    # (read once the Stop was carried out: the engine thread takes it with the next block, so
    # a loaded machine records a few rows past the moment of the click)
    stopped = samples(win)
    saved = win.statusBar().currentMessage()
    assert "Recording saved" in saved

    with h5py.File(target, "r") as f:
        assert bool(f.attrs["complete"])
        # the file's duration as info, review and the report print it (issue 25: not the
        # wall clock's "00:02"), to a tenth of a second
        assert f", {float(f.attrs['duration_s']):.1f} s)" in saved, saved
        t = f["timeline/t_s"][:]
        rows = len(t)
        # 2 s at 100 Hz: the file holds what arrived between Record and Stop
        assert 195 <= rows <= stopped - start + 5
        assert t[-1] - t[0] == pytest.approx((rows - 1) / 100.0, abs=0.02)
        labels = [x.decode() if isinstance(x, bytes) else x for x in f["markers"]["label"][:]]
        assert labels == ["turn"]
        marker_row = int(f["markers"]["sample_idx"][0])
        assert 90 <= marker_row <= rows - 50  # dropped ~1 s into the recording
        assert f["session"].attrs["patient_id"] == "P001"
        assert f["session"].attrs["side"] == "R"
        assert f["session"].attrs["operator"] == "op-a"
    # the form remembers the operator and the folder, not the notes
    win.act_record.trigger()
    dlg2 = win.recording_part.session_dialog
    assert dlg2.operator.text() == "op-a" and dlg2.notes.toPlainText() == ""
    assert dlg2.path.text().startswith(str(tmp_path))
    dlg2.reject()


def test_cut_link_shows_reconnecting_then_recovers(qtbot, window):
    win = window
    qtbot.waitUntil(lambda: samples(win) >= 100, timeout=WAIT_MS)
    assert win.act_cut.isEnabled()
    win.device_part.cut_simulated_link(1.0)
    qtbot.waitUntil(lambda: win.status.state_text.startswith("Reconnecting"), timeout=WAIT_MS)
    assert win.status.link_banner.isVisible()
    assert "Connection to the unit lost — reconnecting" in win.status.link_banner.text()
    at_cut = samples(win)
    qtbot.waitUntil(lambda: win.status.state_text == "Connected", timeout=WAIT_MS)
    qtbot.waitUntil(lambda: samples(win) >= at_cut + 100, timeout=WAIT_MS)
    assert not win.status.link_banner.isVisible()
    assert win.engine.device.stats.reconnects >= 1
    # frames lost in the outage are shown, and graded as lossy (not quiet)
    qtbot.waitUntil(lambda: win.status.health_label.property("grade") == "lossy", timeout=WAIT_MS)
    lost = win.engine.device.stats.decoder.frames_lost
    link_down = [e for e in win.conn.unit.ledger.dropped if e.fault == "link_down"]
    assert lost >= len(link_down) > 50  # ~1 s of frames at 100 Hz went nowhere
    health = win.status.health_label.full_text
    assert f"{lost} lost" in health or "% lost" in health


def test_pause_freezes_the_curves_while_samples_keep_counting(qtbot, window):
    win = window
    qtbot.waitUntil(lambda: win.live.curve_points("joint_kalman_deg", 1, "kalman") > 50)
    win.act_pause.trigger()
    assert win.view_part.paused and win.pause_label.isVisible()
    frozen_path = win.live.curve_path("joint_kalman_deg", 1, "kalman")
    frozen_points = win.live.curve_points("joint_kalman_deg", 1, "kalman")
    shown_before = int(win.status.samples_label.property("samples"))
    qtbot.wait(700)
    shown_after = int(win.status.samples_label.property("samples"))
    assert shown_after >= shown_before + 40  # ~70 samples in 0.7 s still counted on screen
    assert win.live.curve_path("joint_kalman_deg", 1, "kalman") is frozen_path
    assert win.live.curve_points("joint_kalman_deg", 1, "kalman") == frozen_points
    win.act_pause.trigger()
    assert not win.view_part.paused
    qtbot.waitUntil(lambda: win.live.curve_path("joint_kalman_deg", 1, "kalman") is not frozen_path)


def test_settings_reject_a_bad_cutoff_then_apply_and_persist(qtbot, window, ui_settings):
    win = window
    win.act_settings.trigger()
    dlg = win.processing_part.settings_dialog
    assert dlg.isVisible()
    dlg.edits["cutoff_hz"].setText("70")
    qtbot.mouseClick(dlg.buttons.buttons()[0], Qt.MouseButton.LeftButton)
    assert dlg.isVisible()  # refused, the dialog stays open with the reason
    assert dlg.error.isVisible() and "Nyquist" in dlg.error.text() and "70" in dlg.error.text()
    assert win.engine.config.cutoff_hz == 4.0
    dlg.edits["cutoff_hz"].setText("3")
    dlg.edits["fsr_threshold"].setText("900")
    qtbot.mouseClick(dlg.buttons.buttons()[0], Qt.MouseButton.LeftButton)
    assert not dlg.isVisible()
    qtbot.waitUntil(lambda: win.engine.config.cutoff_hz == 3.0, timeout=WAIT_MS)
    assert win.engine.config.fsr_threshold == 900.0
    assert win.live.fsr_threshold == 900.0
    y = win.live.threshold.path.elementAt(0).y  # the dashed line is drawn at it
    assert y == 900.0 and win.live.threshold.path.elementAt(1).y == 900.0
    ui_settings.sync()
    assert float(ui_settings.value("pipeline/cutoff_hz")) == 3.0


def test_zero_is_refused_while_walking_with_the_engines_reason(
    qtbot, ui_settings, no_leaked_threads
):
    win = make_window(qtbot, ui_settings, standing_s=4.0)
    try:
        # standing: 1.5 s of still data -> accepted
        qtbot.waitUntil(lambda: samples(win) >= 170, timeout=WAIT_MS)
        assert samples(win) < 380, "the machine was too slow to zero while standing"
        win.act_zero.trigger()
        qtbot.waitUntil(lambda: "zeroed" in win.statusBar().currentMessage(), timeout=WAIT_MS)
        qtbot.waitUntil(lambda: "zero: standing calibration" in win.status.method_label.full_text,
                        timeout=WAIT_MS)  # fmt: skip
        # walking: refused, and the window says why
        qtbot.waitUntil(lambda: samples(win) >= 650, timeout=WAIT_MS)
        win.act_zero.trigger()
        qtbot.waitUntil(lambda: "Zero refused" in win.statusBar().currentMessage(), timeout=WAIT_MS)
        assert "moving" in win.statusBar().currentMessage()
        # in a clinician's words, the figures in the tooltip
        assert "Ask the patient to stand still: the " in win.statusBar().currentMessage()
        assert "rad/s" not in win.statusBar().currentMessage()
        assert "rad/s RMS exceeds" in win.statusBar().toolTip()
        assert win.act_zero.isEnabled()
    finally:
        win.close()
    assert win.errors == []


@pytest.mark.parametrize("window", [{"mode": "joint"}], indirect=True)
def test_joint_mode_shows_the_units_angles_and_hides_what_it_does_not_send(qtbot, window):
    win = window
    qtbot.waitUntil(lambda: win.live.curve_points("joint_kalman_deg", 1, "kalman") > 100)
    assert win.live.curve_points("joint_acc_deg", 1, "acc") > 100
    # the unit sends no gyro integration and no tilts in this mode: nothing drawn, no junk
    assert win.live.curve_points("joint_gyro_deg", 1, "gyro") == 0
    assert win.live.curve_points("tilt_kalman_deg", 1, "kalman") == 0
    assert "zero: the unit's own Zero" in win.status.method_label.full_text
    assert not win.mode_combo.isEnabled()


def test_view_options_and_layout_are_remembered(qtbot, ui_settings, no_leaked_threads):
    win = make_window(qtbot, ui_settings, autoconnect=False)
    assert win.view_part.window_s == 10.0  # the default
    win.window_actions[30.0].trigger()
    win.method_boxes["gyro"].setChecked(False)  # the legend's checkbox toggles the traces
    assert not win.live.methods_on["gyro"] and not win.method_actions["gyro"].isChecked()
    win.raw_dock.show()
    win.gait_dock.hide()
    win.close()
    win2 = make_window(qtbot, ui_settings, autoconnect=False)
    try:
        assert win2.view_part.window_s == 30.0 and win2.window_combo.currentData() == 30.0
        assert not win2.method_boxes["gyro"].isChecked() and not win2.live.methods_on["gyro"]
        # layout: docks as they were left (the defaults are the opposite), geometry restored
        # (exact pixels cannot be compared: the offscreen screen is 800 x 800 and clamps)
        assert win2.raw_dock.isVisible() and not win2.gait_dock.isVisible()
        assert win2.geometry_restored and win2.state_restored
        # the pyqtgraph background follows the application palette (light/dark theme)
        from PySide6.QtGui import QGuiApplication, QPalette

        base = QGuiApplication.palette().color(QPalette.ColorRole.Base)
        assert win2.live.backgroundBrush().color().lightness() // 64 == base.lightness() // 64
    finally:
        win2.close()


def test_connect_failure_is_one_line_and_leaves_the_window_usable(qtbot, ui_settings, tmp_path):
    win = make_window(qtbot, ui_settings, autoconnect=False)
    try:
        missing = str(tmp_path / "no-such-port")
        win.port_combo.addItem("missing", missing)
        win.port_combo.setCurrentIndex(win.port_combo.findData(missing))
        win.act_connect.trigger()
        qtbot.waitUntil(
            lambda: "Could not connect" in win.statusBar().currentMessage(), timeout=WAIT_MS
        )
        msg = win.statusBar().currentMessage()
        assert "no such port" in msg and "\n" not in msg
        assert win.conn is None and win.act_connect.isEnabled() and win.port_combo.isEnabled()
        assert win.status.state_text == "Disconnected"
    finally:
        win.close()
    assert win.errors == []


def test_markers_and_events_are_drawn_in_the_window(qtbot, window):
    win = window
    # the first stride since connecting is start-up and not in the cadence (as in a recording)
    qtbot.waitUntil(lambda: win.engine.snapshot(10).gait.n_strides >= 2, timeout=WAIT_MS)
    win.act_marker.trigger()
    qtbot.waitUntil(lambda: win.live.plots["knee"].markers.n_points == 2)
    info = win.live.plots["fsr"]
    qtbot.waitUntil(lambda: info.events_hs.n_points >= 2)
    # every heel strike in the window is one vertical line (two points)
    snap = win.last_snapshot
    assert info.events_hs.n_points == 2 * len(snap.heel_strike_t_s)
    assert win.live.marker_labels()[:2] == ["marker", "marker"]  # one per column
    assert np.isfinite(win.engine.snapshot(1).gait.cadence_derived_steps_per_min)


def _start_recording(qtbot, win, path):
    win.act_record.trigger()
    dlg = win.recording_part.session_dialog
    dlg.path.setText(str(path))
    dlg.path.textEdited.emit(str(path))
    qtbot.mouseClick(dlg.buttons.buttons()[0], Qt.MouseButton.LeftButton)
    assert win.recording


def test_disk_full_stops_the_recording_with_one_line_and_acquisition_goes_on(
    qtbot, window, tmp_path, monkeypatch
):
    import errno

    from gaitmon.io.session import SessionWriter

    win = window
    qtbot.waitUntil(lambda: samples(win) >= 50, timeout=WAIT_MS)
    _start_recording(qtbot, win, tmp_path / "full.h5")
    start = samples(win)
    qtbot.waitUntil(lambda: samples(win) >= start + 50, timeout=WAIT_MS)

    def no_space(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(SessionWriter, "append", no_space)  # the disk fills up now
    qtbot.waitUntil(lambda: win.status.record_banner.isVisible(), timeout=WAIT_MS)
    text = win.status.record_banner.text()
    assert "Recording stopped" in text and "No space left on device" in text
    assert "Acquisition continues" in text and "\n" not in text
    assert not win.recording and win.act_record.text() == "Record"
    after = samples(win)
    qtbot.waitUntil(lambda: samples(win) >= after + 50, timeout=WAIT_MS)  # still acquiring
    qtbot.waitUntil(lambda: win.live.curve_points("joint_kalman_deg", 1, "kalman") > 100)


def test_keyboard_shortcuts_drive_pause_markers_and_window(qtbot, window):
    win = window
    win.activateWindow()
    qtbot.waitUntil(lambda: win.isActiveWindow())
    qtbot.waitUntil(lambda: samples(win) >= 50, timeout=WAIT_MS)
    win.live.setFocus()
    qtbot.keyClick(win.live, Qt.Key.Key_Space)
    assert win.view_part.paused
    qtbot.keyClick(win.live, Qt.Key.Key_Space)
    assert not win.view_part.paused
    qtbot.keyClick(win.live, Qt.Key.Key_1)
    assert win.view_part.window_s == 5.0
    n_markers = len(win.engine.snapshot(60).markers)
    qtbot.keyClick(win.live, Qt.Key.Key_M)
    assert len(win.engine.snapshot(60).markers) == n_markers + 1
    # typing an "m" into the marker label must not drop a marker
    win.marker_edit.setFocus()
    qtbot.keyClicks(win.marker_edit, "mm")
    assert win.marker_edit.text() == "mm"
    assert len(win.engine.snapshot(60).markers) == n_markers + 1
    qtbot.keyClick(win.marker_edit, Qt.Key.Key_Return)  # Enter drops it with the label
    assert win.engine.snapshot(60).markers[-1][1] == "mm"
    # every shortcut in the Help list is a real action shortcut
    from gaitmon.ui.live import SHORTCUTS

    bound = {a.shortcut().toString() for a in win.actions() if not a.shortcut().isEmpty()}
    for keys, _what in SHORTCUTS:
        for key in keys.split(" / "):
            assert key in bound, key


def test_switching_to_a_dark_theme_rebuilds_the_plots_in_dark(qtbot, window):
    from PySide6.QtGui import QColor, QGuiApplication, QPalette
    from PySide6.QtWidgets import QApplication

    win = window
    qtbot.waitUntil(lambda: win.live.curve_points("joint_kalman_deg", 1, "kalman") > 50)
    assert not win.colours.dark
    old_live = win.live
    light = QGuiApplication.palette()
    dark = QPalette(light)
    for role, colour in (
        (QPalette.ColorRole.Window, "#202020"),
        (QPalette.ColorRole.Base, "#181818"),
        (QPalette.ColorRole.Text, "#e0e0e0"),
        (QPalette.ColorRole.WindowText, "#e0e0e0"),
    ):
        dark.setColor(role, QColor(colour))
    try:
        QApplication.setPalette(dark)
        qtbot.waitUntil(lambda: win.colours.dark)
        assert win.live is not old_live
        assert win.live.backgroundBrush().color().lightness() < 64
        # the new plots are fed at once, and keep the view options
        qtbot.waitUntil(lambda: win.live.curve_points("joint_kalman_deg", 1, "kalman") > 50)
        assert win.live.window_s == win.window_combo.currentData()
    finally:
        QApplication.setPalette(light)
    qtbot.waitUntil(lambda: not win.colours.dark)


def test_a_connect_finishing_after_the_window_closed_is_closed_not_leaked(
    qtbot, ui_settings, no_leaked_threads, monkeypatch
):
    from gaitmon.live import connection

    real_open = connection.open_connection
    started, release = threading.Event(), threading.Event()
    opened = []

    def slow_open(*args, **kwargs):
        started.set()
        release.wait(10.0)
        conn = real_open(*args, **kwargs)
        opened.append(conn)
        return conn

    monkeypatch.setattr(connection, "open_connection", slow_open)
    win = make_window(qtbot, ui_settings, autoconnect=False)
    win.device_part.connect_device(SIMULATED_PORT)
    assert win.jobs.busy and win.status.state_text == "Connecting…"
    # closing before the worker has even started the connect would simply drop it (nothing to
    # close): this test is about a connect that is already under way
    assert started.wait(10.0)
    threading.Timer(0.3, release.set).start()  # the unit answers only once closing began
    win.close()
    # the connection was opened after the close and closed again; no thread outlives it
    assert len(opened) == 1 and not opened[0].engine.running
    assert win.conn is None and win.errors == []


def test_stop_finishes_the_file_off_the_gui_thread_and_the_window_draws_on(
    qtbot, window, tmp_path
):
    """Stop used to finish the file on the GUI thread: 0.9 s of smoothing and stride store
    for an hour's recording, 7 s for 8 hours, with the window frozen. Here the close is held
    back (a slow disk) and the window must go on drawing meanwhile."""
    win = window
    qtbot.waitUntil(lambda: samples(win) >= 50, timeout=WAIT_MS)
    target = tmp_path / "slow.h5"
    _start_recording(qtbot, win, target)
    qtbot.waitUntil(lambda: "REC" in win.status.rec_label.text(), timeout=WAIT_MS)
    engine = win.conn.engine
    release = threading.Event()
    real_stop = engine.stop_recording

    def slow_close(*args, **kwargs):
        release.wait(10.0)
        return real_stop(*args, **kwargs)

    engine.stop_recording = slow_close
    try:
        win.act_record.trigger()  # Stop
        assert win.saving and not win.recording
        assert not win.act_record.isEnabled()  # no new recording until this file is done
        assert "Saving" in win.status.rec_label.text()
        assert "saving the file" in win.statusBar().currentMessage()  # not "Recording to …"
        shown = int(win.status.samples_label.property("samples"))
        qtbot.waitUntil(lambda: int(win.status.samples_label.property("samples")) >= shown + 50,
                        timeout=WAIT_MS)  # fmt: skip
    finally:
        release.set()
    qtbot.waitUntil(lambda: not win.saving, timeout=WAIT_MS)
    assert win.act_record.isEnabled() and win.act_record.text() == "Record"
    assert "Recording saved" in win.statusBar().currentMessage()
    with h5py.File(target, "r") as f:
        assert bool(f.attrs["complete"])
