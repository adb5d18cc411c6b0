"""``gaitmon compare`` judges a change against its minimal detectable change (issue 25: it
flagged "Minimum knee −0.1 *" between two walks of one subject) and says each session's gaps
and excluded strides.

Recordings are made with ``gaitmon record --simulate`` (real HDF5 files through the real
decoder): two zeroed 60-s walks of the same simulated subject that differ only in the seed
(the stride-to-stride randomness and the sensor noise), and two that differ in the gait itself
(the stiff-knee pattern; 90 instead of 110 steps/min)."""

import re
import shutil
import subprocess
from collections import Counter

import numpy as np
import pytest

from gaitmon.analysis import SETTLING, analyse_session
from gaitmon.cli import main
from gaitmon.compare import MEASURES, compare_sessions
from gaitmon.finish import open_session

WALK = ("--zero", "--patient", "P7", "--side", "R")
WAIT_MS = 20_000


@pytest.fixture(scope="module")
def walks(tmp_path_factory, record_simulated):
    d = tmp_path_factory.mktemp("walks")

    def rec(name, *options):
        return record_simulated(d / name, *WALK, *options, duration_s=60, standing_s=3)

    return {
        "first": rec("first.h5", "--seed", "1"),
        "again": rec("again.h5", "--seed", "2"),
        "stiff": rec("stiff.h5", "--seed", "2", "--pattern", "stiff-knee"),
        "slow": rec("slow.h5", "--seed", "2", "--cadence", "90"),
    }


def _per_stride(path, key):
    """A measure's per-stride values from the session's own analysis (not the comparison)."""
    with open_session(path) as s:
        inc = [r for r in analyse_session(s).rows if r.included]
    if key == "stride_time":
        return np.array([r.stride.stride_time_s for r in inc])
    return np.array([r.knee_peak_swing_deg for r in inc])


def test_two_walks_of_one_subject_flag_no_change(qapp, walks, capsys):
    c = compare_sessions([walks["first"], walks["again"]])
    ch = c.change(1, "min_knee")
    # fails on the old rule (|Δ| > pooled SD), which flagged this change
    assert abs(ch.delta) > ch.pooled_sd
    assert ch.beyond is False
    # nothing else either: every measure's change is within its MDC95
    assert c.beyond(1) == []
    for m in MEASURES:
        if m.judged:
            assert abs(c.change(1, m.key).delta) < c.change(1, m.key).mdc, m.key
    # the terminal says so, with the rule named
    out = str(walks["first"].with_name("same.pdf"))
    assert main(["compare", str(walks["first"]), str(walks["again"]), "-o", out]) == 0
    said = capsys.readouterr().out
    assert "0 changes from the baseline beyond the minimal detectable change (MDC95" in said
    assert "Minimum knee" not in said


def test_a_real_difference_in_gait_is_flagged(qapp, walks, capsys):
    c = compare_sessions([walks["first"], walks["stiff"], walks["slow"]])
    assert [s.path.name for s in c.sessions] == ["first.h5", "stiff.h5", "slow.h5"]
    # stiff knee: peak knee flexion in swing falls far beyond its MDC95, computed here by hand
    # from the per-stride values of the two files
    a, b = _per_stride(walks["first"], "knee"), _per_stride(walks["stiff"], "knee")
    sem = np.sqrt(((len(a) - 1) * a.var(ddof=1) + (len(b) - 1) * b.var(ddof=1))
                  / (len(a) + len(b) - 2))  # fmt: skip
    ch = c.change(1, "knee_peak_swing")
    assert ch.mdc == pytest.approx(1.96 * np.sqrt(2) * sem)
    assert ch.delta == pytest.approx(b.mean() - a.mean()) and ch.delta < -15
    assert ch.beyond is True
    # slower cadence: longer strides in time, fewer steps a minute
    a, b = _per_stride(walks["first"], "stride_time"), _per_stride(walks["slow"], "stride_time")
    assert b.mean() - a.mean() > 0.15
    assert {"stride_time", "cadence"} <= set(c.beyond(2))
    assert c.change(2, "cadence").delta < -15
    # the terminal lists them, each with its threshold
    out = str(walks["first"].with_name("diff.pdf"))
    assert main(["compare", str(walks["stiff"]), str(walks["first"]), "-o", out]) == 0
    said = capsys.readouterr().out
    line = next(ln for ln in said.splitlines() if "Peak knee flexion in swing" in ln)
    assert re.search(r"-\d+\.\d deg \(MDC \d+\.\d+? deg\)", line), line


# ---- gaps and excluded strides ----


def _pdf_text(pdf):
    if not shutil.which("pdftotext"):
        pytest.skip("pdftotext (poppler-utils) is not installed")
    text = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True,
                          text=True, check=True).stdout  # fmt: skip
    return re.sub(r"\s+", " ", text)


def test_a_link_outage_and_its_excluded_strides_are_said(qapp, gap_recording, walks, tmp_path,
                                                         capsys):  # fmt: skip
    """gap_recording: the frames of 24.63-30.00 s never arrived (537 frames at 100 Hz)."""
    c = compare_sessions([gap_recording, walks["first"]])
    cut = next(s for s in c.sessions if s.path == gap_recording)
    q = cut.quality
    assert q.outages == 1 and q.outage_s == pytest.approx(5.37, abs=0.011)
    with open_session(gap_recording) as s:
        rows = analyse_session(s).rows
        side, zero = {"L": "left", "R": "right"}.get(s.meta.side, "not recorded"), s.zero_source
    reasons = Counter(r.excluded for r in rows if r.excluded)
    assert q.excluded == dict(reasons)
    assert q.excluded[SETTLING] >= 1  # the strides while the filters settle after the cut
    assert q.n_excluded == cut.n_strides_total - cut.n_included
    said = q.text()
    # the leg and the zero first (as info says them), then the link and the exclusions
    assert said.startswith(f"side {side}; zero: {zero}; 1 link outage (5.4 s); ")
    assert f"{q.n_excluded} strides excluded (first stride 1, last stride 1" in said
    assert f"settling after a gap {q.excluded[SETTLING]}" in said
    other = next(s for s in c.sessions if s.path != gap_recording).quality
    assert other.text().endswith(
        "; no link outage; 2 strides excluded (first stride 1, last stride 1)")
    # in the terminal and the PDF
    pdf = tmp_path / "gap.pdf"
    assert main(["compare", str(gap_recording), str(walks["first"]), "-o", str(pdf)]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if "gap.h5" in ln)
    assert line.endswith(said)
    text = _pdf_text(pdf)
    assert said in text and other.text() in text


def test_a_simulated_link_cut_is_said(qapp, cut_recording, walks, tmp_path, capsys):
    """cut_recording: the simulated unit's link drops for 3 s of device time (FaultConfig)."""
    with open_session(cut_recording) as s:
        lost = [g for g in s.gaps if g.reason.startswith("link lost")]
        excluded = Counter(r.excluded for r in analyse_session(s).rows if r.excluded)
    assert len(lost) == 1
    pdf = tmp_path / "cut.pdf"
    assert main(["compare", str(cut_recording), str(walks["first"]), "-o", str(pdf)]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "cut.h5" in ln)
    assert f"1 link outage ({lost[0].duration_s:.1f} s)" in line
    assert lost[0].duration_s > 2.9  # the link was gone for 3 s of device time
    assert f"{sum(excluded.values())} strides excluded" in line
    assert f"settling after a gap {excluded[SETTLING]}" in line and excluded[SETTLING] >= 1


def test_the_compare_view_says_gaps_and_thresholds(review_win, qtbot, monkeypatch,
                                                   gap_recording, walks):  # fmt: skip
    from PySide6.QtWidgets import QFileDialog

    monkeypatch.setattr(QFileDialog, "getOpenFileNames", staticmethod(
        lambda *a, **k: ([str(gap_recording), str(walks["first"])], "")))  # fmt: skip
    with qtbot.waitSignal(review_win.comparer.compared, timeout=WAIT_MS):
        review_win.act["compare_sessions"].trigger()
    view = review_win.comparer.view
    c = view.comparison
    q = next(s for s in c.sessions if s.path == gap_recording).quality
    text = view.sessions.text()
    assert "1 link outage (5.4 s)" in text
    assert f"settling after a gap {q.excluded[SETTLING]}" in text
    # every judged change shows its MDC95 beside it, and its tooltip the figures
    for r, m in enumerate(MEASURES):
        cell = view.table.item(r, 2)
        ch = c.change(1, m.key)
        if ch.beyond is None:
            assert "MDC" not in cell.text() and "not judged" in cell.toolTip()
        else:
            assert "(MDC " in cell.text(), m.key
            assert ("beyond" if ch.beyond else "within") in cell.toolTip()
            assert cell.font().bold() == ch.beyond
