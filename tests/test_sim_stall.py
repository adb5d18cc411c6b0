"""The simulated unit's stall: it holds its frames, then sends the backlog at once (issue 25).

A scheduled stall (``FaultConfig.stalls``) and one asked for now (``SimulatedUnit.stall``)
give nothing to read while they last, then every frame produced meanwhile, in order, through
the real decoder: no sequence gap, no frame in the ledger's dropped list. On a fake clock, so
nothing here depends on the machine's speed.
"""

import numpy as np
import pytest

from gaitmon.io import protocol as P
from gaitmon.io.decoder import FrameDecoder
from gaitmon.io.sim.faults import FaultConfig
from gaitmon.io.sim.kinematics import GaitConfig
from gaitmon.io.sim.unit import SimulatedUnit


class FakeClock:
    def __init__(self, t: float = 0.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def stream(unit: SimulatedUnit, clock: FakeClock, seconds: float, dec: FrameDecoder):
    """Read every 10 ms of ``clock`` for ``seconds``: (device time, data frames got) per read."""
    got = []
    for _ in range(round(seconds / 0.01)):
        clock.t += 0.01
        frames = [f for f in dec.feed(unit.read()) if isinstance(f, P.RawFrame)]
        got.append((unit.device_time_s, frames))
    return got


def test_a_scheduled_stall_holds_every_frame_then_delivers_the_backlog():
    clock = FakeClock()
    unit = SimulatedUnit(GaitConfig(seed=2), clock=clock, faults=FaultConfig(stalls=((2.0, 1.5),)))
    dec = FrameDecoder()
    unit.write(P.encode_command(P.Command.START_STREAM))
    got = stream(unit, clock, 6.0, dec)
    during = [frames for t, frames in got if 2.0 < t < 3.5]
    assert during and all(not frames for frames in during)  # nothing leaves while it stalls
    first_after = next(frames for t, frames in got if t >= 3.5)
    assert len(first_after) >= 149  # the backlog in one read: 1.5 s of frames, held
    seqs = [f.seq for _, frames in got for f in frames]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # every frame, in order
    assert dec.stats.frames_lost == 0 and unit.ledger.dropped == []
    _, sample, _ = unit.frame_log()
    assert len(seqs) == len(sample)  # every data frame produced was delivered


def test_a_stall_asked_for_now_holds_for_its_device_time_and_loses_nothing():
    clock = FakeClock()
    unit = SimulatedUnit(GaitConfig(seed=2), clock=clock, speed=2.0)  # 2x: device seconds
    dec = FrameDecoder()
    unit.write(P.encode_command(P.Command.START_STREAM))
    before = stream(unit, clock, 1.0, dec)
    assert sum(len(f) for _, f in before) >= 190
    unit.stall(3.0)  # three device seconds: 1.5 s of this clock at twice real time
    held = stream(unit, clock, 1.49, dec)
    assert all(not frames for _, frames in held)
    after = stream(unit, clock, 0.5, dec)
    assert sum(len(f) for _, f in after[:2]) >= 299  # the 3 s held, at once (a float step)
    assert dec.stats.frames_lost == 0 and unit.ledger.dropped == []
    n = sum(len(f) for _, f in before + held + after)
    assert n == len(unit.frame_log()[0])


@pytest.mark.parametrize("bad", [((-1.0, 1.0),), ((1.0, 0.0),)])
def test_a_stall_needs_a_start_and_a_duration(bad):
    with pytest.raises(ValueError, match="stalls"):
        FaultConfig(stalls=bad)


def test_the_in_process_transport_waits_out_a_stall_without_reading():
    """``wait_readable`` says "nothing yet" while the unit holds its frames (a transport
    that believed it would read an empty answer in a loop)."""
    clock = FakeClock()
    unit = SimulatedUnit(GaitConfig(seed=2), clock=clock)
    unit.write(P.encode_command(P.Command.START_STREAM))
    clock.t += 0.5
    unit.stall(1.0)
    clock.t += 0.5
    assert unit.queued_bytes > 0 and not unit.wait_readable(0.0)
    clock.t += 0.6
    assert unit.wait_readable(0.0)
    frames = FrameDecoder().feed(unit.read())
    assert len([f for f in frames if isinstance(f, P.RawFrame)]) == pytest.approx(160, abs=1)
    assert np.all(np.diff([f.seq for f in frames]) == 1)
