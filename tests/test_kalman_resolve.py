"""The gait-aware filter's wrap rule: paper 000's wrap(z - theta-), in any chunking.

On the simulated walk the foot's accelerometer tilt jumps by a turn about twice a stride (at the
impacts). The update is a compiled loop in time order, checked here against the same update
written out in Python, and the result is bit-for-bit the same whole, a row at a time and in
blocks cut anywhere, on the walk and on a segment held across +-180 deg.
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


def test_the_update_is_paper_000s_loop_written_out(walk) -> None:
    """The compiled update against the update written out in Python, one sample at a time:
    prediction, innovation wrapped into [-pi, pi), update (the gains and z as the filter
    computes them for the walk)."""
    ax, az, w = walk
    seen: dict[str, np.ndarray] = {}
    real = mk.solve_scheduled

    def keep(th0, b0, k0, k1, z, w_, dt, h, wrap=False):
        seen.update(th0=np.array(th0), b0=np.array(b0), k0=k0, k1=k1, z=z, w=w_, h=h, dt=dt)
        assert wrap
        return real(th0, b0, k0, k1, z, w_, dt, h, wrap=wrap)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(mk, "solve_scheduled", keep)
        got = mk.GaitAwareKalman().process(ax, az, w)
    k0, k1, z, h, dt = seen["k0"], seen["k1"], seen["z"], seen["h"], seen["dt"]
    wrapped = 0
    for c in range(4):
        th, b = float(seen["th0"][c]), float(seen["b0"][c])
        for i in range(len(z)):
            pred = th + (w[i, c] - b) * dt
            e = z[i, c] - pred - h[i, c] * b
            if abs(e) > np.pi:
                e = (e + np.pi) % (2 * np.pi) - np.pi
                wrapped += 1
            th, b = pred + k0[i, c] * e, b + k1[i, c] * e
            assert got[i, c] == pytest.approx(th, abs=1e-9), (i, c)
    assert wrapped > 10, "the walk never wrapped an innovation (the test would be moot)"


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
