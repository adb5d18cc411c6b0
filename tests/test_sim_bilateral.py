"""Two simulated units from one walk: their byte streams, clocks, events and symmetry.

The references are independent of the pair's own bookkeeping: the real frame decoder, the
single-unit pipeline's heel strikes (gaitmon.dsp.pipeline) on each unit's decoded samples,
mapped to common time with the clock parameters written here, the single-unit gait model, and
pyserial on the pseudo-terminals.
"""

import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import serial

from gaitmon.dsp.bilateral import bilateral_gait
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.io import protocol as P
from gaitmon.io.decoder import FrameDecoder
from gaitmon.io.sim.bilateral import (
    BilateralConfig,
    BilateralSim,
    UnitSpec,
    serve_pair_on_ptys,
)
from gaitmon.io.sim.clock import CrystalClock
from gaitmon.io.sim.faults import FaultConfig
from gaitmon.io.sim.kinematics import GaitConfig, GaitModel

FS = 100.0
EVENT_TOL_S = 0.010  # measured: |error| <= 7.7 ms (heel strike), 5.0 ms (toe off); bias ~ +2.7 ms


def cmd(c: P.Command, arg: int = 0) -> bytes:
    return P.encode_command(c, arg)


def common_time(clock: CrystalClock, idx: np.ndarray) -> np.ndarray:
    """t = offset + n / (fs (1 + ppm 1e-6)), written out here, not taken from the simulator."""
    return clock.offset_s + idx / (FS * (1.0 + clock.ppm * 1e-6))


def record(config: BilateralConfig, n_samples: int) -> dict:
    """Both units streamed as fast as possible through the real decoder; per side the
    identity, the decoder, the sample index of each RAW frame and the single-unit pipeline's
    events (sample indices in that unit's clock)."""
    sim = BilateralSim(config, afap_block=3000)
    out: dict = {"sim": sim}
    for side, unit in zip("LR", sim.units, strict=True):
        dec = FrameDecoder()
        unit.write(cmd(P.Command.IDENTIFY) + cmd(P.Command.START_STREAM))
        frames = []
        while unit.samples_produced < n_samples:
            frames += dec.feed(unit.read())
        ident = next(f.identity for f in frames if isinstance(f, P.IdentityFrame))
        raw = [f for f in frames if isinstance(f, P.RawFrame)]
        seq = np.array([f.seq for f in raw])
        counts = np.array([f.adc for f in raw])
        # streaming began before the first sample: one frame per tick from sample 0 on
        sample = seq - seq[0]
        pb = Pipeline(PipelineConfig()).process(counts)
        out[side] = {
            "identity": ident,
            "decoder": dec,
            "seq": seq,
            "sample": sample,
            "hs_idx": sample[pb.heel_strike_idx],
            "to_idx": sample[pb.toe_off_idx],
        }
    return out


def nearest(true_s: np.ndarray, got_s: np.ndarray) -> np.ndarray:
    """Index of the true event nearest to each detected one (each matched once)."""
    k = np.clip(np.searchsorted(true_s, got_s), 1, len(true_s) - 1)
    near = np.where(np.abs(true_s[k] - got_s) < np.abs(true_s[k - 1] - got_s), k, k - 1)
    assert len(np.unique(near)) == len(near), "two detections matched one true event"
    return near


@pytest.fixture(scope="module")
def symmetric():
    return record(BilateralConfig(speed=math.inf), 12000)  # 120 s each


HEMI_CLOCKS = (CrystalClock(0.731, 800.0), CrystalClock(1.402, -500.0))  # drift exaggerated


@pytest.fixture(scope="module")
def hemiparetic():
    cfg = BilateralConfig(
        speed=math.inf,
        asymmetry="hemiparetic",
        affected="R",
        seed=4,
        left=UnitSpec(serial=71, clock=HEMI_CLOCKS[0]),
        right=UnitSpec(serial=72, clock=HEMI_CLOCKS[1]),
    )
    return record(cfg, 9000)


def measured_events(rec: dict, clocks: tuple[CrystalClock, CrystalClock]) -> dict:
    return {
        side: (common_time(c, rec[side]["hs_idx"]), common_time(c, rec[side]["to_idx"]))
        for side, c in zip("LR", clocks, strict=True)
    }


def default_clocks() -> tuple[CrystalClock, CrystalClock]:
    cfg = BilateralConfig()
    return cfg.left.clock, cfg.right.clock


def test_each_unit_decodes_and_says_its_side_and_serial(symmetric):
    for side, serial_no in (("L", 1001), ("R", 1002)):
        r = symmetric[side]
        ident = r["identity"]
        assert (ident.side, ident.serial, ident.name) == (side, serial_no, "gaitmon-sim")
        assert ident.sample_rate_hz == 100
        st = r["decoder"].stats
        assert st.frames_lost == 0 and st.crc_failures == 0 and st.bytes_skipped == 0
        assert np.all(np.diff(r["seq"]) == 1) and len(r["seq"]) >= 12000
        # our reading of the stream (one frame per tick from sample 0) is the unit's own log
        unit = symmetric["sim"].unit(side)
        no, sample, _ = unit.frame_log()
        np.testing.assert_array_equal(sample[np.searchsorted(no, r["seq"])], r["sample"])


@pytest.mark.parametrize("case", ["symmetric", "hemiparetic"])
def test_detected_events_mapped_to_common_time_match_the_truth(case, request):
    rec = request.getfixturevalue(case)
    clocks = default_clocks() if case == "symmetric" else HEMI_CLOCKS
    truth = rec["sim"].truth(0.0, 200.0)  # beyond both units' samples: nothing matches wrong
    got = measured_events(rec, clocks)
    for side in "LR":
        st = truth.side(side)
        hs, to = got[side]
        end_s = common_time(st.clock, rec[side]["sample"][-1])
        inside = (st.heel_strike_s > st.heel_strike_s[0] + 1.0) & (st.heel_strike_s < end_s - 1)
        assert len(hs) >= inside.sum() > 50  # every true heel strike found (but the first)
        for name, true_s, got_s in (("hs", st.heel_strike_s, hs), ("to", st.toe_off_s, to)):
            err = got_s - true_s[nearest(true_s, got_s)]
            assert np.max(np.abs(err)) <= EVENT_TOL_S, (side, name, err)
            assert abs(np.median(err)) <= 0.005, (side, name)
        # the first sample at or after each true event, in the unit's own clock
        t_idx = common_time(st.clock, st.heel_strike_idx)
        assert np.all(t_idx >= st.heel_strike_s - 1e-9)
        assert np.all(t_idx - st.heel_strike_s < 1.0 / FS * (1 + 1e-3))
        # read as if the unit's counter were the common clock, the leg would be off by its
        # start offset (and drift): the mapping matters
        naive = rec[side]["hs_idx"] / FS - st.heel_strike_s[nearest(st.heel_strike_s, hs)]
        assert np.max(np.abs(naive)) > 0.03


@pytest.mark.parametrize("case", ["symmetric", "hemiparetic"])
def test_each_units_drift_is_the_configured_one(case, request):
    """The slope of the true common time of each detected heel strike against the unit's
    sample counter (a least-squares line) is 1 / (fs (1 + ppm))."""
    rec = request.getfixturevalue(case)
    clocks = default_clocks() if case == "symmetric" else HEMI_CLOCKS
    truth = rec["sim"].truth(0.0, 200.0)
    for side, clock in zip("LR", clocks, strict=True):
        idx = rec[side]["hs_idx"].astype(np.float64)
        true_s = truth.side(side).heel_strike_s
        k = nearest(true_s, common_time(clock, idx))
        slope, intercept = np.polyfit(idx, true_s[k], 1)
        ppm = (1.0 / (slope * FS) - 1.0) * 1e6
        assert ppm == pytest.approx(clock.ppm, abs=15.0), side
        # detections lag the true event by ~3 ms on average: the offset within 10 ms
        assert intercept == pytest.approx(clock.offset_s, abs=0.010), side


def test_pacing_follows_each_units_clock():
    """In real time each unit's counter is floor((t - offset) fs (1 + ppm)) at common time t."""

    class FakeClock:
        t = 500.0

        def __call__(self) -> float:
            return self.t

    fake = FakeClock()
    clocks = (CrystalClock(0.25, 5000.0), CrystalClock(1.5, -3000.0))
    cfg = BilateralConfig(left=UnitSpec(1, clocks[0]), right=UnitSpec(2, clocks[1]))
    sim = BilateralSim(cfg, clock=fake)
    for t in (0.2, 1.0, 20.0, 30.0):
        fake.t = 500.0 + t
        for unit, c in zip(sim.units, clocks, strict=True):
            unit.read()
            assert unit.samples_produced == max(0, math.floor((t - c.offset_s) * FS * c.rate))
    # 30 s of common time: 30 * 100 * 1.005 - 0.25 * 100.5 = 2989.9 and 30 * 99.7 - 149.55
    assert [u.samples_produced for u in sim.units] == [2989, 2841]
    wait = sim.left.seconds_until_next_sample()
    assert wait == pytest.approx(clocks[0].offset_s + 2990 / (FS * 1.005) - 30.0)


def test_symmetric_default_is_symmetric_and_half_a_cycle_apart(symmetric):
    got = measured_events(symmetric, default_clocks())
    g = bilateral_gait(*got["L"], *got["R"], max_stride_s=2.0)
    step = g.symmetry_of("step_s")
    assert step.ratio == pytest.approx(1.0, abs=0.01)
    assert step.index_pct < 1.0
    for m in ("stance_s", "swing_s", "single_support_s", "initial_double_support_s"):
        assert g.symmetry_of(m).ratio == pytest.approx(1.0, abs=0.05), m
    truth = symmetric["sim"].truth()
    assert truth.gait.symmetry_of("step_s").ratio == pytest.approx(1.0, abs=0.01)
    # each left heel strike halfway through the right stride around it
    hs_l, hs_r = got["L"][0], got["R"][0]
    k = np.searchsorted(hs_r, hs_l)
    inner = (k > 0) & (k < len(hs_r))
    frac = (hs_l[inner] - hs_r[k[inner] - 1]) / (hs_r[k[inner]] - hs_r[k[inner] - 1])
    assert np.mean(frac) == pytest.approx(0.5, abs=0.005)
    assert np.all(np.abs(frac - 0.5) < 0.02)
    # cadence measured from both legs: the configured 110 steps/min
    assert g.cadence_steps_min == pytest.approx(110.0, rel=0.02)


def test_hemiparetic_pair_has_the_configured_asymmetry(hemiparetic):
    got = measured_events(hemiparetic, HEMI_CLOCKS)
    g = bilateral_gait(*got["L"], *got["R"], max_stride_s=2.0)
    step = g.symmetry_of("step_s")
    assert step.ratio_of("R") == pytest.approx(0.85, abs=0.02)  # affected R: shorter step
    assert step.index_pct == pytest.approx(200 * 0.15 / 1.85, abs=1.0)  # 16.2 %
    # stance 0.60 of the stride on the affected side, 0.66 on the other
    assert np.nanmean(g.right.pct("stance_s")) == pytest.approx(60.0, abs=1.0)
    assert np.nanmean(g.left.pct("stance_s")) == pytest.approx(66.0, abs=1.0)
    # double support: affected stance - unaffected step share, and the other way round
    share_r = 0.85 / 1.85
    assert np.nanmean(g.right.pct("initial_double_support_s")) == pytest.approx(
        100 * (0.66 - share_r), abs=1.5
    )
    assert np.nanmean(g.left.pct("initial_double_support_s")) == pytest.approx(
        100 * (0.60 - (1 - share_r)), abs=1.5
    )
    # the affected knee swings as stiff as the single-unit stiff-knee pattern, the other normal
    sim = hemiparetic["sim"]
    for side, pattern in (("R", "stiff-knee"), ("L", "normal")):
        peak = np.degrees(sim.unit(side).truth(3000, 9000).joint_rad[:, 1].max())
        single = GaitModel(GaitConfig(pattern=pattern, seed=4)).evaluate(3000, 9000)
        assert peak == pytest.approx(np.degrees(single.joint_rad[:, 1].max()), abs=1.5), side


def test_one_walk_drives_both_legs():
    """With perfect clocks the right leg is the single-unit gait with the same seed, and the
    left heel strike falls at the configured share of each right stride."""
    perfect = CrystalClock()
    cfg = BilateralConfig(
        seed=11,
        stride_cv=0.05,
        asymmetry="hemiparetic",
        affected="L",
        left=UnitSpec(1, perfect),
        right=UnitSpec(2, perfect),
    )
    sim = BilateralSim(cfg, epoch=0.0)
    truth = sim.truth(0.0, 200.0)
    single = GaitModel(GaitConfig(seed=11, stride_cv=0.05, stance_fraction=0.66))
    hs_r = single.heel_strike_times_s(200.0)
    np.testing.assert_allclose(truth.right.heel_strike_s, hs_r, atol=1e-9)
    np.testing.assert_allclose(truth.right.heel_strike_idx, single.events(0, 20000)[0])
    stride_r = np.diff(hs_r)
    assert np.std(stride_r) / np.mean(stride_r) == pytest.approx(0.05, rel=0.25)
    hs_l = truth.left.heel_strike_s
    n = len(stride_r)
    np.testing.assert_allclose(hs_l[:n] - hs_r[:n], (0.85 / 1.85) * stride_r, atol=1e-9)
    assert truth.gait.symmetry_of("step_s").ratio_of("L") == pytest.approx(0.85)
    assert truth.step_time_ratio == 0.85 and truth.affected == "L"


def test_each_unit_has_its_own_faults():
    cfg = BilateralConfig(
        speed=math.inf,
        left=UnitSpec(1, CrystalClock(0.1, 10.0), faults=FaultConfig(seed=1, loss_pct=5.0)),
        right=UnitSpec(2, CrystalClock(0.2, -10.0), faults=FaultConfig(seed=2, corrupt_pct=3.0)),
    )
    sim = BilateralSim(cfg)
    for unit in sim.units:
        dec = FrameDecoder()
        unit.write(cmd(P.Command.START_STREAM))
        while unit.samples_produced < 2000:
            dec.feed(unit.read())
        # what the decoder missed is what this unit's ledger says it broke
        ledger = unit.ledger
        broken = len(ledger.dropped) + len(ledger.corrupted)
        last = ledger.frames_produced - 1
        unseen_at_end = int(last in ledger.dropped_frame_nos() + ledger.corrupted_frame_nos)
        assert dec.stats.frames_lost == broken - unseen_at_end
    left, right = sim.units
    assert len(left.ledger.dropped) > 50 and len(left.ledger.corrupted) == 0
    assert len(right.ledger.corrupted) > 20 and len(right.ledger.dropped) == 0


def test_a_leg_of_a_pair_cannot_stop_on_request():
    sim = BilateralSim(BilateralConfig(speed=math.inf))
    with pytest.raises(NotImplementedError, match="pair"):
        sim.left.stand_still()


def test_bad_settings_say_what_to_change():
    with pytest.raises(ValueError, match=r"stance .* must outlast"):
        BilateralConfig(asymmetry="hemiparetic", step_ratio=0.6)
    with pytest.raises(ValueError, match="clock offset"):
        BilateralConfig(left=UnitSpec(1, CrystalClock(6.0, 0.0)))
    with pytest.raises(ValueError, match="different serial"):
        BilateralConfig(left=UnitSpec(5), right=UnitSpec(5))
    with pytest.raises(ValueError, match="ppm"):
        CrystalClock(0.0, 20000.0)
    with pytest.raises(ValueError, match="finite"):
        BilateralConfig(standing_s=math.inf)
    with pytest.raises(ValueError, match="asymmetry"):
        BilateralConfig(asymmetry="limp")


def _read_first(port: serial.Serial, dec: FrameDecoder, timeout_s: float = 60.0) -> list:
    """The first frames read from ``port``: waits for them as long as a loaded machine needs."""
    frames: list = []
    end = time.monotonic() + timeout_s
    while not frames and time.monotonic() < end:
        frames += dec.feed(port.read(4096))
    return frames


def test_both_ptys_serve_at_once_through_pyserial():
    cfg = BilateralConfig(speed=2.0)
    with serve_pair_on_ptys(cfg) as pair:
        ports = [serial.Serial(str(p), timeout=0.05) for p in pair.link_paths]
        decs = [FrameDecoder(), FrameDecoder()]
        try:
            for port in ports:
                port.write(cmd(P.Command.IDENTIFY) + cmd(P.Command.START_STREAM))
            deadline = time.monotonic() + 60  # ~1 s at 2 x 100 Hz; longer on a loaded machine
            frames: list[list] = [[], []]
            while time.monotonic() < deadline and min(
                sum(isinstance(f, P.RawFrame) for f in got) for got in frames
            ) <= 100:  # read both, interleaved
                for i, port in enumerate(ports):
                    frames[i] += decs[i].feed(port.read(port.in_waiting or 1))
        finally:
            for port in ports:
                port.close()
        for side, got, dec in zip("LR", frames, decs, strict=True):
            ident = [f.identity for f in got if isinstance(f, P.IdentityFrame)]
            raw = [f for f in got if isinstance(f, P.RawFrame)]
            assert ident and ident[0].side == side
            assert len(raw) > 100  # 2 x 100 Hz for ~1 s
            assert dec.stats.frames_lost == 0 and dec.stats.crc_failures == 0
    assert not any(p.exists() for p in pair.link_paths)


def test_cli_serves_two_ports_and_prints_both_links(tmp_path):
    links = (tmp_path / "left", tmp_path / "right")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "gaitmon", "simulate", "--pty", "--bilateral",
         "--asymmetry", "hemiparetic", "--drift-ppm=-20,30", "--links", f"{links[0]},{links[1]}"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    try:
        lines = [proc.stdout.readline().strip() for _ in range(2)]
        assert lines == [str(links[0]), str(links[1])]
        for path, side in zip(lines, "LR", strict=True):
            with serial.Serial(path, timeout=0.1) as port:
                dec = FrameDecoder()
                port.write(cmd(P.Command.IDENTIFY))
                frames = _read_first(port, dec)  # the answer to IDENTIFY
            assert frames and frames[0].identity.side == side
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0 and "Traceback" not in err
    assert "drift -20 ppm" in err and "drift +30 ppm" in err
    assert not links[0].exists() and not links[1].exists()


def test_command_line_options_become_the_pairs_config():
    import argparse

    from gaitmon.commands.simulate import add_arguments, bilateral_config_from_args, run
    from gaitmon.errors import UserError

    p = argparse.ArgumentParser()
    add_arguments(p)
    cfg = bilateral_config_from_args(p.parse_args(["--pty", "--bilateral"]))
    assert (cfg.left.clock, cfg.right.clock) == (BilateralConfig().left.clock,
                                                 BilateralConfig().right.clock)  # fmt: skip
    assert cfg.asymmetry == "none" and cfg.step_time_ratio == 1.0
    args = p.parse_args(["--pty", "--bilateral", "--asymmetry", "hemiparetic", "--affected", "R",
                         "--drift-ppm=-5,12.5", "--clock-offset-s", "0,1", "--loss-pct", "2",
                         "--serials", "7,8", "--seed", "3"])  # fmt: skip
    cfg = bilateral_config_from_args(args)
    assert (cfg.affected, cfg.step_time_ratio, cfg.stance_fraction("R")) == ("R", 0.85, 0.60)
    assert cfg.left.clock == CrystalClock(0.0, -5.0) and cfg.right.clock == CrystalClock(1.0, 12.5)
    assert (cfg.left.serial, cfg.right.serial) == (7, 8)
    assert cfg.left.faults.loss_pct == cfg.right.faults.loss_pct == 2.0
    assert cfg.left.faults.seed != cfg.right.faults.seed  # each link loses its own frames
    with pytest.raises(UserError, match="--stand is not available"):
        bilateral_config_from_args(p.parse_args(["--pty", "--bilateral", "--stand"]))
    with pytest.raises(UserError, match="must outlast"):
        bilateral_config_from_args(p.parse_args(["--pty", "--bilateral", "--step-ratio", "0.6"]))
    with pytest.raises(UserError, match="--links names the two ports"):
        run(p.parse_args(["--pty", "--links", "a,b"]))
    with pytest.raises(UserError, match="name them with --links"):
        run(p.parse_args(["--pty", "--bilateral", "--link", "x"]))
    with pytest.raises(SystemExit):
        p.parse_args(["--drift-ppm", "3"])  # argparse: two numbers, LEFT,RIGHT
