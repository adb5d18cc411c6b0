"""The public Python API (``gaitmon.open``, README "For researchers"): its doctests, its numbers
against gaitmon's own outputs, and ``import gaitmon`` staying cheap.

The doctests run on a copy of the kept fixture ``tests/data/golden/one_leg.h5`` (a real
recording of the simulated unit with frame loss and a stored exclusion); the strides are
compared with ``gaitmon export --format strides`` of a session recorded by the real recorder.
pandas is not a dependency: the DataFrame checks skip without it, and without it
``to_data_frame`` must say so in one line.
"""

from __future__ import annotations

import csv
import doctest
import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gaitmon
from gaitmon.cli import main

GOLDEN = Path(__file__).resolve().parent / "data" / "golden"
HAS_PANDAS = importlib.util.find_spec("pandas") is not None


@pytest.fixture(scope="module")
def fixture_copy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("api")
    for p in GOLDEN.glob("one_leg.h5*"):
        shutil.copyfile(p, d / p.name)
    return d / "one_leg.h5"


@pytest.fixture(scope="module")
def walk(tmp_path_factory: pytest.TempPathFactory, record_simulated) -> Path:
    path = tmp_path_factory.mktemp("api_walk") / "walk.h5"
    return record_simulated(path, "--loss-pct", "1", "--side", "R", duration_s=25)


def test_import_gaitmon_loads_nothing_until_a_name_is_used() -> None:
    """``gaitmon --version`` and every command import the package: it must stay one small
    file (the API is imported on first use of ``gaitmon.open``)."""
    code = (
        "import sys, gaitmon\n"
        "before = sorted(m for m in sys.modules if m.split('.')[0] in "
        "('gaitmon', 'numpy', 'h5py', 'scipy'))\n"
        "f = gaitmon.open\n"
        "print(before, f.__module__, 'gaitmon.api' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()  # fmt: skip
    assert out == ["['gaitmon']", "gaitmon.api", "True"]
    assert "open" in dir(gaitmon) and "Recording" in gaitmon.__all__
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        gaitmon.nope  # noqa: B018


def test_the_docstring_examples_run(fixture_copy: Path) -> None:
    from gaitmon import api

    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    ran = 0
    for test in finder.find(api, "gaitmon.api",
                            extraglobs={"path": str(fixture_copy), "gaitmon": gaitmon, "np": np}):
        if not test.examples or ("to_data_frame" in test.name and not HAS_PANDAS):
            continue
        runner.run(test)
        ran += len(test.examples)
    result = runner.summarize(verbose=False)
    assert result.failed == 0
    assert ran >= 12  # the module's, open's and every method's examples


def test_angles_events_gaps_markers_are_the_readers(walk: Path) -> None:
    from gaitmon.finish import open_session

    with gaitmon.open(walk) as rec, open_session(walk) as s:
        assert rec.side == "R" and rec.mode == "raw" and rec.n_samples == s.n_samples
        t = s.read("timeline/t_s")
        for kind in ("smoothed", "live"):
            a = rec.angles(kind)
            view = s.with_angles(kind)
            np.testing.assert_array_equal(a.joint_deg, view.read("processed/joint_deg"))
            np.testing.assert_array_equal(a.tilt_deg, view.read("processed/tilt_deg"))
            np.testing.assert_array_equal(a.t_s, t)
            assert a.kind == kind and a.method == view.angle_method
        # the two kinds are different estimates (the smoother is zero-lag)
        assert not np.allclose(rec.angles("smoothed").joint_deg, rec.angles("live").joint_deg)
        ev = rec.events()
        np.testing.assert_array_equal(ev.heel_strike_idx, s.heel_strike_idx)
        np.testing.assert_array_equal(ev.heel_strike_s, t[s.heel_strike_idx])
        np.testing.assert_array_equal(ev.toe_off_s, t[s.toe_off_idx])
        assert len(ev.heel_strike_idx) > 10
        g = rec.gaps()
        assert len(g["n_lost"]) == len(s.gaps) > 0
        assert int(g["n_lost"].sum()) == sum(x.n_lost for x in s.gaps)
        np.testing.assert_array_equal(g["t_s"], t[g["sample_idx"]])
        assert len(rec.markers()["label"]) == len(s.markers)
        with pytest.raises(ValueError, match="kind must be one of smoothed, live"):
            rec.angles("kalman")


def test_strides_are_the_per_stride_exports_numbers(walk: Path, tmp_path: Path) -> None:
    """One truth: the API's stride table is what ``gaitmon export --format strides`` writes,
    to the export's decimals, column by column."""
    out = tmp_path / "s.strides.csv"
    assert main(["export", str(walk), "--format", "strides", "-o", str(out), "-q"]) == 0
    with open(out, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    with gaitmon.open(walk) as rec:
        st = rec.strides()
    assert len(rows) == len(st["stride_s"]) > 10
    compared = 0
    for key, column in st.items():
        if key not in rows[0]:
            continue
        for k, row in enumerate(rows):
            cell, value = row[key], column[k]
            if key == "status":
                assert cell == value
            elif cell in ("–", ""):
                assert not np.isfinite(value), (key, k)
            else:
                decimals = len(cell.split(".")[1]) if "." in cell else 0
                assert abs(float(cell) - float(value)) <= 0.5 * 10.0**-decimals + 1e-9, (key, k)
        compared += 1
    assert compared == 14  # every column of the export
    assert st["included"].sum() == sum(r["status"] == "included" for r in rows)


def test_a_session_of_both_legs_is_opened_one_leg_at_a_time(tmp_path: Path) -> None:
    from gaitmon.io.session import SessionError

    both = tmp_path / "two_legs.h5"
    shutil.copyfile(GOLDEN / "two_legs.h5", both)
    with pytest.raises(SessionError) as e:
        gaitmon.open(both)
    assert str(e.value) == ("two_legs.h5 records both legs; open one with "
                            "gaitmon.open(path, side='L') or side='R'")  # fmt: skip
    with gaitmon.open(both, side="L") as left, gaitmon.open(both, side="R") as right:
        assert (left.side, right.side) == ("L", "R")
        assert len(left.strides()["stride_s"]) > 3 and len(right.events().toe_off_idx) > 3
    with pytest.raises(ValueError, match="side must be 'L', 'R' or None"):
        gaitmon.open(both, side="left")


def test_without_pandas_to_data_frame_says_so_in_one_line(fixture_copy: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "pandas", None)  # as if not installed: import fails
    with gaitmon.open(fixture_copy) as rec, pytest.raises(ModuleNotFoundError) as e:
        rec.to_data_frame()
    assert str(e.value) == (
        "to_data_frame needs pandas, which gaitmon does not install: pip install 'gaitmon[pandas]'")


def test_data_frames_have_a_time_index_and_the_arrays(walk: Path) -> None:
    pytest.importorskip("pandas")
    with gaitmon.open(walk) as rec:
        df = rec.to_data_frame("angles", kind="live")
        a = rec.angles("live")
        assert df.index.name == "time_s"
        np.testing.assert_array_equal(df.index.to_numpy(), a.t_s)
        np.testing.assert_array_equal(df["knee_flexion_deg"].to_numpy(), a.joint_deg[:, 1])
        np.testing.assert_array_equal(df["foot_tilt_deg"].to_numpy(), a.tilt_deg[:, 3])
        ev = rec.to_data_frame("events")
        assert (ev["event"] == "heel_strike").sum() == len(rec.events().heel_strike_idx)
        assert ev.index.is_monotonic_increasing
        st = rec.to_data_frame("strides")
        np.testing.assert_array_equal(st["stride_s"].to_numpy(), rec.strides()["stride_s"])
        np.testing.assert_array_equal(st.index.to_numpy(), rec.strides()["start_s"])
        assert len(rec.to_data_frame("gaps")) == len(rec.gaps()["n_lost"])
        assert list(rec.to_data_frame("markers").columns) == ["sample_idx", "label"]
