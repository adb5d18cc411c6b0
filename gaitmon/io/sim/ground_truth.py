"""What really happened on a simulated unit (``SimulatedUnit.truth``): the true motion, events
and strides over a range of samples, from its gait and sensor models."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitmon.io.sim.kinematics import GaitModel
from gaitmon.io.sim.sensors import SensorModel


@dataclass(frozen=True)
class GroundTruth:
    """What really happened over samples start .. stop-1."""

    sample_idx: np.ndarray  # (N,)
    tilt_rad: np.ndarray  # (N, 4) true segment tilts (what a perfect zeroing would show)
    joint_rad: np.ndarray  # (N, 3) hip, knee, ankle, clinical signs
    rate_rad_s: np.ndarray  # (N, 4)
    gyro_bias_rad_s: np.ndarray  # (N, 4)
    phase: np.ndarray  # (N,) continuous normative gait phase
    mount_offset_rad: np.ndarray  # (4,) per-board mounting offset (added to the true tilt)
    heel_strike_idx: np.ndarray  # first sample at/after each true heel strike in the range
    toe_off_idx: np.ndarray
    # per heel strike above, the stride it opens (to the next heel strike, which may lie beyond
    # the range): the foot sensor's forward displacement from one foot-flat to the next, and its
    # highest point over that interval above its foot-flat height (GaitModel.strides)
    stride_length_m: np.ndarray
    foot_clearance_m: np.ndarray
    stride_time_s: np.ndarray
    # out of the sagittal plane (realism="real", docs/simulator.md): the walking direction
    # (rad, > 0 to the left; turns) and each board's roll about it; with turns a stride's
    # length above is the straight distance between its two foot-flats (the footprints')
    heading_rad: np.ndarray | None = None  # (N,)
    roll_rad: np.ndarray | None = None  # (N, 4)


def ground_truth(gait: GaitModel, sensors: SensorModel, start: int, stop: int) -> GroundTruth:
    """True motion for samples start .. stop-1 (the caller holds the unit's lock)."""
    kin = gait.evaluate(start, stop)
    hs, to = gait.events(start, stop)
    strides = gait.strides(start, stop)
    bias = sensors.gyro_bias(kin.t_s)
    return GroundTruth(
        sample_idx=kin.sample_idx,
        tilt_rad=kin.tilt_rad,
        joint_rad=kin.joint_rad,
        rate_rad_s=kin.rate_rad_s,
        gyro_bias_rad_s=bias,
        phase=kin.phase,
        mount_offset_rad=sensors.mount_offset_rad.copy(),
        heel_strike_idx=hs,
        toe_off_idx=to,
        stride_length_m=strides.stride_length_m,
        foot_clearance_m=strides.foot_clearance_m,
        stride_time_s=strides.stride_time_s,
        heading_rad=kin.heading_rad,
        roll_rad=kin.roll_rad,
    )
