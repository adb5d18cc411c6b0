"""Issue 28: the live window's GUI thread only draws. The engine thread prepares each frame
(``gaitmon.engine.display``: the series as drawn, the phase bands and shading, the event
lines, the gait cycles' mean and SD) right after a block, and the window hands those arrays
to its curves and paints. Checked without timing: with the window's timer stopped the plots
keep showing new data; every frame was prepared off the GUI thread; the curves hold exactly
the frame's arrays; and the frame's arrays are the engine's samples (x = seconds before now)
and the cycles' mean and sample SD computed here from the engine's cycles."""

import threading

import numpy as np

import gaitmon.engine.display as display
import gaitmon.ui.live.views as views
import gaitmon.ui.plots.cycles as cycles
import gaitmon.ui.plots.live as live_plots
from gaitmon.engine.display import DisplayRequest, decimate_peak, prepare_display
from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.ui.live import MainWindow

WAIT_MS = 60_000


def path_xy(path):
    """The points of a QPainterPath (one polyline) as (x, y) arrays."""
    pts = [path.elementAt(i) for i in range(path.elementCount())]
    return np.array([p.x for p in pts]), np.array([p.y for p in pts])


def test_frames_are_prepared_off_the_gui_thread_and_drawn_as_prepared(
    qtbot, ui_settings, no_leaked_threads, monkeypatch
):
    prepared_on: list[int] = []
    real = display.prepare_display

    def spy(snap, req):
        prepared_on.append(threading.get_ident())
        return real(snap, req)

    for module in (display, views, live_plots):
        monkeypatch.setattr(module, "prepare_display", spy)

    def not_here(_cycles):
        raise AssertionError("the gait cycles' mean and SD computed by the plots")

    monkeypatch.setattr(cycles, "cycle_mean_sd", not_here)
    win = MainWindow(ui_settings, sim=SimConfig(standing_s=1.0, speed=4.0),
                     autoconnect=SIMULATED_PORT, mode="raw", confirm_close=False)  # fmt: skip
    win.show()
    gui = threading.get_ident()
    try:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: win.view_part.last_frame is not None
                        and np.isfinite(win.view_part.last_frame.newest_idx), timeout=WAIT_MS)
        win.timer.stop()  # no tick draws from here on: only frames from the engine thread
        prepared_on.clear()
        paints = win.live.paints
        newest = win.view_part.last_frame.newest_idx
        qtbot.waitUntil(
            lambda: len(win.engine.snapshot().gait.cycles_deg) >= 3
            and win.view_part.last_frame.newest_idx > newest + 200
            and win.live.paints > paints + 10,
            timeout=WAIT_MS,
        )
        qtbot.waitUntil(lambda: len(win.view_part.last_frame.snap.gait.cycles_deg) >= 3,
                        timeout=WAIT_MS)  # fmt: skip
        assert prepared_on and gui not in prepared_on  # all on the engine thread
        assert win.errors == []  # the cycle plots never computed a mean themselves

        frame = win.view_part.last_frame
        s = frame.snap.series
        # the frame is the engine's samples, x in seconds before the right edge
        c = frame.curves["joint_kalman_deg"]
        np.testing.assert_array_equal(c.x, s["t_s"] - frame.t_now)
        np.testing.assert_array_equal(c.y, s["joint_kalman_deg"])
        assert frame.t_now >= s["t_s"][-1]
        # and the curves hold exactly the frame's arrays
        shown = [tr for tr in win.live.curves if tr.visible]
        assert {tr.series for tr in shown} == {"joint_kalman_deg", "fsr_counts"}  # clinical
        for tr in shown:
            got = frame.curves[tr.series]
            x, y = path_xy(tr.path)
            keep = np.isfinite(got.y[:, tr.column])
            np.testing.assert_allclose(x, got.x[keep])
            np.testing.assert_allclose(y, got.y[keep, tr.column])
        # the cycles' mean and sample SD, as the review computes them, drawn as prepared
        cyc = frame.snap.gait.cycles_deg
        mean, sd = frame.cycle_mean_sd
        np.testing.assert_allclose(mean, cyc.mean(axis=0))
        np.testing.assert_allclose(sd, cyc.std(axis=0, ddof=1))
        if win.gait_panel.cycles._shown_strides == frame.snap.gait.n_strides:
            _x, y = win.gait_panel.cycles.mean_curves[1].getData()
            np.testing.assert_allclose(y, mean[:, 1])
    finally:
        win.close()


def test_a_long_window_is_decimated_to_the_same_minima_and_maxima_as_by_hand():
    """The frame of a 30-s window (3000 rows): min/max pairs of consecutive groups, computed
    here with a plain loop."""
    from tests.test_ui_live_paint import _snapshot

    snap = _snapshot(60.0, window_s=30.0)
    req = DisplayRequest(window_s=30.0, series=("tilt_kalman_deg",), max_points=1400)
    frame = prepare_display(snap, req)
    y = snap.series["tilt_kalman_deg"]
    t = snap.series["t_s"] - frame.t_now
    f = int(np.ceil(len(t) / 700))
    start = len(t) - (len(t) // f) * f
    want_x, want_y = [], []
    for a in range(start, len(t), f):
        want_x += [t[a], t[a + f - 1]]
        want_y += [y[a : a + f].min(axis=0), y[a : a + f].max(axis=0)]
    got = frame.curves["tilt_kalman_deg"]
    assert len(got.x) <= 1400
    np.testing.assert_array_equal(got.x, want_x)
    np.testing.assert_array_equal(got.y, np.array(want_y))
    np.testing.assert_array_equal(decimate_peak(t, y, 1400)[1], got.y)
