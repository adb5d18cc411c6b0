"""The review window's lanes, summary, Both legs cycles and status bar (issue 25, review items).

A real two-leg recording (two simulated units through their decoders, a hemiparetic walk) and a
real one-leg one, opened in the real window. What the window shows is checked against readers
independent of it: the file read with ``open_session``, the report's per-leg means
(``bilateral_report_from_file``), and text widths measured with the widgets' own fonts.

* the tilt lane's y range is the tilts' (the selected method's), not the drifting gyro
  integration's, whose legend entry says it drifts and is off scale;
* every lane's legend names each trace drawn, whole, inside its lane (also in a narrow window);
* a two-leg summary does not say that equal steps are assumed (a one-leg one does);
* the Both legs tab overlays each leg's mean cycles, equal to the report's and the one-leg
  review's, and follows the angles shown;
* the status bar's file message is not cut by the angles label; the readout says
  "loading response", not "loading".
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import QRectF
from PySide6.QtGui import QFontMetrics

from gaitmon.cli import main
from gaitmon.dsp.channels import SEGMENTS
from gaitmon.finish import open_session

WAIT_MS = 30_000
ASSUMED = "two equal steps per stride are assumed"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("lanes") / "both.h5"
    rc = main(["record", "--simulate-bilateral", "--duration", "12", "--speed", "4",
               "--asymmetry", "hemiparetic", "--standing-s", "1.5", "-o", str(out),
               "-q"])  # fmt: skip
    assert rc == 0
    return out


@pytest.fixture
def both(recorded: Path, tmp_path: Path) -> Path:
    p = tmp_path / "both.h5"  # a copy: the window may write exclusions beside it
    shutil.copyfile(recorded, p)
    return p


@pytest.fixture(scope="module")
def one_leg(tmp_path_factory: pytest.TempPathFactory, record_simulated) -> Path:
    return record_simulated(tmp_path_factory.mktemp("lanes1") / "one.h5", duration_s=15)


@pytest.fixture
def win(review_win):  # tests/conftest.py: a real window, checked for errors and left threads
    return review_win


def open_and_wait(qtbot, w, path: Path, bilateral: bool = True) -> None:
    if bilateral:
        with qtbot.waitSignal(w.legs.computed, timeout=WAIT_MS), \
                qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):  # fmt: skip
            w.open_file(path)
    else:
        with qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):
            w.open_file(path)
    qtbot.waitUntil(lambda: w.timeline.applied_requests > 0, timeout=WAIT_MS)


def redrawn(qtbot, w, change) -> None:
    """Make ``change`` and wait for the timeline to apply a view read after it."""
    n = w.timeline.applied_requests
    change()
    qtbot.waitUntil(lambda: w.timeline.applied_requests > n, timeout=WAIT_MS)


# -- 1. the tilt lane's range ----------------------------------------------------------------------


def test_tilt_lane_range_is_the_tilts_not_the_drifting_gyro_integration(qtbot, win, both) -> None:
    open_and_wait(qtbot, win, both)
    tl = win.timeline
    with open_session(both, side="L") as s:  # the file, read without the window
        tilts = np.asarray(s.read("processed/tilt_deg"), np.float64)
        gyros = np.asarray(s.read("processed/tilt_gyro_deg"), np.float64)
    x0, x1 = tl.view_range()
    assert x0 <= float(tl.doc.t_s[0]) and x1 >= float(tl.doc.t_s[-1])  # all 12 s in view
    # the segment whose integral drifts farthest out of its tilts' range (the simulated bias
    # is random: up or down, more on one segment than another)
    lo, hi = tilts.min(axis=0), tilts.max(axis=0)
    excess = np.maximum(gyros.max(axis=0) - hi, lo - gyros.min(axis=0)) / (hi - lo)
    k = int(np.argmax(excess))
    assert excess[k] > 1.0, excess  # it leaves the range by more than the range itself
    redrawn(qtbot, win, lambda: tl.set_segment(k))
    lo, hi, gyro = float(lo[k]), float(hi[k]), gyros[:, k]
    margin = 0.1 * (hi - lo)
    lane = tl.lanes["tilt"]
    for _ in range(2):  # as fitted for the segment, and after Home (fit y again)
        y0, y1 = lane.plot.getViewBox().viewRange()[1]
        assert lo - margin <= y0 <= lo and hi <= y1 <= hi + margin, (y0, y1, lo, hi)
        tl.fit_y()
    # still drawn (clipped), and labelled as what it is, with how far off scale it is
    assert tl.trace_points("tilt", "processed/tilt_gyro_deg", k) > 100
    text = next(t for t in lane.legend.texts() if t.startswith("gyro integration"))
    assert "drifts: not a measurement" in text and "off scale here" in text, text
    shown = [float(v) for v in re.findall(r"([+-]\d+)", text.split("off scale here")[1])]
    assert len(shown) == 2, text  # its lowest and highest value in view
    # (a wrap at +-180 deg is broken, not drawn: its first sample is left out)
    assert shown[0] == pytest.approx(gyro.min(), abs=2.0) or abs(gyro.min()) > 170
    assert shown[1] == pytest.approx(gyro.max(), abs=2.0) or abs(gyro.max()) > 170


# -- 2. the legends --------------------------------------------------------------------------------


def _legend_whole(lane) -> None:
    """The legend lies inside its lane's view box (which clips it), and its text is laid out
    in the width it is drawn in."""
    legend, vb = lane.legend, lane.plot.getViewBox()
    assert legend.isVisible()
    box = legend.textItem.mapRectToScene(legend.textItem.boundingRect())
    inside = QRectF(vb.sceneBoundingRect()).adjusted(-0.5, -0.5, 0.5, 0.5)
    assert inside.contains(box), (lane.key, box, inside)
    doc = legend.textItem.document()
    assert doc.idealWidth() <= legend.textItem.boundingRect().width() + 0.5
    shown = legend.textItem.toPlainText().replace("\u00a0", " ")
    for text in legend.texts():
        assert text in shown, (text, shown)


def test_every_lane_has_a_legend_entry_for_each_trace_drawn(qtbot, win, both) -> None:
    open_and_wait(qtbot, win, both)
    tl = win.timeline
    method = win.doc.angle_method
    assert method  # "gait-aware Kalman + RTS smoother"
    # the joints' comparison methods, and the raw counts, drawn too (View menu)
    for m in ("acc", "gyro"):
        redrawn(qtbot, win, lambda m=m: tl.set_method(m, True))
    redrawn(qtbot, win, lambda: tl.set_lane_visible("raw", True))
    gyro = "gyro integration (°), drifts: not a measurement"
    want = {
        **{j: [gyro, "accelerometer (°)", f"{j} (°), {method}"] for j in ("hip", "knee", "ankle")},
        "tilt": [gyro, "accelerometer tilt (°)", f"thigh tilt (°), {method}"],
        "fsr": ["heel (counts)", "toe (counts)", "loading response", "foot flat", "push-off",
                "contact threshold (counts)"],
        "raw": [f"{s} (counts)" for s in ("body", "thigh", "shank", "foot", "heel", "toe")],
    }  # fmt: skip
    for key, names in want.items():
        lane = tl.lanes[key]
        texts = lane.legend.texts()
        assert len(texts) == len(names), (key, texts)
        for name, text in zip(names, texts, strict=True):
            assert text.startswith(name), (key, text, name)
        # every trace drawn has its entry (a raw segment's three channels share one)
        drawn = {spec.label.format(method=method, segment=SEGMENTS[spec.column % 4]).split(" (")[0]
                 for spec, tr in lane.specs
                 if tr.visible and tr.path is not None and spec.label}  # fmt: skip
        assert drawn <= {t.split(" (")[0] for t in texts}, (key, drawn, texts)
        _legend_whole(lane)
    # the other segment: its name in the tilt legend
    redrawn(qtbot, win, lambda: tl.set_segment(2))
    assert f"shank tilt (°), {method}" in tl.lanes["tilt"].legend.texts()
    # the narrowest window: a long legend wraps, still whole inside its lane
    win.resize(win.minimumSizeHint().width(), 920)
    qtbot.waitUntil(lambda: tl.lanes["tilt"].plot.getViewBox().width() < 1000)
    qtbot.wait(50)
    for key in want:
        _legend_whole(tl.lanes[key])


# -- 3. the per-leg summary of a two-leg session ---------------------------------------------------


def test_two_leg_summary_says_steps_are_measured_one_leg_keeps_the_assumption(
    qtbot, win, both, one_leg
) -> None:
    open_and_wait(qtbot, win, both)
    text = win.summary.text()
    assert "Cadence (derived)" in text  # the leg's own 120 / stride time, still shown
    assert ASSUMED not in text
    assert "measured per leg" in text and "Both legs tab" in text
    open_and_wait(qtbot, win, one_leg, bilateral=False)
    assert ASSUMED in win.summary.text()


# -- 4. both legs' cycles overlaid -----------------------------------------------------------------


def test_both_legs_tab_overlays_each_legs_mean_cycles_as_the_report_and_review(
    qtbot, win, both
) -> None:
    from gaitmon.report import bilateral_report_from_file
    from gaitmon.ui.theme import side_colours

    open_and_wait(qtbot, win, both)
    win.tabs.setCurrentIndex(1)
    qtbot.waitUntil(lambda: win.both_legs.cycles.isVisible())
    cyc = win.both_legs.cycles
    report = bilateral_report_from_file(both)  # the report's per-leg means
    for side in "LR":
        d = report.sides[side]
        assert d.summary.n_strides >= 3
        for j in range(3):
            np.testing.assert_allclose(cyc.mean_curve(side, j), d.mean_deg[:, j], rtol=0,
                                       atol=1e-9)  # fmt: skip
            lo = cyc.sides[side].lower[j].getData()[1]
            np.testing.assert_allclose(lo, d.mean_deg[:, j] - d.sd_deg[:, j], atol=1e-9)
        toe = cyc.sides[side].toe_off[0]
        assert toe.isVisible() and toe.value() == pytest.approx(d.toe_off_pct)
    # the hemiparetic legs differ: two curves, not one drawn twice
    assert np.abs(cyc.mean_curve("L", 1) - cyc.mean_curve("R", 1)).max() > 5.0
    # the one-leg review's cycles of the leg shown are the same curves, on either leg
    for j in range(3):
        np.testing.assert_allclose(cyc.mean_curve("L", j), win.analysis.mean_deg[:, j], atol=1e-9)
    with qtbot.waitSignal(win.legs.computed, timeout=WAIT_MS), \
            qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):  # fmt: skip
        win.act["leg_R"].trigger()
    for j in range(3):
        np.testing.assert_allclose(win.both_legs.cycles.mean_curve("R", j),
                                   win.analysis.mean_deg[:, j], atol=1e-9)  # fmt: skip
    # one colour per leg, named in the legend (the title), whole in the plots' width
    colours = side_colours(win.colours)
    entries = cyc.legend_entries()
    assert [c for c, _t in entries] == [colours["L"].name(), colours["R"].name()]
    assert entries[0][1].startswith("left leg") and entries[1][1].startswith("right leg")
    for side in "LR":
        assert cyc.sides[side].mean[0].opts["pen"].color().name() == colours[side].name()
    title = cyc.title.item
    assert title.boundingRect().width() <= cyc.viewport().width()
    assert all(t in title.toPlainText() for _c, t in entries)


def test_both_legs_cycles_follow_the_angles_shown(qtbot, win, both) -> None:
    open_and_wait(qtbot, win, both)
    smoothed = win.both_legs.cycles.mean_curve("L", 1).copy()
    with qtbot.waitSignal(win.legs.computed, timeout=WAIT_MS), \
            qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):  # fmt: skip
        win.act["angles_live"].trigger()
    assert win.doc.angle_source == "live"
    live = win.both_legs.cycles.mean_curve("L", 1)
    np.testing.assert_allclose(live, win.analysis.mean_deg[:, 1], atol=1e-9)
    assert np.abs(live - smoothed).max() > 0.1  # other angles: other curves


# -- 5. the status bar and the readout -------------------------------------------------------------


def test_status_bar_message_is_not_cut_by_the_angles_label(qtbot, win, both) -> None:
    open_and_wait(qtbot, win, both)
    assert win.width() == 1500  # the window's default width
    win.resize(1400, win.height())  # narrower than the default: the message must still fit
    qtbot.waitUntil(lambda: win.width() == 1400)
    sb = win.statusBar()
    msg = sb.currentMessage()
    assert msg.startswith("both.h5 — left leg:") and msg.endswith("0 markers")
    angles = win.status.angles
    qtbot.waitUntil(angles.isVisible)
    # QStatusBar draws its message from x = 6 up to 2 px before the first permanent widget
    room = angles.x() - 2 - 6
    width = QFontMetrics(sb.font()).horizontalAdvance(msg)
    assert width <= room, (width, room)
    assert not win.status.hint.isVisible()  # the message is not drawn over another text
    # and the angles label is given the width its text needs, whole on screen
    assert angles.width() >= angles.sizeHint().width()
    assert angles.x() + angles.width() <= sb.width()
    text = angles.text()
    assert win.doc.angle_method in text and "zero: " in text


def test_readout_names_the_loading_response_phase(qtbot, win, both) -> None:
    from gaitmon.dsp.gait import Phase

    open_and_wait(qtbot, win, both)
    doc = win.doc
    with open_session(both, side="L") as s:
        phase = np.asarray(s.read("processed/phase"))
    lag = doc.current.config.phase_lag_samples  # drawn on the events' time base (view.py)
    rows = np.flatnonzero(phase[lag:] == Phase.LOADING)
    assert len(rows) > 10
    win.timeline.set_cursor(float(doc.t_s[rows[len(rows) // 2]]))
    text = win.timeline.readout.text()
    assert text.endswith("loading response"), text
