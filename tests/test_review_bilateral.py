"""The review window on a file that records both legs, driven like a user would.

A real bilateral recording (two simulated units, a hemiparetic walk: the left step is 0.85 of the
right) is opened in the real window. The references are independent of the window: each leg as
``open_session(side=)`` and ``analyse_session`` give it, and the bilateral measures as
``analyse_bilateral`` and ``gaitmon info`` give them.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import Qt

from gaitmon.analysis import analyse_bilateral, analyse_session
from gaitmon.cli import main
from gaitmon.finish import open_session
from gaitmon.finish.bilateral import open_bilateral
from gaitmon.review.both_legs import BothLegs

WAIT_MS = 30_000


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bireview") / "both.h5"
    # 1.5 s standing (default 5, of which the recording keeps what is left once the units
    # connect: a warm process connects sooner and kept 3 of the 12 s walking, 3 strides)
    rc = main(["record", "--simulate-bilateral", "--duration", "12", "--speed", "4",
               "--asymmetry", "hemiparetic", "--standing-s", "1.5", "-o", str(out),
               "-q"])  # fmt: skip
    assert rc == 0
    return out


@pytest.fixture
def both(recorded: Path, tmp_path: Path) -> Path:
    p = tmp_path / "both.h5"  # a copy: the tests write exclusions beside it
    shutil.copyfile(recorded, p)
    return p


@pytest.fixture
def win(review_win):  # tests/conftest.py: a real window, checked for errors and left threads
    return review_win


def reference(path: Path, side: str):  # the leg as every reader of one unit sees it
    with open_session(path, side=side) as s:
        an = analyse_session(s)
        return s.n_samples, an, s.read("processed/joint_deg")


def open_and_wait(qtbot, w, path, side=None):
    with qtbot.waitSignal(w.legs.computed, timeout=WAIT_MS), \
            qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):  # fmt: skip
        w.open_file(path, side)
    qtbot.waitUntil(lambda: w.timeline.applied_requests > 0, timeout=WAIT_MS)


def statuses(w) -> list[str]:
    m = w.table.model()
    return [m.index(r, m.columnCount() - 1).data() for r in range(m.rowCount())]


def test_opens_on_the_left_leg_with_a_leg_chooser(qtbot, win, both) -> None:
    open_and_wait(qtbot, win, both)
    n_l, an_l, _ = reference(both, "L")
    assert win.doc.side == "L" and win.doc.sides == ("L", "R")
    assert win.banner_box.isHidden(), win.last_problem
    assert win.leg_bar.isVisible() and win.leg_bar.shown == "L"
    assert win.act["leg_L"].isChecked() and win.act["leg_R"].isEnabled()
    assert win.windowTitle().endswith("both.h5 — left leg")
    assert win.doc.n_rows == n_l
    assert win.table.model().rowCount() == len(an_l.rows)
    assert win.analysis.summary.n_strides == an_l.n_included
    # recorded at 4x, a busy machine can start one leg's part seconds of its clock after the
    # other's (the host behind one link): the file then says so, and so does the tab
    with open_bilateral(both) as b:
        caution = " (caution)" if b.caveats() else ""
    assert win.tabs.isTabVisible(1) and win.tabs.tabText(1) == "Both legs" + caution


def test_switching_to_the_right_leg_shows_its_traces_strides_and_cycles(
    qtbot, win, both
) -> None:
    open_and_wait(qtbot, win, both)
    _, _, joint_l = reference(both, "L")
    n_r, an_r, joint_r = reference(both, "R")
    n_applied = win.timeline.applied_requests
    with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
        qtbot.mouseClick(win.leg_bar.buttons["R"], Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: win.timeline.applied_requests > n_applied, timeout=WAIT_MS)
    assert win.doc.side == "R" and win.leg_bar.shown == "R" and win.act["leg_R"].isChecked()
    assert win.windowTitle().endswith("right leg")
    assert win.doc.n_rows == n_r
    assert win.table.model().rowCount() == len(an_r.rows)
    assert win.analysis.summary.n_strides == an_r.n_included
    assert win.cycles.strides[1].getData()[0].size == an_r.n_included * 102  # knee cycles
    # the knee trace drawn is the right unit's, row for row
    key = (win.doc.current.key, "processed/joint_deg")
    w = win.timeline.last_window[key]
    assert len(w.idx) > 100
    np.testing.assert_allclose(w.y[:, 1], joint_r[w.idx, 1], atol=1e-4)
    m = min(len(joint_l), int(w.idx.max()) + 1)
    idx = w.idx[w.idx < m]
    assert np.abs(w.y[: len(idx), 1] - joint_l[idx, 1]).max() > 5.0  # not the left knee
    assert win.timeline.trace_points("knee", "processed/joint_deg", 1) > 100


def test_the_other_leg_opens_on_the_same_stretch_and_angles(qtbot, win, both) -> None:
    open_and_wait(qtbot, win, both)
    assert win.doc.angle_source == "smoothed"
    with qtbot.waitSignal(win.angles_changed, timeout=WAIT_MS):
        win.act["angles_live"].trigger()
    win.timeline.set_view(4.0, 8.0)
    # the right leg opens (smoothed, as any file), then shows the live angles as the left did
    with qtbot.waitSignal(win.angles_changed, timeout=WAIT_MS):
        win.act["leg_R"].trigger()
    assert win.doc.side == "R" and win.doc.angle_source == "live"
    assert win.act["angles_live"].isChecked()
    # the same moments: left 4 s and 8 s on the common time line, as right unit times
    with open_bilateral(both) as b:
        t_r = b.unit("R").read("timeline/t_s")
        want = np.interp(b.common_s("L", np.array([4.0, 8.0])), b.common_s("R", t_r), t_r)
    assert win.timeline.view_range() == pytest.approx(tuple(want), abs=0.01)


def test_an_exclusion_on_the_left_is_kept_for_the_left_and_changes_only_its_numbers(
    qtbot, win, both
) -> None:
    open_and_wait(qtbot, win, both)
    before = win.both_legs.result
    assert before is not None
    t = win.doc.t_s
    rows = win.analysis.rows
    t0 = 0.5 * (t[rows[3].stride.start_idx] + t[rows[3].stride.end_idx])
    t1 = 0.5 * (t[rows[5].stride.start_idx] + t[rows[5].stride.end_idx])
    win.timeline.set_selection(t0, t1)
    with qtbot.waitSignal(win.legs.computed, timeout=WAIT_MS), \
            qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):  # fmt: skip
        win.act_exclude.trigger()
    # kept in FILE.L.review.json, nowhere else
    kept = both.with_name("both.h5.L.review.json")
    assert kept.exists()
    assert not both.with_name("both.h5.R.review.json").exists()
    assert not both.with_name("both.h5.review.json").exists()
    assert len(json.loads(kept.read_text())["excluded_ranges"]) == 1
    assert statuses(win)[3:6] == ["excluded: excluded range"] * 3
    # the Both legs tab: the left leg counts 3 strides fewer, the right is untouched
    after = win.both_legs.result
    assert after is not None and after is not before
    assert after.n_strides["L"] == before.n_strides["L"] - 3
    assert after.n_strides["R"] == before.n_strides["R"]
    # (a right heel strike's row counts by the right stride it opens: none was excluded)
    assert [r[3:5] for r in after.rows()] == [r[3:5] for r in before.rows()]
    assert [r[1:3] for r in after.rows()] != [r[1:3] for r in before.rows()]
    assert win.both_legs.cell("step time", "Right s") == before.rows()[0][4]
    # and it is what analyse_bilateral makes of the kept file (nothing held only in the window)
    with open_bilateral(both) as b:
        ref = analyse_bilateral(b)
    assert ref.sides["L"].n_user_excluded == 3 and ref.sides["R"].n_user_excluded == 0
    assert after.rows() == BothLegs(both, ref).rows()
    shown = [tuple(win.both_legs.table.item(r, c).text() for c in range(7)) for r in range(7)]
    assert shown == after.rows()
    # the right leg shows no exclusion; back on the left, the range is there again
    with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
        win.act["leg_R"].trigger()
    assert win.doc.side == "R" and win.doc.exclusions == []
    assert "excluded: excluded range" not in statuses(win)
    with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
        win.act["leg_L"].trigger()
    assert win.doc.side == "L" and len(win.doc.exclusions) == 1
    assert statuses(win)[3:6] == ["excluded: excluded range"] * 3


def test_the_both_legs_table_is_what_analyse_bilateral_gives_and_info_prints(
    qtbot, win, both, capsys
) -> None:
    open_and_wait(qtbot, win, both)
    panel = win.both_legs
    with open_bilateral(both) as b:
        ref = analyse_bilateral(b)
    g = ref.gait
    # SR and SI of every measure, to the digits shown, and as numbers within that rounding
    for row in g.symmetry:
        sr = panel.cell(row.label, "SR (L/R)")
        assert sr == f"{row.ratio:.3f}"
        assert float(sr) == pytest.approx(row.left / row.right, abs=5e-4 + 1e-12)
        assert panel.cell(row.label, "SI") == f"{row.index_pct:.1f} %"
    step = g.symmetry_of("step_s")
    assert 0.78 < step.ratio < 0.92  # the hemiparetic left step: 0.85 of the right
    # the same figures as gaitmon info prints them
    capsys.readouterr()
    assert main(["info", str(both)]) == 0
    lines = capsys.readouterr().out.splitlines()

    def cells(label: str) -> list[str]:
        return [panel.cell(label, c) for c in ("Left %", "Left s", "Right %", "Right s")]

    for row in g.symmetry:  # "               step time     0.506 s   0.593 s   0.854     15.8 %"
        line = next(ln for ln in lines
                    if ln.startswith(" " * 15) and ln.strip().startswith(row.label + " "))
        shown = [panel.cell(row.label, c) for c in ("Left s", "Right s", "SR (L/R)", "SI")]
        assert " ".join(shown).split() == line.split()[-7:]
    l_s, r_s = cells("step time")[1::2]
    assert any(ln.startswith("  step time    ") and f"L {l_s}, R {r_s}" in ln for ln in lines)
    for label, printed in (("stance", "  stance "), ("swing", "  swing "),
                           ("initial double support", "  double supp. initial "),
                           ("terminal double support", " " * 15 + "terminal "),
                           ("single support", "  single supp. ")):  # fmt: skip
        lp, ls, rp, rs = cells(label)
        assert any(ln.startswith(printed) and f"L {lp} ({ls}), R {rp} ({rs})" in ln
                   for ln in lines), label  # fmt: skip
    out = "\n".join(lines)
    cadence = next(ln for ln in out.splitlines() if ln.strip().startswith("cadence  ")
                   and "measured" in ln)  # fmt: skip
    assert f"cadence      {g.cadence_steps_min:.0f} steps/min" in cadence
    assert f"cadence <b>{g.cadence_steps_min:.0f}</b> steps/min" in panel.headline.text()


def test_export_report_and_filters_take_the_leg_shown(qtbot, win, both, tmp_path,
                                                       monkeypatch) -> None:  # fmt: skip
    open_and_wait(qtbot, win, both, "R")
    n_r, an_r, _ = reference(both, "R")
    # export: the right leg, named as gaitmon export --side R names it
    win.act["export"].trigger()
    dlg = win.outputs.export
    assert dlg.side == "R" and Path(dlg.output_edit.text()).name == "both_R.csv"
    dlg.output_edit.setText(str(tmp_path / "right.csv"))
    with qtbot.waitSignal(dlg.export_finished, timeout=WAIT_MS):
        dlg.start_export()
    assert len((tmp_path / "right.csv").read_text().splitlines()) == n_r + 1
    dlg.reject()
    # report: the right leg's strides, named both_R.pdf by default
    import gaitmon.ui.report_pdf as report_pdf

    got = []
    real = report_pdf.write_report_pdf
    monkeypatch.setattr(report_pdf, "write_report_pdf",
                        lambda data, path: got.append(data) or real(data, path))  # fmt: skip
    from PySide6.QtWidgets import QFileDialog

    asked = []
    monkeypatch.setattr(QFileDialog, "getSaveFileName",
                        lambda *a: asked.append(a[2]) or ("", ""))  # fmt: skip
    win.outputs.report_dialog()
    assert Path(asked[0]).name == "both_R.pdf"
    with qtbot.waitSignal(win.report_written, timeout=60_000):
        win.jobs.write_report(tmp_path / "r.pdf")
    assert got[0].header.side == "right"
    assert got[0].summary.n_strides == an_r.n_included
    # filters: the right unit's signals and its own simulator truth
    win.act["filters"].trigger()
    fw = win.outputs.filters_window
    assert fw is not None and fw.source == (both, "R")
    fw.wait_idle()
    assert fw._has_truth and fw._n_rows == n_r
    assert win.errors == []


def test_a_reprocessed_leg_cannot_be_saved_and_the_action_says_why(qtbot, win, both) -> None:
    from gaitmon.dsp.pipeline import PipelineConfig

    open_and_wait(qtbot, win, both)
    save = win.act["save_reprocessed"]
    assert not save.isEnabled() and "both legs" in save.toolTip()
    config = PipelineConfig(**{**win.doc.session.config.as_dict(), "cutoff_hz": 6.0})
    with qtbot.waitSignal(win.reprocessed, timeout=WAIT_MS):
        win.jobs.start_reprocess(config)
    assert win.doc.reprocessed is not None  # the leg is reprocessed in memory ...
    assert not save.isEnabled() and "both legs" in save.toolTip()  # ... but not saved
    win.outputs.save_reprocessed_dialog()  # no dialog, no error: a line in the status bar
    assert not win.banner_box.isVisible()


def test_a_one_unit_file_shows_no_leg_chooser(qtbot, win, tmp_path, record_simulated) -> None:
    one = record_simulated(tmp_path / "one.h5", duration_s=8)
    with qtbot.waitSignal(win.analysis_done, timeout=WAIT_MS):
        win.open_file(one)
    assert win.doc.side == "" and win.doc.sides == ()
    assert not win.leg_bar.isVisible() and not win.tabs.isTabVisible(1)
    assert not win.act["leg_L"].isEnabled() and not win.act["leg_R"].isEnabled()
    assert win.act["save_reprocessed"].toolTip().startswith("Write a new session file")
    win.act["export"].trigger()
    assert win.outputs.export.side is None
    assert Path(win.outputs.export.output_edit.text()).name == "one.csv"
    win.outputs.export.reject()


def test_review_command_takes_a_side(both, tmp_path, monkeypatch, capsys) -> None:
    import gaitmon.ui as ui

    launched = []
    monkeypatch.setattr(ui, "launch", lambda module, args: launched.append(args) or 0)
    assert main(["review", str(both), "--side", "R"]) == 0
    assert launched[-1].side == "R" and launched[-1].file == str(both)
    assert main(["review", str(both)]) == 0 and launched[-1].side is None
    one = tmp_path / "one.h5"
    assert main(["record", "--simulate", "--speed", "max", "--duration", "2", "-o", str(one),
                 "-q"]) == 0  # fmt: skip
    capsys.readouterr()
    assert main(["review", str(one), "--side", "L"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "records one unit; leave --side out" in err


def test_the_ranges_in_force_count_even_when_no_file_keeps_them(both) -> None:
    """(Qt-free) The leg shown counts the window's ranges as given, e.g. when the folder is
    read-only and nothing could be written; the other leg counts what is kept for it."""
    from gaitmon.io.session.exclusions import Exclusion
    from gaitmon.review.both_legs import both_legs

    with open_session(both, side="R") as s:
        n = s.n_samples
    plain = both_legs(both, "R", [])
    given = both_legs(both, "R", [Exclusion(n // 3, 2 * n // 3, "turn")])
    assert not list(both.parent.glob("*.review.json"))  # nothing was written
    assert given.analysis.sides["R"].n_user_excluded > 0
    assert given.n_strides["R"] < plain.n_strides["R"]
    assert given.n_strides["L"] == plain.n_strides["L"]
