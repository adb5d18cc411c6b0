"""The live Gait panel's gait speed: the foot-IMU stride lengths of the last included strides,
computed as the file's analysis computes them, against the simulator's truth."""


import numpy as np
import pytest
from helpers import wait_for

from gaitmon.engine import Engine
from gaitmon.io.device import Device
from gaitmon.io.sim import GaitConfig, SimulatedUnit
from gaitmon.io.transport import InProcessTransport


@pytest.mark.parametrize("pattern", ["normal", "stiff-knee"])
def test_live_gait_speed_is_the_true_speed_within_3_percent(pattern):
    unit = SimulatedUnit(GaitConfig(seed=5, standing_s=1.0, pattern=pattern), speed=20.0)
    eng = Engine(Device(InProcessTransport(unit)), "raw", transport_label="simulated")
    with eng:
        wait_for(lambda: eng.snapshot(0.1).gait.n_strides >= 14, what="14 strides")
        g = eng.snapshot(0.1).gait
        truth = unit.truth(0, unit.samples_produced)
    true_speed = truth.stride_length_m / truth.stride_time_s
    steady = true_speed[2:]  # after the start-up
    assert np.isfinite(g.speed_mean_m_s) and np.isfinite(g.stride_length_mean_m)
    assert g.speed_mean_m_s == pytest.approx(np.median(steady), rel=0.03)
    assert g.stride_length_mean_m == pytest.approx(np.median(truth.stride_length_m[2:]), rel=0.03)
