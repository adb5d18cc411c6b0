"""One unit as the one-unit case of a group of engines (``gaitmon.engine.pair.EngineGroup``).

The two-leg group (``EnginePair``) is tested against the simulator's truth in
``test_bilateral_record.py``; here a group of one records straight into its file, as
``Engine.start_recording`` does, and never deletes a file it did not create.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from gaitmon.engine import Engine, EngineError
from gaitmon.engine.pair import EngineGroup, EnginePair
from gaitmon.finish import open_session
from gaitmon.io.device import Device
from gaitmon.io.session import SessionMeta
from gaitmon.io.session.parts import parts_of
from gaitmon.io.sim import GaitConfig, SimulatedUnit
from gaitmon.io.transport import InProcessTransport


def _engine(seed: int = 3) -> Engine:
    unit = SimulatedUnit(GaitConfig(seed=seed, standing_s=3.0), speed=20.0)
    return Engine(Device(InProcessTransport(unit)), "raw", transport_label="simulated")


def test_a_group_of_one_records_straight_into_the_file(tmp_path: Path) -> None:
    out = tmp_path / "one.h5"
    group = EngineGroup({"": _engine()})
    assert not group.in_parts and group.sides == ("",)
    group.start(out, SessionMeta(patient_id="P1", side="R"))
    try:
        deadline = time.monotonic() + 60.0
        while group.recorded_s("") < 2.0:
            assert time.monotonic() < deadline, "the unit did not record in time"
            time.sleep(0.02)
    finally:
        statuses = group.stop()
    assert list(statuses) == [""] and statuses[""].error == ""
    assert group.finish() == out  # nothing to combine
    assert not parts_of(out)
    with open_session(out) as s:
        assert s.n_samples == statuses[""].rows >= 2.0 * s.header.sample_rate_hz
        assert s.header.meta.patient_id == "P1" and s.header.meta.side == "R"  # as given


def test_a_group_of_one_that_cannot_start_keeps_a_file_it_did_not_create(
    tmp_path: Path,
) -> None:
    out = tmp_path / "taken.h5"
    out.write_bytes(b"someone else's file")
    group = EngineGroup({"": _engine()})
    with pytest.raises(EngineError):
        group.start(out)  # no overwrite: the session writer refuses an existing file
    assert out.read_bytes() == b"someone else's file"
    assert not group.engines[""].running


def test_the_pair_is_the_group_of_its_left_and_right_engines() -> None:
    left, right = _engine(1), _engine(2)
    pair = EnginePair(left, right)
    assert pair.engines == {"L": left, "R": right} and pair.in_parts
    assert pair.sides == ("L", "R")
