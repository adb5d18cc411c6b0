"""The standing Zero picks its window by the unit's samples, not by when a thread runs.

``record --simulate --zero --speed 10`` failed on a busy machine ("the foot and shank are
moving"): the simulated subject stands 5 s of its clock, 0.5 s of wall time at 10x, and the
zero took the last 1.5 s of data at the moment its thread ran. Here the thread runs late on
purpose (after the subject has walked for 8 s of its clock): the last 1.5 s are walking, and
the zero from the units' start still finds the standing pose and its true offsets. The
simulated subject of ``record --simulate`` stands its ``standing_s`` from the first streamed
sample (``SimulatedUnit.stand_until_streamed``), however late the PC started streaming."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from helpers import make_engine, wait_for

from gaitmon.engine import EngineError
from gaitmon.engine.pair import EngineGroup


def test_a_late_zero_finds_the_standing_window_by_the_samples() -> None:
    # (20x: the engine's 60-s ring must still hold the first samples at the last zero; at 50x
    # it held 1.2 s of wall time, which a busy machine spent before that zero)
    unit, eng = make_engine(speed=20.0, standing_s=math.inf, seed=4)
    unit.stand_until_streamed(4.0)  # as `record --simulate` does: 4 s of samples stand
    with eng:
        wait_for(lambda: eng.samples_total >= 1200, what="walking data")
        with pytest.raises(EngineError, match="moving"):  # the last 1.5 s: walking
            eng.zero(apply=False)
        with pytest.raises(EngineError, match="moving"):  # from now on: walking too
            EngineGroup({"": eng}).zero(timeout_s=0.5)
        cals = EngineGroup({"": eng}).zero(from_start=True)
        wait_for(lambda: eng.calibration is cals[""], what="the zero in force")
    offsets = np.degrees(cals[""].tilt_offset_rad)
    mounted = np.degrees(unit.truth(0, 1).mount_offset_rad)
    assert np.max(np.abs(mounted)) > 1.0  # the boards really are mounted askew
    np.testing.assert_allclose(offsets, mounted, atol=0.5)


def test_the_window_is_the_earliest_still_one_after_the_given_sample() -> None:
    """``Engine.zero(since_idx=...)``: the same calibration however much data came after the
    standing (the windows are found in the samples held, in the unit's time order)."""
    unit, eng = make_engine(speed=50.0, standing_s=math.inf, seed=5)
    unit.stand_until_streamed(4.0)
    with eng:
        wait_for(lambda: eng.samples_total >= 600, what="the first walking data")
        early = eng.zero(apply=False, since_idx=0)
        wait_for(lambda: eng.samples_total >= 1500, what="more walking data")
        late = eng.zero(apply=False, since_idx=0)
        with pytest.raises(EngineError, match="moving"):  # nothing still after 4 s in
            eng.zero(apply=False, since_idx=450)
    np.testing.assert_array_equal(early.tilt_offset_rad, late.tilt_offset_rad)
    np.testing.assert_array_equal(early.gyro_bias_rad_s, late.gyro_bias_rad_s)


def test_the_simulated_subject_stands_its_standing_from_the_first_streamed_sample() -> None:
    """However long the unit sat before streaming (here 20 s of its clock), the first
    ``standing_s`` of streamed samples are standing and walking follows."""
    shift = [0.0]
    unit, eng = make_engine(speed=100.0, standing_s=math.inf, seed=6,
                            clock=lambda: time.monotonic() + shift[0])  # fmt: skip
    unit.stand_until_streamed(2.0)
    shift[0] = 0.2  # 20 s of the unit's clock pass before anyone streams
    with eng:
        wait_for(lambda: eng.samples_total >= 600, what="data")
        first = eng.zero(apply=False, since_idx=0)  # the first 2 s stand
        with pytest.raises(EngineError, match="moving"):
            eng.zero(apply=False, since_idx=round(2.5 * eng.fs_hz))  # then it walks
    _frame_no, sample_idx, _kind = unit.frame_log()
    assert sample_idx.min() >= 2000  # the stream really began 20 s into the unit's clock
    assert np.all(np.isfinite(first.tilt_offset_rad))
