"""Issue 25's walk-through, scripted: the clinician's path through the real windows.

The live window connects to the simulated unit (through the real decoder, 3x real time),
zeroes, walks, records ~30 s with a link cut of a few seconds in it, stops, records a second
walk; the review window opens the first, writes its report; ``gaitmon info``, the strides
export and ``compare`` read it; then both legs (the live two-leg window, record, review's Both
legs tab, the two-leg report) and one leg again in a fresh window. Along the path:

* nothing on screen older than its data: no current-stride line from before the cut, the Gait
  panel's count is the recording's, figures marked stale while no data comes, no banner left
  from the cut once the link is back, nothing of the connection left drawn after it;
* one number everywhere: the recording's strides, cadence, stride time, stance, stride length,
  speed, duration, side and zero source read the same in the live window (at Stop), ``info``,
  review, the report's PDF (pdftotext), the strides export and ``compare``'s PDF;
* no text cut short: every visible label, the status bar's message and every table cell of
  each window visited fits its drawn width (tests/walkthrough_checks.py), and the PDFs hold
  the whole values (no "…").

Each live session is recorded once by a fixture driving the real windows, read by one test;
the ``check_*`` steps assert on what the windows showed (at 1400 x 860, and at 854 x 774 while
recording). ``GAITMON_WALK_SHOTS=DIR`` saves each window's picture and the PDFs.
"""

from __future__ import annotations

import csv
import json
import math
import re
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from PySide6.QtCore import QSettings
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QApplication, QWidget
from walkthrough_checks import (
    WAIT_S,
    Truth,
    current_points,
    drawn_after_gap,
    gaitmon_threads,
    keep,
    number,
    pdf_text,
    record_dialog,
    settled_cut_text,
    shot,
    show_at_default_size,
    sim_action,
    truncated_words,
    truth_of,
    wait_threads_gone,
    wait_until,
)

from gaitmon.cli import main

SPEED = 3.0  # the simulated unit's time factor
CUT_S = 2.0  # wall seconds the link is cut (the stale mark comes after 1 s): ~6 s of the unit's
needs_pdftotext = pytest.mark.skipif(
    shutil.which("pdftotext") is None, reason="pdftotext (poppler-utils) is not installed"
)


def cli(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    capsys.readouterr()
    assert main(list(args)) == 0, args
    return capsys.readouterr().out


@dataclass
class Seen:
    """What the windows showed along the live path (the tests assert on it)."""

    cut: dict[str, list[str]] = field(default_factory=dict)  # window state -> texts cut short
    values: dict[str, str] = field(default_factory=dict)  # what a label said at a moment
    facts: dict[str, object] = field(default_factory=dict)  # observations to assert on


@dataclass
class OneLeg:
    walk: Path  # ~30 s with a link cut
    second: Path  # a second walk (for compare)
    settings: Path  # the live window's settings file
    seen: Seen


def look(seen: Seen, window: QWidget, name: str) -> None:
    seen.cut[name] = settled_cut_text(window)
    shot(window, name)


def look_narrow(seen: Seen, window: QWidget, name: str) -> None:
    """:func:`look` at 854 x 774 (a small screen), then back to the default size."""
    window.resize(854, 774)
    QApplication.processEvents()
    seen.facts[f"{name} width"] = window.width()
    look(seen, window, name)
    show_at_default_size(window)


def stop_and_save(win) -> str:
    win.act_record.trigger()
    assert not win.recording
    wait_until(lambda: not win.saving, "the file to be finished")
    return win.statusBar().currentMessage()


@pytest.fixture(scope="module")
def one_leg(qapp, tmp_path_factory) -> OneLeg:
    """The live one-leg path: connect, zero, walk, record with a link cut, stop, a second
    walk. What the window showed is kept in ``seen``."""
    from gaitmon.io.sim.config import SimConfig
    from gaitmon.live.connection import SIMULATED_PORT
    from gaitmon.ui.live import MainWindow

    d = tmp_path_factory.mktemp("walk")
    ini = d / "settings" / "gaitmon.ini"
    ini.parent.mkdir()
    seen = Seen()
    threads = gaitmon_threads()
    win = MainWindow(QSettings(str(ini), QSettings.Format.IniFormat),
                     sim=SimConfig(standing_s=math.inf, speed=SPEED),
                     autoconnect=SIMULATED_PORT, mode="raw", confirm_close=False,
                     confirm_unzeroed=True)  # fmt: skip
    show_at_default_size(win)
    panel = win.gait_panel
    try:
        wait_until(lambda: win.engine is not None, "the connection")
        wait_until(lambda: win.engine.samples_total >= 200, "2 s of samples")
        look(seen, win, "live-1-connected")
        win.act_zero.trigger()  # the subject stands (standing_s = inf) until told to walk
        wait_until(lambda: win.guide.state.zeroed, "the Zero")
        seen.values["zero hint"] = win.guide.hint_text
        look(seen, win, "live-2-zeroed")
        sim_action(win, "Walk again").trigger()  # Device ▸ Simulator ▸ Walk again, as hinted
        wait_until(lambda: win.engine.snapshot(0.05).gait.n_strides >= 3, "walking")
        look(seen, win, "live-3-walking")

        walk = d / "walk.h5"
        record_dialog(win, walk, patient="P025", side="L")
        wait_until(lambda: panel.strides_name.text() == "Strides (this recording)",
                   "the recording's count")  # fmt: skip
        rows = lambda: win.engine.snapshot(0.05).recording.rows  # noqa: E731
        wait_until(lambda: rows() >= 1200, "12 s recorded")
        wait_until(lambda: current_points(win) > 5, "a current stride drawn")
        look(seen, win, "live-4-recording")
        look_narrow(seen, win, "live-4-recording-854")

        # the link cut: while no data comes the panel says so and draws no current stride
        win.device_part.cut_simulated_link(CUT_S)
        wait_until(lambda: win.status.state_text.startswith("Reconnecting"), "the cut")
        wait_until(lambda: panel.stale_text().startswith("⚠ stale: no data"),
                   "the stale mark")  # fmt: skip
        wait_until(lambda: current_points(win) == 0, "the current stride to go")
        seen.facts["greyed in the cut"] = [k for k in ("cadence", "speed", "stride", "stance")
                                           if not panel.values[k].isEnabled()]  # fmt: skip
        seen.values["banner in the cut"] = (
            win.status.link_banner.text() if win.status.link_banner.isVisible() else ""
        )
        look(seen, win, "live-5-cut")
        wait_until(lambda: win.status.state_text == "Connected", "the reconnect")
        at = win.engine.samples_total
        wait_until(lambda: win.engine.samples_total >= at + 300, "3 s after the cut")
        wait_until(lambda: panel.stale_text() == "" and current_points(win) > 5,
                   "fresh figures after the cut")  # fmt: skip
        after = []
        for _ in range(10):  # a few ticks' snapshots, each what the panel draws from
            after.append(drawn_after_gap(win.engine.snapshot()))
            QTest.qWait(25)
        seen.facts["current stride after the gap"] = all(after)
        seen.values["banner after the cut"] = (
            win.status.link_banner.text() if win.status.link_banner.isVisible() else ""
        )
        look(seen, win, "live-6-after-cut")

        wait_until(lambda: rows() >= 2800, "28 s recorded")
        # the patient stops walking (Device ▸ Simulator ▸ Stand still), then Stop: the panel's
        # figures are final (its count the recording's), and marked stale
        sim_action(win, "Stand still").trigger()
        wait_until(lambda: panel.stale_text().startswith("⚠ stale: last stride"), "standing")
        wait_until(lambda: current_points(win) == 0, "no stride in progress while standing")
        seen.values["stale standing"] = panel.stale_text()
        seen.facts["greyed standing"] = [k for k in ("cadence", "speed", "stride", "stance")
                                         if not panel.values[k].isEnabled()]  # fmt: skip
        look(seen, win, "live-7-standing")
        for key, label in panel.values.items():
            seen.values[f"panel {key}"] = label.text()
        seen.values["panel strides name"] = panel.strides_name.text()
        seen.values["status zero"] = win.status.method_label.text()
        seen.values["status rec"] = win.status.rec_label.text()
        seen.facts["live strides (engine)"] = panel.recording_start.strides(
            win.engine.snapshot(0.05).gait
        )
        seen.values["saved"] = stop_and_save(win)
        seen.facts["after Stop: current stride after the gap"] = drawn_after_gap(
            win.engine.snapshot()
        )
        seen.values["after Stop strides name"] = panel.strides_name.text()
        seen.facts["after Stop record banner"] = win.status.record_banner.isVisible()
        look(seen, win, "live-8-stopped")

        sim_action(win, "Walk again").trigger()
        n = win.engine.snapshot(0.05).gait.n_strides
        wait_until(lambda: win.engine.snapshot(0.05).gait.n_strides >= n + 3, "walking again")
        second = d / "second.h5"
        record_dialog(win, second)  # the dialog remembers the patient and the side
        # 12 s (~10 strides): compare needs its figures, not a long walk (was 25 s: ~4 s of
        # the suite's longest test at 3x)
        wait_until(lambda: rows() >= 1200, "the second walk")
        seen.values["saved second"] = stop_and_save(win)
        win.disconnect_device()
        wait_until(lambda: win.engine is None, "the disconnect")
        seen.facts["points after disconnect"] = current_points(win)
        look(seen, win, "live-9-disconnected")
        seen.facts["errors"] = list(win.errors)
    finally:
        win.close()
    wait_threads_gone(threads)
    return OneLeg(walk, second, ini, seen)


# -- the live window, one leg ------------------------------------------------------------------


def check_live_window_shows_nothing_older_than_its_data(one_leg: OneLeg) -> None:
    seen = one_leg.seen
    assert seen.facts["errors"] == []
    assert "Simulator ▸ Walk again" in seen.values["zero hint"]  # how the subject walks
    # in the cut: the figures greyed, the banner says no data comes
    assert seen.facts["greyed in the cut"] == ["cadence", "speed", "stride", "stance"]
    assert seen.values["banner in the cut"].startswith("Connection to the unit lost"), \
        seen.values  # fmt: skip
    # the link back: no banner left of the cut, no current stride from before it
    assert seen.values["banner after the cut"] == ""
    assert seen.facts["current stride after the gap"]
    # at Stop the panel counted this recording's strides; after it, the connection's again
    assert seen.values["panel strides name"] == "Strides (this recording)"
    assert seen.values["after Stop strides name"] == "Strides (since connect)"
    # standing before Stop: the figures greyed and said to be old, no stride in progress
    assert seen.values["stale standing"].startswith("⚠ stale: last stride")
    assert seen.facts["greyed standing"] == ["cadence", "speed", "stride", "stance"]
    assert seen.facts["after Stop: current stride after the gap"]
    assert not seen.facts["after Stop record banner"]
    assert seen.facts["points after disconnect"] == 0  # nothing of the connection drawn


def check_live_window_text_is_not_cut(one_leg: OneLeg) -> None:
    cut = {state: texts for state, texts in one_leg.seen.cut.items() if texts}
    assert cut == {}
    assert one_leg.seen.facts["live-4-recording-854 width"] == 854  # nothing forces it wider


# -- one number everywhere ---------------------------------------------------------------------


def truth_of_walk(one_leg: OneLeg) -> Truth:
    t = truth_of(one_leg.walk)
    # the recording is what the path made: a cut in it, the side entered, a standing Zero
    assert t.gaps == 1, t
    assert t.side == "left" and t.zero == "standing calibration", t
    assert t.n_total >= 20 and t.n_included >= 15, t
    return t


def check_live_panel_at_stop_agrees_with_the_file(one_leg: OneLeg, truth: Truth) -> None:
    v = one_leg.seen.values
    # the subject stood before Stop: the count the panel showed is the file's strides, the
    # one across the cut (when the cut began inside a stride: "crosses a gap") included
    assert int(v["panel strides"]) == truth.n_total, (v["panel strides"], truth)
    assert one_leg.seen.facts["live strides (engine)"] == truth.n_total
    # the saved line's duration is the stored one, as info and the report say it
    assert f", {truth.duration})" in v["saved"], v["saved"]
    assert f"zero: {truth.zero}" in v["status zero"], v["status zero"]
    # the panel's cadence and speed are of the last strides (the tooltip says so): the
    # simulated walk is steady, so they lie within 3 % of the recording's, and the text
    # within half its last digit of them (cadence in whole steps/min, speed to 0.01 m/s)
    cadence = float(number(v["panel cadence"], r"([\d.]+) steps/min"))
    assert abs(cadence - truth.cadence) <= 0.03 * truth.cadence + 0.5 + 1e-9, \
        (cadence, truth.cadence)  # fmt: skip
    speed = float(number(v["panel speed"], r"([\d.]+) m/s"))
    assert abs(speed - truth.speed_m_s) <= 0.03 * truth.speed_m_s + 0.005 + 1e-12, \
        (speed, truth.speed_m_s)  # fmt: skip


def info_expected(t: Truth) -> list[str]:
    return [
        f", {t.duration}, ",
        f"side {t.side}",
        f"strides      {t.n_included} included, {t.n_total - t.n_included} excluded",
        f"stride time {t.stride_s:.2f} s",
        f"stance {t.stance_pct:.1f} %",
        f"cadence {t.cadence:.0f} steps/min",
        f"stride length {t.length_m:.2f} ±",
        f"gait speed {t.speed_m_s:.2f} ±",
        f"zero: {t.zero}",
    ]


def check_info_says_the_recordings_figures(one_leg: OneLeg, truth: Truth, capsys) -> None:
    info = cli(capsys, "info", str(one_leg.walk))
    missing = [e for e in info_expected(truth) if e not in info]
    assert missing == [], info
    assert "1 gap" in info and "0 reconnects" not in info.split("link")[0]


def check_strides_export_holds_the_same_strides(one_leg: OneLeg, truth: Truth, tmp_path,
                                               capsys) -> None:  # fmt: skip
    out = tmp_path / "walk.strides.csv"
    line = cli(capsys, "export", str(one_leg.walk), "--format", "strides", "-o", str(out))
    assert f"exported {truth.n_total} strides" in line, line
    with open(out, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == truth.n_total
    inc = [r for r in rows if r["status"] == "included"]
    assert len(inc) == truth.n_included

    # a figure that cannot be computed (the stride at the cut has no length) is the marker
    # the side file names: every other cell is a number
    meta = json.loads(out.with_name("walk.strides.meta.json").read_text(encoding="utf-8"))
    missing = meta["strides"]["missing_value"]

    numeric = [k for k in rows[0] if k != "status"]
    cells = [r[k] for r in rows for k in numeric]
    not_numbers = [c for c in cells if c != missing and not re.fullmatch(r"-?\d+(\.\d+)?", c)]
    assert not_numbers == [], (missing, sorted(set(not_numbers)))

    def mean(key: str) -> float:
        vals = [float(r[key]) for r in inc if r[key] != missing]
        return sum(vals) / len(vals)

    # the export's per-stride values (rounded) average to the summary's figures
    assert mean("stride_s") == pytest.approx(truth.stride_s, abs=0.0006)
    assert mean("stance_pct") == pytest.approx(truth.stance_pct, abs=0.06)
    assert mean("stride_length_m") == pytest.approx(truth.length_m, abs=0.006)
    assert mean("speed_m_s") == pytest.approx(truth.speed_m_s, abs=0.006)
    assert 120.0 / mean("stride_s") == pytest.approx(truth.cadence, rel=0.002)


def summary_text(win) -> str:
    from PySide6.QtGui import QTextDocument

    doc = QTextDocument()
    doc.setHtml(win.summary.text())
    return " ".join(doc.toPlainText().split())


def check_review_and_its_report_say_the_same(one_leg: OneLeg, truth: Truth, review_win, qtbot,
                                            tmp_path) -> None:  # fmt: skip
    w = review_win
    with qtbot.waitSignal(w.analysis_done, timeout=WAIT_S * 1000):
        w.open_file(one_leg.walk)
    qtbot.waitUntil(lambda: w.timeline.applied_requests > 0, timeout=WAIT_S * 1000)
    msg = w.statusBar().currentMessage()
    assert f"({truth.duration})" in msg and f"side {truth.side}" in msg and "1 gap" in msg, msg
    assert f"zero: {truth.zero}" in w.status.angles.text()
    text = summary_text(w)
    t = truth
    for want in (f"Strides analysed {t.n_included} of {t.n_total} "
                 f"({t.n_total - t.n_included} excluded)",
                 f"Stride time {t.stride_s:.3f} ± {t.stride_sd_s:.3f} s",
                 f"Stance {t.stance_pct:.1f} % of stride",
                 f"Cadence (derived) {t.cadence:.0f} steps/min",
                 f"Stride length {t.length_m:.2f} ±",
                 f"Gait speed {t.speed_m_s:.2f} ±"):  # fmt: skip
        assert want in text, (want, text)
    assert w.table.model().rowCount() == t.n_total
    qtbot.wait(100)
    shot(w, "review-1-walk")
    assert settled_cut_text(w) == []
    # File ▸ Report from the review: the PDF says the same
    pdf = tmp_path / "walk.pdf"
    with qtbot.waitSignal(w.report_written, timeout=WAIT_S * 1000):
        w.jobs.write_report(pdf)
    keep(pdf)
    rep = pdf_text(pdf)
    for want in ("SIDE MEASURED", f"{t.duration} (", f"Strides analysed {t.n_included} of "
                 f"{t.n_total} ({t.n_total - t.n_included} excluded)",
                 f"Stride time {t.stride_s:.2f} ± {t.stride_sd_s:.2f} s",
                 f"Cadence (derived) {t.cadence:.0f} steps/min",
                 f"Stance / swing {t.stance_pct:.1f} %",
                 f"Stride length, speed {t.length_m:.2f} ± ", f"m, {t.speed_m_s:.2f} ± ",
                 f"zero: {t.zero}", "walk.h5", "1 gap"):  # fmt: skip
        assert want in rep, (want, rep)
    assert t.side in rep.split("SIDE MEASURED")[1][:300]
    assert truncated_words(rep) == []


def check_compare_says_the_same(one_leg: OneLeg, truth: Truth, tmp_path, capsys) -> None:
    pdf = tmp_path / "compare.pdf"
    cli(capsys, "compare", str(one_leg.walk), str(one_leg.second), "-o", str(pdf))
    keep(pdf)
    text = pdf_text(pdf)
    t, t2 = truth, truth_of(one_leg.second)
    assert t2.side == t.side and t2.zero == t.zero  # the dialog remembered the side
    for want in ("walk.h5", "second.h5", t.duration, t2.duration,
                 f"Strides included {t.n_included} of {t.n_total} {t2.n_included} of "
                 f"{t2.n_total}",
                 f"Stride time (s) {t.stride_s:.2f} ± {t.stride_sd_s:.2f}",
                 f"Cadence (derived) (steps/min) {t.cadence:.0f} ±",
                 f"Stance (% of cycle) {t.stance_pct:.1f} ±",
                 f"Stride length (m) {t.length_m:.2f} ±",
                 f"Gait speed (m/s) {t.speed_m_s:.2f} ±"):  # fmt: skip
        assert want in text, (want, text)
    assert truncated_words(text) == []


# -- both legs, then one leg again -------------------------------------------------------------


@dataclass
class TwoLegs:
    path: Path
    settings: Path  # the window's settings file (a one-leg window opens on it next)
    seen: Seen


@pytest.fixture(scope="module")
def two_legs(qapp, tmp_path_factory) -> TwoLegs:
    """The live two-leg window: connect the simulated pair, zero while both stand, record
    ~20 s of walking, stop."""
    from gaitmon.io.sim.bilateral import BilateralConfig
    from gaitmon.live.pair import PairSource
    from gaitmon.ui.live import MainWindow

    seen = Seen()
    threads = gaitmon_threads()
    config = BilateralConfig(standing_s=15.0, speed=SPEED)
    d = tmp_path_factory.mktemp("both")
    ini = d / "settings" / "gaitmon.ini"
    ini.parent.mkdir()
    win = MainWindow(QSettings(str(ini), QSettings.Format.IniFormat),
                     pair_sim=config, pair=PairSource(sim=config), mode="raw",
                     confirm_close=False, confirm_unzeroed=True)  # fmt: skip
    show_at_default_size(win)
    path = d / "both.h5"
    try:
        wait_until(lambda: win.pair is not None, "both legs connected")
        engines = win.pair.engines
        wait_until(lambda: min(e.samples_total for e in engines.values()) >= 100, "samples")
        win.act_zero.trigger()  # while both stand (15 s of the pair's time)
        wait_until(lambda: all(e.snapshot(0.05).calibrated for e in engines.values()),
                   "both legs zeroed", window=win)  # fmt: skip
        wait_until(lambda: min(e.snapshot(0.05).gait.n_strides for e in engines.values()) >= 3,
                   "both legs walking")  # fmt: skip
        record_dialog(win, path, patient="P025")
        rows = lambda: min(e.snapshot(0.05).recording.rows for e in engines.values())  # noqa: E731
        wait_until(lambda: rows() >= 2000, "20 s of both legs")
        look(seen, win, "live-both-recording")
        look_narrow(seen, win, "live-both-recording-854")
        seen.values["saved"] = stop_and_save(win)
        look(seen, win, "live-both-stopped")
        seen.facts["errors"] = list(win.errors)
    finally:
        win.close()
    wait_threads_gone(threads)
    return TwoLegs(path, ini, seen)


def check_live_two_leg_window(two_legs: TwoLegs) -> None:
    seen = two_legs.seen
    assert seen.facts["errors"] == []
    assert seen.values["saved"].startswith("Recording saved: both legs in"), seen.values
    assert {k: v for k, v in seen.cut.items() if v} == {}
    assert seen.facts["live-both-recording-854 width"] == 854


SYMMETRY = ("step time", "stance", "terminal double support")


def check_both_legs_review_and_report_say_what_info_says(two_legs: TwoLegs, review_win, qtbot,
                                                        tmp_path, capsys) -> None:  # fmt: skip
    from PySide6.QtGui import QTextDocument

    from gaitmon.report import bilateral_report_from_file

    info = cli(capsys, "info", str(two_legs.path))
    cadence = number(info, r"cadence\s+(\d+) steps/min \(measured")
    n_l, n_r = number(info, r"strides L (\d+), R"), number(info, r"strides L \d+, R (\d+)")
    sr = {m: number(info, rf"\n\s+{m}\s+[\d.]+ s\s+[\d.]+ s\s+([\d.]+)") for m in SYMMETRY}
    assert info.count("zero: standing calibration") == 2, info  # both legs zeroed live
    assert "side left" in info and "side right" in info
    # the review's Both legs tab
    w = review_win
    with qtbot.waitSignal(w.legs.computed, timeout=WAIT_S * 1000), \
            qtbot.waitSignal(w.analysis_done, timeout=WAIT_S * 1000):  # fmt: skip
        w.open_file(two_legs.path)
    w.tabs.setCurrentIndex(1)
    qtbot.waitUntil(lambda: w.both_legs.isVisible())
    qtbot.wait(100)
    shot(w, "review-2-both-legs")
    assert settled_cut_text(w) == []
    doc = QTextDocument()
    doc.setHtml(w.both_legs.headline.text())
    head = " ".join(doc.toPlainText().split())
    assert f"cadence {cadence} steps/min" in head and f"left {n_l}, right {n_r}" in head, head
    for m in SYMMETRY:
        assert w.both_legs.cell(m, "SR (L/R)") == sr[m], m
    # the two-leg report
    pdf = tmp_path / "both.pdf"
    cli(capsys, "report", str(two_legs.path), "-o", str(pdf), "-q")
    keep(pdf)
    rep = pdf_text(pdf)
    assert truncated_words(rep) == []
    assert f"Cadence (measured) {cadence} steps/min" in rep, rep
    assert f"Strides counted left {n_l} of" in rep and f"right {n_r} of" in rep, rep
    for m in SYMMETRY:
        assert re.search(rf"{m}( [\d.–]+){{4}} {re.escape(sr[m])} ", rep), (m, sr[m], rep)
    assert "zero: standing calibration" in rep
    flat = " ".join(subprocess.run(["pdftotext", str(pdf), "-"], capture_output=True,
                                   text=True, check=True).stdout.split())  # fmt: skip
    devices = bilateral_report_from_file(two_legs.path).units
    assert devices in flat, devices  # whole, though it wraps


def check_one_leg_again_in_a_fresh_window(settings: Path, qtbot) -> None:
    from gaitmon.io.sim.config import SimConfig
    from gaitmon.live.connection import SIMULATED_PORT
    from gaitmon.ui.live import MainWindow

    win = MainWindow(QSettings(str(settings), QSettings.Format.IniFormat),
                     sim=SimConfig(standing_s=0.0, speed=SPEED), autoconnect=SIMULATED_PORT,
                     mode="raw", confirm_close=False)  # fmt: skip
    show_at_default_size(win)
    try:
        assert win.gait_dock.isVisible() and win.gait_dock.toggleViewAction().isChecked()
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_S * 1000)
        qtbot.waitUntil(lambda: win.gait_panel.values["strides"].text() not in ("", "—", "0"),
                        timeout=WAIT_S * 1000)  # fmt: skip
        qtbot.waitUntil(lambda: current_points(win) > 5, timeout=WAIT_S * 1000)
        assert win.gait_panel.strides_name.text() == "Strides (since connect)"
        assert not win.pair_part.view.isVisible() if win.pair_part.view else True
        qtbot.wait(100)
        shot(win, "live-10-one-leg-again")
        assert settled_cut_text(win) == []
        assert win.errors == []
    finally:
        win.close()


@needs_pdftotext
def test_one_leg_path_shows_nothing_stale_one_number_and_no_cut_text(
    one_leg: OneLeg, review_win, qtbot, tmp_path, capsys
) -> None:
    """Live (at Stop), info, the strides export, review, its report and compare of one walk:
    one test, so that its live session is recorded once however the suite is spread over
    worker processes."""
    check_live_window_shows_nothing_older_than_its_data(one_leg)
    check_live_window_text_is_not_cut(one_leg)
    truth = truth_of_walk(one_leg)
    check_live_panel_at_stop_agrees_with_the_file(one_leg, truth)
    check_info_says_the_recordings_figures(one_leg, truth, capsys)
    check_strides_export_holds_the_same_strides(one_leg, truth, tmp_path, capsys)
    check_review_and_its_report_say_the_same(one_leg, truth, review_win, qtbot, tmp_path)
    check_compare_says_the_same(one_leg, truth, tmp_path, capsys)


@needs_pdftotext
def test_both_legs_then_one_leg_again(
    two_legs: TwoLegs, review_win, qtbot, tmp_path, capsys, no_leaked_threads
) -> None:
    """The live two-leg window, review's Both legs tab and the two-leg report agree with
    info; then a one-leg window on the same settings shows its Gait panel, nothing cut."""
    check_live_two_leg_window(two_legs)
    check_both_legs_review_and_report_say_what_info_says(two_legs, review_win, qtbot,
                                                        tmp_path, capsys)  # fmt: skip
    check_one_leg_again_in_a_fresh_window(two_legs.settings, qtbot)


def test_strides_export_names_the_marker_its_missing_cells_hold(gap_recording, tmp_path,
                                                                capsys) -> None:  # fmt: skip
    """The side file's ``missing_value`` is what a cell without a figure holds (it said "-"
    while the cells held "–", so a reader told to treat "-" as missing failed on them). The
    deterministic gap recording has a stride at its gap with no length."""
    out = tmp_path / "gap.strides.csv"
    cli(capsys, "export", str(gap_recording), "--format", "strides", "-o", str(out))
    meta = json.loads(out.with_name("gap.strides.meta.json").read_text(encoding="utf-8"))
    missing = meta["strides"]["missing_value"]
    with open(out, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    cells = [r[k] for r in rows for k in r if k != "status"]
    assert missing in cells
    assert [c for c in cells if c != missing and not re.fullmatch(r"-?\d+(\.\d+)?", c)] == []
