"""The review window driven like a user would, on a session recorded from the simulator.

The simulator stores its true heel strikes in ``/truth``; the stride table is checked against
them. Every test gets its own QSettings file, fails if the window caught an unexpected
exception, and fails if a review worker thread outlives the window.
"""

import hashlib
import os
import shutil
import subprocess
import sys
import threading

import h5py
import numpy as np
import pytest
from PySide6.QtCore import QMimeData, QPoint, QPointF, Qt, QUrl
from PySide6.QtGui import QDropEvent

from gaitmon.cli import main as cli_main
from gaitmon.dsp.pipeline import PipelineConfig

WAIT_MS = 20_000


def _series(path, name, angles):
    """A per-sample series as the session reader gives it with ``angles`` (smoothed | live):
    the session format derives and decodes them (docs/file-format.md, "Storage")."""
    from gaitmon.finish import open_session

    with open_session(path) as s:
        s.use_angles(angles)
        return s.read(name)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory, record_simulated):
    return record_simulated(tmp_path_factory.mktemp("rec") / "walk.h5", duration_s=40)


@pytest.fixture
def session_file(recorded, tmp_path):
    p = tmp_path / "walk.h5"
    shutil.copyfile(recorded, p)
    return p


@pytest.fixture
def win(review_win):
    return review_win  # tests/conftest.py: a real window, checked for errors and leftover threads


def open_and_wait(qtbot, w, path):
    with qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):
        w.open_file(path)
    qtbot.waitUntil(lambda: w.timeline.applied_requests > 0, timeout=WAIT_MS)


def show_angles(qtbot, w, angles):
    """View ▸ Angles ▸ Smoothed | Live, as a user picks it; waits until the strides and the
    lanes show them."""
    n = w.timeline.applied_requests
    with qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):
        w.act[f"angles_{angles}"].trigger()
    assert w.doc.angle_source == angles
    qtbot.waitUntil(lambda: w.timeline.applied_requests > n, timeout=WAIT_MS)


# where each angle source's series are stored in the file (read here with plain h5py)
STORED = {"smoothed": "smoothed/joint_deg", "live": "processed/joint_deg"}


def _md5(p):
    return hashlib.md5(p.read_bytes()).hexdigest()


def test_stride_table_matches_the_simulator_truth(qtbot, win, session_file):
    with h5py.File(session_file) as f:
        truth_hs = f["truth/heel_strike"][()]
        t_s = f["timeline/t_s"][()]
    open_and_wait(qtbot, win, session_file)
    model = win.table.model()
    # a heel strike is detected once the sensor stayed loaded past the low-pass and the minimum
    # contact (~0.15 s): a true one in the recording's last rows may not be in the file (the
    # recording stops wherever it stops), so the last true stride may or may not be there
    truth_hs = truth_hs[truth_hs < len(t_s) - 30]
    n_truth = len(truth_hs) - 1  # strides between consecutive true heel strikes
    n_rows = model.rowCount()
    assert n_rows in (n_truth, n_truth + 1)
    status = [model.index(r, model.columnCount() - 1).data() for r in range(n_rows)]
    assert status[0] == "excluded: first stride" and status[-1] == "excluded: last stride"
    assert status[1:-1] == ["included"] * (n_rows - 2)
    # every stride starts within 30 ms of a true heel strike, and its time matches the truth
    starts = np.array([float(model.index(r, 1).data()) for r in range(n_rows)])
    np.testing.assert_allclose(starts[:n_truth + 1], t_s[truth_hs[:n_rows]], atol=0.03)
    stride_s = np.array([float(model.index(r, 2).data()) for r in range(n_truth)])
    np.testing.assert_allclose(stride_s, np.diff(t_s[truth_hs]), atol=0.03)
    assert f"<b>{n_rows - 2}</b> of {n_rows}" in win.summary.text()
    assert "Cadence (derived)" in win.summary.text()
    assert win.windowTitle().endswith("walk.h5")


def test_cycle_plots_hold_101_point_curves_of_the_included_strides(qtbot, win, session_file):
    open_and_wait(qtbot, win, session_file)
    n_included = win.analysis.summary.n_strides
    for j in range(3):
        x, y = win.cycles.mean[j].getData()
        assert len(x) == 101 and x[0] == 0 and x[-1] == 100
        sx, _ = win.cycles.strides[j].getData()
        assert len(sx) == n_included * 102  # 101 points + a NaN break per stride
    # the mean knee curve is the mean of the strides normalised independently here, from the
    # series of the angles shown: the smoothed ones at open, the live ones once switched
    for angles in ("smoothed", "live"):
        if angles == "live":
            show_angles(qtbot, win, "live")
        knee = _series(session_file, "processed/joint_deg", angles)[:, 1].astype(float)
        curves = []
        for r in win.analysis.rows:
            if r.included:
                s = r.stride
                pos = np.linspace(s.start_idx, s.end_idx, 101)
                curves.append(np.interp(pos, np.arange(len(knee)), knee))
        _, y = win.cycles.mean[1].getData()
        np.testing.assert_allclose(y, np.mean(curves, axis=0), atol=1e-3)
    assert win.cycles.toe_off[1].isVisible()
    assert 55 < win.cycles.toe_off[1].value() < 65  # mean stance % of normal walking


def test_overview_and_detail_hold_points_and_keep_the_peaks(qtbot, win, session_file):
    open_and_wait(qtbot, win, session_file)
    tl = win.timeline
    assert tl.overview_points() > 100
    x0, x1 = tl.view_range()
    with h5py.File(session_file) as f:
        t = f["timeline/t_s"][()]
    knee = _series(session_file, "processed/joint_deg", "smoothed")[:, 1]  # shown at open
    n = tl.trace_points("knee", "processed/joint_deg", 1)
    assert 100 < n <= 4000
    in_view = knee[(t >= x0) & (t <= x1)]
    path = next(tr for s, tr in tl.lanes["knee"].specs if s.method == "kalman").path
    r = path.boundingRect()
    # min/max decimation keeps the extremes of the data in view (within a row at the edges)
    assert r.top() == pytest.approx(float(in_view.min()), abs=0.5)
    assert r.bottom() == pytest.approx(float(in_view.max()), abs=0.5)
    # zoom out to the whole session: the view is reloaded and still holds every peak
    n_applied = tl.applied_requests
    win.nav.show_whole()
    qtbot.waitUntil(lambda: tl.applied_requests > n_applied, timeout=WAIT_MS)
    r = next(tr for s, tr in tl.lanes["knee"].specs if s.method == "kalman").path.boundingRect()
    assert r.bottom() == pytest.approx(float(knee.max()), abs=1e-3)
    assert r.top() == pytest.approx(float(knee.min()), abs=1e-3)
    assert tl.trace_points("fsr", "processed/fsr_counts", 0) > 0


def test_clicking_a_stride_moves_the_timeline_and_the_cursor(qtbot, win, session_file):
    open_and_wait(qtbot, win, session_file)
    row = 30
    stride = win.analysis.rows[row].stride
    t = win.doc.t_s
    assert t[stride.start_idx] > win.timeline.view_range()[1]  # not in the first view
    win.table.scrollTo(win.table.model().index(row, 2))
    rect = win.table.visualRect(win.table.model().index(row, 2))
    qtbot.mouseClick(win.table.viewport(), Qt.MouseButton.LeftButton, pos=rect.center())
    x0, x1 = win.timeline.view_range()
    assert x0 < t[stride.start_idx] < t[stride.end_idx] < x1
    assert win.timeline.cursor_t_s == pytest.approx(t[stride.start_idx])
    assert f"row {stride.start_idx}" in win.timeline.readout.text()


def test_excluding_a_range_greys_its_strides_and_is_kept_beside_the_file(
    qtbot, win, session_file
):
    digest = _md5(session_file)
    open_and_wait(qtbot, win, session_file)
    rows = win.analysis.rows
    t = win.doc.t_s
    # a "turn" from the middle of stride 10 to the middle of stride 12
    t0 = 0.5 * (t[rows[10].stride.start_idx] + t[rows[10].stride.end_idx])
    t1 = 0.5 * (t[rows[12].stride.start_idx] + t[rows[12].stride.end_idx])
    win.timeline.set_selection(t0, t1)
    assert win.act_exclude.isEnabled()
    with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
        win.act_exclude.trigger()
    model = win.table.model()
    last = model.columnCount() - 1
    for r in (10, 11, 12):
        assert model.index(r, last).data() == "excluded: excluded range"
        assert model.index(r, 2).data(Qt.ItemDataRole.ForegroundRole).alpha() < 255
    assert model.index(9, last).data() == "included"
    assert model.index(13, last).data() == "included"
    assert model.index(9, 2).data(Qt.ItemDataRole.ForegroundRole) is None
    n_all = model.rowCount()
    assert win.analysis.summary.n_strides == n_all - 2 - 3
    shaded = win.timeline.lanes["knee"].shade.spans("excluded")
    assert len(shaded) == 1 and shaded[0][0] == pytest.approx(t0, abs=0.011)
    side = session_file.with_name("walk.h5.review.json")
    assert side.exists()
    assert _md5(session_file) == digest  # the recording is never written
    # reopened: the exclusion comes back from the side file
    win.close_document()
    open_and_wait(qtbot, win, session_file)
    assert win.analysis.summary.n_strides == n_all - 5
    assert model.index(11, last).data() == "excluded: excluded range"


def test_info_and_report_count_the_strides_the_review_window_counts(
    qtbot, win, session_file, capsys
):
    """Exclusions made in the window (two ranges, by its own action) reach the command line:
    ``gaitmon info`` and ``gaitmon report`` include exactly the strides the window does."""
    from gaitmon.finish import open_session
    from gaitmon.report import gather_report

    open_and_wait(qtbot, win, session_file)
    rows = win.analysis.rows
    t = win.doc.t_s
    for a, b in ((5, 6), (14, 17)):
        t0 = 0.5 * (t[rows[a].stride.start_idx] + t[rows[a].stride.end_idx])
        t1 = 0.5 * (t[rows[b].stride.start_idx] + t[rows[b].stride.end_idx])
        win.timeline.set_selection(t0, t1)
        with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
            win.act_exclude.trigger()
    in_window = win.analysis.summary.n_strides
    assert in_window == len(rows) - 2 - 2 - 4  # first/last, and the strides of both ranges
    capsys.readouterr()
    assert cli_main(["info", str(session_file)]) == 0
    assert f"  strides      {in_window} included, " in capsys.readouterr().out
    with open_session(session_file) as s:
        assert gather_report(s).summary.n_strides == in_window
    pdf = session_file.with_suffix(".pdf")
    assert cli_main(["report", str(session_file), "-o", str(pdf)]) == 0 and pdf.stat().st_size


@pytest.mark.parametrize("kind", ["garbage", "foreign", "truncated", "missing", "folder"])
def test_a_bad_file_shows_one_line_and_the_window_survives(
    qtbot, win, session_file, tmp_path, kind
):
    bad = tmp_path / f"bad_{kind}.h5"
    if kind == "garbage":
        bad.write_bytes(os.urandom(5000))
    elif kind == "foreign":
        with h5py.File(bad, "w") as f:
            f["x"] = np.arange(3)
    elif kind == "truncated":
        data = session_file.read_bytes()
        bad.write_bytes(data[: len(data) // 3])
    elif kind == "folder":
        bad.mkdir()
    with qtbot.waitSignal(win.open_failed, timeout=WAIT_MS) as sig:
        win.open_file(bad)
    msg = sig.args[0]
    assert "\n" not in msg and bad.name in msg
    assert win.banner_box.isVisible() and win.banner.text().startswith("Cannot open")
    assert win.doc is None
    open_and_wait(qtbot, win, session_file)  # and a good file still opens afterwards
    assert win.table.model().rowCount() > 0
    assert not win.banner_box.isVisible()


def test_recent_files_and_drag_and_drop(qtbot, win, session_file):
    drop = QMimeData()
    drop.setUrls([QUrl.fromLocalFile(str(session_file))])
    ev = QDropEvent(QPointF(QPoint(50, 50)), Qt.DropAction.CopyAction, drop,
                    Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier)  # fmt: skip
    with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
        win.dropEvent(ev)
    assert win.recent_files() == [str(session_file.resolve())]
    win.recent_menu.aboutToShow.emit()
    names = [a.text() for a in win.recent_menu.actions()]
    assert "walk.h5" in names


def test_reprocessing_matches_gaitmon_process_and_leaves_the_recording(
    qtbot, win, session_file, tmp_path
):
    digest = _md5(session_file)
    open_and_wait(qtbot, win, session_file)
    n_before = len(win.doc.recorded.heel_strike_idx)
    cfg = win.doc.recorded.config.replace(cutoff_hz=6.0, fsr_threshold=1400.0)
    with qtbot.waitSignal(win.analysis_done, timeout=60_000):
        win.jobs.start_reprocess(cfg)
    assert win.doc.reprocessed is not None and win.strides.before is not None
    # the independent path: the gaitmon process command on the same file
    ref = tmp_path / "ref.h5"
    assert cli_main(["process", str(session_file), "-o", str(ref), "--cutoff-hz", "6",
                     "--fsr-threshold", "1400"]) == 0  # fmt: skip
    with h5py.File(ref) as f:
        np.testing.assert_array_equal(win.doc.reprocessed.heel_strike_idx, f["events/heel_strike"])
    ref_knee = {a: _series(ref, "processed/joint_deg", a)[:, 1] for a in STORED}
    recorded_smoothed = _series(session_file, "processed/joint_deg", "smoothed")[:, 1]
    # smoothed angles shown: they do not depend on the settings, so they are the recording's,
    # and gaitmon process stores the same ones
    got = win.doc.reprocessed.read_rows("processed/joint_deg", 0, len(recorded_smoothed))[:, 1]
    np.testing.assert_array_equal(got, recorded_smoothed)
    np.testing.assert_array_equal(got, ref_knee["smoothed"])
    # the live ones: the reprocessed filter's, as gaitmon process computes them
    show_angles(qtbot, win, "live")
    got = win.doc.reprocessed.read_rows("processed/joint_deg", 0, len(ref_knee["live"]))[:, 1]
    # (the file stores the tilts at 0.01 deg, the window's replay holds float32)
    np.testing.assert_allclose(got, ref_knee["live"], rtol=0, atol=0.01 + 1e-4)
    assert not np.array_equal(got, recorded_smoothed)
    assert abs(len(win.doc.reprocessed.heel_strike_idx) - n_before) <= 2
    qtbot.waitUntil(
        lambda: win.timeline.trace_points("knee", "processed/joint_deg", 1, before=True) > 0,
        timeout=WAIT_MS,
    )
    assert "was " in win.summary.text()  # before -> after in the summary
    x, _ = win.cycles.before[1].getData()
    assert len(x) == 101
    assert _md5(session_file) == digest
    win.jobs.revert_reprocessing()
    assert win.doc.reprocessed is None


def test_review_command_without_a_display_is_one_line(tmp_path, recorded):
    env = {k: v for k, v in os.environ.items()
           if k not in ("QT_QPA_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY")}  # fmt: skip
    out = subprocess.run([sys.executable, "-m", "gaitmon", "review", str(recorded)], env=env,
                         capture_output=True, text=True, timeout=60)  # fmt: skip
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "no display" in out.stderr
    out = subprocess.run([sys.executable, "-m", "gaitmon", "review", str(tmp_path / "nope.h5")],
                         env=env, capture_output=True, text=True, timeout=60)  # fmt: skip
    assert out.returncode == 2 and "does not exist" in out.stderr
    assert "PySide6" not in out.stderr


def test_pipeline_config_in_the_dialog_is_the_recorded_one(qtbot, win, session_file):
    open_and_wait(qtbot, win, session_file)
    assert win.doc.recorded.config == PipelineConfig(**win.doc.session.config.as_dict())
    win.outputs.reprocess_dialog()
    dlg = win.outputs.settings_dialog
    assert dlg.edits["cutoff_hz"].text() == f"{win.doc.session.config.cutoff_hz:g}"
    dlg.reject()


# filters_view.py (another module) fills its table with a deprecated QTableWidgetItem overload
@pytest.mark.filterwarnings("ignore:Function.*setTextAlignment:DeprecationWarning")
def test_report_normative_band_plot_export_and_filters_are_wired(
    qtbot, win, session_file, tmp_path
):
    open_and_wait(qtbot, win, session_file)
    # normative band: the example file drawn behind the cycle plots (101 points per joint)
    example = os.path.join(os.path.dirname(__file__), "..", "docs", "normative-example.csv")
    win.strides.load_normative(example)
    assert win.strides.normative is not None and not win.banner_box.isVisible()
    x, y = win.cycles.norm_mean[1].getData()
    assert len(x) == 101
    np.testing.assert_allclose(y, win.strides.normative.mean_deg[:, 1])
    # report: a PDF with the exclusions in force
    pdf = tmp_path / "report.pdf"
    with qtbot.waitSignal(win.report_written, timeout=60_000):
        win.jobs.write_report(pdf)
    assert pdf.read_bytes()[:5] == b"%PDF-"
    # right-click ▸ Save plot as PNG / SVG on every lane
    for lane in win.timeline.lanes.values():
        texts = [a.text() for a in lane.plot.getViewBox().menu.actions()]
        assert any("PNG" in t for t in texts)
    # menus hold the other parts
    file_texts = [a.text() for a in win.file_menu.actions()]
    assert "&Export…" in file_texts and "&Report (PDF)…" in file_texts
    win.outputs.export_dialog()
    assert win.outputs.export.isVisible()
    win.outputs.export.reject()
    win.outputs.show_filters()
    assert win.outputs.filters_window is not None and win.outputs.filters_window.isVisible()
    win.outputs.filters_window.wait_idle()


def test_an_interrupted_recording_is_recovered_with_progress(qtbot, win, recorded, tmp_path):
    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.finish import close_recording
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionWriter, journal_path

    with h5py.File(recorded) as f:
        adc = f["raw/adc"][()]
    live, crashed = tmp_path / "live.h5", tmp_path / "crashed.h5"
    header = SessionHeader("raw", 100.0)
    w = SessionWriter(live, header)
    pipe = Pipeline(header.config)
    for i in range(0, len(adc), 50):
        block = adc[i : i + 50]
        seq = np.arange(i, i + len(block))
        w.append(SampleBlock(FrameKind.RAW, seq, seq / 100.0, 0.0, adc=block), pipe.process(block))
    w.flush()
    for src, dst in ((live, crashed), (journal_path(live), journal_path(crashed))):
        shutil.copyfile(src, dst)  # file + journal as a kill -9 would leave them
    close_recording(w)
    fractions = []
    win.jobs.job.progressed.connect(fractions.append)
    open_and_wait(qtbot, win, crashed)
    assert not journal_path(crashed).exists()
    assert win.doc.session.recovered and win.doc.n_rows == len(adc)
    assert fractions and max(fractions) <= 1.0
    with h5py.File(recorded) as f:
        n_truth = len(f["truth/heel_strike"]) - 1
    assert abs(win.table.model().rowCount() - n_truth) <= 1


def _reprocessed(qtbot, win, session_file):
    open_and_wait(qtbot, win, session_file)
    cfg = win.doc.recorded.config.replace(cutoff_hz=6.0, fsr_threshold=1400.0)
    with qtbot.waitSignal(win.analysis_done, timeout=60_000):
        win.jobs.start_reprocess(cfg)
    assert win.doc.reprocessed is not None


def test_save_reprocessed_shows_its_progress_on_the_bar(qtbot, win, session_file, tmp_path):
    _reprocessed(qtbot, win, session_file)
    out = tmp_path / "saved.h5"
    bar = win.status.progress
    seen: list[tuple[int, bool]] = []  # (bar value, bar shown) at each progress report
    finished: list[str] = []
    # connected after the window's own slot: sees the bar as that slot left it
    win.jobs.job.progressed.connect(lambda f: seen.append((bar.value(), bar.isVisible())))
    win.saved.connect(finished.append)
    with qtbot.waitSignal(win.saved, timeout=60_000):
        win.jobs.save_reprocessed(out)
    assert finished == [str(out)]
    assert any(value > 0 and shown for value, shown in seen)  # it moved while it ran
    assert not bar.isVisible() and f"Saved {out}" in win.statusBar().currentMessage()
    with h5py.File(out) as f:
        np.testing.assert_array_equal(f["events/heel_strike"], win.doc.reprocessed.heel_strike_idx)


def test_cancel_while_saving_reprocessed_leaves_no_file(
    qtbot, win, session_file, tmp_path, monkeypatch
):
    from gaitmon.finish.reprocess import partial_path
    from gaitmon.ui.review import jobs

    reached, release = threading.Event(), threading.Event()
    real = jobs.rewrite_processed

    def gated(src, dst, config, **kw):
        progress = kw.pop("progress")

        def slow_progress(fraction: float) -> object:
            if fraction > 0 and not reached.is_set():
                reached.set()
                release.wait(30)  # the user clicks Cancel meanwhile
            return progress(fraction)

        return real(src, dst, config, progress=slow_progress, **kw)

    monkeypatch.setattr(jobs, "rewrite_processed", gated)
    _reprocessed(qtbot, win, session_file)
    out = tmp_path / "cancelled.h5"
    win.jobs.save_reprocessed(out)
    qtbot.waitUntil(reached.is_set, timeout=30_000)
    assert partial_path(out).exists()  # midway: the copy is being written
    assert win.status.cancel_button.isVisible()
    qtbot.mouseClick(win.status.cancel_button, Qt.MouseButton.LeftButton)  # GUI thread is free
    release.set()
    assert win.jobs.job.wait_idle(30)
    assert not out.exists() and not partial_path(out).exists()
    assert sorted(p.name for p in tmp_path.iterdir() if "cancelled" in p.name) == []
    assert not win.status.progress.isVisible()
    assert "cancelled" in win.statusBar().currentMessage()
    assert not win.banner_box.isVisible()


def test_gcd_band_deviation_in_summary_and_caveat_in_tooltips(qtbot, win, session_file, tmp_path):
    from gaitmon.normative import deviation_deg, load

    open_and_wait(qtbot, win, session_file)
    assert "GVS-like" not in win.summary.text()
    gcd = os.path.join(os.path.dirname(__file__), "data", "gcd", "vicon_style_normal.gcd")
    win.strides.load_normative(gcd)
    assert not win.banner_box.isVisible()
    # the band is drawn: the knee of this file is 0, 1, ..., 100 after resampling 51 -> 101
    x, y = win.cycles.norm_mean[1].getData()
    np.testing.assert_allclose(x, np.arange(101.0))
    np.testing.assert_allclose(y, np.arange(101.0))
    # the summary names the band and gives each joint's deviation of the shown mean cycle
    text = win.summary.text()
    assert "Sagittal GVS-like deviation, deg" in text and "vicon_style_normal (GCD)" in text
    dev = deviation_deg(win.analysis.mean_deg, load(gcd))
    assert f"hip <b>{dev[0]:.1f}</b> · knee <b>{dev[1]:.1f}</b> · ankle <b>{dev[2]:.1f}</b>" in text
    assert "zeroed at the standing pose" in win.summary.toolTip()
    # the caveat where the band is drawn: every cycle plot's tooltip and the title's
    for p in win.cycles.plots:
        tip = p.toolTip()
        assert "vicon_style_normal (GCD)" in tip and "thigh relative to the trunk" in tip
    assert "licence: not stated" in win.cycles.title.toolTip()
    # removed: no deviation, no caveat
    win.strides.set_normative(None)
    assert "GVS-like" not in win.summary.text() and not win.summary.toolTip()
    assert "thigh relative" not in win.cycles.plots[0].toolTip()
    # a bad GCD: one line naming the line, the band in force is kept
    bad = tmp_path / "bad.gcd"
    bad.write_text("!KneeFlexExt 3\n1 2\nx 2\n", encoding="utf-8")
    win.strides.load_normative(bad)
    assert win.banner_box.isVisible()
    assert "bad.gcd: line 3 (variable KneeFlexExt)" in win.banner.text()
    assert win.strides.normative is None


def test_every_view_follows_the_documents_exclusions_event(qtbot, win, session_file):
    """An exclusion made through the document alone (no window slot is called) reaches the
    stride table, the summary, the timeline's shading and the status bar: they listen to its
    event; and it is kept where ``gaitmon report`` reads it."""
    from gaitmon.finish import open_session
    from gaitmon.io.session import exclusions

    open_and_wait(qtbot, win, session_file)
    rows = win.analysis.rows
    n_before = win.analysis.summary.n_strides
    a, b = rows[7].stride.start_idx + 3, rows[8].stride.end_idx - 3
    with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
        win.doc.exclude(a, b, "turn")
    model = win.table.model()
    last = model.columnCount() - 1
    assert [model.index(r, last).data() for r in (6, 7, 8, 9)] == [
        "included", "excluded: excluded range", "excluded: excluded range", "included"
    ]
    assert win.analysis.summary.n_strides == n_before - 2
    assert f"{n_before - 2}" in win.summary.text()
    shaded = win.timeline.lanes["knee"].shade.spans("excluded")
    t = win.doc.t_s
    assert len(shaded) == 1 and shaded[0][0] == pytest.approx(t[a], abs=1e-6)
    assert win.statusBar().currentMessage() == "1 excluded range, kept in walk.h5.review.json"
    with open_session(session_file) as s:
        assert exclusions.read(s) == ([exclusions.Exclusion(a, b, "turn")], "")
    with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
        win.doc.clear_exclusions()
    assert win.analysis.summary.n_strides == n_before
    assert len(win.timeline.lanes["knee"].shade.spans("excluded")) == 0


def test_a_report_being_prepared_takes_the_exclusions_made_meanwhile(
    qtbot, win, session_file, tmp_path, monkeypatch
):
    """The report job listens to the document: ranges excluded while the report is gathered
    are in the report written."""
    import gaitmon.ui.report_pdf as report_pdf

    written = []

    def fake_pdf(data, path):
        written.append(data)
        return path

    monkeypatch.setattr(report_pdf, "write_report_pdf", fake_pdf)
    open_and_wait(qtbot, win, session_file)
    rows = win.analysis.rows
    a, b = rows[4].stride.start_idx + 3, rows[4].stride.end_idx - 3
    with qtbot.waitSignal(win.report_written, timeout=WAIT_MS):
        win.jobs.write_report(tmp_path / "r.pdf")
        win.doc.exclude(a, b, "stumble")  # before the report's answer can arrive
    assert len(written) == 1
    assert [(s.reason, s.n_strides) for s in written[0].excluded_spans] == [("stumble", 1)]
