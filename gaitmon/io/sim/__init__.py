"""The simulated gait unit: true gait motion, sensor model, byte-level device and pty transport.

* ``kinematics`` -- normative sagittal gait (hip/knee/ankle, segment tilts, sensor-point motion);
* ``contact``    -- the foot on the ground: foot-flat, the hip above it, where each stride lands;
* ``jets``       -- values with their time derivatives, and the gait's curves built from them;
* ``sensors``    -- the channel table's ADC channels in counts (gravity, linear acceleration,
  impacts, gyro bias/drift, mounting offsets, FSR loading, noise, 12-bit quantisation);
* ``unit``       -- ``SimulatedUnit``: speaks ``gaitmon.io.protocol`` through ``write``/``read``,
  paced by a clock, with fault injection and ground truth;
* ``faults``     -- ``FaultConfig`` (what goes wrong on the link) and the ``FaultLedger``;
* ``pty``        -- ``PtySimulator``: the unit behind a pseudo-terminal for pyserial clients;
* ``clock``      -- ``CrystalClock``: when a unit's samples are taken on a common time line
  (start offset, crystal drift in ppm);
* ``bilateral``  -- two units, one per leg, from one walk (``BilateralConfig``, ``BilateralSim``,
  its truth on the common time base, ``serve_pair_on_ptys``); docs/simulator.md;
* ``config``     -- ``SimConfig``: what a user chooses about the simulator, as one frozen value,
  and ``build_unit`` / ``serve_on_pty`` that make the unit from it;
* ``patterns``   -- the gait patterns by name;
* ``linkfaults`` -- byte-level link faults (lost bytes and tails, noise, bursts) on a stream of
  random frames, with a ledger that predicts every decoder counter (fault-injection tests).

Importing the package imports none of them: a name is loaded from its module on first use
(PEP 562), so the command line can name the simulator's options without paying for numpy and
scipy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gaitmon.lazy import keep

if TYPE_CHECKING:
    from gaitmon.io.sim.bilateral import (
        BilateralConfig,
        BilateralPty,
        BilateralSim,
        BilateralTruth,
        UnitSpec,
        serve_pair_on_ptys,
    )
    from gaitmon.io.sim.clock import CrystalClock
    from gaitmon.io.sim.config import SimConfig, build_unit, serve_on_pty
    from gaitmon.io.sim.faults import FaultConfig, FaultLedger
    from gaitmon.io.sim.kinematics import GaitConfig, GaitModel
    from gaitmon.io.sim.patterns import PATTERNS
    from gaitmon.io.sim.sensors import SensorConfig, SensorModel
    from gaitmon.io.sim.unit import GroundTruth, SimulatedUnit


def __getattr__(name: str) -> object:
    """A name of the package, imported from its module on first use (PEP 562): a plain
    import here, so the layer test sees the arrow; later lookups find it in the package."""
    if name in ("SimConfig", "build_unit", "serve_on_pty"):
        from gaitmon.io.sim import config

        return keep(globals(), name, config)
    if name in ("GaitConfig", "GaitModel"):
        from gaitmon.io.sim import kinematics

        return keep(globals(), name, kinematics)
    if name == "PATTERNS":
        from gaitmon.io.sim import patterns

        return keep(globals(), name, patterns)
    if name in ("SensorConfig", "SensorModel"):
        from gaitmon.io.sim import sensors

        return keep(globals(), name, sensors)
    if name in ("FaultConfig", "FaultLedger"):
        from gaitmon.io.sim import faults

        return keep(globals(), name, faults)
    if name in ("GroundTruth", "SimulatedUnit"):
        from gaitmon.io.sim import unit

        return keep(globals(), name, unit)
    if name == "CrystalClock":
        from gaitmon.io.sim import clock

        return keep(globals(), name, clock)
    if name in (
        "BilateralConfig",
        "BilateralPty",
        "BilateralSim",
        "BilateralTruth",
        "UnitSpec",
        "serve_pair_on_ptys",
    ):
        from gaitmon.io.sim import bilateral

        return keep(globals(), name, bilateral)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")



__all__ = [
    "PATTERNS",
    "BilateralConfig",
    "BilateralPty",
    "BilateralSim",
    "BilateralTruth",
    "CrystalClock",
    "FaultConfig",
    "FaultLedger",
    "GaitConfig",
    "GaitModel",
    "GroundTruth",
    "SensorConfig",
    "SensorModel",
    "SimConfig",
    "SimulatedUnit",
    "UnitSpec",
    "build_unit",
    "serve_on_pty",
    "serve_pair_on_ptys",
]
