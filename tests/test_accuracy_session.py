"""A recorded session is analysed on the zero-lag smoother's angles, stored in ``/smoothed`` when
the recording closes (and when it is recovered or reprocessed), closer to the simulator's /truth
than the live filter's and the paper's; the file and the reader name the method of each."""

import h5py
import numpy as np
import pytest

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.finish import open_session
from gaitmon.finish.reprocess import rewrite_processed
from gaitmon.io.session import SessionError

OFFLINE = "gait-aware Kalman + RTS smoother"


@pytest.fixture(scope="module")
def walk(tmp_path_factory, record_simulated):
    path = tmp_path_factory.mktemp("acc") / "walk.h5"
    return record_simulated(path, duration_s=30, standing_s=3)


def rmse(est, true):
    ok = np.isfinite(true).all(axis=1)
    ok[:800] = False  # standing and the first stride
    e = est[ok] - true[ok]
    e -= e.mean(axis=0)
    return np.sqrt(np.mean(e**2, axis=0))


def joint_rmse(path, source="smoothed"):
    """(RMSE per joint vs /truth, the method's name) of the angles the reader gives."""
    with h5py.File(path, "r") as f:
        true = f["truth/joint_deg"][()].astype(float)
    with open_session(path) as s:
        s.use_angles(source)
        return rmse(s.read("processed/joint_deg").astype(float), true), s.angle_method


def test_a_recording_stores_the_smoothed_angles_and_readers_use_them_by_default(walk):
    from gaitmon.io.session.codec import joints_from_stored_tilts

    with h5py.File(walk, "r") as f:
        assert f["smoothed"].attrs["method"] == OFFLINE
        # format 2 stores the tilts; the joints are their differences (docs/file-format.md)
        stored = joints_from_stored_tilts(f["smoothed/tilt_deg"][()], "smoothed/tilt_deg")
        live_stored = joints_from_stored_tilts(f["processed/tilt_deg"][()], "processed/tilt_deg")
        assert f["processed"].attrs["tilt_method"] == "gait-aware Kalman"
    with open_session(walk) as s:
        assert s.angle_sources == ("smoothed", "live") and s.smoothed_stored
        assert s.angle_method == OFFLINE
        np.testing.assert_array_equal(s.read("processed/joint_deg"), stored)
        s.use_angles("live")
        assert s.angle_method == "gait-aware Kalman"
        np.testing.assert_array_equal(s.read("processed/joint_deg"), live_stored)
        with pytest.raises(SessionError, match="no 'zero-lag' angles"):
            s.use_angles("zero-lag")


def test_the_smoother_is_closer_to_truth_than_the_live_filter_and_the_paper(walk, tmp_path):
    off, off_method = joint_rmse(walk)
    live, method = joint_rmse(walk, "live")
    assert (off_method, method) == (OFFLINE, "gait-aware Kalman")
    paper = rewrite_processed(walk, tmp_path / "paper.h5", PipelineConfig(tilt_method="paper")).path
    pap, pap_method = joint_rmse(paper, "live")
    print(f"\njoint RMSE deg: paper {pap.round(2)}, live {live.round(2)}, offline {off.round(2)}")
    assert pap_method == "Kalman (paper, seed 000)"
    # (the live figures depend on how the recording's frames met the engine: compared loosely.
    # The knee gains least from the smoother: 0.87-0.88 against 0.89-0.90 deg locally, and 1.01
    # against 0.89 in one loaded CI run. Since the live filter's start-up (issue 24) and the
    # simulated subject standing from the first streamed sample, the live hip is as good as the
    # smoother's (live 0.41 / 0.89 / 1.04, offline 0.48 / 0.87 / 0.45; the live hip was 2.1,
    # its start-up still settling past 8 s): the smoother's gain is the ankle's)
    assert np.all(off < live + 0.25) and np.mean(off) < np.mean(live) - 0.1
    assert np.all(off < pap) and np.mean(live) < np.mean(pap)
    # the paper-reprocessed file still has the smoother's angles as its analysed default
    assert joint_rmse(paper)[1] == OFFLINE
    with open_session(paper) as s:
        assert s.config.tilt_method == "paper"


def test_a_file_without_smoothed_angles_gets_the_same_ones_computed_when_read(walk, tmp_path):
    old = tmp_path / "old.h5"
    old.write_bytes(walk.read_bytes())
    with h5py.File(old, "r+") as f:
        del f["smoothed"]  # as written before /smoothed existed
    with open_session(walk) as s:
        stored = s.read("processed/tilt_deg")
    with open_session(old) as s:
        assert not s.smoothed_stored and s.angle_method == OFFLINE
        # computed in float32 here, stored at 0.01 deg in the file
        np.testing.assert_allclose(s.read("processed/tilt_deg"), stored, atol=0.005 + 1e-4)
        part = s.read_range(1000, 1100, ["processed/tilt_deg"])["processed/tilt_deg"]
        np.testing.assert_array_equal(part, s.read("processed/tilt_deg")[1000:1100])


def test_process_command_chooses_the_live_method_and_stores_the_smoother(walk, tmp_path, capsys):
    from gaitmon.cli import main

    out = tmp_path / "cli.h5"
    assert main(["process", str(walk), "-o", str(out), "--method", "paper"]) == 0
    err = capsys.readouterr().err
    assert OFFLINE in err and "live: Kalman (paper, seed 000)" in err
    assert joint_rmse(out)[1] == OFFLINE
    assert joint_rmse(out, "live")[1] == "Kalman (paper, seed 000)"


def test_export_writes_the_smoothed_angles_by_default_and_names_them(walk, tmp_path):
    import csv
    import json

    from gaitmon.export import export_session

    def knee(angles):
        out = tmp_path / f"{angles}.csv"
        res = export_session(walk, "csv", out, angles=angles)
        meta = json.loads(next(p for p in res.paths if str(p).endswith(".json")).read_text())
        with open(out, newline="") as fh:
            rows = list(csv.DictReader(fh))
        return np.array([float(r["knee_flexion_deg"]) for r in rows]), meta["angles"]

    with open_session(walk) as s:
        smoothed = s.read("processed/joint_deg")[:, 1]
        s.use_angles("live")
        live = s.read("processed/joint_deg")[:, 1]
    got, meta = knee("smoothed")
    np.testing.assert_allclose(got, smoothed, atol=1e-3)
    assert meta == {"source": "smoothed", "method": OFFLINE, "live_method": "gait-aware Kalman"}
    got, meta = knee("live")
    np.testing.assert_allclose(got, live, atol=1e-3)
    assert meta["source"] == "live" and meta["method"] == "gait-aware Kalman"
    assert np.abs(smoothed - live).max() > 0.5  # the two really differ
