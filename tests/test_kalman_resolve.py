"""The gait-aware filter's wrap rule re-solves few rows, with the row-at-a-time result.

On the simulated walk the foot's accelerometer tilt crosses the rule about twice a stride. The
filter once re-solved the whole rest of a 16384-row block each time (~65 rows solved per row
given, 0.09 M frames/s), then at most a 256-row window each time (2.4 rows per row, in 3.5x as
many solves as blocks). It now solves the block once, predicts the segment's other
re-anchorings from that solve and re-solves that segment alone from its first one. The result is
bit-for-bit the same as one row at a time (single-row blocks re-solve nothing beyond their row).
"""

from __future__ import annotations

import itertools

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


@pytest.mark.parametrize("n", [6000, 30000])
def test_a_walk_is_solved_about_once_and_only_the_foot_again(n) -> None:
    counts = simulate(n, GaitModel(GaitConfig(seed=1)), SensorConfig(seed=1)).counts
    phys = ChannelTable().to_physical(counts)
    solved: list[tuple[int, int]] = []
    real = mk.solve_scheduled

    def counting(*args, **kw):
        solved.append(np.shape(args[4]))  # (rows, segments) of z
        return real(*args, **kw)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(mk, "solve_scheduled", counting)
        mk.GaitAwareKalman().process(phys[:, ACC_X_IDX], phys[:, ACC_Z_IDX], phys[:, GYRO_IDX])
    assert solved[0] == (n, 4)  # the whole block once
    again = solved[1:]
    assert again, "the rule did not re-anchor on this walk (the test would be moot)"
    assert all(cols == 1 for _, cols in again)  # only the segment that re-anchored
    # the old windowed solve: 2.4 rows per row given; the whole rest each time: ~65
    assert sum(rows * cols for rows, cols in solved) <= 1.5 * 4 * n, solved


def test_the_block_solve_is_the_row_at_a_time_result(walk) -> None:
    ax, az, w = walk
    whole = mk.GaitAwareKalman().process(ax, az, w)
    k = mk.GaitAwareKalman()
    rows = np.vstack([k.process(ax[i : i + 1], az[i : i + 1], w[i : i + 1])
                      for i in range(len(ax))])  # fmt: skip
    np.testing.assert_array_equal(whole, rows)


def test_a_segment_near_the_wrap_with_impacts_is_the_row_at_a_time_result() -> None:
    """Every path of the rule: a segment held near +-180 deg (its accelerometer tilt crosses
    the wrap back and forth while the gyro sees a slow sway), single-sample impacts, and a
    stretch where the accelerometer stays a turn off for a while; in blocks that cut the
    solve's windows anywhere."""
    fs, n = 100.0, 4000
    t = np.arange(n) / fs
    rng = np.random.default_rng(7)
    tilt = np.pi - 0.05 + 0.12 * np.sin(2 * np.pi * 0.7 * t)  # radians, across +-pi
    w = np.gradient(tilt, 1 / fs) + rng.normal(0, 0.01, n)
    g = 9.81
    ax, az = g * np.cos(tilt), g * np.sin(tilt)
    ax, az = ax + rng.normal(0, 0.3, n), az + rng.normal(0, 0.3, n)
    hits = rng.choice(np.arange(50, n - 50), 60, replace=False)
    ax[hits] *= -1.0  # an impact: the accelerometer tilt a half turn off for one sample
    az[hits] *= -1.0
    ax[2000:2040], az[2000:2040] = -ax[2000:2040], -az[2000:2040]  # and for 0.4 s
    cols = [np.tile(a[:, None], (1, 4)) for a in (ax, az, w)]
    whole = mk.GaitAwareKalman(fs).process(*cols)
    k = mk.GaitAwareKalman(fs)
    rows = np.vstack([k.process(*(c[i : i + 1] for c in cols)) for i in range(n)])
    np.testing.assert_array_equal(whole, rows)
    k = mk.GaitAwareKalman(fs)  # and in blocks that split the windows anywhere
    cuts = np.r_[0, np.sort(rng.choice(np.arange(1, n), 40, replace=False)), n]
    parts = np.vstack([k.process(*(c[a:b] for c in cols)) for a, b in itertools.pairwise(cuts)])
    np.testing.assert_array_equal(whole, parts)
