"""LSL with two units: ``gaitmon record --simulate-bilateral --lsl``.

Watched from outside, as LabRecorder would: each leg's unit publishes its own streams, their
names and source ids carrying the leg, their descriptions the side and the unit's serial
number; and each leg's timestamps follow that unit's own sample clock. The reference for the
clocks is the simulator's configuration: the left crystal runs 400 ppm fast and the right one
400 ppm slow, so on the host clock a left sample period is 1 / (fs * speed * (1 + 400e-6)) and
a right one 1 / (fs * speed * (1 - 400e-6)); one clock shared by both legs would stamp both at
the same rate.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

pylsl = pytest.importorskip("pylsl")

from gaitmon.finish.bilateral import open_bilateral  # noqa: E402
from gaitmon.lsl import layout  # noqa: E402

FS_HZ, SPEED = 100.0, 4.0
PPM = {"L": 400.0, "R": -400.0}


def test_record_bilateral_lsl_publishes_each_leg_on_its_own_clock(tmp_path: Path) -> None:
    # serial numbers of our own: another run's streams on this machine are not ours
    base = 1_000_000 + int(uuid.uuid4().int % 1_000_000) * 2
    serials = {"L": str(base), "R": str(base + 1)}
    out = tmp_path / "both.h5"
    since = pylsl.local_clock()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen(
        [sys.executable, "-m", "gaitmon", "record", "--simulate-bilateral", "--lsl",
         "--duration", "60", "--speed", str(SPEED), "--serials", f"{serials['L']},{serials['R']}",
         "--drift-ppm", f"{PPM['L']:g},{PPM['R']:g}", "-o", str(out)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, text=True,
    )  # fmt: skip
    inlets: dict[str, pylsl.StreamInlet] = {}
    infos = {}
    got: dict[str, list[tuple[list, list]]] = {"L": [], "R": []}
    try:
        deadline = time.monotonic() + 120  # a loaded machine starts it slowly
        while len(inlets) < 2 and time.monotonic() < deadline and proc.poll() is None:
            for side in "LR":
                if side in inlets:
                    continue
                sid = layout.source_id("sim", "raw", side)
                found = [i for i in pylsl.resolve_byprop("source_id", sid, 0, 0.5)
                         if i.created_at() >= since]  # fmt: skip
                for i in found:
                    inlet = pylsl.StreamInlet(i, max_buflen=120, recover=False)
                    info = inlet.info(timeout=5.0)
                    if info.desc().child("acquisition").child_value("serial_number") == serials[
                        side
                    ]:
                        inlets[side], infos[side] = inlet, info
                        inlet.open_stream(timeout=5.0)
        assert set(inlets) == {"L", "R"}, "gaitmon record --lsl published no raw stream per leg"
        lost: set[str] = set()  # the outlets close at the stop, before the process ends
        while proc.poll() is None and len(lost) < 2:
            for side, inlet in inlets.items():
                if side not in lost:
                    try:
                        data, ts = inlet.pull_chunk(timeout=0.0)
                    except pylsl.util.LostError:
                        lost.add(side)
                        continue
                    if ts:
                        got[side].append((data, ts))
            time.sleep(0.05)
    finally:
        _out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    for side in "LR":  # the names the command announced: the leg in each
        for stream in ("angles", "events", "raw"):
            assert repr(layout.stream_name("sim", stream, side)) in err
    assert layout.stream_name("sim", "raw", "L") == "gaitmon sim L raw"
    for side, info in infos.items():
        assert info.name() == f"gaitmon sim {side} raw"
        assert info.source_id() == f"gaitmon-sim-{side}-raw"
        assert info.desc().child("gaitmon").child_value("side") == side

    slope = {}
    with open_bilateral(out) as b:
        for side in "LR":
            k = np.concatenate([np.asarray(d)[:, 0] for d, _t in got[side]]).astype(np.int64)
            ts = np.concatenate([np.asarray(t) for _d, t in got[side]])
            # the unit's own frames: the counters of the file's rows, all streamed from the
            # inlet's first (the last second's may be on their way when the outlets close)
            seq = b.unit(side).read("timeline/seq").astype(np.int64)
            assert set(seq[(seq >= k[0])][:-100].tolist()) <= set(k.tolist())
            # once the clock has learnt the rate (its first 10 s of samples)
            keep = k >= max(int(k[0]), 1000)
            assert keep.sum() > 1000
            slope[side] = np.polyfit(k[keep], ts[keep], 1)[0]
    print("stamp rate vs 4x nominal, ppm (configured +400 L, -400 R):",
          {s: round((1 / (slope[s] * FS_HZ * SPEED) - 1) * 1e6, 1) for s in slope})  # fmt: skip
    for side in "LR":
        nominal = 1.0 / (FS_HZ * SPEED * (1 + PPM[side] * 1e-6))
        # within 300 ppm of that unit's own rate (the two are 800 ppm apart; 12 s of stamps at
        # 4x, three busy processes: 2-14 ppm off; 5 s of stamps were up to 183 off): a stamp
        # that ignored the unit's drift would be 400 ppm off, one clock for both 0 ppm apart
        assert slope[side] / nominal - 1 == pytest.approx(0.0, abs=300e-6), side
    assert (slope["L"] / slope["R"] - 1) * 1e6 == pytest.approx(-800, abs=400)


def test_each_legs_events_say_the_sessions_file_on_their_own_streams(tmp_path: Path) -> None:
    """In process: EnginePair streams first (record=False, as with --zero), the inlets open,
    then both parts start; each leg's events stream says recording_start with the session's
    file name (not its part's), and the two legs' streams are distinct."""
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.engine import Engine
    from gaitmon.engine.pair import EnginePair
    from gaitmon.io.device import Device
    from gaitmon.io.session import SessionMeta
    from gaitmon.io.sim.bilateral import BilateralConfig, BilateralSim
    from gaitmon.io.transport import InProcessTransport
    from gaitmon.lsl.layout import EventWord, parse_event
    from gaitmon.lsl.outlets import LslOutlets

    unit_id = f"test{uuid.uuid4().hex[:8]}"
    sim = BilateralSim(BilateralConfig(speed=SPEED))
    pair = EnginePair(*(Engine(Device(InProcessTransport(u)), "raw", PipelineConfig())
                        for u in sim.units))  # fmt: skip
    outlets: dict[str, LslOutlets] = {}

    def open_outlets(side: str, engine: Engine) -> None:
        outlets[side] = LslOutlets.attach(engine, SessionMeta(side=side), unit=unit_id, leg=side)

    out = tmp_path / "both.h5"
    pair.start(out, record=False, before_stream=open_outlets)
    try:
        inlets = {}
        for side in "LR":
            found = pylsl.resolve_byprop("source_id", layout.source_id(unit_id, "events", side),
                                         1, 10.0)  # fmt: skip
            assert found, side
            inlets[side] = pylsl.StreamInlet(found[0], recover=False)
            inlets[side].open_stream(timeout=10.0)
            assert inlets[side].info().name() == f"gaitmon {unit_id} {side} events"
        pair.start_recording()
        words: dict[str, list[str]] = {"L": [], "R": []}
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and not all(
            any(w.startswith("recording_start") for w in ws) for ws in words.values()
        ):
            for side, inlet in inlets.items():
                data, _ts = inlet.pull_chunk(timeout=0.1)
                words[side] += [d[0] for d in data]
    finally:
        pair.stop()
        for o in outlets.values():
            o.detach()
    pair.finish()
    for side in "LR":
        starts = [parse_event(w) for w in words[side] if w.startswith("recording_start")]
        assert starts == [(EventWord.RECORDING_START, "both.h5")], (side, words[side])
    with open_bilateral(out) as b:
        assert b.sides == ("L", "R")
