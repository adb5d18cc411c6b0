"""Opening a unit for the window: a serial port, or the simulated unit on a pseudo-terminal.

No Qt here: `open_connection` runs in a worker thread (it blocks while the unit identifies
itself) and hands back a started :class:`Connection`. The simulated unit runs in this process
behind a `PtySimulator` and is reached through the real `SerialTransport`, so link cuts,
reconnects and the decoder behave exactly as with a Bluetooth port.
"""

from __future__ import annotations

import argparse
import contextlib
from dataclasses import dataclass

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine, EngineError, Mode
from gaitmon.io.device import Device
from gaitmon.io.sim.pty import PtySimulator
from gaitmon.io.sim.unit import SimulatedUnit
from gaitmon.io.transport import LinkError, PortInfo, SerialTransport, list_ports

SIMULATED_PORT = "simulated"
SIMULATED_LABEL = "Simulated device"


def default_sim_args() -> argparse.Namespace:
    """The simulated unit's options at their command-line defaults."""
    from gaitmon.commands.simulate import add_simulator_options

    p = argparse.ArgumentParser(add_help=False)
    add_simulator_options(p)
    return p.parse_args([])


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
    sim_args: argparse.Namespace | None = None,
    calibration: Calibration | None = None,
    baudrate: int | None = None,
) -> Connection:
    """Connect, identify and start streaming; raises EngineError with a one-line reason."""
    from gaitmon.errors import UserError

    simulator = unit = None
    if port == SIMULATED_PORT:
        from gaitmon.commands.simulate import build_unit

        try:
            unit = build_unit(sim_args if sim_args is not None else default_sim_args())
        except UserError as exc:
            raise EngineError(f"simulated unit: {exc}") from None
        try:
            simulator = PtySimulator(unit)
        except OSError as exc:
            unit.close()
            raise EngineError(f"cannot create the simulator's pseudo-terminal: {exc}") from None
        path = str(simulator.link_path)
        label = "simulated unit"
    else:
        path = port
        label = port
    kwargs = {} if baudrate is None else {"baudrate": baudrate}
    transport = SerialTransport(path, **kwargs)
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
