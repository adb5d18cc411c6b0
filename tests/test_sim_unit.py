"""The simulated unit through the real protocol: commands, pacing, fault ledger, pty, CLI."""

import math
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import serial

from gaitmon.dsp.channels import DEFAULT_TABLE
from gaitmon.io import protocol as P
from gaitmon.io.decoder import FrameDecoder
from gaitmon.io.sim.faults import FaultConfig
from gaitmon.io.sim.kinematics import GaitConfig, GaitModel
from gaitmon.io.sim.pty import PtySimulator
from gaitmon.io.sim.sensors import SensorConfig, SensorModel
from gaitmon.io.sim.unit import SimulatedUnit

FS = 100.0


class FakeClock:
    def __init__(self, t: float = 1000.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def cmd(c: P.Command, arg: int = 0) -> bytes:
    return P.encode_command(c, arg)


def afap_unit(**kw) -> SimulatedUnit:
    return SimulatedUnit(GaitConfig(seed=5), SensorConfig(seed=5), speed=math.inf, **kw)


def expected_counts(seed: int, n: int) -> np.ndarray:
    """The ADC samples an independent sensor model with the same seed produces."""
    return (
        SensorModel(GaitModel(GaitConfig(seed=seed)), SensorConfig(seed=seed)).next_block(n).counts
    )


def test_identify_answers_with_the_identity_and_channel_table():
    unit, dec = afap_unit(side="L", serial=4242), FrameDecoder()
    unit.write(cmd(P.Command.IDENTIFY))
    (frame,) = dec.feed(unit.read())
    assert isinstance(frame, P.IdentityFrame)
    ident = frame.identity
    assert (ident.name, ident.side, ident.serial) == ("gaitmon-sim", "L", 4242)
    assert ident.n_channels == len(DEFAULT_TABLE.channels) and ident.sample_rate_hz == 100
    assert ident.matches_table(DEFAULT_TABLE)


def test_polled_raw_frames_carry_the_right_samples():
    unit, dec = afap_unit(), FrameDecoder()
    unit.write(cmd(P.Command.SELECT_KIND, P.FrameKind.RAW))
    (ack,) = dec.feed(unit.read())
    assert isinstance(ack, P.AckFrame) and ack.ok and ack.command == P.Command.SELECT_KIND
    frames = []
    for _ in range(50):
        unit.write(cmd(P.Command.REQUEST_FRAME))
        frames += dec.feed(unit.read())
    assert len(frames) == 50 and all(isinstance(f, P.RawFrame) for f in frames)
    assert [f.seq for f in frames] == list(range(1, 51))  # one frame per request, no gaps
    no, sample, _ = unit.frame_log()
    ref = expected_counts(5, unit.samples_produced)
    for f in frames:
        s = sample[no == f.seq][0]
        np.testing.assert_array_equal(f.adc, ref[s])
    assert dec.stats.frames_lost == 0 and dec.stats.crc_failures == 0


def test_streaming_starts_and_stops():
    unit, dec = afap_unit(), FrameDecoder()
    unit.write(cmd(P.Command.START_STREAM))
    frames = dec.feed(unit.read()) + dec.feed(unit.read())
    assert isinstance(frames[0], P.AckFrame) and frames[0].command == P.Command.START_STREAM
    raw = [f for f in frames[1:] if isinstance(f, P.RawFrame)]
    assert len(raw) == 2 * unit.afap_block
    # consecutive samples, every tick
    _, sample, _ = unit.frame_log()
    assert np.all(np.diff(sample) == 1)
    unit.write(cmd(P.Command.STOP_STREAM))
    (stop_ack,) = dec.feed(unit.read())
    assert stop_ack.command == P.Command.STOP_STREAM
    assert unit.read() == b""
    assert dec.stats.frames_lost == 0


def test_unknown_and_bad_commands_get_a_nak():
    unit, dec = afap_unit(), FrameDecoder()
    unit.write(cmd(P.Command.SELECT_KIND, 0x7F) + P.encode_command(0x55))
    bad, unknown = dec.feed(unit.read())
    assert bad.status == P.AckStatus.BAD_ARGUMENT
    assert unknown.status == P.AckStatus.UNKNOWN_COMMAND and unknown.command == 0x55
    unit.write(cmd(P.Command.IDENTIFY)[:3])  # a command split across writes still works
    unit.write(cmd(P.Command.IDENTIFY)[3:])
    assert isinstance(dec.feed(unit.read())[0], P.IdentityFrame)


def test_zero_then_joint_and_tilt_frames_track_the_truth():
    unit, dec = afap_unit(afap_block=500), FrameDecoder()
    unit.write(cmd(P.Command.ZERO))  # the subject stands still for the first 5 s
    (ack,) = dec.feed(unit.read())
    assert ack.command == P.Command.ZERO and ack.ok
    unit.write(cmd(P.Command.SELECT_KIND, P.FrameKind.JOINT) + cmd(P.Command.START_STREAM))
    frames = []
    while unit.samples_produced < 6000:
        frames += dec.feed(unit.read())
    joint = [f for f in frames if isinstance(f, P.JointFrame)]
    no, sample, _ = unit.frame_log()
    lookup = dict(zip(no.tolist(), sample.tolist(), strict=True))
    s = np.array([lookup[f.seq] for f in joint])
    truth = unit.truth(0, unit.samples_produced)
    true_deg = np.rad2deg(truth.joint_rad[s])
    acc = np.array([f.acc_joint_deg for f in joint])
    kal = np.array([f.kalman_joint_deg for f in joint])
    standing = (s > 200) & (s < 480)
    assert np.abs(acc[standing] - true_deg[standing]).max() < 1.0  # zeroing removed the offsets
    walking = s > 1500
    rms_acc = np.sqrt(np.mean((acc[walking] - true_deg[walking]) ** 2, axis=0))
    rms_kal = np.sqrt(np.mean((kal[walking] - true_deg[walking]) ** 2, axis=0))
    assert np.all(rms_kal < rms_acc)  # the paper's finding: Kalman beats the accelerometer
    assert rms_kal[1] < 10.0  # knee
    # Heel contact from the device's FSR detector follows the true heel strikes.
    heel = np.array([f.heel_loaded for f in joint])
    onsets = s[1:][np.diff(heel.astype(np.int8)) == 1]
    true_hs = truth.heel_strike_idx[truth.heel_strike_idx > 600]
    lag = np.array([onsets[onsets >= h].min() - h for h in true_hs[:-1]])
    assert np.all((lag >= 0) & (lag <= 15))  # 4 Hz low-pass delay, not a missed stride

    unit.write(cmd(P.Command.SELECT_KIND, P.FrameKind.TILT))
    tilt = [f for f in dec.feed(unit.read()) if isinstance(f, P.TiltFrame)]
    assert len(tilt) > 0
    no, sample, _ = unit.frame_log()
    lookup = dict(zip(no.tolist(), sample.tolist(), strict=True))
    st = np.array([lookup[f.seq] for f in tilt])
    true_tilt = np.rad2deg(unit.truth(0, unit.samples_produced).tilt_rad[st])
    kal_tilt = np.array([f.kalman_tilt_deg for f in tilt])
    assert np.sqrt(np.mean((kal_tilt - true_tilt) ** 2)) < 15.0


def test_zero_while_walking_is_refused():
    unit = SimulatedUnit(GaitConfig(seed=5, standing_s=0.0), speed=math.inf)
    dec = FrameDecoder()
    unit.write(cmd(P.Command.REQUEST_FRAME))
    for _ in range(5):
        unit.write(cmd(P.Command.REQUEST_FRAME) * 100)
        dec.feed(unit.read())
    unit.write(cmd(P.Command.ZERO))
    (ack,) = [f for f in dec.feed(unit.read()) if isinstance(f, P.AckFrame)]
    assert ack.status == P.AckStatus.BUSY


def test_pacing_has_no_drift_over_an_hour():
    clock = FakeClock(1000.0)
    unit = SimulatedUnit(clock=clock)
    unit.write(cmd(P.Command.START_STREAM))  # at t0: no sample due yet
    rng = np.random.default_rng(0)
    t0, n_bytes = clock.t, 0
    while clock.t - t0 < 3600.0:
        clock.t += float(rng.uniform(0.001, 10.0))  # irregular, like a busy thread
        n_bytes += len(unit.read())
        assert unit.samples_produced == math.floor((clock.t - t0) * FS)
    ack_len = P.FRAME_LEN[P.FrameKind.ACK]
    frames = (n_bytes - ack_len) / P.FRAME_LEN[P.FrameKind.RAW]
    assert frames == math.floor((clock.t - t0) * FS)
    # one hour in one jump: exactly 360000 samples, not one more or less
    clock2 = FakeClock(t0)
    unit2 = SimulatedUnit(clock=clock2)
    clock2.t = t0 + 3600.0 - 1e-6
    unit2.read()
    assert unit2.samples_produced == 359999
    clock2.t = t0 + 3600.0
    unit2.read()
    assert unit2.samples_produced == 360000


@pytest.mark.parametrize("speed", [0.5, 10.0])
def test_speed_factor(speed):
    clock = FakeClock(0.0)
    unit = SimulatedUnit(clock=clock, speed=speed)
    clock.t = 60.0
    unit.read()
    assert unit.samples_produced == math.floor(60.0 * FS * speed)
    assert unit.seconds_until_next_sample() == pytest.approx(1.0 / (FS * speed))


def test_ledger_matches_what_the_decoder_saw():
    faults = FaultConfig(seed=3, loss_pct=3.0, corrupt_pct=2.0, burst_pct=0.3, burst_len_frames=6)
    unit, dec = afap_unit(faults=faults), FrameDecoder()
    unit.write(cmd(P.Command.START_STREAM))
    frames = []
    while unit.samples_produced < 8000:
        frames += dec.feed(unit.read(4096))
    frames += dec.feed(unit.read())
    ledger = unit.ledger
    no, _, _ = unit.frame_log()
    dropped = set(ledger.dropped_frame_nos())
    corrupted = set(ledger.corrupted_frame_nos)
    assert len(ledger.dropped_frame_nos("loss")) > 100
    assert len(ledger.dropped_frame_nos("burst")) >= 6
    assert len(corrupted) > 50
    assert not dropped & corrupted
    delivered = {f.seq for f in frames if isinstance(f, P.RawFrame)}
    # exactly the frames the ledger says survived, and each decoded frame is intact
    assert delivered == set(no.tolist()) - dropped - corrupted
    st = dec.stats
    last = max(delivered)
    assert st.frames_lost == sum(1 for n in dropped | corrupted if n < last)
    assert st.frames_ok == len(delivered) + 1  # + the START_STREAM ack
    # A flip in sync/kind/length (the first 32 bits) rejects the header; elsewhere the CRC fails.
    header_hit = sum(1 for e in ledger.corrupted if min(e.bits) < 32)
    assert st.crc_failures >= len(corrupted) - header_hit
    assert 0 < header_hit < len(corrupted)
    # every byte of every corrupted frame was skipped, nothing else
    assert st.bytes_skipped == len(corrupted) * P.FRAME_LEN[P.FrameKind.RAW]
    ref = expected_counts(5, unit.samples_produced)
    for f in frames[1:200]:
        if isinstance(f, P.RawFrame):
            np.testing.assert_array_equal(f.adc, ref[f.seq - 1])  # ack took seq 0


def test_silence_and_link_drop_are_logged():
    faults = FaultConfig(silences=((2.0, 1.0),), link_drops=((5.0, 0.5),))
    clock = FakeClock(0.0)
    unit, dec = SimulatedUnit(clock=clock, faults=faults), FrameDecoder()
    unit.write(cmd(P.Command.START_STREAM))
    down_seen = []
    frames = []
    for _ in range(800):
        clock.t += 0.01
        down_seen.append(unit.link_is_down())
        frames += dec.feed(unit.read())
    down = np.array(down_seen)
    assert down.sum() == pytest.approx(50, abs=1)  # 0.5 s of link drop
    no, sample, _ = unit.frame_log()
    got = {f.seq for f in frames if isinstance(f, P.RawFrame)}
    silent = set(unit.ledger.dropped_frame_nos("silent"))
    link = set(unit.ledger.dropped_frame_nos("link_down"))
    assert {int(s) for n, s in zip(no, sample, strict=True) if n in silent} == set(range(200, 300))
    link_samples = {int(s) for n, s in zip(no, sample, strict=True) if n in link}
    # produced during the drop, plus what was still queued, unread, when it began
    assert set(range(500, 550)) <= link_samples <= set(range(495, 550))
    assert got == set(no.tolist()) - silent - link
    assert dec.stats.frames_lost == len(silent) + len(link)


def test_in_process_transport_streams_from_the_unit():
    from gaitmon.io.transport import InProcessTransport

    unit = SimulatedUnit(GaitConfig(seed=1))
    link = InProcessTransport(unit)
    link.open()
    dec = FrameDecoder()
    link.write(cmd(P.Command.START_STREAM))
    frames: list = []
    deadline = time.monotonic() + 30
    while len(frames) < 11 and time.monotonic() < deadline:
        frames += dec.feed(link.read(0.5))
    link.close()
    assert unit.closed
    assert isinstance(frames[0], P.AckFrame)
    assert [f.seq for f in frames[1:11]] == list(range(1, 11))
    assert unit.read() == b""


def _read_frames(port: serial.Serial, dec: FrameDecoder, until, timeout_s: float = 60.0) -> list:
    """The frames read from ``port`` until ``until(frames)`` holds (or ``timeout_s``, a loaded
    machine's margin: the test's assertions then say what is missing)."""
    out: list = []
    end = time.monotonic() + timeout_s
    while not until(out) and time.monotonic() < end:
        out += dec.feed(port.read(4096))
    return out


def _n_raw(frames: list) -> int:
    return sum(isinstance(f, P.RawFrame) for f in frames)


def test_pty_round_trip_survives_cut_and_restore(tmp_path):
    link = tmp_path / "ttyGAIT0"
    unit = SimulatedUnit(GaitConfig(seed=1))
    threads_before = threading.active_count()
    with PtySimulator(unit, link) as sim:
        port = serial.Serial(str(link), timeout=0.05)
        dec = FrameDecoder()
        port.write(cmd(P.Command.IDENTIFY) + cmd(P.Command.START_STREAM))
        frames = _read_frames(port, dec, lambda fr: _n_raw(fr) >= 20)
        assert isinstance(frames[0], P.IdentityFrame)
        raw = [f for f in frames if isinstance(f, P.RawFrame)]
        assert len(raw) >= 20
        assert dec.stats.frames_lost == 0 and dec.stats.crc_failures == 0

        sim.cut()
        assert not link.exists()
        with pytest.raises(serial.SerialException):
            for _ in range(20):  # the open port reports the hang-up
                port.read(100)
        port.close()
        with pytest.raises(serial.SerialException):
            serial.Serial(str(link))
        time.sleep(0.3)  # at least 30 frames produced while the port is gone (the unit's clock)
        sim.restore()
        port = serial.Serial(str(link), timeout=0.05)  # same path, new pty
        dec2 = FrameDecoder()
        after = [f for f in _read_frames(port, dec2, lambda fr: _n_raw(fr) >= 20)
                 if isinstance(f, P.RawFrame)]  # fmt: skip
        port.close()
        assert len(after) >= 20
        lost = unit.ledger.dropped_frame_nos("link_down")
        assert len(lost) >= 20  # ~0.3 s at 100 Hz produced while the port was gone
        assert after[0].seq > max(lost) >= min(lost) > raw[-1].seq
    assert threading.active_count() == threads_before
    assert not link.exists()


def test_pty_follows_a_scheduled_link_drop(tmp_path):
    link = tmp_path / "tty"
    t_start = 0.3
    unit = SimulatedUnit(GaitConfig(seed=1), faults=FaultConfig(link_drops=((t_start, 0.4),)))
    with PtySimulator(unit, link):
        deadline = time.monotonic() + 60.0  # ends as soon as the link is back
        seen_down = False
        while time.monotonic() < deadline:
            if not link.exists():
                seen_down = True
            elif seen_down:
                break
            time.sleep(0.02)
        assert seen_down and link.exists()  # it went away and came back


def _gaitmon(*args: str, **kw) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "gaitmon", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kw,
    )


def test_cli_help():
    out = subprocess.run(
        [sys.executable, "-m", "gaitmon", "simulate", "--help"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert out.returncode == 0
    for word in ("--pty", "--link", "--cadence", "--pattern", "--loss-pct", "--corrupt-pct"):
        assert word in out.stdout


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_cli_serves_a_port_and_exits_cleanly(tmp_path, sig):
    link = tmp_path / "ttyGAIT0"
    proc = _gaitmon("simulate", "--pty", "--link", str(link), "--seed", "2", "--loss-pct", "0")
    try:
        line = proc.stdout.readline().strip()
        assert line == str(link)
        port = serial.Serial(line, timeout=0.1)
        dec = FrameDecoder()
        port.write(cmd(P.Command.IDENTIFY))
        frames = _read_frames(port, dec, bool)  # the first frame: the answer to IDENTIFY
        port.close()
        assert frames and frames[0].identity.name == "gaitmon-sim"
    finally:
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0
    assert "Traceback" not in err
    assert not link.exists()


def test_cli_refuses_bad_arguments():
    out = subprocess.run(
        [sys.executable, "-m", "gaitmon", "simulate"], capture_output=True, text=True, check=False
    )
    assert out.returncode == 2 and "--pty" in out.stderr and "Traceback" not in out.stderr
    assert os.environ.get("GAITMON_NEVER_SET") is None


def test_sim_config_holds_the_command_line_defaults_and_rejects_bad_values():
    import argparse
    import dataclasses

    from gaitmon.commands.simulate import add_simulator_options, sim_config_from_args
    from gaitmon.errors import UserError
    from gaitmon.io.sim.config import SimConfig, build_unit

    p = argparse.ArgumentParser()
    add_simulator_options(p)
    assert sim_config_from_args(p.parse_args([])) == SimConfig()
    args = p.parse_args(["--pattern", "stiff-knee", "--speed", "max", "--loss-pct", "2"])
    cfg = sim_config_from_args(args)
    assert cfg == SimConfig(pattern="stiff-knee", speed=math.inf, loss_pct=2.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.seed = 1  # type: ignore[misc]
    # the unit built from it carries the settings
    unit = build_unit(SimConfig(side="L", cadence_steps_min=90.0, seed=3))
    try:
        assert unit.identity.side == "L" and unit.gait_config.cadence_steps_min == 90.0
        assert unit.faults.seed == 3
    finally:
        unit.close()
    # bad values: ValueError in the dataclass, the user's error at the argparse edge
    with pytest.raises(ValueError, match="cadence 300"):
        SimConfig(cadence_steps_min=300.0)
    with pytest.raises(ValueError, match="side must be L or R"):
        SimConfig(side="X")
    with pytest.raises(UserError, match=r"stride CV 0\.5 is outside"):
        sim_config_from_args(p.parse_args(["--stride-cv", "0.5"]))
    # `record` has no unit --side of its own: the session's leg, or the right one
    rec = argparse.Namespace(**{**vars(p.parse_args([])), "side": ""})
    assert sim_config_from_args(rec).side == "R"
