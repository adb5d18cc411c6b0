"""The live plots' layered painting (a cached picture of the scene, the traces drawn over it)
shows exactly what painting the whole scene shows: same pixels, after new data, a y zoom and a
resize; the grid and the axes over the traces and the bands, as in the scene. "Same" allows
what blending a cached picture of the axes instead of Qt's per-item pixmaps changes: 1/255 in
a channel where a grid line crosses a trace, and the last pixel of an axis line (a few)."""

import numpy as np
import pytest

from gaitmon.engine import GaitStatus, Mode, RecordingStatus, Snapshot
from gaitmon.engine.buffers import SERIES

FS_HZ = 100.0


def _snapshot(t_end_s: float, window_s: float = 10.0) -> Snapshot:
    """Walking-like series over the last ``window_s``: a lost stretch (NaN rows), the gyro
    integration drifting off scale, foot contacts with phases, events and a marker."""
    t = np.arange(round((t_end_s - window_s) * FS_HZ), round(t_end_s * FS_HZ)) / FS_HZ
    n = len(t)
    s = {k: np.zeros((n, *shape)) for k, shape in SERIES.items()}
    s["t_s"] = t
    s["host_time_s"] = t
    s["idx"] = np.arange(n, dtype=float)
    w = 2 * np.pi * 0.9 * t
    for j in range(4):
        s["tilt_acc_deg"][:, j] = 20 * np.sin(w + j) + 3 * np.sin(7 * w)
        s["tilt_kalman_deg"][:, j] = 20 * np.sin(w + j)
        s["tilt_gyro_deg"][:, j] = 20 * np.sin(w + j) + 9.0 * (t - t[0]) * (j - 1.5)  # drifts
    for j in range(3):
        s["joint_acc_deg"][:, j] = 30 * np.sin(w + 2 * j) + 25
        s["joint_kalman_deg"][:, j] = 30 * np.sin(w + 2 * j) + 20
        s["joint_gyro_deg"][:, j] = 30 * np.sin(w + 2 * j) + 20 + 15.0 * (t - t[0]) * j
    heel = np.sin(w) > 0
    toe = np.sin(w - 1.2) > 0
    s["fsr_counts"][:, 0] = np.where(heel, 2600.0, 40.0)
    s["fsr_counts"][:, 1] = np.where(toe, 2200.0, 30.0)
    s["heel_loaded"], s["toe_loaded"] = heel * 1.0, toe * 1.0
    s["phase"] = np.where(heel & ~toe, 1, np.where(heel & toe, 2, np.where(toe, 3, 0))) * 1.0
    gap = slice(n // 3, n // 3 + 40)  # 0.4 s lost: every value NaN, flagged lost
    for k in s:
        if k not in ("t_s", "lost", "settling"):
            s[k][gap] = np.nan
    s["lost"][gap] = 1.0
    s["settling"][gap.stop : gap.stop + 30] = 1.0
    hs = t[np.flatnonzero(np.diff(heel.astype(int)) == 1) + 1]
    to = t[np.flatnonzero(np.diff(toe.astype(int)) == -1) + 1]
    return Snapshot(
        series=s, heel_strike_t_s=hs, toe_off_t_s=to, markers=((t_end_s - 3.0, "turn"),),
        samples_total=n, frame_rate_hz=FS_HZ, last_data_age_s=0.0, link=None,
        link_state="connected", link_reason="", seconds_to_reconnect=None,
        recording=RecordingStatus(), gait=GaitStatus(), mode=Mode.RAW, calibrated=True,
    )  # fmt: skip


@pytest.fixture
def plots(qtbot):
    from gaitmon.ui.plots import LivePlots
    from gaitmon.ui.theme import current_colours

    live = LivePlots(current_colours())
    qtbot.addWidget(live)
    live.resize(1100, 760)
    live.show()
    qtbot.waitExposed(live)
    return live


def _both(live, qtbot):
    """The widget as painted layered, and as painted through the whole scene."""
    qtbot.wait(10)
    live.layered = True
    layered = live.grab().toImage()
    live.layered = False
    whole = live.grab().toImage()
    live.layered = True
    return layered, whole


def test_layered_painting_shows_what_the_scene_shows(plots, qtbot):
    live = plots
    live.update_from(_snapshot(60.0))
    # what is compared is there: broken lines, the gyro notes, the marker label
    assert "gyro integration off scale" in live.gyro_note("body")
    assert live.marker_labels() == ["turn", "turn"]
    assert live.lost_path("knee") is not None
    layered, whole = _both(live, qtbot)
    _assert_same(layered, whole)
    # new data: the traces move, the cached picture of the rest is reused, still identical
    live.update_from(_snapshot(60.5))
    layered2, whole2 = _both(live, qtbot)
    _assert_same(layered2, whole2)
    assert (_pixels(layered2) != _pixels(layered)).sum() > 1000  # (it sees the traces move)


def test_the_cached_picture_follows_a_zoom_and_a_resize(plots, qtbot):
    live = plots
    live.update_from(_snapshot(30.0))
    before, _ = _both(live, qtbot)
    live.plots["knee"].plot.setYRange(-40, 120, padding=0)  # the axis and the traces change
    layered, whole = _both(live, qtbot)
    _assert_same(layered, whole)
    assert (_pixels(layered) != _pixels(before)).sum() > 1000
    live.resize(900, 700)
    qtbot.waitUntil(lambda: live.width() == 900)
    layered, whole = _both(live, qtbot)
    _assert_same(layered, whole)
    assert layered.size() != before.size()
    live.resize(1100, 760)
    qtbot.waitUntil(lambda: live.width() == 1100)
    live.plots["knee"].plot.setYRange(-10, 80, padding=0)
    layered, whole = _both(live, qtbot)
    _assert_same(layered, whole)
    _assert_same(layered, before)


def _pixels(img):
    from PySide6.QtGui import QImage

    img = img.convertToFormat(QImage.Format.Format_RGB32)
    return np.frombuffer(img.constBits(), np.uint8).reshape(img.height(), -1, 4).copy()


def _assert_same(a, b):
    pa, pb = _pixels(a), _pixels(b)
    assert pa.shape == pb.shape
    off = np.abs(pa.astype(int) - pb.astype(int)).max(axis=2)
    assert (off > 1).sum() <= 8, f"{(off > 1).sum()} pixels differ"
