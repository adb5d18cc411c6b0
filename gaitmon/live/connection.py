"""Opening a unit for the window: a serial port, a paired unit by Bluetooth address
(``bt://…``), or the simulated unit on a pseudo-terminal.

No Qt here: `open_connection` runs in a worker thread (it blocks while the unit identifies
itself) and hands back a started :class:`Connection`. The simulated unit runs in this process
behind a `PtySimulator` and is reached through the real `SerialTransport`, so link cuts,
reconnects and the decoder behave exactly as with a Bluetooth port.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine, EngineError, Mode
from gaitmon.io.device import Device
from gaitmon.io.ports import PortInfo, list_ports, make_transport
from gaitmon.io.sim.config import SimConfig, serve_on_pty
from gaitmon.io.sim.pty import PtySimulator
from gaitmon.io.sim.unit import SimulatedUnit
from gaitmon.io.transport import LinkError

SIMULATED_PORT = "simulated"
SIMULATED_LABEL = "Simulated device"


@dataclass
class Connection:
    """A started engine and, for the simulated unit, the simulator behind it."""

    engine: Engine
    port: str  # the serial port path, or SIMULATED_PORT
    label: str  # what the window calls it
    simulator: PtySimulator | None = None
    unit: SimulatedUnit | None = None

    @property
    def simulated(self) -> bool:
        return self.simulator is not None

    def close(self) -> None:
        """Stop the engine (a recording is completed first), then the simulator. Idempotent."""
        try:
            self.engine.stop()
        finally:
            if self.simulator is not None:
                with contextlib.suppress(RuntimeError):
                    self.simulator.stop()
            if self.unit is not None:
                self.unit.close()


def open_connection(
    port: str,
    mode: Mode | str,
    config: PipelineConfig,
    *,
    sim: SimConfig | None = None,
    calibration: Calibration | None = None,
    baudrate: int | None = None,
) -> Connection:
    """Connect, identify and start streaming; raises EngineError with a one-line reason.

    ``sim``: the simulated unit's settings for ``SIMULATED_PORT`` (default: SimConfig()).
    """
    simulator: PtySimulator | None = None
    unit: SimulatedUnit | None = None
    if port == SIMULATED_PORT:
        try:
            simulator = serve_on_pty(sim if sim is not None else SimConfig())
        except OSError as exc:
            raise EngineError(f"cannot create the simulator's pseudo-terminal: {exc}") from None
        unit = simulator.unit
        path = str(simulator.link_path)
        label = "simulated unit"
    else:
        path = port
        label = port
    transport = make_transport(path, baudrate)  # a serial port, or bt://ADDRESS over RFCOMM
    engine = Engine(
        Device(transport),
        mode,
        config,
        calibration,
        transport_label="simulated" if simulator is not None else port,
    )
    try:
        engine.start()
    except (EngineError, LinkError) as exc:
        if simulator is not None:
            with contextlib.suppress(RuntimeError):
                simulator.stop()
        if unit is not None:
            unit.close()
        raise EngineError(str(exc)) from None
    return Connection(engine, port, label, simulator, unit)


def available_ports() -> list[PortInfo]:
    """Serial ports, never raising (a broken enumeration shows an empty list)."""
    try:
        return list_ports()
    except Exception:  # pyserial's enumeration can fail on odd systems; show none, not a crash
        return []
