"""Exports of a bilateral session (``gaitmon export both.h5 --format F`` without ``--side``).

On a real recorded pair (the simulator's two units, hemiparetic, 4x): each leg's files are the
``--side`` export's; the bilateral tables are ``analyse_bilateral``'s numbers and ``gaitmon
info``'s; the MAT reads back with scipy; the C3D with ezc3d, its events at the common times;
the BIDS files pass the validator's name rules; de-identification reaches every file; a damaged
file is one line.
"""

from __future__ import annotations

import csv
import itertools
import json
import re
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon.analysis import REASONS, analyse_bilateral
from gaitmon.cli import main
from gaitmon.export.tables import NO_STRIDE, PCT_MEASURES, TIME_MEASURES
from gaitmon.finish.bilateral import open_bilateral

PATIENT = "P9X7"


@pytest.fixture(scope="module")
def both(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("biexp") / "both.h5"
    rc = main(["record", "--simulate-bilateral", "--duration", "12", "--speed", "4", "-q",
               "--asymmetry", "hemiparetic", "--standing-s", "1.5", "-o", str(out),
               "--patient", PATIENT])  # fmt: skip
    assert rc == 0
    return out


@pytest.fixture(scope="module")
def analysis(both: Path) -> dict[str, object]:
    with open_bilateral(both) as b:
        an = analyse_bilateral(b)
        t = {s: b.unit(s).read("timeline/t_s") for s in b.sides}
        return {"an": an, "common": {s: np.asarray(b.common_s(s, t[s])) for s in t},
                "hs_rows": {s: b.unit(s).heel_strike_idx for s in b.sides}}


def _export(both: Path, *args: str) -> int:
    return main(["export", str(both), *args, "-q"])


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _num(cell: str) -> float:
    return float(cell) if cell else np.nan


# ---- csv ------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def csv_out(both: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("csv") / "walk.csv"
    assert _export(both, "--format", "csv", "-o", str(out)) == 0
    return out


def test_csv_writes_each_leg_as_its_side_export_does(
    both: Path, csv_out: Path, tmp_path: Path
) -> None:
    names = sorted(p.name for p in csv_out.parent.iterdir())
    assert names == ["walk_L.csv", "walk_L.meta.json", "walk_R.csv", "walk_R.meta.json",
                     "walk_bilateral.csv", "walk_bilateral.meta.json", "walk_symmetry.csv"]
    for side in ("L", "R"):
        one = tmp_path / f"{side}.csv"
        assert _export(both, "--format", "csv", "--side", side, "-o", str(one)) == 0
        assert (csv_out.parent / f"walk_{side}.csv").read_bytes() == one.read_bytes()
        got = json.loads((csv_out.parent / f"walk_{side}.meta.json").read_text())
        want = json.loads(one.with_name(f"{side}.meta.json").read_text())
        for meta in (got, want):
            meta.pop("exported_utc")
        assert got == want


def test_strides_writes_each_legs_per_stride_csv_and_the_tables(
    both: Path, tmp_path: Path, csv_out: Path
) -> None:
    out = tmp_path / "s.strides.csv"
    assert _export(both, "--format", "strides", "-o", str(out)) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "s_L.strides.csv", "s_L.strides.meta.json", "s_R.strides.csv", "s_R.strides.meta.json",
        "s_bilateral.strides.csv", "s_bilateral.strides.meta.json", "s_symmetry.strides.csv"]
    for side in ("L", "R"):
        one = tmp_path / "one" / f"{side}.strides.csv"
        one.parent.mkdir(exist_ok=True)
        assert _export(both, "--format", "strides", "--side", side, "-o", str(one)) == 0
        assert (tmp_path / f"s_{side}.strides.csv").read_bytes() == one.read_bytes()
    # the bilateral tables are the csv export's
    assert (tmp_path / "s_bilateral.strides.csv").read_bytes() == csv_out.with_name(
        "walk_bilateral.csv").read_bytes()


def test_bilateral_csv_rows_are_analyse_bilaterals(
    csv_out: Path, analysis: dict[str, object]
) -> None:
    an = analysis["an"]
    rows = _rows(csv_out.with_name("walk_bilateral.csv"))
    t = [float(r["heel_strike_common_s"]) for r in rows]
    assert t == sorted(t)  # both legs on one time line
    for side in ("L", "R"):
        mine = [r for r in rows if r["side"] == side]
        g = an.gait.side(side)  # type: ignore[attr-defined]
        assert len(mine) == len(g) == len(analysis["hs_rows"][side]) >= 6  # type: ignore[index]
        hs = np.array([float(r["heel_strike_common_s"]) for r in mine])
        np.testing.assert_allclose(hs, g.heel_strike_s, atol=1e-6)
        # the unit row: the heel strike's row in the leg's own export, at that common time
        common = analysis["common"][side]  # type: ignore[index]
        np.testing.assert_allclose(common[[int(r["unit_row"]) for r in mine]], hs, atol=1e-6)
        counted = np.array([r["counted"] == "yes" for r in mine])
        assert counted.sum() == np.isfinite(g.stride_s).sum() >= 4
        assert 1 <= (~counted).sum() <= 3  # the first and the last heel strikes at least
        for r, c in zip(mine, counted, strict=True):
            assert (r["exclusion"] == "") == c
            assert c or r["exclusion"] in (*REASONS, NO_STRIDE)
        for m, _ in TIME_MEASURES:
            got = np.array([_num(r[m]) for r in mine])
            want = getattr(g, m)
            # the rows that count: analyse_bilateral's values; the others: NaN there
            np.testing.assert_allclose(got[counted], want[counted], atol=1e-6)
            assert not np.isfinite(want[~counted]).any()
        for m in PCT_MEASURES:
            pct = np.array([_num(r[m.removesuffix("_s") + "_pct"]) for r in mine])
            np.testing.assert_allclose(pct[counted], g.pct(m)[counted], atol=1e-3)


def test_bilateral_csv_measures_by_hand(csv_out: Path) -> None:
    """Independent of the analysis: a step ends at a heel strike and starts at the other leg's
    heel strike just before it; stance is its three supports."""
    rows = _rows(csv_out.with_name("walk_bilateral.csv"))
    checked = 0
    for prev, row in itertools.pairwise(rows):
        if prev["side"] != row["side"] and row["step_s"]:
            step = float(row["heel_strike_common_s"]) - float(prev["heel_strike_common_s"])
            assert float(row["step_s"]) == pytest.approx(step, abs=2e-6)
            checked += 1
        if row["initial_double_support_s"] and row["terminal_double_support_s"]:
            parts = sum(float(row[m]) for m in ("initial_double_support_s", "single_support_s",
                                                 "terminal_double_support_s"))  # fmt: skip
            assert float(row["stance_s"]) == pytest.approx(parts, abs=5e-6)
    assert checked >= 8


def test_symmetry_csv_is_gaitmon_infos(
    both: Path, csv_out: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from gaitmon.dsp.bilateral import MEASURE_LABELS

    rows = {r["measure"]: r for r in _rows(csv_out.with_name("walk_symmetry.csv"))}
    assert main(["info", str(both)]) == 0
    out = capsys.readouterr().out
    block = out[out.index("symmetry     measure"):]
    for measure, label in MEASURE_LABELS.items():
        if measure not in rows:
            assert measure == "terminal_double_support_s"  # not in the symmetry table
            continue
        line = next(ln for ln in block.splitlines() if ln.strip().startswith(label + " ")
                    and len(ln.split()) >= 6)  # fmt: skip
        # "step time   0.504 s   0.594 s   0.848     16.5 %": left, right, SR, SI
        left, right, sr, si = (float(x) for x in re.findall(r"\d+\.\d+", line))
        r = rows[measure]
        # Both sides are the same number rounded twice: info to its printed digits, the CSV to
        # 6 (SI: 4) decimals. They can differ by both half-units, e.g. 16.15004 -> "16.2" and
        # "16.1500"; one half-unit alone fails on such a value.
        assert float(r["left_mean_s"]) == pytest.approx(left, abs=5e-4 + 5e-7 + 1e-12)
        assert float(r["right_mean_s"]) == pytest.approx(right, abs=5e-4 + 5e-7 + 1e-12)
        assert float(r["symmetry_ratio"]) == pytest.approx(sr, abs=5e-4 + 5e-7 + 1e-12)
        assert float(r["symmetry_index_pct"]) == pytest.approx(si, abs=0.05 + 5e-5 + 1e-12)
        # and by hand from the means: each of the three cells is rounded to 6 decimals, so the
        # ratio lies within half a unit of the ratio of any means within half a unit of the
        # cells. (rel=1e-5 was not that: with a right mean of 0.061 s, initial double
        # support, the three half-units reach 1.06e-5 of the ratio.)
        h = 0.5e-6
        lo_l, hi_l = float(r["left_mean_s"]) - h, float(r["left_mean_s"]) + h
        lo_r, hi_r = float(r["right_mean_s"]) - h, float(r["right_mean_s"]) + h
        assert lo_l / hi_r - h - 1e-12 <= float(r["symmetry_ratio"]) <= hi_l / lo_r + h + 1e-12
    # hemiparetic: the affected (left) leg's step is about 0.85 of the other's
    assert 0.78 < float(rows["step_s"]["symmetry_ratio"]) < 0.92
    hs = _rows(csv_out.with_name("walk_bilateral.csv"))
    n_left = sum(1 for r in hs if r["side"] == "L" and r["counted"] == "yes" and r["step_s"])
    assert int(rows["step_s"]["n_left"]) == n_left


# ---- mat ------------------------------------------------------------------------------------


def test_mat_holds_both_legs_and_the_bilateral_tables(
    both: Path, tmp_path: Path, csv_out: Path, analysis: dict[str, object]
) -> None:
    from scipy.io import loadmat

    out = tmp_path / "both.mat"
    assert _export(both, "--format", "mat", "-o", str(out)) == 0
    m = loadmat(out, squeeze_me=True, struct_as_record=False)
    assert {"L", "R", "bilateral"} <= set(m)
    for side in ("L", "R"):
        one = tmp_path / f"{side}.mat"
        assert _export(both, "--format", "mat", "--side", side, "-o", str(one)) == 0
        s1 = loadmat(one, squeeze_me=True, struct_as_record=False)["session"]
        leg = m[side]
        assert set(leg._fieldnames) == set(s1._fieldnames) | {"t_common_s"}
        for key in ("t_s", "joint_deg", "adc_count", "seq"):
            np.testing.assert_array_equal(getattr(leg, key), getattr(s1, key))
        np.testing.assert_array_equal(leg.events.heel_strike_idx, s1.events.heel_strike_idx)
        common = analysis["common"][side]  # type: ignore[index]
        np.testing.assert_allclose(leg.t_common_s, common, atol=1e-9)
        np.testing.assert_allclose(leg.events.heel_strike_t_common_s,
                                   common[leg.events.heel_strike_idx.astype(int) - 1], atol=1e-9)
    hs = m["bilateral"].heel_strikes
    rows = _rows(csv_out.with_name("walk_bilateral.csv"))
    assert list(hs.side) == [r["side"] for r in rows]
    np.testing.assert_array_equal(hs.unit_row_idx, [int(r["unit_row"]) + 1 for r in rows])
    np.testing.assert_allclose(hs.step_s, [_num(r["step_s"]) for r in rows], atol=1e-6)
    an = analysis["an"]
    sym = m["bilateral"].symmetry
    np.testing.assert_allclose(sym.symmetry_ratio, [r.ratio for r in an.gait.symmetry])  # type: ignore[attr-defined]
    assert m["bilateral"].cadence_steps_min == pytest.approx(an.gait.cadence_steps_min)  # type: ignore[attr-defined]


# ---- c3d ------------------------------------------------------------------------------------


def test_c3d_is_one_file_of_both_legs_on_the_common_time_line(
    both: Path, tmp_path: Path, analysis: dict[str, object]
) -> None:
    ezc3d = pytest.importorskip("ezc3d")
    out = tmp_path / "both.c3d"
    assert _export(both, "--format", "c3d", "-o", str(out)) == 0
    assert [p.name for p in tmp_path.iterdir()] == ["both.c3d"]
    c = ezc3d.c3d(str(out))
    p = c["parameters"]
    fs = float(p["POINT"]["RATE"]["value"][0])
    labels = list(p["POINT"]["LABELS"]["value"])
    for side in ("L", "R"):
        for name in ("HipAngles", "KneeAngles", "AnkleAngles", "BodyTilt", "FootTilt"):
            assert side + name in labels
    analogs = list(p["ANALOG"]["LABELS"]["value"])
    assert "L_heel_fsr_lp" in analogs and "R_heel_fsr_lp" in analogs
    common = analysis["common"]
    n_frames = c["data"]["points"].shape[2]
    assert n_frames == int(np.floor(max(float(v[-1]) for v in common.values()) * fs)) + 1  # type: ignore[attr-defined]
    # events: Left / Right Foot Strike at analyse_bilateral's common times (+-1 sample)
    ev = p["EVENT"]
    times = np.asarray(ev["TIMES"]["value"])
    t = times[0] * 60 + times[1] + float(p["GAITMON"]["PART_START_S"]["value"][0])
    an = analysis["an"]
    for side, ctx in (("L", "Left"), ("R", "Right")):
        for label, want in (("Foot Strike", an.heel_strike_s[side]),  # type: ignore[attr-defined]
                            ("Foot Off", an.toe_off_s[side])):  # type: ignore[attr-defined]
            sel = [k for k in range(len(t)) if ev["CONTEXTS"]["value"][k] == ctx
                   and ev["LABELS"]["value"][k] == label]  # fmt: skip
            assert len(sel) == len(want) >= 6
            np.testing.assert_allclose(np.sort(t[sel]), np.sort(want), atol=1.0 / fs)
    # the points: each unit's knee angle interpolated at the frame's common time (by hand)
    with open_bilateral(both) as b:
        for side in ("L", "R"):
            knee = b.unit(side).read("processed/joint_deg")[:, 1].astype(np.float64)
            c_s = common[side]  # type: ignore[index]
            got = c["data"]["points"][0, labels.index(side + "KneeAngles")]
            frames = np.arange(n_frames) / fs
            inside = (frames > c_s[0] + 1.0 / fs) & (frames < c_s[-1] - 1.0 / fs)
            want = np.interp(frames, c_s, knee)
            assert np.isfinite(got[inside]).all() and inside.sum() > 1000
            np.testing.assert_allclose(got[inside], want[inside], atol=2e-3)
            assert np.isnan(got[frames < c_s[0] - 1.0 / fs]).all()  # before it started


def test_a_long_c3d_is_split_into_parts_on_the_same_time_line(
    both: Path, tmp_path: Path, analysis: dict[str, object], monkeypatch: pytest.MonkeyPatch
) -> None:
    ezc3d = pytest.importorskip("ezc3d")
    from gaitmon.export.writers import c3d as one_leg_c3d

    monkeypatch.setattr(one_leg_c3d, "C3D_MAX_PART_S", 5.0)  # 500-frame parts
    out = tmp_path / "both.c3d"
    assert _export(both, "--format", "c3d", "-o", str(out)) == 0
    parts = sorted(tmp_path.glob("both_part*.c3d"))
    common = analysis["common"]
    n_frames = int(np.floor(max(float(v[-1]) for v in common.values()) * 100.0)) + 1  # type: ignore[attr-defined]
    assert len(parts) == -(-n_frames // 500) >= 3 and not out.exists()
    strikes: list[float] = []
    frames = 0
    for k, part in enumerate(parts):
        p = ezc3d.c3d(str(part))["parameters"]
        assert float(p["GAITMON"]["PART_START_S"]["value"][0]) == pytest.approx(5.0 * k)
        frames += int(p["POINT"]["FRAMES"]["value"][0])
        times = np.asarray(p["EVENT"]["TIMES"]["value"])
        t = times[0] * 60 + times[1] + 5.0 * k
        strikes += [float(x) for x, ctx, lab in zip(t, p["EVENT"]["CONTEXTS"]["value"],
                                                    p["EVENT"]["LABELS"]["value"], strict=True)
                    if ctx == "Left" and lab == "Foot Strike"]  # fmt: skip
    assert frames == n_frames
    np.testing.assert_allclose(strikes, analysis["an"].heel_strike_s["L"], atol=1e-5)  # type: ignore[attr-defined]


# ---- bids -----------------------------------------------------------------------------------


def test_bids_has_two_tracking_systems_and_one_events_file(
    both: Path, tmp_path: Path, analysis: dict[str, object]
) -> None:
    out = tmp_path / "study"
    assert _export(both, "--format", "bids", "-o", str(out), "--subject", "03") == 0
    paths = sorted("/" + p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    motion = "/sub-03/motion/sub-03_task-walk_"
    for side in ("L", "R"):
        for suffix in ("motion.tsv", "channels.tsv", "motion.json"):
            assert f"{motion}tracksys-imu{side}_{suffix}" in paths
    assert f"{motion}events.tsv" in paths and f"{motion}events.json" in paths
    bids_validator = pytest.importorskip("bids_validator")
    validator = bids_validator.BIDSValidator()
    # gaitmon's own metadata (_gaitmon.json) is hidden from validators by .bidsignore
    assert [p for p in paths if not validator.is_bids(p)
            and not p.endswith("_gaitmon.json") and p != "/.bidsignore"] == []
    folder = out / "sub-03" / "motion"
    lines = {s: (folder / f"sub-03_task-walk_tracksys-imu{s}_motion.tsv").read_text().splitlines()
             for s in ("L", "R")}  # fmt: skip
    assert len(lines["L"]) == len(lines["R"]) > 1150  # one grid, 12 s or more
    for s in ("L", "R"):
        side = json.loads((folder / f"sub-03_task-walk_tracksys-imu{s}_motion.json").read_text())
        assert side["TrackingSystemName"] == f"imu{s}"
        n_chan = len((folder / f"sub-03_task-walk_tracksys-imu{s}_channels.tsv")
                     .read_text().splitlines()) - 1  # fmt: skip
        assert {len(ln.split("\t")) for ln in lines[s]} == {n_chan}
    schema = pytest.importorskip("bidsschematools.schema").load_schema()
    required = {f for group in schema.rules.sidecars.motion.values()
                for f, level in group["fields"].items()
                if (level if isinstance(level, str) else level["level"]) == "required"}
    assert {"SamplingFrequency", "TaskName"} <= required  # (the schema read as meant)
    for s in ("L", "R"):
        sidecar = json.loads((folder / f"sub-03_task-walk_tracksys-imu{s}_motion.json")
                             .read_text())  # fmt: skip
        assert required <= set(sidecar)
    ev = _rows_tsv(folder / "sub-03_task-walk_events.tsv")
    assert list(ev[0])[:2] == list(schema.rules.tabular_data.events.Events.initial_columns)
    onsets = [float(e["onset"]) for e in ev]
    assert onsets == sorted(onsets)
    an = analysis["an"]
    for side in ("L", "R"):
        hs = [float(e["onset"]) for e in ev if e["trial_type"] == "heel_strike"
              and e["side"] == side]  # fmt: skip
        np.testing.assert_allclose(hs, an.heel_strike_s[side], atol=1e-6)  # type: ignore[attr-defined]
        for e in ev:
            if e["side"] == side:
                assert abs(int(e["sample"]) - float(e["onset"]) * 100.0) <= 0.5 + 1e-6


def _rows_tsv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f, delimiter="\t"))


# ---- de-identification, errors ----------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["csv", "strides", "mat", "c3d", "bids"])
def test_deidentified_exports_hold_no_patient_id_anywhere(
    both: Path, tmp_path: Path, fmt: str
) -> None:
    copy = tmp_path / "P9X7-walk.h5"
    shutil.copy(both, copy)
    assert main(["export", str(copy), "--format", fmt, "--deidentify", "-q"]) == 0
    written = [p for p in tmp_path.rglob("*") if p.is_file() and p != copy]
    assert len(written) >= (1 if fmt in ("mat", "c3d") else 5)
    tokens = {p.name.split("_")[0].split(".")[0] for p in written if fmt != "bids"}
    assert len(tokens) <= 1  # the legs and the tables share one random name
    with h5py.File(both, "r") as f:  # when each unit's recording was made, to the second
        created = {str(f[f"units/{s}"].attrs["created_utc"])[:19] for s in ("L", "R")}
    assert all(len(c) == 19 for c in created)
    for p in written:
        data = p.read_bytes()
        assert PATIENT.encode() not in data, p.name
        assert PATIENT not in str(p.relative_to(tmp_path))
        for c in created:
            assert c.encode() not in data and c.replace("T", " ").encode() not in data, p.name


def test_without_deidentify_the_patient_is_kept(both: Path, tmp_path: Path) -> None:
    out = tmp_path / "x.csv"
    assert _export(both, "--format", "csv", "-o", str(out)) == 0
    assert PATIENT in (tmp_path / "x_L.meta.json").read_text()


def test_existing_outputs_are_refused_and_nothing_is_written(
    both: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "w.csv"
    (tmp_path / "w_symmetry.csv").write_text("mine\n")
    assert _export(both, "--format", "csv", "-o", str(out)) == 2
    err = capsys.readouterr().err.strip()
    assert "w_symmetry.csv already exists" in err and err.count("\n") == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w_symmetry.csv"]
    assert _export(both, "--format", "csv", "-o", str(out), "--force") == 0
    assert (tmp_path / "w_symmetry.csv").read_text().startswith("measure,")


@pytest.mark.parametrize("fmt", ["csv", "mat", "c3d", "bids"])
def test_a_damaged_bilateral_file_is_one_line(
    both: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], fmt: str
) -> None:
    bad = tmp_path / "bad.h5"
    shutil.copy(both, bad)
    with h5py.File(bad, "a") as f:
        del f["sync/R/segments"]
    assert main(["export", str(bad), "--format", fmt, "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "bad.h5 is damaged" in err
    assert [p.name for p in tmp_path.iterdir()] == ["bad.h5"]


def test_a_format_that_cannot_write_both_legs_says_so_in_one_line(
    both: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A new format that writes one unit only (no ``export_units``) refuses both legs instead
    of falling through to another format's export; one leg of the file it writes."""
    from dataclasses import dataclass

    from gaitmon import export as ex
    from gaitmon.export.base import Format
    from gaitmon.export.writers import csv as csv_writer

    @dataclass(frozen=True)
    class OneUnitOnly(Format):
        def unit_writer(self, options: object) -> object:  # type: ignore[override]
            return csv_writer

    monkeypatch.setitem(ex.FORMATS, "oneunit", OneUnitOnly("oneunit", ".one.csv", "a test"))
    with pytest.raises(ex.ExportError) as err:
        ex.export_session(both, "oneunit", tmp_path / "o.one.csv")
    assert str(err.value) == ("ONEUNIT export cannot write a session of both legs; export "
                              "each leg with --side L or R")
    assert list(tmp_path.iterdir()) == []
    got = ex.export_session(both, "oneunit", tmp_path / "o.one.csv", side="L")
    want = ex.export_session(both, "csv", tmp_path / "w.csv", side="L")
    assert got.paths[0].read_bytes() == want.paths[0].read_bytes()


def test_an_event_on_a_legs_last_row_is_on_the_c3ds_last_frame() -> None:
    """The C3D's frames run to the later leg's last row (floor of its time x rate); an event
    on that row, in the last half frame, is on the last frame, not one past it (where the
    writer would drop it: CI once found 11 Foot Off events in the C3D against 12)."""
    from gaitmon.export.grid import common_grid

    fs = 100.0
    rows = {"L": np.arange(1000) / fs, "R": np.arange(1001) / fs + 0.006}  # R ends at 10.006 s
    grid = common_grid("s.h5", {"L": fs, "R": fs}, rows)
    assert grid.n_frames == 1001  # frames 0 .. 1000, the last at 10.000 s
    frames = grid.frame_of(np.array([0.0, 5.004, 10.006, rows["R"][-1]]))
    assert frames.tolist() == [0, 500, 1000, 1000]
    assert (frames < grid.n_frames).all()
