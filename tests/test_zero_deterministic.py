"""A standing Zero takes effect, and ``record --zero`` starts its file, at samples the data
decide (issue 24, "load independence"): the engine thread looks at each standing window as soon
as its last sample is processed, the calibration takes effect ``ZERO_MARGIN_S`` after the
window, exactly there whichever block holds that sample, and the recording's first row is that
same sample, however late the caller's thread gets to start it (the engine keeps the rows
processed meanwhile). A busy machine is played by a link that hands the bytes over in random
pieces after random sleeps and by a caller that sleeps; no timing is asserted."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import make_engine, wait_for
from test_load_independence import SlowLink, contents

from gaitmon.dsp.calibration import standing_calibration
from gaitmon.dsp.pipeline import Pipeline
from gaitmon.engine import Engine
from gaitmon.engine.pair import EngineGroup
from gaitmon.engine.zeroing import ZERO_MARGIN_S
from gaitmon.finish import open_session
from gaitmon.io.device import Device
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.config import SimConfig, build_unit
from gaitmon.io.sim.sensors import simulate
from gaitmon.io.transport import InProcessTransport

FS = 100.0
LIMIT_S = 5.0
STAND_S = 3.0


def record_zeroed(path: Path, link_seed: int | None, late_s: float = 0.0) -> tuple[Engine, int]:
    """As ``gaitmon record --simulate --zero``: the search asked for before the unit streams,
    the zero, then the recording from the zero's sample; ``late_s``: the caller's thread runs
    that late before zeroing and again before starting the recording."""
    unit = build_unit(SimConfig(seed=4, speed=20.0, loss_pct=2.0, standing_s=math.inf))
    unit.stand_until_streamed(STAND_S)
    link = InProcessTransport(unit) if link_seed is None else SlowLink(unit, link_seed)
    eng = Engine(Device(link), "raw")
    eng.record_limit_s = LIMIT_S
    group = EngineGroup({"": eng})
    group.start(path, record=False, before_stream=lambda s, e: group.request_zero_from_start(s))
    try:
        time.sleep(late_s)
        cals = group.zero(from_start=True)
        assert list(cals) == [""]
        time.sleep(late_s)
        group.start_recording(at_zero=True)
        deadline = time.monotonic() + 30.0
        while group.recorded_s("") < LIMIT_S + 0.2 and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        group.stop()
    assert eng.recording.error == ""
    return eng, group.zero_at[""]


def test_record_zero_gives_bit_identical_rows_however_late_the_threads_run(tmp_path: Path) -> None:
    quiet, at_quiet = record_zeroed(tmp_path / "quiet.h5", None)
    # 0.4 s of wall time is 8 s of the unit's clock at 20x: the window, the zero's sample and
    # the file's first row have all been processed long before this caller gets to them
    busy, at_busy = record_zeroed(tmp_path / "busy.h5", link_seed=2, late_s=0.4)
    # the same window, found by the samples: its end + the margin (1.5 s from the first
    # sample at the earliest)
    assert at_quiet == at_busy >= round((1.5 + ZERO_MARGIN_S) * FS)
    assert list(quiet.timing_notes) == [] and list(busy.timing_notes) == []
    a, b = contents(tmp_path / "quiet.h5"), contents(tmp_path / "busy.h5")
    assert sorted(a) == sorted(b)
    for name in a:
        assert a[name].shape == b[name].shape, name
        assert a[name].tobytes() == b[name].tobytes(), name
    t = a["timeline/t_s"]
    assert round(t[-1] * FS) == LIMIT_S * FS - 1  # exactly LIMIT_S of the unit's clock
    for path in (tmp_path / "quiet.h5", tmp_path / "busy.h5"):
        with open_session(path) as s:
            assert s.calibration.zeroed and s.calibration_changes == []  # the header's
    with open_session(tmp_path / "quiet.h5") as qa, open_session(tmp_path / "busy.h5") as qb:
        ca, cb = qa.calibration, qb.calibration
        np.testing.assert_array_equal(ca.tilt_offset_rad, cb.tilt_offset_rad)
        np.testing.assert_array_equal(ca.gyro_bias_rad_s, cb.gyro_bias_rad_s)


@pytest.fixture(scope="module")
def sim_counts() -> np.ndarray:
    gait = GaitModel(GaitConfig(seed=12, cadence_steps_min=105.0))
    return simulate(1500, gait, SensorConfig(seed=12)).counts


def test_a_calibration_at_a_sample_gives_the_same_output_in_any_block_split(
    sim_counts: np.ndarray,
) -> None:
    """What the engine does (it cuts its blocks at the calibration's sample and applies it
    between) gives the output of two blocks split exactly there, for any other split. Applied
    at the start of whichever block holds the sample instead (the old "from the next block"),
    the output differs: the gyro integration restarts from another sample."""
    at = 700
    first = Pipeline().process(sim_counts[:450])
    cal = standing_calibration(first.acc_ms2[100:450], first.gyro_rad_s[100:450])
    ref = Pipeline()
    whole = [ref.process(sim_counts[:at])]
    ref.set_calibration(cal)
    whole.append(ref.process(sim_counts[at:]))
    rng = np.random.default_rng(8)
    differed = 0
    for trial in range(3):
        p, parts, i = Pipeline(), [], 0
        late = None  # the calibration applied at the start of the block holding ``at``
        q, q_parts = Pipeline(), []
        while i < len(sim_counts):
            c = int(rng.choice([1, 7, 33, 120, 301]))
            block = sim_counts[i : i + c]
            if i < at < i + c:  # the engine's cut
                parts.append(p.process(block[: at - i]))
                p.set_calibration(cal)
                parts.append(p.process(block[at - i :]))
            else:
                if i == at:
                    p.set_calibration(cal)
                parts.append(p.process(block))
            if late is None and i + c > at:
                late = i
                q.set_calibration(cal)
            q_parts.append(q.process(block))
            i += c
        for name in ("tilt_kalman_rad", "tilt_gyro_rad", "joint_kalman_rad", "gyro_rad_s"):
            got = np.concatenate([getattr(b, name) for b in parts])
            want = np.concatenate([getattr(b, name) for b in whole])
            np.testing.assert_array_equal(got, want, err_msg=f"{name}, split {trial}")
        assert late is not None
        if late != at:  # the old way: the calibration from the block's first sample on
            old = np.concatenate([b.tilt_gyro_rad for b in q_parts])
            want = np.concatenate([b.tilt_gyro_rad for b in whole])
            assert not np.array_equal(old, want)
            differed += 1
    assert differed >= 2


def test_a_zero_for_a_sample_already_processed_takes_effect_from_the_next_block_and_says_so(
    tmp_path: Path,
) -> None:
    """The fallback: a machine so far behind that the scheduled sample was processed before
    the calibration was handed over loses no data; the zero and the recording start from the
    next block, and ``timing_notes`` says so."""
    _unit, eng = make_engine(speed=20.0, standing_s=math.inf)
    with eng:
        wait_for(lambda: eng.samples_total >= 400, what="standing data")
        cal = eng.zero(apply=False)
        eng.use_calibration(cal, at_idx=10)  # long processed
        wait_for(lambda: eng.calibration is cal, what="the zero in force")
        eng.start_recording(tmp_path / "late.h5", from_idx=20)
        wait_for(lambda: eng.recording.rows >= 50, what="rows")
        eng.stop_recording()
    notes = list(eng.timing_notes)
    assert len(notes) == 2
    assert notes[0].startswith("the zero took effect") and "behind" in notes[0]
    assert notes[1].startswith("the recording started") and "behind" in notes[1]
    with open_session(tmp_path / "late.h5") as s:
        assert s.calibration is not None and s.calibration_changes == []
        np.testing.assert_array_equal(s.calibration.tilt_offset_rad, cal.tilt_offset_rad)


def test_the_live_zero_takes_effect_at_its_sample_and_a_pair_at_each_units_own(
    tmp_path: Path,
) -> None:
    """``EngineGroup.zero`` (the live window's pair Zero, `record --simulate-bilateral
    --zero`): both units zeroed, each at the sample its own engine thread scheduled (its
    window's end + ``ZERO_MARGIN_S``), from the last 1.5 s before the request on. No timing
    is asserted: which window a live press takes is the press's moment."""
    engines = {s: make_engine(speed=20.0, standing_s=math.inf, seed=k)[1]
               for k, s in ((3, "L"), (4, "R"))}  # fmt: skip
    group = EngineGroup(engines)
    for e in engines.values():
        e.start()
    try:
        wait_for(lambda: min(e.samples_total for e in engines.values()) >= 300, what="data")
        cals = group.zero(timeout_s=2.0)
        assert sorted(cals) == ["L", "R"] and sorted(group.zero_at) == ["L", "R"]
        for s, e in engines.items():
            wait_for(lambda e=e, s=s: e.calibration is cals[s], what=f"{s} zeroed")
            # a window of 1.5 s from the last 1.5 s before the request on, + the margin (the
            # last window before the request may have been processed a block before it was
            # looked at: then it took effect from the next block, as timing_notes says)
            assert group.zero_at[s] >= round((1.5 + ZERO_MARGIN_S) * FS)
    finally:
        group.stop()
