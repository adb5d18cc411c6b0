"""Review shows the angles of one source, switched as a user would (View ▸ Angles): the
zero-lag smoothed angles stored with a raw-mode recording (the default) or the live filter's.

Everything drawn and counted follows the switch, and equals what is stored in the file for that
source (read here with plain h5py) and what ``gaitmon info`` / the report compute from a session
reading the same angles (:func:`gaitmon.analysis.analyse_session`). The method in force is on
screen; a tilt-mode recording has nothing to switch; an export from review carries the angles
shown; a flagged force sensor is a visible note; the reprocess dialog offers the live method.
"""

from __future__ import annotations

import json
import shutil
import threading

import h5py
import numpy as np
import pytest

from gaitmon.analysis import STRIDE_COLUMNS, analyse_session
from gaitmon.finish import close_recording, open_session

WAIT_MS = 30_000
JOINT = "processed/joint_deg"
STORED = {"smoothed": "smoothed/joint_deg", "live": "processed/joint_deg"}
METHOD = {"smoothed": "gait-aware Kalman + RTS smoother", "live": "gait-aware Kalman"}


@pytest.fixture(scope="module")
def raw_file(tmp_path_factory, record_simulated):
    return record_simulated(tmp_path_factory.mktemp("angles") / "walk.h5", duration_s=30)


@pytest.fixture(scope="module")
def tilt_file(tmp_path_factory, record_simulated):
    return record_simulated(tmp_path_factory.mktemp("angles_tilt") / "tilt.h5", "--mode", "tilt",
                            duration_s=12)  # fmt: skip


@pytest.fixture
def session_file(raw_file, tmp_path):
    p = tmp_path / "walk.h5"
    shutil.copyfile(raw_file, p)
    return p


@pytest.fixture
def win(review_win):
    return review_win  # tests/conftest.py: a real window, checked for errors and leftover threads


def open_and_wait(qtbot, w, path):
    with qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):
        w.open_file(path)
    qtbot.waitUntil(lambda: w.timeline.applied_requests > 0, timeout=WAIT_MS)


def pick_angles(qtbot, w, angles):
    """View ▸ Angles ▸ Smoothed | Live, triggered as a click does; waits for the strides and
    for the lanes read with those angles."""
    with qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):
        w.act[f"angles_{angles}"].trigger()
    key = f"recorded/{angles}"
    qtbot.waitUntil(lambda: (key, JOINT) in w.timeline.last_window, timeout=WAIT_MS)


def drawn(path):
    """(x, y) of the points of a drawn QPainterPath."""
    pts = [path.elementAt(i) for i in range(path.elementCount())]
    return np.array([p.x for p in pts]), np.array([p.y for p in pts])


def knee_trace(w):
    lane = w.timeline.lanes["knee"]
    return next(tr for s, tr in lane.specs if s.method == "kalman" and not s.before)


def table_column(w, col):
    m = w.table.model()
    return [m.index(r, col).data() for r in range(m.rowCount())]


KNEE_PEAK_COL, KNEE_ROM_COL = (  # by name: the table's columns are analysis.STRIDE_COLUMNS
    [c.key for c in STRIDE_COLUMNS].index(k) for k in ("knee_peak_swing_deg", "knee_rom_deg")
)


def _stored(path, angles="smoothed", name=JOINT):
    """A series of ``angles`` as the file stores it, through the session reader (format 2
    stores the tilts quantised, the joints are derived: docs/file-format.md, "Storage")."""
    from gaitmon.finish import open_session

    with open_session(path) as s:
        s.use_angles(angles)
        return s.read(name)


def _stored_smoothed(path):
    return _stored(path)


def test_switching_the_angles_redraws_everything_with_that_sources_series(
    qtbot, win, session_file
):
    with h5py.File(session_file) as f:
        t_s = f["timeline/t_s"][()]
    stored = {a: _stored(session_file, a).astype(np.float64) for a in STORED}
    tilt = {a: _stored(session_file, a, "processed/tilt_deg").astype(np.float64)
            for a in STORED}  # fmt: skip
    assert np.abs(stored["smoothed"][:, 1] - stored["live"][:, 1]).max() > 1.0  # they differ
    open_and_wait(qtbot, win, session_file)
    assert win.act["angles_smoothed"].isEnabled() and win.act["angles_live"].isEnabled()
    menu = [a.text() for a in win.angles_menu.actions()]
    assert menu == ["&Smoothed (zero-lag, offline)", "&Live (as shown while recording)"]
    # a 5 s view: every row is drawn (no decimation), so the curve is the series itself
    n_applied = win.timeline.applied_requests
    win.timeline.set_view(10.0, 15.0)
    qtbot.waitUntil(lambda: win.timeline.applied_requests > n_applied, timeout=WAIT_MS)
    seen = {}
    for angles in ("smoothed", "live", "smoothed"):
        if angles != win.doc.angle_source:
            pick_angles(qtbot, win, angles)
        assert win.act[f"angles_{angles}"].isChecked()
        other = "live" if angles == "smoothed" else "smoothed"
        assert not win.act[f"angles_{other}"].isChecked()
        # the method in force, on screen
        assert METHOD[angles] in win.status.angles.text() and win.status.angles.isVisible()
        assert f"Angles: {METHOD[angles]}" in win.summary.text()
        # the knee lane: exactly the rows of this source in view
        x, y = drawn(knee_trace(win).path)
        rows = np.searchsorted(t_s, x)
        np.testing.assert_array_equal(t_s[rows], x)
        assert len(rows) > 400
        np.testing.assert_allclose(y, stored[angles][rows, 1], rtol=0, atol=1e-9)
        # the tilt lane (thigh) too
        tr = next(t for sp, t in win.timeline.lanes["tilt"].specs
                  if sp.series == "processed/tilt_deg" and not sp.before)  # fmt: skip
        tx, ty = drawn(tr.path)
        np.testing.assert_allclose(ty, tilt[angles][np.searchsorted(t_s, tx), 1], atol=1e-9)
        # the readout at the cursor
        win.timeline.set_cursor(12.0)
        i = int(np.argmin(np.abs(t_s - 12.0)))
        knee = f"{stored[angles][i, 1]:+.1f}"
        knee = "0.0" if float(knee) == 0.0 else knee  # a zero has no sign ("0.0", not "+0.0")
        assert f"knee {knee}°" in win.timeline.readout.text()
        # every joint lane's y range holds its curve: refitted to the angles now shown
        for key in ("hip", "knee", "ankle"):
            lane = win.timeline.lanes[key]
            tr = next(t for sp, t in lane.specs if sp.method == "kalman" and not sp.before)
            r = tr.path.boundingRect()
            y0, y1 = lane.plot.getViewBox().viewRange()[1]
            assert y0 <= r.top() and r.bottom() <= y1, (key, angles, (y0, y1), r)
        # the whole-session strip keeps this source's extremes
        _ox, oy = win.timeline.strip.curve.getData()
        assert np.nanmax(oy) == pytest.approx(stored[angles][:, 1].max(), abs=1e-4)
        assert np.nanmin(oy) == pytest.approx(stored[angles][:, 1].min(), abs=1e-4)
        # the stride table and the cycles: what gaitmon info and the report compute from a
        # session reading the same angles
        with open_session(session_file) as s:
            s.use_angles(angles)
            ref = analyse_session(s).rows
        assert [r.stride for r in win.analysis.rows] == [r.stride for r in ref]
        np.testing.assert_array_equal([r.knee_peak_swing_deg for r in win.analysis.rows],
                                      [r.knee_peak_swing_deg for r in ref])  # fmt: skip
        np.testing.assert_array_equal([r.rom_deg for r in win.analysis.rows],
                                      [r.rom_deg for r in ref])  # fmt: skip
        peaks = table_column(win, KNEE_PEAK_COL)
        assert peaks == [f"{r.knee_peak_swing_deg:.1f}".replace("-0.0", "0.0") for r in ref]
        seen[angles] = (peaks, table_column(win, KNEE_ROM_COL), win.cycles.mean[1].getData()[1])
        included = [r.stride for r in ref if r.included]
        mean = np.mean([np.interp(np.linspace(s.start_idx, s.end_idx, 101),
                                  np.arange(len(t_s)), stored[angles][:, 1])
                        for s in included], axis=0)  # fmt: skip
        np.testing.assert_allclose(seen[angles][2], mean, atol=1e-6)
    assert seen["smoothed"][0] != seen["live"][0]  # the table changed with the angles
    assert not np.allclose(seen["smoothed"][2], seen["live"][2], atol=0.1)


def test_a_tilt_mode_session_has_no_angle_switch(qtbot, win, tilt_file, tmp_path):
    p = tmp_path / "tilt.h5"
    shutil.copyfile(tilt_file, p)
    open_and_wait(qtbot, win, p)
    assert win.doc.angle_sources == ("live",) and win.doc.angle_source == "live"
    assert not win.act["angles_smoothed"].isEnabled()
    assert not win.act["angles_live"].isEnabled()
    assert win.act["angles_live"].isChecked()
    assert "the unit's own" in win.status.angles.text()
    win.jobs.set_angles("smoothed")  # e.g. a stale shortcut: refused in one line, nothing breaks
    assert win.doc.angle_source == "live" and win.act["angles_live"].isChecked()
    assert "has only" in win.statusBar().currentMessage()


def test_the_export_dialog_exports_the_angles_shown(qtbot, win, session_file, tmp_path):
    stored = {a: _stored(session_file, a) for a in STORED}
    open_and_wait(qtbot, win, session_file)
    for angles in ("smoothed", "live"):
        if angles == "live":
            pick_angles(qtbot, win, "live")
        win.outputs.export_dialog()
        dlg = win.outputs.export
        assert METHOD[angles] in dlg.angles_label.text()
        dlg.set_format("csv")
        out = tmp_path / f"{angles}.csv"
        dlg.output_edit.setText(str(out))
        with qtbot.waitSignal(dlg.export_finished, timeout=WAIT_MS):
            dlg.export_button.click()
        dlg.close()
        # the window's status line says what was written, in words (it printed a tuple of paths)
        status = win.statusBar().currentMessage()
        assert status.startswith("Exported ") and f"to {out.name}" in status, status
        meta = json.loads(out.with_suffix(".meta.json").read_text())
        assert meta["angles"] == {"source": angles, "method": METHOD[angles],
                                  "live_method": METHOD["live"]}  # fmt: skip
        data = np.genfromtxt(out, delimiter=",", names=True)
        knee = next(n for n in data.dtype.names if n.startswith("knee") and "acc" not in n
                    and "gyro" not in n)  # fmt: skip
        np.testing.assert_allclose(data[knee], stored[angles][:, 1], atol=1e-4)


def test_the_reprocess_dialog_offers_the_live_method_and_q_r_only_for_the_papers(
    qtbot, win, session_file
):
    from gaitmon.commands.process import PAPER_ONLY as CLI_PAPER_ONLY
    from gaitmon.reprocessing import PAPER_ONLY

    assert PAPER_ONLY == CLI_PAPER_ONLY  # the dialog follows gaitmon process's rule
    open_and_wait(qtbot, win, session_file)
    win.outputs.reprocess_dialog()
    dlg = win.outputs.settings_dialog
    assert dlg.method == "gait-aware"  # as recorded
    assert "do not depend on these settings" in dlg.angles_note.text().replace("\n", " ") or (
        "not on these settings" in dlg.angles_note.text())
    assert dlg.angles_note.isVisible()
    assert not any(dlg.edits[k].isEnabled() for k in PAPER_ONLY)
    assert dlg.edits["cutoff_hz"].isEnabled()
    dlg.method_combo.setCurrentIndex(dlg.method_combo.findData("paper"))
    assert all(dlg.edits[k].isEnabled() for k in PAPER_ONLY)
    dlg.edits["r"].setText("0.1")
    with qtbot.waitSignal(win.reprocessed, timeout=60_000):
        dlg.accept()  # OK: the reprocessing runs with the paper's filter and that R
    assert dlg.config is not None
    assert dlg.config.tilt_method == "paper" and dlg.config.r == pytest.approx(0.1)
    assert win.doc.reprocessed.config == dlg.config
    # back to gait-aware: R is the one in force again (the gait-aware filter does not read it)
    win.outputs.reprocess_dialog()
    dlg = win.outputs.settings_dialog
    assert dlg.method == "paper" and dlg.edits["r"].text() == "0.1"  # starts from the current
    dlg.edits["r"].setText("0.02")
    dlg.method_combo.setCurrentIndex(dlg.method_combo.findData("gait-aware"))
    assert dlg.edits["r"].text() == "0.1" and not dlg.edits["r"].isEnabled()
    assert dlg.parsed().tilt_method == "gait-aware" and dlg.parsed().r == pytest.approx(0.1)
    dlg.reject()


def test_reprocessing_in_smoothed_view_keeps_the_smoothed_angles_and_takes_its_events(
    qtbot, win, session_file
):
    smoothed = _stored_smoothed(session_file)
    open_and_wait(qtbot, win, session_file)
    cfg = win.doc.recorded.config.replace(tilt_method="paper", r=0.05, fsr_threshold=1400.0)
    with qtbot.waitSignal(win.analysis_done, timeout=60_000):
        win.jobs.start_reprocess(cfg)
    rep = win.doc.reprocessed
    assert rep is not None and rep.angles == "smoothed"
    np.testing.assert_array_equal(rep.read_rows(JOINT, 0, rep.n_rows), smoothed)
    assert "do not depend on these settings" in win.statusBar().currentMessage()
    # the strides come from the reprocessing's events, their angles from the smoothed series
    assert [r.stride.start_idx for r in win.analysis.rows] == list(rep.heel_strike_idx[:-1])
    pick_angles(qtbot, win, "live")
    live = win.doc.reprocessed.read_rows(JOINT, 0, rep.n_rows)
    assert not np.allclose(live, smoothed, atol=0.5)
    assert "Kalman (paper, seed 000) (reprocessed)" in win.status.angles.text()


def test_a_flagged_force_sensor_is_a_visible_note(qtbot, win, tmp_path):
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import FSR_IDX
    from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionWriter
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import realistic_sensors, simulate

    n, dead_from, fs = 4000, 2000, 100.0
    counts = simulate(n, GaitModel(GaitConfig(seed=11)), realistic_sensors(11)).counts.copy()
    counts[dead_from:, FSR_IDX[0]] = 15  # the heel sensor's wire breaks at 20 s
    path = tmp_path / "dead_heel.h5"
    header = SessionHeader("raw", fs, config=PipelineConfig(), calibration=Calibration.identity())
    w = SessionWriter(path, header)
    pipe = Pipeline(PipelineConfig())
    for i in range(0, n, 25):
        seq = np.arange(i, min(n, i + 25), dtype=np.int64)
        adc = counts[seq]
        w.append(SampleBlock(FrameKind.RAW, seq, seq / fs, 1.7e9,
                             lost_before=np.zeros(len(seq), np.int64), adc=adc),
                 pipe.process(adc))  # fmt: skip
    close_recording(w)
    with open_session(path) as s:
        faults = s.fsr_faults
    assert [(f.sensor, f.reason) for f in faults] == [("heel", "never loads")]
    open_and_wait(qtbot, win, path)
    note = win.status.notes.text()
    assert win.status.notes.isVisible()
    assert faults[0].message() in note
    assert f"from {faults[0].decided_idx / fs:.1f} s" in note
    assert dead_from / fs < faults[0].decided_idx / fs < dead_from / fs + 10
    # reprocessed: the note is the reprocessing's own check (the same settings flag the same
    # sensor at the same row, as gaitmon process stores it); back to the recording's after
    with qtbot.waitSignal(win.analysis_done, timeout=60_000):
        win.jobs.start_reprocess(win.doc.recorded.config)
    assert win.doc.replay.fsr_faults == tuple(faults)
    assert f"reprocessed: {faults[0].message()}" in win.status.notes.text()
    with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
        win.jobs.revert_reprocessing()
    assert "reprocessed" not in win.status.notes.text() and note in win.status.notes.text()


def test_the_report_from_review_analyses_and_names_the_angles_shown(
    qtbot, win, session_file, tmp_path, monkeypatch
):
    import gaitmon.report as report

    made = []
    real = report.gather_report

    def spy(session, **kw):
        data = real(session, **kw)
        made.append((session.angle_source, data))
        return data

    monkeypatch.setattr(report, "gather_report", spy)
    open_and_wait(qtbot, win, session_file)
    pick_angles(qtbot, win, "live")
    with qtbot.waitSignal(win.report_written, timeout=60_000):
        win.jobs.write_report(tmp_path / "live.pdf")
    assert f"angles: {METHOD['live']}" in win.statusBar().currentMessage()
    source, data = made[-1]
    assert source == "live"
    chain = dict(data.settings)["Signal chain"]
    assert f"tilt: {METHOD['live']}" in chain and "RTS" not in chain
    # the figures are the window's: the same knee peaks, stride by stride
    assert [r.knee_peak_swing_deg for r in data.rows] == [
        r.knee_peak_swing_deg for r in win.analysis.rows]
    assert win.doc.session.angle_source == "smoothed"  # the window's own reader is untouched


def test_a_file_without_stored_smoothed_angles_gets_them_computed(qtbot, win, session_file):
    stored = _stored_smoothed(session_file)
    with h5py.File(session_file, "a") as f:
        del f["smoothed"]
    open_and_wait(qtbot, win, session_file)
    assert win.doc.angle_source == "smoothed"
    assert not win.doc.session.smoothed_stored
    knee = win.doc.recorded.read_rows(JOINT, 0, win.doc.n_rows)
    # computed here in float32, stored as tilts at 0.01 deg (session format 2)
    np.testing.assert_allclose(knee, stored, atol=0.01 + 1e-4)
    assert METHOD["smoothed"] in win.status.angles.text()


def test_cancel_while_switching_keeps_the_angles_shown(qtbot, win, session_file, monkeypatch):
    from PySide6.QtCore import Qt

    from gaitmon.ui.review import jobs

    reached, release = threading.Event(), threading.Event()
    real = jobs.build_overview

    def gated(doc, angles, replay=None, progress=None):
        if progress is not None:
            progress(0.1)
        reached.set()
        release.wait(30)  # the user clicks Cancel meanwhile
        return real(doc, angles, replay, progress)

    open_and_wait(qtbot, win, session_file)
    monkeypatch.setattr(jobs, "build_overview", gated)
    win.act["angles_live"].trigger()
    qtbot.waitUntil(reached.is_set, timeout=WAIT_MS)
    assert win.act["angles_live"].isChecked()  # the click shows at once
    qtbot.waitUntil(win.status.cancel_button.isVisible, timeout=WAIT_MS)
    qtbot.mouseClick(win.status.cancel_button, Qt.MouseButton.LeftButton)
    release.set()
    assert win.jobs.angles_job.wait_idle(30)
    qtbot.wait(100)  # a response that still arrived would be applied by now
    assert win.doc.angle_source == "smoothed"
    assert win.act["angles_smoothed"].isChecked() and not win.act["angles_live"].isChecked()
    assert METHOD["smoothed"] in win.status.angles.text()
    assert "cancelled" in win.statusBar().currentMessage()
    assert not win.status.progress.isVisible()
