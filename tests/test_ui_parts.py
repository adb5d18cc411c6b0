"""Pieces of the live monitor that need no running unit: decimation, phase bands, health
grading, link banners, session file names, settings validation, the command-line entry."""

import datetime as dt
import os
import subprocess
import sys

import numpy as np
import pytest

from gaitmon.live.health import HealthTracker, link_view


def test_peak_decimation_keeps_every_groups_min_and_max():
    from gaitmon.ui.plots import decimate_peak

    rng = np.random.default_rng(1)
    n, f = 3003, 5  # 3003 samples into at most 1202 points -> groups of 5, 3 oldest dropped
    x = np.arange(n) / 100.0
    y = rng.normal(size=(n, 3))
    xd, yd = decimate_peak(x, y, 1202)
    m = (n - 3) // f
    assert xd.shape == (2 * m,) and yd.shape == (2 * m, 3)
    groups = y[3:].reshape(m, f, 3)  # brute force, group by group
    np.testing.assert_array_equal(yd[0::2], groups.min(axis=1))
    np.testing.assert_array_equal(yd[1::2], groups.max(axis=1))
    np.testing.assert_array_equal(xd[0::2], x[3::f])
    # the global extremes survive decimation (short peaks stay visible)
    assert yd.max() == y[3:].max() and yd.min() == y[3:].min()
    # short windows are passed through untouched
    xs, ys = decimate_peak(x[:1000], y[:1000], 1400)
    assert np.shares_memory(xs, x)
    assert len(ys) == 1000


def test_step_band_is_top_exactly_over_the_runs():
    from gaitmon.ui.plots import step_band

    x = np.arange(10.0)
    mask = np.array([0, 0, 1, 1, 1, 0, 0, 1, 1, 0], dtype=bool)
    bx, by = step_band(x, mask, top=5.0, bottom=-1.0)
    # runs: [0,2) off, [2,5) on, [5,7) off, [7,9) on, [9] off -> two points per run
    np.testing.assert_array_equal(bx, [0, 2, 2, 5, 5, 7, 7, 9, 9, 9])
    np.testing.assert_array_equal(by, [-1, -1, 5, 5, -1, -1, 5, 5, -1, -1])
    # the filled area equals the time spent "on" (hand count: 3 + 2 samples of width 1)
    area = np.sum(np.diff(bx)[0::2] * (by[0::2] - -1.0))
    assert area == pytest.approx(6.0 * (3 + 2))


def test_step_runs_are_the_spans_step_band_draws_at_its_top():
    from gaitmon.ui.plots import step_runs

    x = np.arange(10.0)
    mask = np.array([0, 0, 1, 1, 1, 0, 0, 1, 1, 0], dtype=bool)
    x0, x1 = step_runs(x, mask)  # the same runs as above, by hand: [2, 5] and [7, 9]
    np.testing.assert_array_equal(x0, [2, 7])
    np.testing.assert_array_equal(x1, [5, 9])
    x0, x1 = step_runs(x, np.ones(10, bool))  # on to the end: up to the last sample
    assert (x0.tolist(), x1.tolist()) == ([0.0], [9.0])
    assert [len(a) for a in step_runs(x[:0], mask[:0])] == [0, 0]


def test_health_is_quiet_then_lossy_then_alert():
    h = HealthTracker(recent_s=5.0, no_data_alert_s=2.0)
    ok = h.update(0.0, 1000, 0, 0, 100.0, 0.01)
    assert ok.grade == "ok" and "0 lost" in ok.text and "0 CRC" in ok.text
    ok = h.update(1.0, 1100, 0, 0, 100.0, 0.01)
    assert ok.grade == "ok"
    # 3 frames lost and 1 CRC failure; over the last 5 s (since t=0): 197 received + 3 lost,
    # so 3 / 200 = 1.5 %
    lossy = h.update(2.0, 1197, 3, 1, 97.0, 0.01)
    assert lossy.grade == "lossy" and "1.5 % lost" in lossy.text and "1 CRC" in lossy.text
    # more than recent_s later with no new losses: quiet again
    for t in range(3, 9):
        quiet = h.update(float(t), 1197 + 100 * (t - 2), 3, 1, 100.0, 0.01)
    assert quiet.grade == "ok"
    alert = h.update(9.0, 1797, 3, 1, 0.0, 2.4)
    assert alert.grade == "alert" and "no data for 2 s" in alert.text


def test_health_shows_engine_and_receive_errors_amber_with_the_reason():
    h = HealthTracker(recent_s=5.0, no_data_alert_s=2.0)
    clean = h.update(0.0, 1000, 0, 0, 100.0, 0.01)
    assert clean.grade == "ok" and "error" not in clean.text
    err = h.update(1.0, 1100, 0, 0, 100.0, 0.01, errors=2, last_error="processing error: boom")
    assert err.grade == "lossy" and "2 errors" in err.text
    assert "processing error: boom" in err.tooltip


def test_link_view_shows_the_countdown_and_the_reason():
    # plain words and whole seconds in the banner; the library's reason in the tooltip
    v = link_view("reconnecting", "link lost: EIO", 1.26, 3.0, "/dev/rfcomm0", attempt=3)
    assert v.state == "reconnecting" and v.grade == "warn"
    assert v.banner.startswith(
        "Connection to the unit lost — reconnecting (attempt 3, next in 2 s)"
    )
    assert "EIO" not in v.banner and v.tooltip == "/dev/rfcomm0: link lost: EIO"
    assert v.pill == "Reconnecting (2 s)"
    assert "(attempt 1, trying now)" in link_view("reconnecting", "x", 0.0, 3.0, "p").banner
    lost = link_view("failed", "gave up after 5 attempts: no such port", None, 9.0, "COM3")
    assert lost.state == "lost" and "gave up reconnecting" in lost.banner
    assert "gave up after 5 attempts: no such port" in lost.tooltip
    assert link_view("connected", "", None, 0.05, "x").banner == ""
    silent = link_view("connected", "", None, 2.5, "x")
    assert silent.grade == "alert" and "No data from the unit for 2 s" in silent.banner


def test_default_file_name_is_safe_and_dated():
    from gaitmon.ui.dialogs import default_file_name

    when = dt.datetime(2026, 11, 22, 4, 5, 6)
    assert default_file_name("P017", "R", when) == "P017_R_20261122-040506.h5"
    assert default_file_name(" a/b c ", "", when) == "a-b-c_20261122-040506.h5"
    assert default_file_name("", "L", when) == "session_L_20261122-040506.h5"


def test_settings_dialog_names_the_bad_field(qtbot):
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.ui.dialogs import SettingsDialog

    dlg = SettingsDialog(None, PipelineConfig())
    qtbot.addWidget(dlg)
    dlg.edits["q_gyro"].setText("abc")
    with pytest.raises(ValueError, match="Kalman Q_gyro: 'abc' is not a number"):
        dlg.parsed()
    dlg.edits["q_gyro"].setText("0.003")
    dlg.edits["fsr_threshold"].setText("5000")
    with pytest.raises(ValueError, match="above 0 and below 4095"):
        dlg.parsed()
    dlg.edits["fsr_threshold"].setText("800")
    dlg.edits["cutoff_hz"].setText("6,5")  # a decimal comma is accepted
    cfg = dlg.parsed()
    assert (cfg.cutoff_hz, cfg.fsr_threshold, cfg.q_angle) == (6.5, 800.0, 0.001)


def _env_without_display():
    env = {k: v for k, v in os.environ.items()}
    for k in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM"):
        env.pop(k, None)
    return env


def test_gaitmon_without_a_display_says_so_in_one_line():
    out = subprocess.run(
        [sys.executable, "-m", "gaitmon"],
        capture_output=True,
        text=True,
        env=_env_without_display(),
        timeout=60,
    )
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gaitmon: error: no display available")
    assert "Traceback" not in out.stderr


def test_gaitmon_help_still_works_and_lists_simulate():
    out = subprocess.run(
        [sys.executable, "-m", "gaitmon", "--help"],
        capture_output=True,
        text=True,
        env=_env_without_display(),
        timeout=60,
    )
    assert out.returncode == 0
    assert "--simulate" in out.stdout and "opens the live monitor" in out.stdout


def test_an_unloadable_x11_plugin_is_a_one_line_message(tmp_path):
    from gaitmon.ui import XCB_HINT, xcb_plugin_problem

    broken = tmp_path / "libqxcb.so"
    broken.write_bytes(b"not a shared library")
    msg = xcb_plugin_problem(broken)
    assert msg is not None and "\n" not in msg
    assert msg.startswith("the Qt X11 platform plugin cannot load") and msg.endswith(XCB_HINT)
    assert xcb_plugin_problem(tmp_path / "absent.so") is None  # nothing to check
    assert xcb_plugin_problem() is None  # this machine's real plugin loads


def test_an_unreachable_x_display_is_a_one_line_message():
    env = _env_without_display()
    # a display number no X server holds (a leftover Xvfb on :97 once made this hang)
    n = next(n for n in range(97, 200) if not os.path.exists(f"/tmp/.X11-unix/X{n}")
             and not os.path.exists(f"/tmp/.X{n}-lock"))  # fmt: skip
    env["DISPLAY"] = f":{n}"
    out = subprocess.run(
        [sys.executable, "-m", "gaitmon"], capture_output=True, text=True, env=env, timeout=60
    )
    assert out.returncode == 2, out.stderr
    assert out.stderr.strip() == (
        f"gaitmon: error: cannot connect to the X display ':{n}': is the desktop session running "
        "and may this user use it?"
    )


def test_live_cycle_band_is_mean_plus_minus_the_sample_sd(qtbot):
    from gaitmon.engine import GaitStatus, Mode, RecordingStatus, Snapshot
    from gaitmon.ui.plots import CyclePlots
    from gaitmon.ui.theme import current_colours

    def snap(cycles):
        gait = GaitStatus(n_strides=len(cycles), last_stance_pct=60.0, cycles_deg=cycles)
        return Snapshot(
            series={}, heel_strike_t_s=np.empty(0), toe_off_t_s=np.empty(0), markers=(),
            samples_total=0, frame_rate_hz=100.0, last_data_age_s=0.0, link=None,
            link_state="connected", link_reason="", seconds_to_reconnect=None,
            recording=RecordingStatus(), gait=gait, mode=Mode.RAW, calibrated=True,
        )  # fmt: skip

    plots = CyclePlots(current_colours())
    qtbot.addWidget(plots)
    rng = np.random.default_rng(3)
    cycles = rng.normal(20.0, 5.0, size=(4, 101, 3))
    plots.update_from(snap(cycles))
    mean, sd = cycles.mean(axis=0), cycles.std(axis=0, ddof=1)
    for j in range(3):
        np.testing.assert_allclose(plots.upper[j].yData, mean[:, j] + sd[:, j])
        np.testing.assert_allclose(plots.lower[j].yData, mean[:, j] - sd[:, j])
    plots.update_from(snap(cycles[:1]))  # one stride: a mean, but no spread to draw
    np.testing.assert_allclose(plots.mean_curves[1].yData, cycles[0, :, 1])
    assert len(plots.upper[1].yData) == 0 and len(plots.lower[1].yData) == 0


@pytest.mark.parametrize("height", [300, 700])
def test_live_cycle_axis_labels_fit_their_plots(qtbot, height):
    """Each cycle plot's y-axis label is no longer than its plot is tall (rotated, it runs
    along the axis): in a short panel (the both-legs view's 300 px) the long clinical label
    overlapped the next plot's; there the plot says "knee (deg)", and the long one when tall."""
    from PySide6.QtGui import QFontMetrics

    from gaitmon.ui.plots import CyclePlots
    from gaitmon.ui.theme import current_colours

    plots = CyclePlots(current_colours())
    qtbot.addWidget(plots)
    plots.resize(380, height)
    plots.show()
    qtbot.waitExposed(plots)
    qtbot.wait(50)
    for p in plots._plots:
        axis = p.getAxis("left")
        text = axis.labelText
        width = QFontMetrics(axis.label.font()).horizontalAdvance(f"{text} ({axis.labelUnits})"
                                                                  if axis.labelUnits else text)
        assert width <= p.vb.height(), (text, width, p.vb.height())
    labels = [p.getAxis("left").labelText for p in plots._plots]
    if height >= 700:  # room for the clinical names
        assert labels == ["hip flexion (deg)", "knee flexion (deg)", "ankle dorsiflexion (deg)"]
    else:
        assert labels == ["hip (deg)", "knee (deg)", "ankle (deg)"]


# what the live window stored, by the key strings it has always used (issue 23 named them once,
# in gaitmon.review.settings): a user's saved settings must still load
STORED_BEFORE = {
    "pipeline/cutoff_hz": 3.0, "pipeline/q_angle": 0.002, "pipeline/q_gyro": 0.004,
    "pipeline/r": 0.5, "pipeline/fsr_threshold": 900.0, "pipeline/tilt_method": "paper",
    "device/last_port": "/dev/ttyUSB3", "device/mode": "joint",
    "session/folder": "/data/gait", "session/operator": "A. Nurse", "session/side": "L",
    "session/patient_id": "P-0042",
    "view/window_s": 30.0, "view/four_phases": False, "view/engineering": True,
    "view/method_acc": False, "view/method_kalman": True, "view/method_gyro": False,
    "lsl/enabled": True, "lsl/patient_id": False,
}  # fmt: skip


def test_the_live_windows_saved_settings_load_by_the_keys_named_once(tmp_path):
    from PySide6.QtCore import QByteArray, QSettings

    from gaitmon.review.settings import PIPELINE_SETTINGS, LiveKey
    from gaitmon.ui.live.prefs import Prefs

    ini = str(tmp_path / "gaitmon.ini")
    old = QSettings(ini, QSettings.Format.IniFormat)
    for key, value in STORED_BEFORE.items():
        old.setValue(key, value)
    old.setValue("window/geometry", QByteArray(b"\x01\xd9\xd0\xcb"))
    old.sync()
    named = [k.key for k in LiveKey] + [s.key for s in PIPELINE_SETTINGS]
    assert len(named) == len(set(named))
    # issue 25 added the typed ports connected to (nothing stored before it: default "")
    assert set(named) == {*STORED_BEFORE, "window/geometry", "window/state", "device/recent_ports"}
    prefs = Prefs(QSettings(ini, QSettings.Format.IniFormat))  # read back from the file: text
    got = {k.key: prefs.get(k) for k in LiveKey if k.kind is not object}
    assert got == {k: v for k, v in STORED_BEFORE.items() if k in got} | {"device/recent_ports": ""}
    assert [prefs.get(LiveKey.shown(t)) for t in ("acc", "kalman", "gyro")] == [False, True, False]
    assert prefs.get(LiveKey.GEOMETRY) == QByteArray(b"\x01\xd9\xd0\xcb")
    assert prefs.get(LiveKey.STATE) is None
    cfg = prefs.pipeline_config()
    assert (cfg.cutoff_hz, cfg.q_angle, cfg.q_gyro, cfg.r, cfg.fsr_threshold, cfg.tilt_method) == (
        3.0, 0.002, 0.004, 0.5, 900.0, "paper")  # fmt: skip
    # nothing stored: each key's default
    empty = Prefs(QSettings(str(tmp_path / "new.ini"), QSettings.Format.IniFormat))
    assert (empty.get(LiveKey.WINDOW_S), empty.get(LiveKey.MODE), empty.get(LiveKey.LSL)) == (
        10.0, "raw", False)  # fmt: skip
    assert empty.get(LiveKey.SESSION_FOLDER, "/home/x/gaitmon") == "/home/x/gaitmon"
    empty.save_pipeline_config(cfg.replace(cutoff_hz=5.0, tilt_method="gait-aware"))
    assert float(empty.s.value("pipeline/cutoff_hz")) == 5.0
    assert empty.s.value("pipeline/tilt_method") == "gait-aware"


def test_the_settings_applied_message_names_every_setting_as_before():
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.ui.live.processing import settings_text

    assert settings_text(PipelineConfig(cutoff_hz=3.0, r=0.5, fsr_threshold=850.0)) == (
        "cut-off 3 Hz, Q_angle 0.001, Q_gyro 0.003, R 0.5, FSR threshold 850"
    )


def test_every_live_action_row_names_a_window_slot_once():
    from gaitmon.ui.live import MainWindow
    from gaitmon.ui.live.actions import window_actions
    from gaitmon.ui.live.window import PART_TYPES

    specs = window_actions()
    names = [spec.name for spec in specs]
    assert len(names) == len(set(names))
    shortcuts = [spec.shortcut for spec in specs if spec.shortcut]
    assert len(shortcuts) == len(set(shortcuts))  # no key does two things
    for spec in specs:  # a slot of the window or of one of its parts
        owners = (MainWindow, *PART_TYPES)
        assert any(callable(getattr(o, spec.slot, None)) for o in owners), spec.slot


def test_the_live_window_is_composed_of_parts_not_a_stack_of_mixins():
    from PySide6.QtWidgets import QMainWindow

    from gaitmon.ui.live.window import PART_TYPES, MainWindow

    assert MainWindow.__bases__ == (QMainWindow,)
    for part in PART_TYPES:  # plain objects that own their widgets, not window subclasses
        assert part.__bases__ == (object,), part


@pytest.mark.parametrize("nan_pct", [1.0, 30.0])
def test_a_line_broken_at_nans_draws_what_pyqtgraphs_finite_connect_draws(qtbot, nan_pct):
    """The live plots build NaN-broken lines (the gyro integration off scale, lost rows) one
    polygon per finite run; the pixels drawn must be pyqtgraph's connect='finite' ones, both
    below and above the 2 % of NaN where pyqtgraph switches its method."""
    import pyqtgraph as pg
    from PySide6.QtCore import Qt
    from PySide6.QtGui import QImage, QPainter, QPen, QTransform

    from gaitmon.ui.plots.traces import broken_line_path

    rng = np.random.default_rng(int(nan_pct))
    n = 1000
    x = np.linspace(-10.0, 0.0, n)
    y = np.cumsum(rng.normal(size=n))
    nan = rng.random(n) < nan_pct / 100.0
    nan[[3, 5, 6, 7]] = True  # lone finite points between NaNs, and a run of NaNs
    nan[-2], nan[-1] = True, False  # a lone finite point at the very end
    y[nan] = np.nan

    def draw(path):
        img = QImage(600, 300, QImage.Format.Format_ARGB32)
        img.fill(Qt.GlobalColor.white)
        p = QPainter(img)
        lo, hi = np.nanmin(y), np.nanmax(y)
        p.setTransform(
            QTransform().scale(60.0, -290.0 / (hi - lo))
            * QTransform().translate(600.0, 295.0 + 290.0 * lo / (hi - lo))
        )
        pen = QPen(Qt.GlobalColor.black)
        pen.setCosmetic(True)
        p.setPen(pen)
        p.drawPath(path)
        p.end()
        return img

    ours = draw(broken_line_path(x, y))
    theirs = draw(pg.arrayToQPath(x, y, connect="finite", finiteCheck=True))
    assert ours == theirs
    assert ours != draw(pg.arrayToQPath(x, np.nan_to_num(y), connect="all"))  # gaps show
    # one subpath per run of finite points (runs of one point only at the end draw nothing)
    fin = ~nan
    runs = np.sum(fin & ~np.concatenate([[False], fin[:-1]]))
    path = broken_line_path(x, y)
    moves = sum(
        path.elementAt(i).type.name == "MoveToElement" for i in range(path.elementCount())
    )
    assert moves == runs - 1  # the lone point at the end
