"""Link cuts of 1, 3 and 8 s over a real pty while recording: detection, loss, one file.

The simulated unit streams in real time on a pseudo-terminal; the engine records it through
the real SerialTransport into one session file while the pty is cut (the port's node vanishes,
as a Bluetooth port does) for 1, 3 and 8 s, 5 s apart. Per cut it prints how long the loss took
to detect (in the unit's frames: 10 = 0.1 s), the frames the unit sent into the dead link (its
ledger), the frames lost beyond those (what a late reconnect costs), and the gaps the file
holds. The same run is repeated with the old reconnect schedule (pure exponential backoff,
0.25 s doubling to 5 s, no watch on the port's node) as the reference.

    python benchmarks/fault_link_cut.py            # goal: detected <= 10 frames, beyond <= 50

Takes about a minute (the cuts happen in real time).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import h5py

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine
from gaitmon.io.device import Device
from gaitmon.io.sim.kinematics import GaitConfig
from gaitmon.io.sim.pty import PtySimulator
from gaitmon.io.sim.unit import SimulatedUnit
from gaitmon.io.transport import LinkState, ReconnectPolicy, SerialTransport

CUTS_S = (1.0, 3.0, 8.0)
BETWEEN_S = 5.0  # longer than ReconnectPolicy.stable_s: each cut is a fresh outage, not a flap


class OldSchedule(SerialTransport):
    """The reconnect schedule before the port's node was watched: backoff only."""

    def __init__(self, port: str) -> None:
        super().__init__(port, reconnect=ReconnectPolicy(present_max_s=5.0, stable_s=10.0))

    def _present(self) -> bool | None:
        return None


def run(transport_cls: type[SerialTransport], folder: Path) -> list[tuple[float, int, int, int]]:
    unit = SimulatedUnit(GaitConfig(standing_s=1.0), speed=1.0)
    rows: list[tuple[float, int, int, int]] = []
    path = folder / f"{transport_cls.__name__}.h5"
    with PtySimulator(unit) as sim:
        transport = transport_cls(str(sim.link_path))
        engine = Engine(Device(transport), "raw", PipelineConfig(), transport_label="pty")
        engine.start()
        try:
            engine.start_recording(path)
            time.sleep(BETWEEN_S)
            for cut_s in CUTS_S:
                down_before = len(unit.ledger.dropped_frame_nos("link_down"))
                lost_before = engine.device.stats.decoder.frames_lost
                unit.link_is_down()  # the unit's clock up to now
                at_cut = unit.samples_produced
                sim.cut()
                while transport.status.state == LinkState.CONNECTED:
                    time.sleep(0.002)
                unit.link_is_down()
                detect = unit.samples_produced - at_cut
                time.sleep(cut_s)
                sim.restore()
                time.sleep(BETWEEN_S)
                down = len(unit.ledger.dropped_frame_nos("link_down")) - down_before
                lost = engine.device.stats.decoder.frames_lost - lost_before
                rows.append((cut_s, detect, down, lost - down))
            status = engine.stop_recording()
        finally:
            engine.stop()
    with h5py.File(path, "r") as f:
        gaps = f["gaps"][()]
        n_lost = [int(g["n_lost"]) for g in gaps]
    assert status.rows > 0 and len(n_lost) >= len(CUTS_S), (status, n_lost)
    print(f"  one file: {path.name}, {status.rows} rows, gaps of {n_lost} frames")
    return rows


def main() -> int:
    ok = True
    with tempfile.TemporaryDirectory(prefix="gaitmon-cut-") as tmp:
        results = {}
        for label, cls in (("now", SerialTransport), ("old schedule", OldSchedule)):
            print(f"{label}:")
            results[label] = run(cls, Path(tmp))
    print()
    print("| cut | detected after (frames) | sent into the dead link | lost beyond it: now | old |")
    print("|---|---|---|---|---|")
    for new, old in zip(results["now"], results["old schedule"], strict=True):
        cut_s, detect, down, beyond = new
        print(f"| {cut_s:g} s | {detect} | {down} | {beyond} | {old[3]} |")
        ok &= detect <= 10 and beyond <= 50
    print(f"\ngoal: detected <= 10 frames (0.1 s), lost beyond the outage <= 50 (0.5 s): "
          f"{'met' if ok else 'NOT met'}")  # fmt: skip
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
