"""The standing Zero with frames lost on the link: losses are not movement.

``record --simulate --zero --loss-pct 2`` failed ("need 1.5 s of data"): a lost frame is a NaN
row of the live display (one row per frame of the unit's clock) and the Zero refused any NaN,
so at 2 % loss hardly any 1.5-s window qualified. It now takes its 1.5 s of the unit's clock
from the samples received, and still refuses movement and a loss long enough to hide one."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import make_engine, wait_for

from gaitmon.dsp.calibration import CalibrationError, check_stillness, standing_calibration
from gaitmon.engine import EngineError
from gaitmon.engine.pair import EngineGroup
from gaitmon.io.sim.faults import FaultConfig

FS = 100.0


def _standing(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    tilt = np.radians([2.0, -3.0, 4.0, 1.0])
    acc = np.stack([9.81 * np.cos(tilt), 9.81 * np.sin(tilt)], axis=1)[None] + rng.normal(
        0, 0.02, (n, 4, 2))  # fmt: skip
    gyro = 0.01 + rng.normal(0, 0.005, (n, 4))
    return acc, gyro


def _lose(acc: np.ndarray, gyro: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, ...]:
    """As the live ring holds them: NaN on the rows standing for lost frames."""
    acc, gyro = acc.copy(), gyro.copy()
    acc[rows] = np.nan
    gyro[rows] = np.nan
    lost = np.zeros(len(acc), bool)
    lost[rows] = True
    return acc, gyro, lost


def test_standing_with_single_frames_lost_calibrates_from_the_received_samples():
    acc, gyro = _standing(150)
    rows = np.arange(5, 150, 37)
    a, g, lost = _lose(acc, gyro, rows)
    with pytest.raises(CalibrationError, match="NaN"):  # without saying which rows are lost
        standing_calibration(a, g, fs_hz=FS)
    cal = standing_calibration(a, g, lost, fs_hz=FS)
    want = standing_calibration(acc[~lost], gyro[~lost], fs_hz=FS)
    np.testing.assert_allclose(cal.tilt_offset_rad, want.tilt_offset_rad, rtol=0, atol=1e-15)
    np.testing.assert_allclose(cal.gyro_bias_rad_s, want.gyro_bias_rad_s, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.degrees(cal.tilt_offset_rad), [2, -3, 4, 1], atol=0.05)


def test_movement_and_long_losses_are_still_refused():
    acc, gyro = _standing(150)
    moving = gyro.copy()
    moving[:, 2] += 0.5 * np.sin(np.arange(150) / 10.0)
    a, g, lost = _lose(acc, moving, np.arange(5, 150, 37))
    r = check_stillness(a, g, fs_hz=FS, lost=lost)
    assert not r.still and "moving" in r.reason and "shank" in r.reason
    # a loss longer than the pipeline bridges: movement could hide in it
    a, g, lost = _lose(acc, gyro, np.arange(60, 70))
    r = check_stillness(a, g, fs_hz=FS, lost=lost)
    assert not r.still and "lost 0.10 s" in r.reason
    # too few samples received to judge
    a, g, lost = _lose(acc, gyro, np.flatnonzero(np.arange(150) % 2 == 0))
    r = check_stillness(a, g, fs_hz=FS, lost=lost)
    assert not r.still and "too short" in r.reason


def test_the_engine_zeroes_the_standing_pose_with_two_percent_loss():
    unit, eng = make_engine(speed=50.0, standing_s=math.inf, seed=4,
                            faults=FaultConfig(seed=11, loss_pct=2.0))  # fmt: skip
    unit.stand_until_streamed(4.0)
    with eng:
        cals = EngineGroup({"": eng}).zero(from_start=True, timeout_s=3.0)
        wait_for(lambda: eng.samples_total >= 1200, what="walking data")
        with pytest.raises(EngineError, match="moving"):  # the last 1.5 s: walking
            eng.zero(apply=False)
    assert len(unit.ledger.dropped) > 10  # frames were lost
    offsets = np.degrees(cals[""].tilt_offset_rad)
    mounted = np.degrees(unit.truth(0, 1).mount_offset_rad)
    np.testing.assert_allclose(offsets, mounted, atol=0.5)


def test_record_simulate_zero_with_loss(tmp_path, record_simulated):
    import h5py

    # (seed 1: at 2 % loss no 1.5-s window of its standing is free of loss)
    path = record_simulated(tmp_path / "z.h5", "--zero", "--loss-pct", "2", "--seed", "1",
                            duration_s=6, standing_s=4)  # fmt: skip
    with h5py.File(path, "r") as f:
        assert len(f["gaps"]) > 0  # frames were lost
