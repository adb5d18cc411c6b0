"""A pipeline that makes no joint angles (``Pipeline(joints=False)``) computes every other number
as one that does, bit for bit: ``gaitmon process`` of a format-2 file, which derives its joints
on read, runs it so (``replay_pipeline(only=...)`` without a joint row). References: the full
pipeline over the same counts, in other chunkings, with a gap and a new calibration."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import killed_recording

from gaitmon.dsp import kernels
from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.finish.replay import replay_pipeline
from gaitmon.io.session.rows import JOINT_ROWS, PIPELINE_ROWS
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

N = 6000


def _record() -> tuple[np.ndarray, np.ndarray, Calibration]:
    counts = simulate(N, GaitModel(GaitConfig(seed=4)), SensorConfig(seed=4)).counts
    lost = np.zeros(N, dtype=np.int64)
    lost[2500] = 250  # a long gap (a restart) and a short one (bridged: frames filled in)
    lost[4100] = 3
    cal = Calibration(np.array([0.1, -0.05, 0.2, 0.3]), np.array([0.01, -0.02, 0.0, 0.015]))
    return counts, lost, cal


@pytest.mark.parametrize("form", ["python", "compiled"])
def test_without_joints_every_other_output_is_the_same(form):
    if form == "compiled" and not kernels.numba_available():
        pytest.skip("numba is not installed")
    counts, lost, cal = _record()
    full = Pipeline(PipelineConfig(), cal)
    lean = Pipeline(PipelineConfig(), cal, joints=False)
    for a, b in [(0, 1000), (1000, 4500), (4500, N)]:
        with kernels.use(form):
            want = full.process(counts[a:b], lost[a:b])
            got = lean.process(counts[a:b], lost[a:b])
        for f in dataclasses.fields(want):
            w, g = getattr(want, f.name), getattr(got, f.name)
            if f.name.startswith("joint_"):
                assert w.shape == (b - a, 3) and g.shape == (b - a, 0)
            elif isinstance(w, np.ndarray):
                np.testing.assert_array_equal(g, w, err_msg=f.name)
            else:
                assert g == w, f.name
    # a successor (new settings) keeps the choice
    assert not lean.successor(PipelineConfig(cutoff_hz=5.0)).joints


def test_a_replay_without_joint_rows_gives_the_same_rows():
    counts, lost, cal = _record()
    stored = [p for p in PIPELINE_ROWS if p not in JOINT_ROWS]
    assert len(JOINT_ROWS) == 3 and len(stored) == len(PIPELINE_ROWS) - 3
    new = (3000, PipelineConfig(cutoff_hz=5.0))
    full = list(replay_pipeline(counts, PipelineConfig(), cal, [new], chunk_rows=1777,
                                lost_before=lost))  # fmt: skip
    lean = list(replay_pipeline(counts, PipelineConfig(), cal, [new], chunk_rows=1777,
                                lost_before=lost, only=stored))  # fmt: skip
    assert len(full) == len(lean) > 3
    for w, g in zip(full, lean, strict=True):
        assert sorted(g.rows) == sorted(stored)
        for path in stored:
            np.testing.assert_array_equal(g.rows[path], w.rows[path], err_msg=path)
        np.testing.assert_array_equal(g.heel_strike, w.heel_strike)
        np.testing.assert_array_equal(g.toe_off, w.toe_off)
        assert g.fsr_faults == w.fsr_faults
        if w.first_pass_rad is None:
            assert g.first_pass_rad is None
        else:
            np.testing.assert_array_equal(g.first_pass_rad, w.first_pass_rad)


def test_the_stages_take_the_samples_as_they_are_made(monkeypatch):
    """Each channel group reaches the low-passes and the tilt filter as an array of its own,
    C-contiguous, so neither copies it (a column pick of the 14 channels arrives column-major,
    and every stage copied it: ~7 % of a batch pipeline's CPU)."""
    import gaitmon.dsp.iir as iir
    import gaitmon.dsp.motion_kalman as motion_kalman

    seen: list[bool] = []
    lowpass, kalman = iir.LinearFilter.process, motion_kalman.GaitAwareKalman.process

    def lowpass_seen(self, x):
        seen.append(bool(np.asarray(x).flags.c_contiguous))
        return lowpass(self, x)

    def kalman_seen(self, ax, az, w):
        seen.extend(bool(a.flags.c_contiguous) for a in (ax, az, w))
        return kalman(self, ax, az, w)

    monkeypatch.setattr(iir.LinearFilter, "process", lowpass_seen)
    monkeypatch.setattr(motion_kalman.GaitAwareKalman, "process", kalman_seen)
    counts, lost, cal = _record()
    Pipeline(PipelineConfig(), cal).process(counts[:3000], lost[:3000])
    assert len(seen) >= 7 and all(seen), seen


def test_process_and_recovery_of_a_format_2_recording_make_no_joint_angles(
    gap_recording, tmp_path, monkeypatch
):
    """Both replays that write a format-2 file (``process``, a recovery) run the pipeline
    without joint angles (the file derives them on read), and the file reads the same joints
    as the recording's own."""
    import h5py

    import gaitmon.dsp.pipeline as pipeline_module
    from gaitmon.finish import open_session
    from gaitmon.finish.reprocess import rewrite_processed

    made: list[bool] = []
    init = pipeline_module.Pipeline.__init__

    def recorded(self, *a, **k):
        init(self, *a, **k)
        made.append(self.joints)

    with h5py.File(gap_recording) as f:
        assert int(f.attrs["format_version"]) == 2
    with open_session(gap_recording) as s:
        config, want = s.config, s.read("processed/joint_deg")
    monkeypatch.setattr(pipeline_module.Pipeline, "__init__", recorded)
    rewrite_processed(gap_recording, tmp_path / "new.h5", config)
    assert made and not any(made)
    with open_session(tmp_path / "new.h5") as s:
        np.testing.assert_array_equal(s.read("processed/joint_deg"), want)

    src = killed_recording(tmp_path)
    made.clear()
    with open_session(src) as s:
        assert s.recovered and s.n_samples == 6_000
        joints = s.read("processed/joint_deg")
    assert made and not any(made)
    assert joints.shape == (6_000, 3) and np.isfinite(joints).all()
