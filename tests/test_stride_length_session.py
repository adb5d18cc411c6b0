"""Stride length and gait speed of a recorded session, as info, review, the report and exports
get them (gaitmon.analysis), against the simulator's truth of each stride."""

import h5py
import numpy as np
import pytest

from gaitmon.analysis import analyse_session
from gaitmon.finish import open_session


@pytest.fixture(scope="module")
def walk(tmp_path_factory, record_simulated):
    path = tmp_path_factory.mktemp("spatial") / "walk.h5"
    return record_simulated(path, duration_s=40, standing_s=3)


def _truth(path):
    with h5py.File(path, "r") as f:
        t = f["truth"]
        return (t["heel_strike"][()], t["stride_length_m"][()], t["stride_time_s"][()],
                t["foot_clearance_m"][()])  # fmt: skip


def test_every_included_stride_has_its_length_and_speed_within_3_percent_of_truth(walk):
    true_hs, true_len, true_time, true_clear = _truth(walk)
    with open_session(walk) as s:
        a = analyse_session(s)
    rows = [r for r in a.rows if r.included]
    assert len(rows) >= 20
    err_len, err_speed, err_clear = [], [], []
    for r in rows:
        k = int(np.argmin(np.abs(true_hs - r.stride.start_idx)))
        assert abs(int(true_hs[k]) - r.stride.start_idx) <= 3  # the same stride
        assert np.isfinite(r.stride_length_m)
        err_len.append(r.stride_length_m / true_len[k] - 1)
        err_speed.append(r.speed_m_s / (true_len[k] / true_time[k]) - 1)
        err_clear.append(r.foot_clearance_m - true_clear[k])
    assert np.median(np.abs(err_len)) <= 0.03 and np.median(np.abs(err_speed)) <= 0.03
    assert np.median(np.abs(err_clear)) <= 0.02  # m
    sp = a.spatial()
    assert sp.n_strides == len(rows)
    assert sp.stride_length_mean_m == pytest.approx(np.mean([r.stride_length_m for r in rows]))
    assert sp.speed_mean_m_s == pytest.approx(np.mean(true_len / true_time), rel=0.03)


def test_info_prints_stride_length_and_gait_speed(walk, capsys):
    from gaitmon.cli import main

    with open_session(walk) as s:
        sp = analyse_session(s).spatial()
    assert main(["info", str(walk)]) == 0
    out = capsys.readouterr().out
    assert (f"stride length {sp.stride_length_mean_m:.2f} ± {sp.stride_length_sd_m:.2f} m, "
            f"gait speed {sp.speed_mean_m_s:.2f} ± {sp.speed_sd_m_s:.2f} m/s") in out


def test_a_session_without_raw_counts_has_no_stride_length(tmp_path, record_simulated):
    path = record_simulated(tmp_path / "joint.h5", "--mode", "joint", duration_s=15, standing_s=2)
    with open_session(path) as s:
        a = analyse_session(s)
    assert a.rows and all(np.isnan(r.stride_length_m) for r in a.rows)
    assert a.spatial().n_strides == 0


def test_strides_export_has_the_review_tables_cells_one_row_per_stride(walk, tmp_path):
    import csv
    import json

    from gaitmon.analysis import STRIDE_COLUMNS
    from gaitmon.cli import main

    out = tmp_path / "walk.strides.csv"
    assert main(["export", str(walk), "--format", "strides", "-o", str(out), "--quiet"]) == 0
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    with open_session(walk) as s:
        a = analyse_session(s)
        t_s = s.read("timeline/t_s")
    assert [c.key for c in STRIDE_COLUMNS] == list(rows[0])
    assert len(rows) == len(a.rows)
    eps = 1e-12  # each cell is one rounding (half its last digit) + the parsed text's float error
    for k, (got, r) in enumerate(zip(rows, a.rows, strict=True)):
        assert int(got["stride"]) == k + 1
        assert float(got["start_s"]) == pytest.approx(t_s[r.stride.start_idx], abs=0.005 + eps)
        assert float(got["stride_s"]) == pytest.approx(r.stride.stride_time_s, abs=0.0005 + eps)
        assert got["status"] == ("included" if r.included else f"excluded: {r.excluded}")
        if r.included:
            assert float(got["stride_length_m"]) == pytest.approx(r.stride_length_m,
                                                                  abs=0.005 + eps)  # fmt: skip
            assert float(got["speed_m_s"]) == pytest.approx(r.speed_m_s, abs=0.005 + eps)
            assert float(got["knee_peak_swing_deg"]) == pytest.approx(r.knee_peak_swing_deg,
                                                                      abs=0.05 + eps)  # fmt: skip
    meta = json.loads((tmp_path / "walk.strides.meta.json").read_text())
    assert meta["strides"]["included"] == a.n_included
    assert meta["angles"]["method"] == "gait-aware Kalman + RTS smoother"
