"""``gaitmon lab``: every experiment writes its report and figures, and the key figures hold
against independent references (closed forms, the simulator's truth, the papers' numbers)."""

import math

import numpy as np
import pytest

from gaitmon.cli import main
from gaitmon.lab import EXPERIMENTS, run_all

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    out = tmp_path_factory.mktemp("lab")
    messages: list[str] = []
    reports = run_all(list(EXPERIMENTS), out, quick=True, progress=messages.append)
    return out, reports, messages


def test_every_experiment_writes_a_report_with_its_figures(lab):
    out, reports, messages = lab
    assert set(reports) == {"p000", "p001", "p002", "p003", "p004"}
    for name, rep in reports.items():
        md = (out / f"{name}.md").read_text()
        assert md.startswith("# Paper")
        assert rep.figures, f"{name} has no figure"
        for fig in rep.figures:
            assert fig.read_bytes()[:8] == PNG_MAGIC
            assert fig.stat().st_size > 5000  # an actual plot, not an empty canvas
            assert f"]({fig.name})" in md
    assert len(messages) == 2 * len(EXPERIMENTS)


def test_p002_published_gain_poles_and_their_real_verdict(lab):
    out, reports, _ = lab
    pub = reports["p002"].numbers["published"]
    assert pub[1.0]["agree"]  # 0.871 +- 0.664i, 0.576 reproduced
    assert pub[1.0]["max_abs"] == pytest.approx(math.hypot(0.8719, 0.6647), abs=1e-3)
    assert pub[1.0]["verdict"] == "unstable" and pub[1.0]["verdict_filter_form"] == "stable"
    assert not pub[1e-5]["agree"] and not pub[1000.0]["agree"]
    sweep = reports["p002"].numbers["sweep"]
    assert all(v["verdict_filter_form"] == "stable" for v in sweep.values())
    md = (out / "p002.md").read_text()
    assert "0.8719 + 0.6647i" in md and "0.5763" in md
    # gravity: at rest tilted 30 deg the raw x axis reads sin(30 deg) g, compensated ~0
    assert reports["p002"].numbers["gravity_raw_rest_cm_s2"] == pytest.approx(490.0, abs=2.0)
    assert abs(reports["p002"].numbers["gravity_rest_cm_s2"]) < 1.0


def test_p004_reproduces_the_papers_ordering(lab):
    out, reports, _ = lab
    nums = reports["p004"].numbers
    for kind in ("accelerometer", "gyroscope"):
        k, e = np.array(nums[kind]["kalman"]), np.array(nums[kind]["exponential"])
        assert np.all(k < e) and nums[kind]["kalman_below"]
        assert np.all(np.diff(k) < 0) and np.all(np.diff(e) < 0) and nums[kind]["both_fall"]
    md = (out / "p004.md").read_text()
    assert "Rata-rata" in md and "1.3008" in md  # the paper's averages sit next to ours
    assert f"{nums['gyroscope']['kalman'][0]:.4g}" in md


def test_p003_rest_rmsd_and_adaptive_cutoff(lab):
    _, reports, _ = lab
    n = reports["p003"].numbers
    assert n["rmsd_acc_deg"] == pytest.approx(0.34, abs=0.005)  # calibrated to the paper
    # the filter's improvement is what the first-order closed form predicts for white noise
    assert n["improvement"] == pytest.approx(n["closed_form_improvement"], rel=0.1)
    assert n["fc_picked_hz"] == pytest.approx([1.0, 3.0, 0.5], abs=0.1)  # true motion freqs


def test_p001_filter_beats_the_gyro_model_and_off_axis_metric_is_undefined(lab):
    _, reports, _ = lab
    for axis, v in reports["p001"].numbers.items():
        assert v["galat_after"] < v["galat_before"], axis
        assert v["rmse_after_deg"] < v["rmse_before_deg"], axis
        assert v["akurasi_after"] > 97.0, axis
        assert all(np.isnan(g) for g in v["off_axis_galat"])


def test_p000_against_the_simulator_truth(lab):
    out, reports, _ = lab
    n = reports["p000"].numbers
    acc = np.array(n["tilt_rmse_deg"]["accelerometer"])
    kal = np.array(n["tilt_rmse_deg"]["kalman (paper 000)"])
    assert np.all(kal[1:] < acc[1:])  # impacts and swing fool the accelerometer
    for ev in n["events"].values():
        assert ev["matched"] == ev["true"] == ev["found"]
        assert ev["max_abs_ms"] <= 20.0
    assert f"{kal[2]:.3g}" in (out / "p000.md").read_text()


def test_cli_runs_one_experiment(tmp_path, capsys):
    assert main(["lab", "p001", "-o", str(tmp_path / "new" / "dir")]) == 0
    assert (tmp_path / "new" / "dir" / "p001.md").exists()
    assert "p001" in capsys.readouterr().out


def test_cli_errors_are_one_line(tmp_path, capsys):
    assert main(["lab", "p999", "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "unknown experiment 'p999'" in err and err.count("\n") == 1
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["lab", "p001", "-o", str(f)]) == 2
    assert "not a directory" in capsys.readouterr().err
