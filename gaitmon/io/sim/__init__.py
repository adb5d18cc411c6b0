"""The simulated gait unit: true gait motion, sensor model, byte-level device and pty transport.

* ``kinematics`` -- normative sagittal gait (hip/knee/ankle, segment tilts, sensor-point motion);
* ``sensors``    -- the 14 ADC channels in counts (gravity, linear acceleration, impacts, gyro
  bias/drift, mounting offsets, FSR loading, noise, 12-bit quantisation);
* ``unit``       -- ``SimulatedUnit``: speaks ``gaitmon.io.protocol`` through ``write``/``read``,
  paced by a clock, with fault injection, a fault ledger and ground truth;
* ``pty``        -- ``PtySimulator``: the unit behind a pseudo-terminal for pyserial clients;
* ``config``     -- ``SimConfig``: what a user chooses about the simulator, as one frozen value,
  and ``build_unit`` / ``serve_on_pty`` that make the unit from it.
"""

from gaitmon.io.sim.config import SimConfig, build_unit, serve_on_pty
from gaitmon.io.sim.kinematics import PATTERNS, GaitConfig, GaitModel
from gaitmon.io.sim.sensors import SensorConfig, SensorModel
from gaitmon.io.sim.unit import FaultConfig, FaultLedger, GroundTruth, SimulatedUnit

__all__ = [
    "PATTERNS",
    "FaultConfig",
    "FaultLedger",
    "GaitConfig",
    "GaitModel",
    "GroundTruth",
    "SensorConfig",
    "SensorModel",
    "SimConfig",
    "SimulatedUnit",
    "build_unit",
    "serve_on_pty",
]
