"""Load independence: what a recording of the simulated unit holds depends on the samples only,
never on how the host's scheduler delivered them (issue 24: the same command, run twice on a
busy machine, read different live angles). A loaded machine is played here by a link that
hands the bytes over in random pieces after random sleeps; no timing is asserted."""

import math
import time

import h5py
import numpy as np

from gaitmon.engine import Engine
from gaitmon.io import protocol as P
from gaitmon.io.device import Device
from gaitmon.io.sim.config import SimConfig, build_unit
from gaitmon.io.transport import InProcessTransport

FS = 100.0
LIMIT_S = 6.0  # the recording's length on the unit's clock


class SlowLink(InProcessTransport):
    """An in-process link on a busy machine: each read sleeps a random while (0-30 ms) and
    returns a random part of what is due (the rest on the next reads)."""

    def __init__(self, unit: object, seed: int) -> None:
        super().__init__(unit)
        self._rng = np.random.default_rng(seed)
        self._held = b""

    def read(self, timeout_s: float) -> bytes:
        time.sleep(float(self._rng.uniform(0.0, 0.03)))
        if not self._held:
            self._held = super().read(timeout_s)
        k = int(self._rng.integers(1, len(self._held) + 1)) if self._held else 0
        out, self._held = self._held[:k], self._held[k:]
        return out


def record(path, link_seed: int | None, delay_s: float = 0.0) -> None:
    unit = build_unit(SimConfig(seed=4, speed=20.0, loss_pct=2.0, standing_s=1.0))
    time.sleep(delay_s)  # a host that takes its time to start: the unit's clock waits for it
    link = InProcessTransport(unit) if link_seed is None else SlowLink(unit, link_seed)
    eng = Engine(Device(link), "raw")
    eng.record_limit_s = LIMIT_S
    eng.start(before_stream=lambda: eng.start_recording(path))
    try:
        deadline = time.monotonic() + 30.0
        while eng.seconds_since() < LIMIT_S + 0.5 and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        eng.stop()
    assert eng.recording.error == ""


def contents(path) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    with h5py.File(path, "r") as f:
        for g in ("processed", "raw", "events", "timeline/t_s", "timeline/seq"):
            obj = f[g]
            if isinstance(obj, h5py.Dataset):
                out[g] = obj[()]
            else:
                obj.visititems(lambda n, o, g=g: out.__setitem__(f"{g}/{n}", o[()])
                               if isinstance(o, h5py.Dataset) else None)  # fmt: skip
    return out


def test_the_same_seed_records_bit_identical_rows_however_the_blocks_arrive(tmp_path):
    record(tmp_path / "quiet.h5", None)
    record(tmp_path / "busy.h5", link_seed=1, delay_s=0.1)
    a, b = contents(tmp_path / "quiet.h5"), contents(tmp_path / "busy.h5")
    assert sorted(a) == sorted(b)
    # exactly LIMIT_S of the unit's clock: rows plus lost frames
    t = a["timeline/t_s"]
    assert len(t) < LIMIT_S * FS and round(t[-1] * FS) == LIMIT_S * FS - 1
    assert len(t) + np.diff(a["timeline/seq"]).sum() - (len(t) - 1) > len(t)  # frames were lost
    assert len(a["events/heel_strike"]) >= 3
    for name in a:
        assert a[name].shape == b[name].shape, name
        assert a[name].tobytes() == b[name].tobytes(), name


def test_the_simulated_units_clock_starts_when_samples_are_first_asked_for():
    from gaitmon.io.sim.unit import SimulatedUnit

    class Clock:
        t = 100.0

        def __call__(self) -> float:
            return self.t

    clock = Clock()
    unit = SimulatedUnit(clock=clock, start_on_request=True)
    own = SimulatedUnit(clock=clock)  # without it: from its construction (a pair's epoch)
    clock.t += 50.0  # the host is slow to start: nothing is produced meanwhile
    unit.write(P.encode_command(P.Command.IDENTIFY))
    unit.read()
    assert unit.samples_produced == 0
    unit.write(P.encode_command(P.Command.START_STREAM))
    clock.t += 2.0
    unit.read()
    own.read()
    assert unit.samples_produced == math.floor(2.0 * FS)
    assert own.samples_produced == math.floor(52.0 * FS)
    # the command line's and the window's unit is built so
    built = build_unit(SimConfig(seed=1, speed=10.0))
    time.sleep(0.05)
    built.read()
    assert built.samples_produced == 0
