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
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gaitmon.io.sim.faults import FaultConfig
    from gaitmon.io.sim.kinematics import GaitConfig
    from gaitmon.io.sim.pty import PtySimulator
    from gaitmon.io.sim.sensors import SensorConfig
    from gaitmon.io.sim.unit import SimulatedUnit

SIDES = ("L", "R")


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

        return GaitConfig(
            cadence_steps_min=self.cadence_steps_min,
            stride_cv=self.stride_cv,
            pattern=self.pattern,
            standing_s=self.standing_s,
            seed=self.seed,
        )

    def sensor_config(self) -> SensorConfig:
        from gaitmon.io.sim.sensors import SensorConfig

        return SensorConfig(
            seed=self.seed,
            heel_dead_from_s=self.heel_dead_at_s,
            toe_stuck_from_s=self.toe_stuck_at_s,
        )

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
