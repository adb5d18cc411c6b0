"""The bilateral session file from the command line, and the one clock fit.

``gaitmon record --simulate-bilateral`` writes one file; ``gaitmon info`` prints both legs and the
bilateral block; ``gaitmon export`` exports both legs (or one, with ``--side``); the commands
that take one unit say in one line that they cannot take both legs yet; a one-unit file opens
exactly as before.
"""

from __future__ import annotations

import re
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers import parts_with_late_rows

from gaitmon.cli import main
from gaitmon.dsp.clock_fit import ClockFit, envelope_line, fit_clock
from gaitmon.engine.markers import RecentEnvelope
from gaitmon.finish import open_session
from gaitmon.finish.bilateral import open_bilateral, parts_of


@pytest.fixture(scope="module")
def both(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bi") / "both.h5"
    rc = main(["record", "--simulate-bilateral", "--duration", "12", "--speed", "4",
               "--asymmetry", "hemiparetic", "-o", str(out), "-q", "--patient", "P9"])  # fmt: skip
    assert rc == 0
    return out


def test_record_writes_one_file_with_both_units_and_their_clock_fits(both: Path) -> None:
    assert both.exists() and not parts_of(both)
    assert not list(both.parent.glob("*.partial")) and not list(both.parent.glob("*.journal"))
    with h5py.File(both, "r") as f:
        assert bool(f.attrs["bilateral"]) and f.attrs["sides"] == "L R"
        assert bool(f.attrs["complete"]) and not bool(f.attrs["recovered"])
        for side, serial in (("L", 1001), ("R", 1002)):
            u = f[f"units/{side}"]
            # the whole single-unit layout, copied: raw counts, processed series, truth
            for name in ("raw/adc", "timeline/t_s", "timeline/host_time_s", "events/heel_strike",
                         "smoothed/tilt_deg", "truth/heel_strike"):  # fmt: skip
                assert name in u, name
            assert u["device"].attrs["serial"] == serial
            assert u["session"].attrs["side"] == side and u["session"].attrs["patient_id"] == "P9"
            seg = f[f"sync/{side}/segments"][()]
            # host seconds per unit second: 1/4 at 4x real time, give or take the crystal
            # (50 ppm) and a loaded machine's scheduler: a reader that lags more at the end
            # of the 3 wall seconds than at the start stretches the line by a few ms (0.1 %)
            assert len(seg) == 1 and seg["host_s_per_unit_s"][0] == pytest.approx(0.25, rel=1e-2)
        assert f["sync"].attrs["host_s_per_common_s"] == pytest.approx(0.25, rel=1e-2)


def test_info_prints_both_legs_and_the_symmetry(
    both: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["info", str(both)]) == 0
    out = capsys.readouterr().out
    assert "gaitmon bilateral session (both legs)" in out and ", complete" in out
    assert "left leg (L):" in out and "right leg (R):" in out
    assert out.count("strides      ") == 2  # each side's usual lines
    assert "(measured: both legs' steps)" in out
    for label in ("step time", "stance", "swing", "double supp. initial", "terminal",
                  "single supp.", "SR (L/R)"):  # fmt: skip
        assert label in out, label
    row = next(ln for ln in out.splitlines() if ln.strip().startswith("step time") and " s " in ln
               and "SR" not in ln and len(ln.split()) >= 6)  # fmt: skip
    sr = float(row.split()[-3])
    assert 0.78 < sr < 0.92  # the affected (left) leg's step is 0.85 of the other's


# (gaitmon report FILE of both legs makes the bilateral report: tests/test_report_bilateral.py)


def test_export_without_a_side_exports_both_legs(both: Path, tmp_path: Path) -> None:
    """(It was refused; tests/test_bilateral_export.py checks the files' contents.)"""
    out = tmp_path / "b.csv"
    assert main(["export", str(both), "--format", "csv", "-o", str(out), "-q"]) == 0
    assert {p.name for p in tmp_path.glob("*.csv")} == {
        "b_L.csv", "b_R.csv", "b_bilateral.csv", "b_symmetry.csv"}


def test_export_takes_one_side(both: Path, tmp_path: Path) -> None:
    out = tmp_path / "left.csv"
    assert main(["export", str(both), "--format", "csv", "--side", "L", "-o", str(out), "-q"]) == 0
    with open_session(both, side="L") as s:
        n = s.n_samples
    assert len(out.read_text().splitlines()) == n + 1


def test_side_on_a_one_unit_file_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    one = tmp_path / "one.h5"
    assert main(["record", "--simulate", "--speed", "max", "--duration", "3", "-o", str(one),
                 "-q"]) == 0  # fmt: skip
    with open_session(one) as s:  # opens exactly as before
        assert s.n_samples >= 300 and s.unit_side == ""
    assert main(["report", str(one), "--side", "L", "-o", str(tmp_path / "r.pdf")]) == 2
    assert "records one unit; leave --side out" in capsys.readouterr().err


def test_open_bilateral_maps_both_units_onto_one_time_line(both: Path) -> None:
    with open_bilateral(both) as b:
        assert b.sides == ("L", "R")
        firsts = [float(b.common_s(s, b.unit(s).read("timeline/t_s")[0])) for s in b.sides]
        assert min(firsts) == pytest.approx(0.0, abs=1e-9)  # t = 0: the first sample of either
        assert max(firsts) < 4.0  # the units started one after the other (4x real time)
        # the common time line runs at the units' mean clock: the simulator's 4x is scaled out
        for s in b.sides:
            t = b.unit(s).read("timeline/t_s")
            span = float(b.common_s(s, t[-1]) - b.common_s(s, t[0]))
            assert span == pytest.approx(t[-1] - t[0], rel=2e-3)
            assert t[-1] - t[0] >= 11.9


# ---- the one clock fit ----------------------------------------------------------------------


def _stamps(n: int, fs: float, slope: float, a: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Receive times: a line plus a delay that is never negative (and often 0), with reads that
    collect several frames (they share the last one's time)."""
    rng = np.random.default_rng(seed)
    k = np.arange(n, dtype=np.float64)
    delay = np.where(rng.random(n) < 0.3, 0.0, rng.exponential(0.008, n))
    h = a + slope * k / fs + delay
    for i in range(0, n - 3, 7):  # a read of 3 frames: all stamped with the last one's time
        h[i : i + 3] = h[i + 2]
    return k / fs, h


def test_fit_clock_finds_the_line_under_the_delays() -> None:
    slope = 1.0 / (1.0 + 37e-6)  # a unit 37 ppm fast
    x, h = _stamps(100 * 600, 100.0, slope, 1234.5, seed=1)
    fit = fit_clock(x, h)
    assert len(fit.x0_s) == 10  # one line per 60 s
    true = 1234.5 + slope * x
    err = fit.host_at(x) - true
    assert np.abs(err).max() < 0.5e-3  # within half a millisecond everywhere
    assert (fit.mean_slope / slope - 1.0) * 1e6 == pytest.approx(0.0, abs=2.0)
    assert fit.residual_p50_ms > 0


def test_the_live_marker_clock_uses_the_same_fit() -> None:
    x, h = _stamps(3000, 100.0, 1.0, 50.0, seed=2)
    k = np.round(x * 100).astype(np.int64)
    clock = RecentEnvelope(100.0, window_s=30.0)
    clock.add(k, h)
    a, b = envelope_line((k - k[-1]).astype(float), h - h[-1], 0.01, 100.0)
    got = clock.k_at(60.0)
    assert got == pytest.approx(k[-1] + (60.0 - h[-1] - a) / b, abs=1e-9)
    assert got == pytest.approx(1000.0, abs=0.2)  # host 60.0 s is the sample taken at 10 s


def test_each_leg_keeps_its_own_exclusions(
    both: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import shutil

    from gaitmon.analysis import analyse_bilateral
    from gaitmon.io.session.exclusions import Exclusion, save

    copy = tmp_path / "both.h5"
    shutil.copy(both, copy)
    with open_session(copy, side="L") as s:
        n, created = s.n_samples, s.created_utc
    # the left leg's middle excluded (a turn): its file is FILE.L.review.json
    written = save(copy.with_name("both.h5.L"), [Exclusion(n // 3, 2 * n // 3, "turn")],
                   created, n)  # fmt: skip
    assert written.name == "both.h5.L.review.json"
    with open_bilateral(copy) as b:
        an = analyse_bilateral(b)
        assert an.sides["L"].n_user_excluded > 0 and an.sides["R"].n_user_excluded == 0
        assert an.sides["L"].side_file.name == "both.h5.L.review.json"
        # the left heel strikes inside the range count in no bilateral measure
        t = b.unit("L").read("timeline/t_s")
        lo, hi = (float(b.common_s("L", t[i])) for i in (n // 3, 2 * n // 3))
        g = an.gait.left
        inside = (g.heel_strike_s > lo + 1.2) & (g.heel_strike_s < hi - 1.2)
        assert inside.any() and not np.isfinite(g.stride_s[inside]).any()
        # those outside still count (a 12-s walk: first, last and the turn leave one or two)
        assert np.isfinite(g.stride_s[~inside]).sum() >= 1
    assert main(["info", str(copy)]) == 0
    assert "user-excluded range from both.h5.L.review.json" in capsys.readouterr().out


def test_record_from_two_ports(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from gaitmon.io.sim.bilateral import BilateralConfig, serve_pair_on_ptys

    out = tmp_path / "ports.h5"
    with serve_pair_on_ptys(BilateralConfig(speed=4.0, standing_s=1.0)) as pty:
        left, right = (str(p) for p in pty.link_paths)
        assert main(["record", "--ports", f"{left},{right}", "--duration", "6", "-o", str(out),
                     "-q"]) == 0  # fmt: skip
        assert "warning" not in capsys.readouterr().err
        # swapped: each unit says which leg it is configured for
        assert main(["record", "--ports", f"{right},{left}", "--duration", "2", "-o",
                     str(tmp_path / "swapped.h5"), "-q"]) == 0  # fmt: skip
        err = capsys.readouterr().err
        assert "recorded as the L leg (serial 1002) says it is worn on R" in err
    with open_bilateral(out) as b:
        for side, port in (("L", left), ("R", right)):
            u = b.unit(side)
            assert u.device["transport"] == port and u.device["side"] == side
            # --duration is of the unit's clock, rows received and frames lost (a pty at 4x on
            # a loaded machine loses some: 258 rows + gaps were seen)
            assert u.n_samples + sum(g.n_lost for g in u.gaps) >= 590
            assert u.n_samples >= 100
    assert main(["record", "--ports", f"{left},{left}", "--duration", "6", "-o",
                 str(tmp_path / "x.h5")]) == 2  # fmt: skip
    assert "--ports needs two different ports" in capsys.readouterr().err


def test_parts_left_beside_a_combined_file_are_removed(both: Path, tmp_path: Path) -> None:
    import shutil

    from gaitmon.finish.bilateral import part_path

    copy = tmp_path / "both.h5"
    shutil.copy(both, copy)
    for side in "LR":  # the process died while deleting the parts, after the combine
        part_path(copy, side).write_bytes(b"left over")
    with open_bilateral(copy) as b:
        assert b.complete and b.sides == ("L", "R")
    assert not parts_of(copy)


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--simulate", "--asymmetry", "hemiparetic"], "--asymmetry: only with --simulate-bilat"),
        (["--simulate-bilateral", "--speed", "max"], "--speed max is not available"),
        (["--simulate-bilateral", "--side", "L"], "--side names the leg of one unit"),
        (["--simulate-bilateral", "--lsl-markers", "Stim"], "--lsl-markers are not available with"),
    ],
)
def test_bilateral_record_options_are_checked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], words: str
) -> None:
    out = tmp_path / "x.h5"
    assert main(["record", *args, "--duration", "5", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and err.count("\n") == 0
    assert not list(tmp_path.iterdir())  # nothing written


# ---- a fit bent by late receive times ---------------------------------------------------------


def _true_common_s(f: h5py.File, side: str) -> np.ndarray:
    """The simulator's common time of each row of that leg (its crystal clock: the truth)."""
    from gaitmon.io.sim.bilateral import DEFAULT_LEFT, DEFAULT_RIGHT

    clock = (DEFAULT_LEFT if side == "L" else DEFAULT_RIGHT).clock
    n = f[f"units/{side}/truth/sample_idx"][()].astype(np.float64)
    return np.asarray([clock.common_time_s(k, 100.0) for k in n])


def _parts_with_late_rows(both: Path, target: Path, side: str, shift_s: float = 0.0) -> None:
    """``helpers.parts_with_late_rows`` with receive times made from the truth (each row's
    simulated common time)."""
    parts_with_late_rows(both, target, side, shift_s, _true_common_s)


def test_a_fit_bent_by_late_rows_takes_the_other_legs_rate_and_says_so(
    both: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A loaded host (`--speed 12`) read one unit's link late for most of a recording: the lower
    # envelope of its receive times then ran from its prompt first second to the late end,
    # a clock 20 % slow against the other's; its leg stretched on the common time line by up
    # to a second and the bilateral measures were wrong with no word said (SI 19 % between
    # equal stride times)
    from gaitmon.finish.combine import combine_parts

    out = tmp_path / "late.h5"
    _parts_with_late_rows(both, out, "R")
    combine_parts(out)
    with open_bilateral(out) as b, h5py.File(out, "r") as f:
        # the right leg's data was late: it is the one refitted, at the left leg's rate
        assert b.sync["R"].mean_slope == pytest.approx(b.sync["L"].mean_slope, rel=1e-12)
        assert "right unit's data arrived late" in b.clock_warning
        assert f["sync"].attrs["warning"] == b.clock_warning
        err = {}
        for s in ("L", "R"):
            t = b.unit(s).read("timeline/t_s")
            err[s] = np.asarray(b.common_s(s, t)) - _true_common_s(f, s)
        # both legs on the simulator's common time line (one offset for both, as the line's 0
        # is the first sample): within 2 ms of the truth (the old fit: 0.1 to 0.8 s off)
        off = np.median(err["L"])
        assert np.abs(err["L"] - off).max() < 2e-3
        assert np.abs(err["R"] - off).max() < 2e-3
    assert main(["info", str(out)]) == 0
    assert "  warning      the units' clock fits disagreed by" in capsys.readouterr().out


def test_two_units_clocks_disagree_by_their_crystals_only() -> None:
    from gaitmon.dsp.clock_fit import MAX_PAIR_PPM, pair_disagreement_ppm

    xl, hl = _stamps(100 * 120, 100.0, 1.0 / (1.0 + 37e-6), 10.0, seed=3)
    xr, hr = _stamps(100 * 120, 100.0, 1.0 / (1.0 - 22e-6), 10.3, seed=4)
    ppm = pair_disagreement_ppm(fit_clock(xl, hl), fit_clock(xr, hr))
    assert ppm == pytest.approx(59.0, abs=5.0)  # the left unit runs 37 + 22 ppm faster
    assert abs(ppm) < MAX_PAIR_PPM


def test_info_says_when_the_legs_were_recorded_together_briefly(
    both: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Each unit's recording starts as its unit is started, one after the other, and holds
    # --duration of its own clock: at --speed 12 on a loaded machine the right leg started
    # 6-18 s after the left of 12 s, and info printed blank step and support cells unexplained
    from gaitmon.finish.combine import combine_parts

    out = tmp_path / "apart.h5"
    _parts_with_late_rows(both, out, "", shift_s=8.0)
    combine_parts(out)
    with open_bilateral(out) as b, h5py.File(out, "r") as f:
        assert b.clock_warning == ""
        truth = {s: _true_common_s(f, s) for s in ("L", "R")}
        together = min(truth["L"][-1], truth["R"][-1] + 8.0) - max(truth["L"][0],
                                                                  truth["R"][0] + 8.0)
        assert b.together_s() == pytest.approx(together, abs=2e-3)
        late = truth["R"][0] + 8.0 - truth["L"][0]
        assert b.span_s("R")[0] - b.span_s("L")[0] == pytest.approx(late, abs=2e-3)
    assert 0.0 < together < 5.0
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    got = re.search(r"  together     both legs recorded together for ([\d.]+) s only: the right "
                    r"unit's recording started ([\d.]+) s after the left unit's", text)
    assert got is not None, text
    # info's 1 decimal: half its last digit, plus the 2 ms above
    assert float(got[1]) == pytest.approx(together, abs=0.05 + 2e-3)
    assert float(got[2]) == pytest.approx(late, abs=0.05 + 2e-3)


def test_a_unit_whose_rows_were_all_read_at_once_is_combined(tmp_path: Path) -> None:
    """A unit's rows all stamped with one receive time (a short recording read in one burst
    on a loaded machine): its end-to-end rate is 0, which was its fit's slope, and the combine
    then divided by it (CI: "cannot write a.h5 (float division by zero)" from a 1-s
    `record --simulate-bilateral`). Its fit now runs at the other leg's rate."""
    from helpers import TWO_LEGS

    from gaitmon.finish.bilateral import part_path
    from gaitmon.finish.combine import combine_parts

    out = tmp_path / "burst.h5"
    parts_with_late_rows(TWO_LEGS, out, "")
    with h5py.File(part_path(out, "L"), "r+") as g:
        h = g["timeline/host_time_s"]
        h[...] = np.full(h.shape, float(h[-1]))
    x = np.arange(500) / 100.0
    assert fit_clock(x, np.full(500, 7.0)).mean_slope > 0  # (old: 0.0)
    combine_parts(out)
    with open_bilateral(out) as b:
        assert b.sync["L"].mean_slope == pytest.approx(b.sync["R"].mean_slope, rel=1e-12)
        assert "left unit's data arrived late" in b.clock_warning


def test_fits_shorter_than_10_s_are_not_judged_and_longer_ones_allow_for_the_reads() -> None:
    """Two 1-s recordings at 1x, both links working, gave fits 2e5 ppm apart (their slopes are
    their first reads'): such fits are not judged. Over longer spans the limit is two crystals
    plus what 20 ms of read floor can tilt two fits over the host's span."""
    from gaitmon.dsp.clock_fit import MAX_PAIR_PPM, READ_FLOOR_S, bent_pair_ppm

    def fit(seconds: float, host_per_unit: float) -> ClockFit:
        x, h = _stamps(round(100 * seconds), 100.0, host_per_unit, 10.0, seed=2)
        return fit_clock(x, h)

    assert np.isnan(bent_pair_ppm(fit(5.0, 1.0), fit(60.0, 1.0)))
    assert bent_pair_ppm(fit(20.0, 1.0), fit(60.0, 1.0)) == pytest.approx(
        MAX_PAIR_PPM + 4 * READ_FLOOR_S / 19.99 * 1e6, rel=1e-2)  # fmt: skip
    # a simulator at 4x: 20 s of its clock is 5 s of the host's
    assert bent_pair_ppm(fit(20.0, 0.25), fit(60.0, 0.25)) == pytest.approx(
        MAX_PAIR_PPM + 4 * READ_FLOOR_S / (19.99 / 4) * 1e6, rel=1e-2)  # fmt: skip
