"""The harder simulator (``realism="real"``, docs/simulator.md "Realism levels"): each effect is
there and of its documented size, the truth agrees with what the sensors see, and the default
simulator is untouched (its samples are also pinned by tests/test_unchanged_outputs.py)."""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
import pytest

from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, GYRO_IDX, STANDARD_GRAVITY_MS2
from gaitmon.io.sim.config import (
    REAL_GAIT,
    REAL_SENSORS,
    SimConfig,
    realism_gait,
    realism_sensors,
)
from gaitmon.io.sim.contact import FLAT_END, FLAT_START
from gaitmon.io.sim.kinematics import GaitConfig, GaitModel
from gaitmon.io.sim.sensors import SensorConfig, SensorModel, simulate

FS = 100.0
G = STANDARD_GRAVITY_MS2
FOOT = 3
# a perfect sensor: no noise, no bias or drift, no mounting offset, no impacts or soft tissue
PERFECT = {
    "acc_noise_ms2": 0.0, "gyro_noise_rad_s": 0.0, "gyro_bias_rad_s": (0.0,) * 4,
    "gyro_drift_amp_rad_s": 0.0, "mount_offset_rad": (0.0,) * 4, "impact_peak_ms2": (0.0,) * 4,
}  # fmt: skip


def _hard(n: int, seed: int = 3, gait: dict | None = None, sensors: dict | None = None):  # type: ignore[no-untyped-def]
    g = GaitModel(replace(realism_gait(GaitConfig(seed=seed), "real"), **(gait or {})))
    s = replace(realism_sensors(SensorConfig(seed=seed), "real"), **(sensors or {}))
    return g, simulate(n, g, s)


def _flat_samples(phase: np.ndarray, walking: np.ndarray) -> np.ndarray:
    """Samples in the middle of foot-flat once walking (the foot lies still there without the
    stance rocking)."""
    q = np.mod(phase, 1.0)
    mid = 0.5 * (FLAT_START + FLAT_END)
    return np.flatnonzero((np.abs(q - mid) < 0.25 * (FLAT_END - FLAT_START)) & (walking > 0.999))


def test_default_level_is_the_old_simulator() -> None:
    """SimConfig's default level hands the simulator exactly the configs it always had."""
    cfg = SimConfig()
    assert cfg.gait_config() == GaitConfig(cadence_steps_min=110.0, stride_cv=0.02)
    assert cfg.sensor_config() == SensorConfig()
    assert not cfg.gait_config().out_of_plane
    real = SimConfig(realism="real")
    assert real.gait_config().out_of_plane
    assert real.gait_config().stride_length_cv == REAL_GAIT["stride_length_cv"]
    assert real.sensor_config().acc_gain_sd == REAL_SENSORS["acc_gain_sd"]
    with pytest.raises(ValueError, match="realism"):
        SimConfig(realism="brutal")


def test_cli_option() -> None:
    from gaitmon.commands.simulate import add_simulator_options, sim_config_from_args

    ap = argparse.ArgumentParser()
    add_simulator_options(ap)
    assert sim_config_from_args(ap.parse_args(["--realism", "real"])).realism == "real"
    assert sim_config_from_args(ap.parse_args([])).realism == "default"


def test_accelerometer_gain_shows_in_standing_magnitude() -> None:
    """Standing still (tilt = mount offset), each axis reads its gain times its share of g
    plus the cross-axis share of the other: the closed form, and |a| off g by the drawn
    gains (within the documented 2.5 SD clip)."""
    g, sb = _hard(300, sensors={"acc_noise_ms2": 0.0, "tissue_acc_ms2": (0.0,) * 4})
    model = SensorModel(g, replace(realism_sensors(SensorConfig(seed=3), "real")))
    th = sb.kinematics.tilt_rad[100] + model.mount_offset_rad
    gain, cross = model.acc_gain, model.acc_cross
    ax = gain[:, 0] * G * np.cos(th) + cross[:, 0] * G * np.sin(th)
    az = gain[:, 1] * G * np.sin(th) + cross[:, 2] * G * np.cos(th)
    np.testing.assert_allclose(sb.physical[100, ACC_X_IDX], ax, atol=1e-9)
    np.testing.assert_allclose(sb.physical[100, ACC_Z_IDX], az, atol=1e-9)
    mag = np.hypot(sb.physical[100, ACC_X_IDX], sb.physical[100, ACC_Z_IDX]) / G - 1.0
    bound = 2.5 * (REAL_SENSORS["acc_gain_sd"] + REAL_SENSORS["acc_cross_sd"])
    assert np.all(np.abs(mag) <= bound)
    assert np.max(np.abs(mag)) > 0.005  # the default reads g to its noise
    easy = simulate(300, GaitModel(GaitConfig(seed=3)), SensorConfig(seed=3, acc_noise_ms2=0.0))
    ph = easy.physical[100]
    np.testing.assert_allclose(np.hypot(ph[ACC_X_IDX], ph[ACC_Z_IDX]), G, rtol=1e-12)


def test_gyro_scale_error() -> None:
    """A perfect gyro but for its scale reads (1 + s) times the true rate (no turns, no roll:
    no cross-axis rate), s within the documented 2.5 SD."""
    flat = {"roll_sd_deg": (0.0,) * 4, "swing_roll_deg": (0.0,) * 4,
            "swing_yaw_deg": (0.0,) * 4, "turn_every_strides": 0.0}  # fmt: skip
    g, sb = _hard(3000, gait=flat,
                  sensors={**PERFECT, "tissue_wobble_deg": (0.0,) * 4,
                           "gyro_drift2_amp_rad_s": 0.0})  # fmt: skip
    model = SensorModel(g, realism_sensors(SensorConfig(seed=3), "real"))
    rate = sb.kinematics.rate_rad_s
    np.testing.assert_allclose(sb.physical[:, GYRO_IDX], rate * model.gyro_scale, atol=1e-12)
    assert np.all(np.abs(model.gyro_scale - 1.0) <= 2.5 * REAL_SENSORS["gyro_scale_sd"])
    assert np.max(np.abs(model.gyro_scale - 1.0)) > 0.005


def test_stance_foot_rolls_over_as_documented() -> None:
    """The stance foot is not still: through its still phase it turns toe-down (the real
    feet's pitch gyro reads about -0.2 rad/s there in 97 % of gdins strides). The stillest
    0.1 s of each stance: mean |w_y| median 0.12 rad/s on the hard simulator (docs: real 0.14
    x-io, 0.21 gdins), the default's noise floor < 0.02; its signed mean is < 0 in most
    strides; and the planar |a| stays near g there (a slow turn about the ball)."""

    def stillest(gait: GaitModel, sb) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
        w = sb.physical[:, GYRO_IDX[FOOT]] - sb.gyro_bias_rad_s[:, FOOT]
        hs, to = gait.events(0, len(w))
        mean_abs, signed = [], []
        for h in hs[1:-1]:
            t = to[to > h][0]
            run = np.convolve(np.abs(w[h:t]), np.ones(10) / 10, mode="valid")
            i = int(np.argmin(run))
            mean_abs.append(run[i])
            signed.append(np.mean(w[h + i : h + i + 10]))
        return np.asarray(mean_abs), np.asarray(signed)

    g, sb = _hard(6000, gait={"roll_sd_deg": (0.0,) * 4})
    mean_abs, signed = stillest(g, sb)
    assert 0.09 <= np.median(mean_abs) <= 0.2
    assert np.mean(signed < 0) > 0.8
    easy = GaitModel(GaitConfig(seed=3))
    assert np.median(stillest(easy, simulate(6000, easy, SensorConfig(seed=3)))[0]) < 0.02
    kin = sb.kinematics
    flat = _flat_samples(kin.phase, kin.walking)
    assert np.all(kin.rate_rad_s[flat, FOOT] < 0)  # toe-down all through foot-flat
    ph = sb.physical
    mag = np.hypot(ph[flat, ACC_X_IDX[FOOT]], ph[flat, ACC_Z_IDX[FOOT]])
    model = SensorModel(g, realism_sensors(SensorConfig(seed=3), "real"))
    gain = 0.5 * (model.acc_gain[FOOT, 0] + model.acc_gain[FOOT, 1])
    assert np.percentile(np.abs(mag / gain - G), 90) < 0.6


def test_stride_length_variability_is_the_truths() -> None:
    """Stride lengths vary (CV near the documented 0.05), and each true length is the foot
    sensor's forward travel between its foot-flats in the kinematics the sensors are made of."""
    g = GaitModel(replace(realism_gait(GaitConfig(seed=5), "real"), turn_every_strides=0.0))
    n = 9000
    kin = g.evaluate(0, n)
    st = g.strides(0, n)
    lengths = st.stride_length_m[2:-2]
    cv = lengths.std() / lengths.mean()
    assert 0.03 < cv < 0.07
    # the sensor's forward position at the start of each foot-flat (phase k + FLAT_START)
    k = np.arange(3, int(kin.phase[-1]) - 1)
    pos = np.interp(k + FLAT_START, kin.phase, kin.position_m[:, FOOT, 0])
    hs_phase = np.interp(st.heel_strike_idx, np.arange(n), kin.phase)
    first = int(np.searchsorted(np.round(hs_phase), k[0]))
    np.testing.assert_allclose(np.diff(pos), st.stride_length_m[first : first + len(k) - 1],
                               atol=2e-3)  # fmt: skip


def test_stance_roll_over_turns_about_its_pivot() -> None:
    """The roll-over turns the flat foot about the pivot REAL_GAIT places 6.4 cm ahead of and
    7.3 cm below the sensor (gdins): through foot-flat that point stands still while the
    sensor moves at the pitch rate times the lever (forward ~ 0.073 |w|, up ~ 0.064 |w|); about
    the sensor's own point (0, 0) the sensor stands still; the footprints (the sensor at the
    start of each foot-flat, where the roll-over has not begun) are the same either way."""
    px, pz = REAL_GAIT["stance_pivot_m"]
    assert 0.03 < px < 0.1 and -0.1 < pz < -0.03
    plain = {"roll_sd_deg": (0.0,) * 4, "swing_roll_deg": (0.0,) * 4, "swing_yaw_deg": (0.0,) * 4,
             "turn_every_strides": 0.0}  # fmt: skip
    g = GaitModel(replace(realism_gait(GaitConfig(seed=3), "real"), **plain))
    g0 = GaitModel(replace(realism_gait(GaitConfig(seed=3), "real"), **plain,
                           stance_pivot_m=(0.0, 0.0)))  # fmt: skip
    kin, kin0 = g.evaluate(0, 6000), g0.evaluate(0, 6000)
    flat = _flat_samples(kin.phase, kin.walking)
    mu, rate = kin.tilt_rad[flat, FOOT], kin.rate_rad_s[flat, FOOT]  # the roll-over alone
    assert np.all(rate < -0.05)
    # sensor - pivot = R(mu) (-px, -pz); the pivot's velocity: v - mu' J R(mu) (-px, -pz) = 0
    a, b = -px, -pz
    vf = -rate * (np.sin(mu) * a + np.cos(mu) * b)
    vu = rate * (np.cos(mu) * a - np.sin(mu) * b)
    np.testing.assert_allclose(kin.velocity_m_s[flat, FOOT, 0], vf, atol=1e-9)
    np.testing.assert_allclose(kin.velocity_m_s[flat, FOOT, 1], vu, atol=1e-9)
    assert np.median(kin.velocity_m_s[flat, FOOT, 0]) > 0.005  # forward, as the heel rises
    np.testing.assert_allclose(kin0.velocity_m_s[flat, FOOT], 0.0, atol=1e-9)
    starts = np.arange(3, int(kin.phase[-1]) - 1) + FLAT_START
    for k in (kin, kin0):
        assert np.all(np.abs(np.interp(starts, k.phase, k.tilt_rad[:, FOOT])) < 1e-4)
    np.testing.assert_allclose(np.interp(starts, kin.phase, kin.position_m[:, FOOT, 0]),
                               np.interp(starts, kin0.phase, kin0.position_m[:, FOOT, 0]),
                               atol=1e-4)  # fmt: skip
    np.testing.assert_allclose(g.strides(0, 6000).stride_length_m,
                               g0.strides(0, 6000).stride_length_m, atol=1e-12)  # fmt: skip


def test_turns_change_the_truths_heading_and_path() -> None:
    """Each 180-degree turn turns the truth's heading by pi, its strides' turn_rad add up to
    it, and a turning stride's footprint distance is shorter than its path."""
    g, sb = _hard(9000)
    kin = sb.kinematics
    idle = np.flatnonzero(kin.yaw_rate_rad_s == 0.0)  # between turns (the record may end in one)
    turns = int(np.round(kin.heading_rad[idle[-1]] / np.pi))
    assert turns >= 3
    np.testing.assert_allclose(kin.heading_rad[idle], np.round(kin.heading_rad[idle] / np.pi)
                               * np.pi, atol=1e-9)  # fmt: skip
    st = g.strides(0, 8000)
    assert st.turn_rad is not None and st.path_length_m is not None
    # the strides run foot-flat to foot-flat: the last one ends 1 + FLAT_START after its heel
    # strike's phase
    end = np.round(kin.phase[st.heel_strike_idx[-1]]) + 1.0 + FLAT_START
    np.testing.assert_allclose(np.sum(st.turn_rad), np.interp(end, kin.phase, kin.heading_rad)
                               - kin.heading_rad[0], atol=0.2)  # fmt: skip
    turning = np.abs(st.turn_rad) > np.radians(45)
    assert turning.sum() >= turns - 1
    assert np.all(st.stride_length_m[turning] < st.path_length_m[turning])
    np.testing.assert_allclose(st.stride_length_m[~turning], st.path_length_m[~turning],
                               atol=2e-3)  # fmt: skip


def test_the_foot_turns_in_swing() -> None:
    """turn_in_swing (the real level): the foot board's heading (walk + its own yaw) holds
    still from each foot-flat's start to toe off, is the walk's at every foot-flat's start, and
    turns in swing at up to ~4 rad/s (gdins: peak vertical rate 4.5 rad/s in turning strides)."""
    from gaitmon.io.sim.kinematics import TOE_OFF_PHASE

    g = GaitModel(replace(realism_gait(GaitConfig(seed=3), "real"), swing_yaw_deg=(0.0,) * 4))
    assert g.config.turn_in_swing
    kin = g.evaluate(0, 9000)
    foot = kin.heading_rad + kin.board_yaw_rad[:, FOOT]
    rate = kin.yaw_rate_rad_s + kin.board_yaw_rate_rad_s[:, FOOT]
    q = np.mod(kin.phase, 1.0)
    stance = (q > FLAT_START + 0.01) & (q < TOE_OFF_PHASE - 0.01) & (kin.walking > 0.999)
    np.testing.assert_allclose(rate[stance], 0.0, atol=1e-12)
    assert np.max(np.abs(kin.yaw_rate_rad_s[stance])) > 0.5  # the walk turns meanwhile
    starts = np.arange(2, int(kin.phase[-1]) - 1) + FLAT_START
    walk = np.interp(starts, kin.phase, kin.heading_rad)
    np.testing.assert_allclose(np.interp(starts, kin.phase, foot), walk, atol=2e-3)
    np.testing.assert_allclose(np.gradient(foot, 1.0 / FS), rate, atol=0.05)
    assert 3.0 < np.max(np.abs(rate)) < 5.0


def test_turn_and_roll_leak_into_the_planar_sensors() -> None:
    """With a perfect sensor: the pitch gyro reads the tilt rate minus yaw rate x sin(roll)
    (the leak, up to ~0.1 rad/s in a turn), and the still flat foot's planar |a| is g cos(roll):
    gravity leaves the plane."""
    _, sb = _hard(6000, gait={"stance_micro_rad": 0.0},
                  sensors={**PERFECT, "acc_gain_sd": 0.0, "acc_cross_sd": 0.0,
                           "gyro_scale_sd": 0.0, "gyro_cross_sd": 0.0,
                           "tissue_wobble_deg": (0.0,) * 4, "tissue_acc_ms2": (0.0,) * 4,
                           "gyro_drift2_amp_rad_s": 0.0})  # fmt: skip
    kin = sb.kinematics
    leak = -(kin.yaw_rate_rad_s[:, None] + kin.board_yaw_rate_rad_s) * np.sin(kin.roll_rad)
    np.testing.assert_allclose(sb.physical[:, GYRO_IDX], kin.rate_rad_s + leak, atol=1e-12)
    assert np.max(np.abs(leak[:, FOOT])) > 0.05
    flat = _flat_samples(kin.phase, kin.walking)
    flat = flat[np.abs(kin.yaw_rate_rad_s[flat]) < 1e-9]  # no turn: no centripetal force
    assert np.all(kin.board_yaw_rad[flat, :FOOT] == 0.0)  # the swing yaw is over
    assert np.all(kin.board_yaw_rate_rad_s[flat] == 0.0)  # the foot may still face the turn
    mag = np.hypot(sb.physical[flat, ACC_X_IDX[FOOT]], sb.physical[flat, ACC_Z_IDX[FOOT]])
    np.testing.assert_allclose(mag, G * np.cos(kin.roll_rad[flat, FOOT]), rtol=1e-9)
    assert np.max(np.degrees(np.abs(kin.roll_rad[flat, FOOT]))) > 2.0
    # the accelerometer's tilt there is still the truth's
    tilt = np.arctan2(sb.physical[flat, ACC_Z_IDX[FOOT]], sb.physical[flat, ACC_X_IDX[FOOT]])
    np.testing.assert_allclose(tilt, kin.tilt_rad[flat, FOOT], atol=1e-9)


def test_integrating_the_noiseless_gyro_gives_the_truths_tilt() -> None:
    """Noiseless hard sensors: integrating (gyro - bias) / scale plus the documented leak
    reproduces the truth's tilt of every board over a minute with turns and roll."""
    quiet = {"acc_noise_ms2": 0.0, "gyro_noise_rad_s": 0.0, "gyro_cross_sd": 0.0,
             "tissue_wobble_deg": (0.0,) * 4}  # fmt: skip
    g, sb = _hard(7000, sensors=quiet)
    model = SensorModel(g, realism_sensors(SensorConfig(seed=3), "real"))
    kin = sb.kinematics
    rate = (sb.physical[:, GYRO_IDX] - sb.gyro_bias_rad_s) / model.gyro_scale
    rate = rate + (kin.yaw_rate_rad_s[:, None] + kin.board_yaw_rate_rad_s) * np.sin(kin.roll_rad)
    # Simpson-like accuracy is not needed: trapezoid at 100 Hz on these smooth rates
    tilt = kin.tilt_rad[0] + np.concatenate(
        [np.zeros((1, 4)), np.cumsum(0.5 * (rate[1:] + rate[:-1]) / FS, axis=0)]
    )
    err = np.degrees(np.abs(tilt - kin.tilt_rad))
    assert err.max() < 0.5, err.max(axis=0)


def test_hard_blocks_are_chunk_invariant() -> None:
    """The same samples in any block sizes (the per-stride draws are made in stride order)."""
    cfg = SimConfig(realism="real", seed=2)
    whole = SensorModel(GaitModel(cfg.gait_config()), cfg.sensor_config()).next_block(3000)
    model = SensorModel(GaitModel(cfg.gait_config()), cfg.sensor_config())
    parts = [model.next_block(k) for k in (1, 999, 7, 1993)]
    np.testing.assert_array_equal(np.concatenate([p.counts for p in parts]), whole.counts)
