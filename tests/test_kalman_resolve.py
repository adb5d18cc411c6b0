"""The gait-aware filter's wrap rule re-solves a few rows, not the rest of the block.

On the simulated walk the foot's accelerometer tilt crosses the rule about twice a stride. The
filter used to re-solve the whole rest of a 16384-row block each time (~65 rows solved per row
given, 0.09 M frames/s); it now re-solves at most a window, with bit-for-bit the same result as
one row at a time (here against single-row blocks, which re-solve nothing beyond their row).
"""

from __future__ import annotations

import numpy as np
import pytest

import gaitmon.dsp.motion_kalman as mk
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, GYRO_IDX, ChannelTable
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate


@pytest.fixture(scope="module")
def walk() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    counts = simulate(6000, GaitModel(GaitConfig(seed=1)), SensorConfig(seed=1)).counts
    phys = ChannelTable().to_physical(counts)  # the pipeline's inputs to the filter
    return phys[:, ACC_X_IDX], phys[:, ACC_Z_IDX], phys[:, GYRO_IDX]


def test_rows_solved_stay_near_the_rows_given(walk, monkeypatch) -> None:
    solved = []
    real = mk.solve_scheduled

    def counting(*args, **kw):
        solved.append(len(args[4]))
        return real(*args, **kw)

    monkeypatch.setattr(mk, "solve_scheduled", counting)
    ax, az, w = walk
    mk.GaitAwareKalman().process(ax, az, w)
    n = len(ax)
    calls = len(solved)
    assert calls > n / mk._SOLVE_ROWS + 5  # the rule did re-anchor on this walk (else moot)
    assert sum(solved) <= 3 * n, (sum(solved), n)  # the old code: ~65 n


def test_the_windowed_solve_is_the_row_at_a_time_result(walk) -> None:
    ax, az, w = walk
    whole = mk.GaitAwareKalman().process(ax, az, w)
    k = mk.GaitAwareKalman()
    rows = np.vstack([k.process(ax[i : i + 1], az[i : i + 1], w[i : i + 1])
                      for i in range(len(ax))])  # fmt: skip
    np.testing.assert_array_equal(whole, rows)
