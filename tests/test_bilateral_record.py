"""Both legs into one session file, checked against the simulator's truth.

Two engines read a simulated pair on two pseudo-terminals (``BilateralPty``: the real pyserial
path) at 2x real time for the goals (4x elsewhere); the pair records two parts and combines
them into one file whose clock fits map both legs onto one time line.

How the simulator's common time relates to the host clock, independently of the code under
test: ``BilateralSim`` paces both units on ``time.monotonic`` (the clock the engines stamp
receive times with) from one ``epoch``, common time running ``speed`` times as fast: common
time c is host time ``epoch + c / speed``. A sample is delivered once the next one is due (one
sample period late) plus the link's delay. So an event the analysis places at host time H is at
common time ``(H - epoch) * speed``, give or take a constant delivery delay shared by both
units: the alignment between the units is the spread of the errors after removing ONE constant
for both legs.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from gaitmon.analysis import analyse_bilateral
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine
from gaitmon.engine.pair import EnginePair
from gaitmon.finish import open_session
from gaitmon.finish.bilateral import open_bilateral, parts_of
from gaitmon.io.device import Device
from gaitmon.io.ports import make_transport
from gaitmon.io.session import SessionError
from gaitmon.io.sim.bilateral import BilateralConfig, BilateralPty, BilateralSim, UnitSpec
from gaitmon.io.sim.clock import CrystalClock
from gaitmon.io.sim.faults import FaultConfig

SPEED = 4.0
# the goals' recordings run at 2x: every ms of host jitter in the clock fit counts `speed`
# times in unit time, and at 4x a loaded machine's jitter took the alignment p95 to 13 ms once
GOAL_SPEED = 2.0


def _record(tmp_path: Path, config: BilateralConfig, seconds: float) -> tuple[BilateralSim, Path]:
    sim = BilateralSim(config)
    out = tmp_path / "both.h5"
    with BilateralPty(sim) as pty:
        engines = [
            Engine(Device(make_transport(str(p))), "raw", PipelineConfig(), transport_label=str(p))
            for p in pty.link_paths
        ]
        pair = EnginePair(*engines)
        pair.start(out)
        try:
            deadline = time.monotonic() + seconds / config.speed + 60.0
            while min(pair.recorded_s(s) for s in "LR") < seconds:
                assert time.monotonic() < deadline, "the pair did not record in time"
                time.sleep(0.05)
        finally:
            statuses = pair.stop()
        assert not any(st.error for st in statuses.values()), statuses
        pair.finish()
    return sim, out


def _config(speed: float = SPEED, **kw: object) -> BilateralConfig:
    return BilateralConfig(speed=speed, standing_s=3.0, seed=3, **kw)  # type: ignore[arg-type]


def _nearest(t: np.ndarray, ref: np.ndarray) -> np.ndarray:
    j = np.clip(np.searchsorted(ref, t), 1, len(ref) - 1)
    left, right = ref[j - 1], ref[j]
    return np.where(np.abs(t - left) < np.abs(t - right), j - 1, j)


def _check_against_truth(sim: BilateralSim, out: Path) -> dict[str, float]:
    truth = sim.truth()
    with open_bilateral(out) as b:
        an = analyse_bilateral(b)
        errors: dict[str, np.ndarray] = {}
        for side in "LR":
            u = b.unit(side)
            t = u.read("timeline/t_s")
            host = b.sync[side].host_at(t[u.heel_strike_idx])
            c_est = (host - sim.epoch) * sim.config.speed  # common s, by the simulator's pacing
            true_hs = truth.side(side).heel_strike_s
            j = _nearest(c_est, true_hs)
            e = c_est - true_hs[j]
            errors[side] = e[np.abs(e) < 0.2]  # detected within 0.2 s of a true heel strike
            assert len(errors[side]) >= 0.9 * len(c_est)
        both = np.concatenate(list(errors.values()))
        offset = float(np.median(both))  # the delivery delay both units share
        align = np.abs(both - offset)
        # double support, per heel strike (durations need no offset)
        ds_err = []
        for side in "LR":
            mine = an.gait.side(side)
            tru = truth.gait.side(side)
            # rows matched by time: common time -> host time -> the simulator's common time
            host = b.host_t0_s + mine.heel_strike_s * b.host_s_per_common_s
            c_mine = (host - sim.epoch) * sim.config.speed
            j = _nearest(c_mine, tru.heel_strike_s)
            for m in ("initial_double_support_s", "terminal_double_support_s"):
                d = getattr(mine, m) - getattr(tru, m)[j]
                ds_err.append(d[np.isfinite(d)])
        ds = np.abs(np.concatenate(ds_err))
        sr = an.gait.symmetry_of("step_s").ratio
        sr_true = truth.gait.symmetry_of("step_s").ratio
        # the units' relative drift: L's clock gains on R's by rate_L / rate_R - 1
        rel_ppm = (b.sync["R"].mean_slope / b.sync["L"].mean_slope - 1.0) * 1e6
        rates = [sim.config.unit_spec(s).clock.rate for s in "LR"]
        rel_true = (rates[0] / rates[1] - 1.0) * 1e6
    return {
        "align_p95_ms": float(np.percentile(align, 95) * 1e3),
        "offset_ms": offset * 1e3,
        "side_diff_ms": float(abs(np.median(errors["L"]) - np.median(errors["R"])) * 1e3),
        "ds_median_ms": float(np.median(ds) * 1e3),
        "n_ds": len(ds),
        "sr": sr,
        "sr_true": sr_true,
        "drift_err_ppm": rel_ppm - rel_true,
    }


def test_both_legs_one_file_meet_the_goals(tmp_path: Path) -> None:
    """On the hemiparetic walk (the symmetric walk's step ratio is checked with the cut below:
    the alignment and double-support goals do not depend on the walk, and each run costs 30 s)."""
    asymmetry = "hemiparetic"
    sim, out = _record(tmp_path, _config(GOAL_SPEED, asymmetry=asymmetry), 60.0)
    assert out.exists() and not parts_of(out)
    got = _check_against_truth(sim, out)
    print(got)
    assert got["align_p95_ms"] <= 10.0, got
    assert got["side_diff_ms"] <= 5.0, got
    assert 0.0 <= got["offset_ms"] <= 40.0, got  # one sample late, plus the link's delay
    assert got["n_ds"] >= 150, got
    assert got["ds_median_ms"] <= 10.0, got
    assert abs(got["sr"] - got["sr_true"]) <= 0.02, got
    # (the fitted relative drift is printed, not held: 60 s at 2x is 30 s of host time, where
    # 1 ms of host jitter is 35 ppm; benchmarks/bilateral_record.py measures it over an hour)
    assert got["sr"] < 0.9  # the affected left leg's shorter step is seen


def test_one_link_cut_for_5_s_leaves_a_gap_on_that_side_only(tmp_path: Path) -> None:
    right = UnitSpec(
        serial=1002,
        clock=CrystalClock(offset_s=0.0412, ppm=-22.0),
        faults=FaultConfig(seed=5, link_drops=((20.0, 5.0),)),
    )
    _sim, out = _record(tmp_path, _config(right=right), 45.0)
    assert out.exists() and not parts_of(out)
    with open_bilateral(out) as b:
        left_u, right_u = b.unit("L"), b.unit("R")
        assert sum(g.n_lost for g in left_u.gaps) == 0
        t_left = left_u.read("timeline/t_s")
        assert t_left[-1] - t_left[0] >= 44.0  # the left leg recorded on throughout
        lost_r = sum(g.n_lost for g in right_u.gaps)
        assert lost_r >= 450, right_u.gaps  # the 5 s (500 frames) cut, on the right only
        assert any(g.duration_s >= 4.5 for g in right_u.gaps)
        an = analyse_bilateral(b)
    # both legs' measures still come out, from the strides either side of the cut, and the
    # symmetric walk's step ratio is 1 (1.0000 true over an hour; +-0.003 on 60-s runs)
    assert abs(an.gait.symmetry_of("step_s").ratio - 1.0) <= 0.02


def test_a_bilateral_file_opens_one_side_at_a_time(tmp_path: Path) -> None:
    _sim, out = _record(tmp_path, _config(), 12.0)
    with pytest.raises(SessionError, match="both legs; pick one with --side L or --side R"):
        open_session(out)
    with open_session(out, side="L") as s:
        assert s.meta.side == "L" and s.device["serial"] == 1001 and s.n_samples > 1000
    with open_session(out, side="R") as s:
        assert s.meta.side == "R" and s.device["serial"] == 1002


def test_both_parts_cover_the_same_time_when_one_unit_connects_slowly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`gaitmon record` of two units starts both recordings once both stream: the right unit
    here takes 1.5 s to connect (a Bluetooth unit takes seconds). Each part holds --duration
    of its own rows, so when each started as its unit came up, the right part began and
    ended 3 s of the units' clocks (1.5 s at 2x) after the left one."""
    from gaitmon.cli import main
    from gaitmon.io.transport import InProcessTransport

    connect = InProcessTransport.open

    def slow_right(self: InProcessTransport) -> None:
        if self.name == "simulated R" and self._connections == 0:
            time.sleep(1.5)
        connect(self)

    monkeypatch.setattr(InProcessTransport, "open", slow_right)
    out = tmp_path / "both.h5"
    assert main(["record", "--simulate-bilateral", "--duration", "6", "--speed", "2", "-q",
                 "-o", str(out)]) == 0  # fmt: skip
    with open_bilateral(out) as b:
        (l0, l1), (r0, r1) = b.span_s("L"), b.span_s("R")
        together = b.together_s()
    # on the common time line (the clock fits): the two parts start and end together, within
    # one file's opening and how far each engine is behind its unit, at 2x on a busy machine
    # (old code: 3.3 s apart, the right unit's connect at 2x)
    assert abs(r0 - l0) < 1.5 and abs(r1 - l1) < 1.5, (l0, l1, r0, r1)
    assert together > 6.0 - 1.5 - 0.05
