"""Progress across sessions (gaitmon.compare): the comparison of a normal and a stiff-knee
session shows the changes the simulator put there, with the figures of each session's own
analysis, and the one rule for "beyond the minimal detectable change" (MDC95)."""

import math
import shutil

import numpy as np
import pytest
from conftest import write_simulated_session

from gaitmon.analysis import analyse_session
from gaitmon.compare import (
    MEASURE_BY_KEY,
    MEASURES,
    CompareError,
    Value,
    _stat,
    change_text,
    compare_sessions,
    judge_change,
    list_recordings,
    mdc95,
    pooled_sd,
)
from gaitmon.finish import open_session
from gaitmon.io.sim import GaitConfig, GaitModel
from gaitmon.report import gather_report


def own_figures(path):
    """Each session's own numbers, straight from analyse_session."""
    with open_session(path) as s:
        an = analyse_session(s)
        inc = [r for r in an.rows if r.included]
        return {
            "n": len(inc),
            "knee_peak": [r.knee_peak_swing_deg for r in inc],
            "rom": np.array([r.rom_deg for r in inc]),
            "stride_time": [r.stride.stride_time_s for r in inc],
            "report": gather_report(s),
        }


def true_knee(pattern, n=2500):
    """The simulator's true knee flexion (deg) while walking at full amplitude."""
    k = GaitModel(GaitConfig(seed=7, pattern=pattern, standing_s=2.0)).evaluate(0, n)
    knee = np.degrees(k.joint_rad[:, 1])
    return knee[k.walking > 0.999]


def test_stiff_knee_shows_as_less_knee_flexion_beyond_the_variability(normal_and_stiff_knee):
    normal, stiff = normal_and_stiff_knee
    # given newest first: the comparison orders them by recording date
    c = compare_sessions([stiff, normal])
    assert [s.path for s in c.sessions] == [normal, stiff]
    assert c.warnings == ()
    assert c.patient_id == "P001"
    base, later = c.sessions
    # every figure is the session's own analysis (and what its report shows)
    for s, path in ((base, normal), (later, stiff)):
        own = own_figures(path)
        rep = own["report"]
        assert s.values["n_strides"].n == own["n"] == rep.summary.n_strides >= 10
        assert s.values["knee_peak_swing"].mean == pytest.approx(np.mean(own["knee_peak"]))
        assert s.values["knee_peak_swing"].sd == pytest.approx(np.std(own["knee_peak"], ddof=1))
        assert s.values["knee_peak_swing"].mean == pytest.approx(rep.knee_peak_swing.mean_deg)
        assert s.values["rom_knee"].mean == pytest.approx(own["rom"][:, 1].mean())
        assert s.values["rom_knee"].mean == pytest.approx(rep.rom[1].mean_deg)
        assert s.values["stride_time"].sd == pytest.approx(np.std(own["stride_time"], ddof=1))
        assert s.values["cadence"].mean == pytest.approx(rep.summary.cadence_derived_steps_per_min)
        assert s.values["stance_pct"].mean == pytest.approx(rep.summary.stance_pct_mean)
        assert s.values["max_knee"].mean == pytest.approx(rep.peak[1].mean_deg)
        np.testing.assert_allclose(s.mean_deg, rep.mean_deg)
        np.testing.assert_allclose(s.sd_deg, rep.sd_deg)
    # the simulator's truth: stiff-knee lowers the knee's swing flexion
    true_drop = true_knee("stiff-knee").max() - true_knee("normal").max()
    assert true_drop < -15
    for key in ("knee_peak_swing", "rom_knee", "max_knee"):
        ch = c.change(1, key)
        assert ch.delta == pytest.approx(later.values[key].mean - base.values[key].mean)
        assert np.sign(ch.delta) == np.sign(true_drop), key
        assert abs(ch.delta) > 0.5 * abs(true_drop), key
        assert ch.beyond is True, key
        assert key in c.beyond(1)
    # what the pattern does not change is not flagged (same seed: same stride times, hip)
    for key in ("stride_time", "rom_hip"):
        assert c.change(1, key).beyond is False, key
    assert c.change(1, "n_strides").beyond is None  # a count is never judged


def test_the_rule_is_the_mdc95_of_the_pooled_stride_to_stride_sd():
    a, b = Value(50.0, 2.0, 11), Value(47.0, 4.0, 21)
    sem = math.sqrt((10 * 4.0 + 20 * 16.0) / 30)  # 3.4641 = sqrt(12)
    assert pooled_sd(a, b) == pytest.approx(sem)
    # by hand: 1.96 * sqrt(2) * sqrt(12) = 1.96 * sqrt(24) = 9.6020
    assert mdc95(a, b) == pytest.approx(9.6020, abs=1e-4)
    ch = judge_change(a, b)
    assert ch.delta == -3.0
    assert ch.pooled_sd == pytest.approx(sem)
    assert ch.mdc == pytest.approx(9.6020, abs=1e-4)
    assert ch.beyond is False  # |−3.0| < 9.60: larger than the SD (the old rule) but not the MDC


def test_the_rule_on_synthetic_per_stride_values():
    """Two sessions' per-stride values, the SDs and the threshold computed by hand."""
    first = [10.0, 12.0, 11.0, 13.0, 9.0]  # mean 11, squares 1 + 1 + 0 + 4 + 4 = 10, SD² 2.5
    second = [14.0, 16.0, 15.0]  # mean 15, squares 1 + 0 + 1 = 2, SD² 1
    a, b = _stat(first), _stat(second)
    assert (a.mean, a.sd**2, a.n) == pytest.approx((11.0, 2.5, 5))
    assert (b.mean, b.sd**2, b.n) == pytest.approx((15.0, 1.0, 3))
    # pooled SD² = (4 · 2.5 + 2 · 1) / 6 = 2; MDC95 = 1.96 · √2 · √2 = 3.92
    ch = judge_change(a, b)
    assert ch.pooled_sd == pytest.approx(math.sqrt(2.0))
    assert ch.mdc == pytest.approx(3.92)
    assert ch.delta == pytest.approx(4.0) and ch.beyond is True  # 4 > 3.92
    # the same spread, the later session 0.1 lower: within the MDC
    closer = _stat([v - 0.1 for v in second])
    assert judge_change(a, closer).delta == pytest.approx(3.9)
    assert judge_change(a, closer).beyond is False  # 3.9 < 3.92
    # shown beside the change, in the measure's decimals
    m = MEASURE_BY_KEY["min_knee"]
    assert change_text(ch, m) == "+4.0 (MDC 3.9)"
    assert change_text(judge_change(b, a), m, unit=True, minus="-") == "-4.0 deg (MDC 3.9 deg)"
    # equal when rounded: one more decimal shows which is larger
    assert change_text(judge_change(a, closer), m) == "+3.90 (MDC 3.92)"


def test_the_rule_flags_only_a_change_larger_than_the_mdc():
    a = Value(50.0, 2.0, 11)
    mdc = 1.96 * math.sqrt(2.0) * math.sqrt((10 * 4.0 + 20 * 16.0) / 30)
    assert not judge_change(a, Value(50.0 - 0.99 * mdc, 4.0, 21)).beyond
    assert judge_change(a, Value(50.0 + 1.01 * mdc, 4.0, 21)).beyond
    assert judge_change(a, Value(60.0, math.nan, 1)).beyond is None  # one stride: no SD
    assert judge_change(a, Value(60.0, 2.0, 5), judged=False).beyond is None


def test_three_sessions_changes_from_baseline_and_previous(normal_and_stiff_knee, tmp_path):
    normal, stiff = normal_and_stiff_knee
    third = write_simulated_session(
        tmp_path / "visit3.h5", pattern="normal", seed=8, created_utc="2026-12-01T10:00:00Z"
    )
    c = compare_sessions([third, normal, stiff])
    assert [s.path.name for s in c.sessions] == ["visit1_normal.h5", "visit2_stiff.h5", "visit3.h5"]
    base, prev = c.changes("baseline"), c.changes("previous")
    assert len(base) == len(prev) == 2
    # session 2's previous is the baseline; session 3 recovered from session 2's stiff knee
    assert prev[0]["knee_peak_swing"].delta == base[0]["knee_peak_swing"].delta
    assert prev[1]["knee_peak_swing"].delta > 15 and prev[1]["knee_peak_swing"].beyond
    k = "knee_peak_swing"
    assert base[1][k].delta == pytest.approx(
        c.sessions[2].values[k].mean - c.sessions[0].values[k].mean
    )
    assert set(base[0]) == {m.key for m in MEASURES}


def test_patient_ids_checked(normal_and_stiff_knee, tmp_path):
    normal, _ = normal_and_stiff_knee
    other = write_simulated_session(
        tmp_path / "other.h5", patient_id="P002", created_utc="2026-11-05T09:00:00Z"
    )
    c = compare_sessions([normal, other])
    assert c.patient_id == "" and c.who == "patient ids differ"
    assert any("Patient ids differ" in w and "P002 (other.h5)" in w for w in c.warnings)
    anon = write_simulated_session(
        tmp_path / "anon.h5", patient_id="", created_utc="2026-11-06T09:00:00Z"
    )
    c = compare_sessions([normal, anon])
    assert any("No patient id in anon.h5" in w for w in c.warnings)
    assert c.who == "no patient ID"
    d = compare_sessions([normal, other], deidentify=True)
    text = " ".join(d.warnings) + " ".join(s.label + s.file_name + s.patient_id for s in d.sessions)
    assert "P00" not in text and ".h5" not in text and "2026" not in text
    assert [s.recorded_utc for s in d.sessions] == ["day 0", "day 35"]
    assert d.who == "patient ids differ"  # also when the ids themselves are withheld


@pytest.mark.parametrize("case", ["one", "missing", "twice", "damaged", "tilt", "folder"])
def test_bad_inputs_are_one_line_errors(case, normal_and_stiff_knee, tmp_path,
                                        record_simulated):  # fmt: skip
    normal = normal_and_stiff_knee[0]
    if case == "one":
        paths, words = [normal], "two or more"
    elif case == "missing":
        paths, words = [normal, tmp_path / "nope.h5"], "nope.h5 does not exist"
    elif case == "twice":
        paths, words = [normal, normal], "given twice"
    elif case == "damaged":
        bad = tmp_path / "bad.h5"
        bad.write_bytes(b"not an hdf5 file at all" * 10)
        paths, words = [normal, bad], "bad.h5"
    elif case == "tilt":
        tilt = record_simulated(tmp_path / "tilt.h5", "--mode", "tilt", duration_s=6)
        paths, words = [normal, tilt], "tilt.h5: the unit's tilt mode"
    else:
        paths, words = [normal, tmp_path], "is a folder"
    with pytest.raises(CompareError) as e:
        compare_sessions(paths)
    assert words in str(e.value)
    assert "\n" not in str(e.value)


def test_a_session_with_no_included_stride_is_refused(tmp_path, normal_and_stiff_knee):
    short = write_simulated_session(tmp_path / "short.h5", n=250)  # standing only
    with pytest.raises(CompareError, match=r"short\.h5 has no stride to compare"):
        compare_sessions([normal_and_stiff_knee[0], short])


def test_patient_list_by_patient_and_date(normal_and_stiff_knee, tmp_path):
    for p in normal_and_stiff_knee:
        shutil.copy(p, tmp_path / p.name)
    write_simulated_session(
        tmp_path / "a_other.h5", patient_id="A7", created_utc="2026-12-01T09:00:00Z"
    )
    (tmp_path / "broken.h5").write_bytes(b"junk")
    (tmp_path / "notes.txt").write_text("not a session")
    rows = list_recordings(tmp_path)
    assert [r.path.name for r in rows] == [
        "a_other.h5",
        "visit1_normal.h5",
        "visit2_stiff.h5",
        "broken.h5",
    ]
    assert [r.patient_id for r in rows] == ["A7", "P001", "P001", ""]
    own = own_figures(normal_and_stiff_knee[1])
    stiff = rows[2]
    assert stiff.n_strides == own["n"]
    assert stiff.knee_peak_swing_deg == pytest.approx(np.mean(own["knee_peak"]))
    assert stiff.cadence_steps_min == pytest.approx(
        own["report"].summary.cadence_derived_steps_per_min
    )
    assert rows[1].knee_peak_swing_deg - stiff.knee_peak_swing_deg > 15
    assert rows[3].problem and not rows[2].problem
    with pytest.raises(CompareError, match="not a folder"):
        list_recordings(tmp_path / "notes.txt")


def test_ranges_excluded_in_review_count_in_the_comparison(normal_and_stiff_knee, tmp_path):
    from gaitmon.io.session import exclusions as excl

    normal, stiff = (shutil.copy(p, tmp_path / p.name) for p in normal_and_stiff_knee)
    before = compare_sessions([normal, stiff]).sessions[1].values["n_strides"].n
    with open_session(stiff) as s:
        n, created, t_s = s.n_samples, s.created_utc, s.read("timeline/t_s")
    excl.save(stiff, [excl.Exclusion(800, 1400, "turn")], created, n, t_s)
    after = compare_sessions([normal, stiff]).sessions[1]
    own = own_figures(stiff)  # analyse_session reads the same side file
    assert after.values["n_strides"].n == own["n"] < before
    assert after.n_strides_total == before + 2  # the same strides, fewer of them included


def test_sessions_of_different_legs_are_warned(normal_and_stiff_knee, tmp_path):
    left = write_simulated_session(tmp_path / "left.h5", side="L",
                                   created_utc="2026-11-20T09:00:00Z")  # fmt: skip
    c = compare_sessions([normal_and_stiff_knee[0], left])
    assert [s.side for s in c.sessions] == ["R", "L"]
    assert any("different legs: right (visit1_normal.h5), left (left.h5)" in w
               for w in c.warnings)  # fmt: skip
    assert not compare_sessions(list(normal_and_stiff_knee)).warnings
