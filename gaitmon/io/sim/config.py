"""The simulated unit's settings as one frozen value, and building the unit from them.

:class:`SimConfig` holds what a user can choose about the simulator (``gaitmon simulate``,
``gaitmon --simulate``, ``gaitmon record --simulate`` and the window's *Simulated device*). It
is built from argparse in ``gaitmon.commands.simulate`` (the edge, which turns a ``ValueError``
into the user's error) and passed inward as a value: nothing below the command line ever sees
an argparse namespace.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from gaitmon.io.sim.patterns import REALISM_LEVELS

if TYPE_CHECKING:
    from gaitmon.io.sim.faults import FaultConfig
    from gaitmon.io.sim.kinematics import GaitConfig
    from gaitmon.io.sim.pty import PtySimulator
    from gaitmon.io.sim.sensors import SensorConfig
    from gaitmon.io.sim.unit import SimulatedUnit

SIDES = ("L", "R")

# How hard the simulator is (REALISM_LEVELS, docs/simulator.md "Realism levels"). "default": the
# kind simulator every test and golden output was made with (foot exactly still in stance,
# planar walk, perfect axes, identical stride lengths). "real": the parameters measured on the
# real foot-IMU walks (benchmarks/sim_realism_params.py) on top of the accuracy evaluation's
# realistic sensors.
REAL_GAIT: dict[str, Any] = {
    "stride_cv": 0.05,  # gdins straight strides: local CV of stride time 0.060 (ZV jitter incl.)
    "stride_length_cv": 0.05,  # gdins straight strides: local CV of stride length 0.049
    "stance_micro_rad": 0.13,  # the stance roll-over (toe-down through the still phase): real
    # |w_y| there 0.22 (x-io) .. 0.29 (gdins) rad/s median, stillest 0.1 s 0.14 .. 0.21
    "stance_micro_spread": 0.5,  # stride to stride (real p10 .. p90 of the stillest: x 3 .. 8)
    "stance_pivot_m": (0.064, -0.073),  # the roll-over turns about a point 6.4 cm ahead of and
    # 7.3 cm below the sensor (the ball of the foot): gdins stance velocity against the pitch
    # rate, median over 956 stances (x-io 3 / 6 cm; benchmarks/sim_realism_params.py)
    "roll_sd_deg": (1.0, 2.0, 2.0, 4.4),  # foot: stance |roll| median 3.0 deg (gdins); others
    # not measured (no shared thigh / shank / pelvis data): assumed smaller
    "swing_roll_deg": (0.0, 0.0, 0.0, 10.0),  # foot: roll RMS over a stride 5.1 (gdins), 9.0 deg
    # (x-io), peak 11 / 22 deg
    "swing_yaw_deg": (0.0, 0.0, 0.0, 2.5),  # foot: peak vertical rate in straight strides 2.3
    # rad/s (gdins), 2.2 (x-io)
    "turn_every_strides": 12.0,  # hallway laps: 17.6 % of gdins strides turn > 45 deg (sim
    # 17.6 %); gdins turns back every 21 strides, this simulator every 12
    "turn_strides": 4.0,  # a gdins U-turn spans 3 strides turning > 20 deg, median 58 deg (p90
    # 86) per stride turning > 45 deg, 1.3 % of strides > 90 deg (sim: 3; 73 (78); 0 %)
    "turn_deg": 180.0,
    "first_turn_strides": 3.0,
    "turn_in_swing": True,  # the foot turns in swing (gdins: peak vertical rate 4.5 rad/s in
    # turning strides), not while it stands
}
REAL_SENSORS: dict[str, Any] = {
    "acc_gain_sd": 0.02,  # uncalibrated analog axes (ADXL335: 270..330 mV/g); the calibrated
    # MicroStrain / NGIMU read standing |a| within 0.3 % of g
    "acc_cross_sd": 0.01,  # ADXL335: cross-axis sensitivity +-1 %
    "gyro_scale_sd": 0.02,  # gdins whole-trial heading, gyro / footprints: +2.1 % (p10 -1.8 %)
    "gyro_cross_sd": 0.01,  # axis misalignment ~0.6 deg
}


def realism_gait(config: GaitConfig, realism: str) -> GaitConfig:
    """``config`` at a realism level (REALISM_LEVELS): "real" sets REAL_GAIT's fields (its
    stride time CV replaces ``config.stride_cv``)."""
    _check_realism(realism)
    return config if realism == "default" else replace(config, **REAL_GAIT)


def realism_sensors(config: SensorConfig, realism: str) -> SensorConfig:
    """``config`` at a realism level: "real" adds the accuracy evaluation's realistic sensors
    (soft tissue, impacts along z, a faster gyro drift: ``realistic_sensors``) and
    REAL_SENSORS's gain and cross-axis errors; the sensors' own turns give way to the gait's."""
    _check_realism(realism)
    if realism == "default":
        return config
    from gaitmon.io.sim.sensors import realistic_sensors

    real = realistic_sensors(config.seed)
    keep = {name: getattr(real, name) for name in (
        "tissue_wobble_deg", "tissue_acc_ms2", "impact_z_ratio", "gyro_drift2_amp_rad_s",
    )}  # fmt: skip
    return replace(config, **keep, **REAL_SENSORS, turn_every_s=0.0)


def _check_realism(realism: str) -> None:
    if realism not in REALISM_LEVELS:
        raise ValueError(f"unknown realism {realism!r}; use one of {', '.join(REALISM_LEVELS)}")


@dataclass(frozen=True)
class SimConfig:
    """The simulator's options at the command line's defaults; ``ValueError`` if one is bad."""

    cadence_steps_min: float = 110.0
    stride_cv: float = 0.02  # stride-to-stride coefficient of variation of stride time
    pattern: str = "normal"  # a key of gaitmon.io.sim.patterns.PATTERNS
    standing_s: float = 5.0  # quiet standing before walking starts (time to zero); inf: until
    # the unit is told to walk (SimulatedUnit.walk)
    seed: int = 0
    side: str = "R"  # leg the unit is worn on
    speed: float = 1.0  # time factor: 1 = real time; math.inf = as fast as the client reads
    loss_pct: float = 0.0  # data frames dropped at random
    corrupt_pct: float = 0.0  # data frames with 1-3 flipped bits
    heel_dead_at_s: float = math.inf  # the heel force sensor dies (reads ~0) at this device time
    toe_stuck_at_s: float = math.inf  # the toe force sensor sticks loaded at this device time
    realism: str = "default"  # a REALISM_LEVELS name: "real" is as hard as real feet

    def __post_init__(self) -> None:
        if self.side not in SIDES:
            raise ValueError(f"side must be L or R, got {self.side!r}")
        if not self.speed > 0:
            raise ValueError(
                f"speed must be > 0 (math.inf = as fast as possible), got {self.speed}"
            )
        # the simulator's own configs own the ranges: building them checks, with their messages
        self.gait_config()
        self.sensor_config()
        self.fault_config()

    def gait_config(self) -> GaitConfig:
        from gaitmon.io.sim.kinematics import GaitConfig

        return realism_gait(GaitConfig(
            cadence_steps_min=self.cadence_steps_min,
            stride_cv=self.stride_cv,
            pattern=self.pattern,
            standing_s=self.standing_s,
            seed=self.seed,
        ), self.realism)  # fmt: skip

    def sensor_config(self) -> SensorConfig:
        from gaitmon.io.sim.sensors import SensorConfig

        return realism_sensors(SensorConfig(
            seed=self.seed,
            heel_dead_from_s=self.heel_dead_at_s,
            toe_stuck_from_s=self.toe_stuck_at_s,
        ), self.realism)  # fmt: skip

    def fault_config(self) -> FaultConfig:
        from gaitmon.io.sim.faults import FaultConfig

        return FaultConfig(seed=self.seed, loss_pct=self.loss_pct, corrupt_pct=self.corrupt_pct)


def build_unit(config: SimConfig) -> SimulatedUnit:
    """The simulated unit these settings describe (not started: its clock starts when a client
    first asks for samples, so the same seed streams the same samples on any machine)."""
    from gaitmon.io.sim.unit import SimulatedUnit

    return SimulatedUnit(
        config.gait_config(),
        config.sensor_config(),
        config.fault_config(),
        speed=config.speed,
        side=config.side,
        start_on_request=True,
    )


def serve_on_pty(
    config: SimConfig, link_path: str | os.PathLike[str] | None = None
) -> PtySimulator:
    """Build the unit and serve it on a pseudo-terminal (``.unit``, ``.link_path``).

    ``OSError`` when the pseudo-terminal or the link cannot be made; the unit is closed then.
    """
    from gaitmon.io.sim.pty import PtySimulator

    unit = build_unit(config)
    try:
        return PtySimulator(unit, link_path)
    except OSError:
        unit.close()
        raise
