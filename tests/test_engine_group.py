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


def _record_zeroed_in_tilt_mode(out: Path, sides: tuple[str, ...]) -> dict[str, list[object]]:
    """A group of tilt-mode units (the subject standing) zeroed while it records: the
    calibration changes each unit's file logs."""
    units = {s: SimulatedUnit(GaitConfig(seed=5, standing_s=600.0), speed=20.0) for s in sides}
    engines = {s: Engine(Device(InProcessTransport(u)), "tilt", transport_label="simulated")
               for s, u in units.items()}  # fmt: skip
    group = EngineGroup(engines)
    group.start(out)
    try:
        deadline = time.monotonic() + 60.0
        while min(group.recorded_s(s) for s in sides) < 2.0:
            assert time.monotonic() < deadline, "the units did not record in time"
            time.sleep(0.02)
        before = {s: e.calibration for s, e in engines.items()}
        zeroed = group.zero()
        assert list(zeroed) == list(sides)
        assert all(zeroed[s] is before[s] for s in sides)  # the units zero themselves
        rows = {s: e.recording.rows for s, e in engines.items()}
        while any(e.recording.rows < rows[s] + 100 for s, e in engines.items()):
            assert time.monotonic() < deadline, "the units did not record in time"
            time.sleep(0.02)  # blocks processed after the zeroing
    finally:
        assert all(st.error == "" for st in group.stop().values())
    out_changes: dict[str, list[object]] = {}
    for s in sides:
        with open_session(out, side=s or None) as sess:
            out_changes[s] = list(sess.calibration_changes)
    return out_changes


def test_a_unit_that_zeroes_itself_is_not_handed_its_calibration_again(tmp_path: Path) -> None:
    """As ``Engine.zero``: a tilt-mode unit's zeroing changes nothing on the PC, so a recording
    logs no calibration change, for one unit as for each leg of a pair (a pair's zeroing
    logged the unchanged calibration as a zeroing)."""
    assert _record_zeroed_in_tilt_mode(tmp_path / "one.h5", ("",)) == {"": []}
    assert _record_zeroed_in_tilt_mode(tmp_path / "two.h5", ("L", "R")) == {"L": [], "R": []}


def test_a_unit_that_is_not_a_leg_is_not_named_when_it_cannot_be_zeroed() -> None:
    """One unit: "could not zero: ..." as `gaitmon record --zero` always said; a leg is named."""
    for key, named in (("", "could not zero: "), ("R", "could not zero the right leg (R): ")):
        walking = SimulatedUnit(GaitConfig(seed=3, standing_s=0.0), speed=20.0)
        eng = Engine(Device(InProcessTransport(walking)), "raw", transport_label="simulated")
        group = EngineGroup({key: eng})
        eng.start()
        try:
            with pytest.raises(EngineError) as caught:
                group.zero(timeout_s=1.0)
        finally:
            eng.stop()
        assert str(caught.value).startswith(named), caught.value
