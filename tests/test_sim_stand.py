"""The simulator's stand-still command (issue 12, defect 10): the simulated subject stops and
stands still on request, long enough to zero, and walks again; in the gait model, in process
through the real Device, over the pty with `gaitmon simulate` and its signals, and from the
live window's Simulator menu."""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import QSettings

from gaitmon.dsp.calibration import CalibrationError, standing_calibration
from gaitmon.dsp.channels import DEFAULT_TABLE
from gaitmon.io import protocol as p
from gaitmon.io.device import Device, SampleBlock
from gaitmon.io.sim.config import SimConfig
from gaitmon.io.sim.kinematics import GaitConfig, GaitModel
from gaitmon.io.sim.unit import SimulatedUnit
from gaitmon.io.transport import InProcessTransport, SerialTransport

pytestmark = pytest.mark.timeout(90)
FS = 100
KINDS = [c.kind for c in DEFAULT_TABLE.channels]
GYRO = [i for i, k in enumerate(KINDS) if k == "gyro"]
ACC_X = [i for i, k in enumerate(KINDS) if k == "acc_x"]
ACC_Z = [i for i, k in enumerate(KINDS) if k == "acc_z"]
WALK_GYRO_RMS = 0.5  # rad/s: the segments' rates while walking are well above this


def test_model_stops_at_mid_stance_stands_upright_and_walks_again():
    ref = GaitModel(GaitConfig(standing_s=1.0))
    g = GaitModel(GaitConfig(standing_s=1.0))
    walked = g.evaluate(0, 500)
    t_stand = g.stand(5.0)
    assert 5.0 < t_stand < 5.0 + 3 * GaitConfig().stride_s  # within a couple of strides
    stood = g.evaluate(500, 1500)
    # nothing already produced changed (the truth of a recording stays the truth)
    np.testing.assert_array_equal(g.evaluate(0, 500).tilt_rad, ref.evaluate(0, 500).tilt_rad)
    np.testing.assert_array_equal(walked.lin_acc_ms2, ref.evaluate(0, 500).lin_acc_ms2)
    i = math.ceil(t_stand * FS) - 500
    assert np.all(stood.rate_rad_s[i:] == 0) and np.all(stood.tilt_rad[i:] == 0)
    assert np.all(stood.joint_rad[i:] == 0) and np.all(stood.lin_acc_ms2[i:] == 0)
    assert np.all(np.mod(stood.phase[i:], 1.0) == pytest.approx(0.25))  # both feet loaded
    assert np.sqrt(np.mean(stood.rate_rad_s[: i - 150] ** 2)) > WALK_GYRO_RMS  # it was walking
    g.walk(15.0)
    again = g.evaluate(1500, 2500)
    np.testing.assert_array_equal(g.evaluate(500, 1500).tilt_rad, stood.tilt_rad)
    assert np.sqrt(np.mean(again.rate_rad_s[300:] ** 2)) > WALK_GYRO_RMS
    hs = g.heel_strike_times_s(25.0)
    assert not np.any((hs > t_stand) & (hs < 15.0))  # no steps while standing
    assert np.sum(hs > 15.0) >= 7  # ~10 s of walking at 110 steps/min
    # a request during the first standing period extends it; walk ends it early
    g2 = GaitModel(GaitConfig(standing_s=3.0))
    g2.evaluate(0, 100)
    assert g2.stand(1.0) == 0.0
    assert np.all(g2.evaluate(100, 2000).rate_rad_s == 0)
    g2.walk(20.0)
    assert g2.heel_strike_times_s(30.0)[0] == pytest.approx(20.0 + 1.0, abs=1.0)


def gyro_rms(blocks: list[SampleBlock]) -> float:
    adc = np.concatenate([b.adc for b in blocks])
    gyro = DEFAULT_TABLE.to_physical(adc.astype(np.float64))[:, GYRO]
    gyro = gyro - gyro.mean(axis=0)  # the sensors' bias is not motion
    return float(np.sqrt(np.mean(gyro**2)))


def can_zero(blocks: list[SampleBlock]) -> bool:
    """What the engine's Zero checks: the last 1.5 s received are still and upright."""
    adc = np.concatenate([b.adc for b in blocks])[-150:]
    phys = DEFAULT_TABLE.to_physical(adc.astype(np.float64))
    acc = np.stack([phys[:, ACC_X], phys[:, ACC_Z]], axis=-1)  # (N, segment, x/z)
    try:
        standing_calibration(acc, phys[:, GYRO])
    except CalibrationError:
        return False
    return True


def take(dev: Device, seconds: float) -> list[SampleBlock]:
    out: list[SampleBlock] = []
    while sum(len(b) for b in out) < seconds * FS:
        b = dev.read_block(5.0)  # generous: a loaded machine delays the simulator process
        assert b is not None, "the unit stopped sending"
        out.append(b)
    return out


def take_after(dev: Device, unit: SimulatedUnit, first_sample: int, seconds: float):
    """Blocks of the samples the unit made from ``first_sample`` on (by its frame log: the
    device may still hold samples made before, however far the unit ran ahead)."""
    from gaitmon.io.sim.truth import row_samples

    out: list[SampleBlock] = []
    while sum(len(b) for b in out) < seconds * FS:
        b = dev.read_block(5.0)  # generous: a loaded machine delays the simulator process
        assert b is not None, "the unit stopped sending"
        keep = row_samples(b.seq, unit) >= first_sample
        if keep.any():
            out.append(dataclasses.replace(b, seq=b.seq[keep], adc=b.adc[keep]))
    return out


def stand_and_walk(dev: Device, unit: SimulatedUnit) -> list[tuple[str, float, bool, bool]]:
    """Walk, stand still, walk again: per stage (name, segment gyro RMS in rad/s, whether the
    engine's Zero would accept it, whether the unit said it stands)."""
    dev.select_kind(p.FrameKind.RAW)
    dev.start_stream()
    walking = take(dev, 3.0)  # standing_s=0: walking from the first sample
    stages = [("walking", gyro_rms(walking), can_zero(walking), unit.standing)]
    at = unit.samples_produced
    unit.stand_still()
    # stops within three strides (the hip looks ahead to the next foot-flat): 4 s after the
    # request, on the unit's own sample clock
    standing = take_after(dev, unit, at + 4 * FS, 2.0)
    stages.append(("standing", gyro_rms(standing), can_zero(standing), unit.standing))
    at = unit.samples_produced
    unit.walk()
    # the walk ramps in over a stride
    again = take_after(dev, unit, at + round(1.5 * FS), 2.0)
    stages.append(("walking again", gyro_rms(again), can_zero(again), unit.standing))
    return stages


def check_stages(stages: list[tuple[str, float, bool, bool]]) -> None:
    (_, walk_rms, walk_zero, walk_stands), (_, stand_rms, stand_zero, stands), (
        _, again_rms, _, again_stands) = stages  # fmt: skip
    assert walk_rms > WALK_GYRO_RMS and not walk_zero and not walk_stands
    assert stand_rms < 0.05 and stand_zero and stands  # the segment gyros go quiet
    assert again_rms > WALK_GYRO_RMS and not again_stands  # walking resumes


def test_stand_still_in_process_through_the_device():
    unit = SimulatedUnit(GaitConfig(standing_s=0.0), speed=math.inf)
    with Device(InProcessTransport(unit)) as dev:
        stages = stand_and_walk(dev, unit)
    assert [name for name, *_ in stages] == ["walking", "standing", "walking again"]
    check_stages(stages)


def test_stand_still_over_the_pty():
    from gaitmon.io.sim.pty import PtySimulator

    unit = SimulatedUnit(GaitConfig(standing_s=0.0), speed=10.0)
    with PtySimulator(unit) as sim, Device(SerialTransport(str(sim.link_path))) as dev:
        stages = stand_and_walk(dev, unit)
    check_stages(stages)


def test_gaitmon_simulate_stands_until_sigusr2_and_stands_again_on_sigusr1(tmp_path: Path):
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    proc = subprocess.Popen(
        [sys.executable, "-m", "gaitmon", "simulate", "--pty", "--stand", "--speed", "5",
         "--link", str(tmp_path / "ttyGAIT0")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True,
    )  # fmt: skip
    try:
        assert proc.stdout is not None
        port = proc.stdout.readline().strip()
        with Device(SerialTransport(port), command_timeout_s=5.0) as dev:  # a loaded machine
            dev.select_kind(p.FrameKind.RAW)
            dev.start_stream()
            standing = take(dev, 6.0)  # longer than the default 5 s of standing
            assert gyro_rms(standing) < 0.05 and can_zero(standing)
            proc.send_signal(signal.SIGUSR2)  # walk
            take(dev, 2.0)
            walking = take(dev, 3.0)
            assert gyro_rms(walking) > WALK_GYRO_RMS and not can_zero(walking)
            proc.send_signal(signal.SIGUSR1)  # stand still
            take(dev, 3.0)
            assert can_zero(take(dev, 2.0))
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    assert "Traceback" not in err


def test_live_window_simulator_menu_stands_the_subject_still_for_zeroing(qtbot, tmp_path):
    from gaitmon.live.connection import SIMULATED_PORT
    from gaitmon.ui.live import MainWindow

    settings = QSettings(str(tmp_path / "gaitmon.ini"), QSettings.Format.IniFormat)
    # the subject walks from the start: without the command there is no moment to zero
    win = MainWindow(
        settings, sim=SimConfig(standing_s=0.0, speed=2.0), autoconnect=SIMULATED_PORT,
        confirm_close=False,
    )  # fmt: skip
    win.show()
    try:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=15_000)
        menu = {a.text(): a for a in win.sim_menu.actions()}
        assert {"Stand still", "Walk again"} <= set(menu)
        qtbot.waitUntil(lambda: win.engine.samples_total >= 200, timeout=15_000)
        win.act_zero.trigger()
        qtbot.waitUntil(lambda: "Zero refused" in win.statusBar().currentMessage(), timeout=15_000)

        menu["Stand still"].trigger()
        assert "stands still" in win.statusBar().currentMessage()
        unit = win.conn.unit
        assert unit is not None and unit.standing
        at = win.engine.samples_total
        qtbot.waitUntil(lambda: win.engine.samples_total >= at + 500, timeout=15_000)
        win.act_zero.trigger()
        qtbot.waitUntil(lambda: "zeroed" in win.statusBar().currentMessage(), timeout=15_000)
        # the label follows the engine's snapshot on the next display tick
        qtbot.waitUntil(lambda: "zero: standing calibration" in win.status.method_label.full_text,
                        timeout=5_000)  # fmt: skip

        menu["Walk again"].trigger()
        assert not unit.standing
        at = win.engine.samples_total
        qtbot.waitUntil(lambda: win.engine.samples_total >= at + 400, timeout=15_000)
        win.act_zero.trigger()
        qtbot.waitUntil(lambda: "Zero refused" in win.statusBar().currentMessage(), timeout=15_000)
    finally:
        win.close()
    assert win.errors == []
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(
        t.name.startswith("gaitmon") for t in threading.enumerate()
    ):
        time.sleep(0.05)
