"""Stride length, gait speed and foot clearance from the foot IMU (gaitmon.dsp.stride_length):
a hand-computed synthetic foot, the simulator's truth on three gait patterns (offline and
streaming), a recorded session's /truth, and bad input."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from gaitmon.dsp import StrideLengthTracker, stride_lengths, stride_measures
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX
from gaitmon.dsp.gyro_events import gyro_gait_events
from gaitmon.dsp.stride_length import (
    ANCHOR_LEVER_M,
    FLAG_FIRST_STEP,
    FLAG_NEAR_STILL,
    FLAG_NO_FOOT_FLAT,
    FLAG_OUT_OF_PLANE,
    STILL_GYRO_RAD_S,
)
from gaitmon.io.sim import GaitConfig, GaitModel
from gaitmon.io.sim.sensors import realistic_sensors, simulate

FS = 100.0
G = 9.80665


# ---- a synthetic foot, computed by hand ------------------------------------------------------
V_MS, RAMP_S, CRUISE_S = 1.2, 0.3, 0.5  # swing: ramp up, constant velocity, ramp down
SWING_S = 2 * RAMP_S + CRUISE_S
STANCE_S = 0.5
LIFT_M = 0.07  # the swing's peak height
PITCH0_RAD, SWING_PITCH_RAD = np.radians(4.0), np.radians(-40.0)
# raised-cosine ramps cover half their time at full speed: V (RAMP_S + CRUISE_S) per stride


def synthetic_foot(
    n_strides: int = 6, gyro_bias_rad_s: float = 0.0, v_ms: float = V_MS, toe_up: bool = False
):
    """Stance (still, flat: the board at its mounting pitch) then a swing that moves forward
    with a raised-cosine ramp to V_MS, cruises, and ramps down, lifts by LIFT_M and pitches the
    foot down and back (``toe_up``: down in the first half of the swing, up in the second, as a
    real foot from toe off to heel strike). Returns acc x, acc z, gyro and the heel strikes
    (start of each stance)."""
    stride_s = STANCE_S + SWING_S
    n = round((n_strides * stride_s + STANCE_S) * FS)
    t = np.arange(n) / FS
    tau = np.mod(t, stride_s) - STANCE_S  # time into the swing (< 0: stance)
    swing = tau > 0
    u = np.clip(tau, 0.0, SWING_S)
    # forward acceleration: +V/2 (pi/RAMP) sin over the first ramp, the mirror over the last
    w = np.pi / RAMP_S
    acc_f = np.where(u < RAMP_S, 0.5 * v_ms * w * np.sin(w * u), 0.0)
    late = u > RAMP_S + CRUISE_S
    acc_f = np.where(late, -0.5 * v_ms * w * np.sin(w * (u - RAMP_S - CRUISE_S)), acc_f)
    acc_f = np.where(swing, acc_f, 0.0)
    # height LIFT sin^2(pi u / SWING): its acceleration
    k = np.pi / SWING_S
    acc_u = np.where(swing, LIFT_M * 2.0 * k * k * np.cos(2.0 * k * u), 0.0)
    if toe_up:  # SWING_PITCH sin(2ku) sin^2(ku): its rate is 0 at both ends
        shape = np.sin(2.0 * k * u) * np.sin(k * u) ** 2
        d_shape = k * (2.0 * np.cos(2.0 * k * u) * np.sin(k * u) ** 2
                       + np.sin(2.0 * k * u) ** 2)  # fmt: skip
        pitch = PITCH0_RAD + np.where(swing, 1.5 * SWING_PITCH_RAD * shape, 0.0)
        rate = np.where(swing, 1.5 * SWING_PITCH_RAD * d_shape, 0.0)
    else:
        pitch = PITCH0_RAD + np.where(swing, SWING_PITCH_RAD * np.sin(k * u) ** 2, 0.0)
        rate = np.where(swing, SWING_PITCH_RAD * k * np.sin(2.0 * k * u), 0.0)
    f_f, f_u = acc_f, acc_u + G
    ax = -f_f * np.sin(pitch) + f_u * np.cos(pitch)
    az = f_f * np.cos(pitch) + f_u * np.sin(pitch)
    hs = np.round(np.arange(n_strides + 1) * stride_s * FS).astype(np.int64)
    return ax, az, rate + gyro_bias_rad_s, hs[hs < n]


@pytest.mark.parametrize(("bias", "v_ms"), [(0.0, V_MS), (0.03, V_MS), (0.03, 0.7)])
def test_synthetic_foot_gives_the_hand_computed_stride(bias, v_ms):
    ax, az, gy, hs = synthetic_foot(gyro_bias_rad_s=bias, v_ms=v_ms)
    m = stride_measures(ax, az, gy, FS, hs)
    assert len(m) == len(hs) - 1 == 6
    # v * (0.3 + 0.5) s forward per stride (1.2 m/s: 0.96 m; 0.7 m/s: 0.56 m); lifted 7 cm.
    # A gyro bias left by the calibration reads as a roll of the foot at both foot-flats: the
    # board taken to move forward at ANCHOR_LEVER_M times it (step 4) over the stride's time
    stride_m = v_ms * (RAMP_S + CRUISE_S)
    rolled_m = ANCHOR_LEVER_M * bias * (STANCE_S + SWING_S)
    np.testing.assert_allclose(m.stride_length_m, stride_m - rolled_m, atol=0.002)
    np.testing.assert_allclose(m.foot_clearance_m, LIFT_M, atol=0.002)
    np.testing.assert_allclose(m.stride_time_s, STANCE_S + SWING_S)
    np.testing.assert_allclose(m.speed_m_s, (stride_m - rolled_m) / (STANCE_S + SWING_S),
                               atol=0.002)  # fmt: skip
    # the foot-flat anchors lie in the stances, between heel strike and swing
    assert np.all((m.foot_flat_idx[:, 0] > hs[:-1]) & (m.foot_flat_idx[:, 0] < hs[:-1] + 50))
    np.testing.assert_array_equal(stride_lengths(ax, az, gy, FS, hs), m.stride_length_m)


def test_a_stride_without_a_foot_flat_is_nan():
    ax, az, gy, hs = synthetic_foot()
    gy = gy.copy()
    a, b = hs[2], hs[2] + int(STANCE_S * FS)
    gy[a:b] = 2.0  # the foot never rests in stance 2 (nor comes near: > NEAR_STILL)
    m = stride_measures(ax, az, gy, FS, hs)
    assert np.isnan(m.stride_length_m[1]) and np.isnan(m.stride_length_m[2])
    assert np.all(np.isfinite(m.stride_length_m[[0, 3, 4, 5]]))
    assert m.foot_flat_idx[2, 0] == -1
    assert list(m.flags[1:3]) == [FLAG_NO_FOOT_FLAT] * 2
    assert m.reasons(1) == ["no foot-flat"] and not m.trusted[1]
    assert np.all(m.flags[[0, 3, 4, 5]] == 0) and np.all(m.trusted[[0, 3, 4, 5]])


def test_a_stance_that_never_rests_is_anchored_at_its_stillest_sample():
    """Fast walking: the stance foot keeps rolling (1.5-3x the still threshold, as on gdins at
    2 m/s), so no sample is still; the anchor is the stillest one, here where the roll rate's
    V has its bottom, 12 samples after the heel strike (closed form)."""
    ax, az, gy, hs = synthetic_foot()
    gy = gy.copy()
    n_stance = int(STANCE_S * FS)
    k0 = 12
    v = STILL_GYRO_RAD_S * (1.5 + 0.05 * np.abs(np.arange(n_stance) - k0))
    v *= np.where(np.arange(n_stance) % 2 == 0, 1.0, -1.0)  # a tremor: no net pitch
    for h in hs[1:-1]:
        gy[h : h + n_stance] = v  # least at h + k0
    m = stride_measures(ax, az, gy, FS, hs)
    inner = slice(1, len(m))
    np.testing.assert_array_equal(m.foot_flat_idx[inner, 0], hs[1:-1] + k0)
    assert np.all(m.flags[inner] & FLAG_NEAR_STILL)
    # (the tremor's mean around the anchor, ~0.11 rad/s, reads as a roll: ~1-2 % shorter)
    np.testing.assert_allclose(m.stride_length_m[inner], V_MS * (RAMP_S + CRUISE_S), rtol=0.03)


def test_a_board_yawed_on_the_foot_gives_the_true_stride():
    """A unit strapped on the instep 25 deg off the foot's long axis sees cos 25 deg of the
    foot's pitch rate and forward acceleration (no lateral motion here): read as it is, every
    stride would be ~9 % short. Where the foot speeds up toe-down and slows down toe-up (a
    real swing), the forward acceleration rotated by a wrong pitch leaves a vertical velocity
    at the next foot-flat: its closure finds the yaw (closed form)."""
    ax, az, gy, hs = synthetic_foot(toe_up=True)
    stride_m = V_MS * (RAMP_S + CRUISE_S)
    aligned = stride_measures(ax, az, gy, FS, hs)
    np.testing.assert_allclose(aligned.stride_length_m, stride_m, atol=0.002)
    c = np.cos(np.radians(25.0))
    m = stride_measures(ax, c * az, c * gy, FS, hs)
    # within 2 % (1.6 % on the strides whose sampled swing leaves a -0.01 m/s vertical residual
    # even aligned: this slow swing's closure moves only 1.3 m/s per unit of the cosine)
    np.testing.assert_allclose(m.stride_length_m, stride_m, rtol=0.02)
    assert np.all(m.flags == 0)


def test_a_stride_out_of_the_sagittal_plane_is_flagged():
    """A turn or roll takes part of the foot's rotation off the board's one gyro axis: here the
    gyro sees 75 % of stride 3's swing (a ~10 deg pitch misfit at its next foot-flat)."""
    ax, az, gy, hs = synthetic_foot()
    gy = gy.copy()
    swing = slice(hs[3] + int(STANCE_S * FS), hs[4])
    gy[swing] *= 0.75
    m = stride_measures(ax, az, gy, FS, hs)
    assert m.flags[3] & FLAG_OUT_OF_PLANE and not m.trusted[3]
    assert "turn or roll (out of plane)" in m.reasons(3)
    assert np.all(m.flags[[0, 1, 2, 4, 5]] == 0)


def test_the_first_step_from_standing():
    """The walk opens at heel strike 1 (the first stance is a standing): with first_steps the
    step from that standing is measured too, flagged, and placed first."""
    ax, az, gy, hs = synthetic_foot()
    hs = hs[1:]
    plain = stride_measures(ax, az, gy, FS, hs)
    m = stride_measures(ax, az, gy, FS, hs, first_steps=True)
    assert len(m) == len(plain) + 1
    assert m.flags[0] == FLAG_FIRST_STEP and np.all(m.flags[1:] == 0)
    np.testing.assert_allclose(m.stride_length_m[0], V_MS * (RAMP_S + CRUISE_S), atol=0.002)
    # it runs from the standing's last still sample (the swing starts at STANCE_S; still: the
    # +-2 samples around are still too) to heel strike 1
    assert m.heel_strike_idx[0] == int(STANCE_S * FS) - 2
    np.testing.assert_allclose(m.stride_time_s[0], (hs[0] - m.heel_strike_idx[0]) / FS)
    np.testing.assert_array_equal(m.stride_length_m[1:], plain.stride_length_m)
    np.testing.assert_array_equal(m.heel_strike_idx[1:], plain.heel_strike_idx)


def test_streaming_gives_the_same_strides_in_any_chunking():
    ax, az, gy, hs = synthetic_foot(n_strides=8)
    whole = stride_measures(ax, az, gy, FS, hs)
    rng = np.random.default_rng(0)
    tr = StrideLengthTracker(FS)
    got = []
    a = 0
    while a < len(ax):
        b = min(a + int(rng.integers(1, 60)), len(ax))
        # heel strikes are reported late (a detector's delay): 15 samples after they happen
        known = hs[hs + 15 < b]
        got.append(tr.push(ax[a:b], az[a:b], gy[a:b], known))
        a = b
    got.append(tr.push(np.empty(0), np.empty(0), np.empty(0), hs))
    assert len(got[-1]) == 0  # the last stride's next foot-flat is past the record's end ...
    got.append(tr.finish())  # ... so it comes at the end, from the samples there are
    assert len(got[-1]) == 1
    length = np.concatenate([g.stride_length_m for g in got])
    starts = np.concatenate([g.heel_strike_idx for g in got])
    np.testing.assert_array_equal(starts, whole.heel_strike_idx)
    np.testing.assert_array_equal(length, whole.stride_length_m)
    np.testing.assert_array_equal(np.concatenate([g.flags for g in got]), whole.flags)
    assert len(tr._buf) < 3 * (STANCE_S + SWING_S) * FS  # it does not keep the record


# ---- the simulator's truth ------------------------------------------------------------------
PATTERNS = {  # each with its own stride length, so no constant could pass
    "normal": {},
    "slow (85 steps/min, 1.0 m)": {"cadence_steps_min": 85.0, "stride_length_m": 1.0},
    "stiff-knee (1.1 m)": {"pattern": "stiff-knee", "stride_length_m": 1.1},
}


def _simulated(opts: dict, seed: int, n: int = 6000):
    gait = GaitModel(GaitConfig(seed=seed, **opts))
    sb = simulate(n, gait, realistic_sensors(seed))
    ph = DEFAULT_TABLE.to_physical(sb.counts)
    gyro = ph[:, GYRO_IDX[3]] - ph[100:450, GYRO_IDX[3]].mean()  # standing zero
    return gait, ph[:, ACC_X_IDX[3]], ph[:, ACC_Z_IDX[3]], gyro


def _matched(m, truth, after: int = 1000):
    """(estimated, true) stride lengths and speeds of strides whose opening heel strike is
    within 50 ms of a true one (after the walk's ramp-in)."""
    j = np.clip(np.searchsorted(truth.heel_strike_idx, m.heel_strike_idx - 5), 0, None)
    j = np.minimum(j, len(truth.heel_strike_idx) - 1)
    ok = (np.abs(truth.heel_strike_idx[j] - m.heel_strike_idx) <= 5) & (m.heel_strike_idx > after)
    ok &= np.abs(np.diff(np.append(m.heel_strike_idx, 0))[: len(ok)] - truth.stride_time_s[j]
                 * FS) <= 5  # fmt: skip
    return (m.stride_length_m[ok], truth.stride_length_m[j[ok]], m.speed_m_s[ok],
            truth.speed_m_s[j[ok]])  # fmt: skip


@pytest.mark.parametrize("name", list(PATTERNS))
def test_stride_length_and_speed_within_3_percent_of_the_simulator_truth(name):
    gait, ax, az, gy = _simulated(PATTERNS[name], seed=21)
    hs, _ = gyro_gait_events(gy, FS)  # the app's own foot-gyro heel strikes
    m = stride_measures(ax, az, gy, FS, hs)
    truth = gait.strides(0, len(gy))
    est, true, v_est, v_true = _matched(m, truth)
    assert len(est) >= 30
    assert np.isfinite(est).mean() > 0.95
    err = np.abs(est - true) / true
    v_err = np.abs(v_est - v_true) / v_true
    assert np.nanmedian(err) <= 0.03, np.nanmedian(err)
    assert np.nanmedian(v_err) <= 0.03, np.nanmedian(v_err)
    assert np.nanpercentile(err, 95) <= 0.06
    assert np.median(true) == pytest.approx(gait.config.stride_len_m)
    # streaming (the live Gait panel): the same strides, block by block
    tr = StrideLengthTracker(FS)
    parts = []
    for a in range(0, len(gy), 37):
        b = min(a + 37, len(gy))
        parts.append(tr.push(ax[a:b], az[a:b], gy[a:b], hs[hs + 12 < b]))
    parts.append(tr.push(ax[:0], az[:0], gy[:0], hs))
    parts.append(tr.finish())
    live = np.concatenate([p.stride_length_m for p in parts])
    np.testing.assert_array_equal(live, m.stride_length_m)


def test_a_stop_mid_walk_gives_no_speed_for_its_stride_and_leaves_the_others_right():
    from gaitmon.io.sim.sensors import SensorModel

    gait = GaitModel(GaitConfig(seed=5))
    sensors = SensorModel(gait, realistic_sensors(5))
    blocks = [sensors.next_block(2500)]
    gait.stand(25.0)  # stops within ~3 strides, at mid-stance
    blocks.append(sensors.next_block(800))
    gait.walk(sensors.position / FS + 2.0)
    blocks.append(sensors.next_block(2500))
    ph = DEFAULT_TABLE.to_physical(np.concatenate([b.counts for b in blocks]))
    gy = ph[:, GYRO_IDX[3]] - ph[100:450, GYRO_IDX[3]].mean()
    hs, _ = gyro_gait_events(gy, FS)
    m = stride_measures(ph[:, ACC_X_IDX[3]], ph[:, ACC_Z_IDX[3]], gy, FS, hs)
    stopped = m.stride_time_s > 3.0
    assert stopped.sum() == 1 and np.isnan(m.stride_length_m[stopped]).all()
    est, true, _, _ = _matched(m, gait.strides(0, len(gy)))
    ok = np.isfinite(est)
    assert len(est) >= 30 and (~ok).sum() <= 1  # only the stride that stood
    assert np.max(np.abs(est[ok] - true[ok]) / true[ok]) < 0.03  # into and out of the stop too
    assert true[ok].min() < 0.8 * true[ok].max()  # ... which are shorter: the walk ramps


def test_foot_clearance_follows_the_simulator_truth():
    gait, ax, az, gy = _simulated({}, seed=22)
    truth = gait.strides(0, len(gy))
    m = stride_measures(ax, az, gy, FS, truth.heel_strike_idx)
    ok = truth.heel_strike_idx[:-1] > 1000
    err = m.foot_clearance_m - truth.foot_clearance_m[:-1]
    assert np.nanmedian(np.abs(err[ok])) < 0.01  # m
    gait2, ax2, az2, gy2 = _simulated({"pattern": "stiff-knee"}, seed=22)
    m2 = stride_measures(ax2, az2, gy2, FS, gait2.strides(0, len(gy2)).heel_strike_idx)
    # stiff knee: the foot lifts less, and the estimate says so
    assert np.nanmedian(m2.foot_clearance_m[10:]) < np.nanmedian(m.foot_clearance_m[10:]) - 0.02


def test_a_recorded_session_holds_the_true_strides_and_they_match(tmp_path):
    from gaitmon.cli import main

    out = tmp_path / "s.h5"
    code = main(["record", "--simulate", "--duration", "14", "-o", str(out), "--speed", "8",
                 "--standing-s", "2", "--quiet"])  # fmt: skip
    assert code == 0
    with h5py.File(out, "r") as f:
        hs = f["truth/heel_strike"][()]
        length = f["truth/stride_length_m"][()]
        clearance = f["truth/foot_clearance_m"][()]
        stride_t = f["truth/stride_time_s"][()]
        adc = f["raw/adc"][()]
        bias = f["truth/gyro_bias_rad_s"][()][:, 3]
    assert len(hs) >= 8 and len(length) == len(hs) == len(clearance) == len(stride_t)
    cfg = GaitConfig()
    np.testing.assert_allclose(length[2:], cfg.stride_len_m)
    ph = DEFAULT_TABLE.to_physical(adc)
    # the recording may start after the standing period: the truth's gyro bias, not a zero
    gy = ph[:, GYRO_IDX[3]] - bias
    m = stride_measures(ph[:, ACC_X_IDX[3]], ph[:, ACC_Z_IDX[3]], gy, FS, hs)
    steady = slice(2, None)
    err = np.abs(m.stride_length_m[steady] - length[:-1][steady]) / length[:-1][steady]
    assert np.nanmedian(err) < 0.03


# ---- bad input ------------------------------------------------------------------------------
def test_bad_input_is_one_clear_message():
    ax, az, gy, hs = synthetic_foot()
    with pytest.raises(ValueError, match="differ in length"):
        stride_lengths(ax, az[:-1], gy, FS, hs)
    with pytest.raises(ValueError, match="increasing"):
        stride_lengths(ax, az, gy, FS, hs[::-1])
    with pytest.raises(ValueError, match="sampling rate"):
        stride_lengths(ax, az, gy, 0.0, hs)
    with pytest.raises(ValueError, match="1-D"):
        stride_lengths(np.stack([ax, ax]), az, gy, FS, hs)
    assert len(stride_lengths(ax, az, gy, FS, hs[:1])) == 0  # one heel strike: no stride
    assert len(stride_lengths(ax, az, gy, FS, np.empty(0, np.int64))) == 0


def test_streaming_waits_for_a_long_foot_flat_search_after_a_long_stride():
    """After a long stride (a pause, a missed heel strike) a heel strike's foot-flat search
    (60 % of the stride before it) reaches past the next heel strike's: the tracker waits for
    all of it, so it finds the same foot-flat as the whole record (it used to take the shorter
    still run it had seen)."""
    n = 1000
    gy = np.full(n, 2.0)  # moving, except in the still runs below
    for a, b in ((205, 220), (260, 340), (435, 446), (700, 760)):
        gy[a:b] = 0.0
    ax, az = np.full(n, G), np.zeros(n)
    hs = np.array([0, 200, 230, 690])  # 200's search: 120 rows; 230's: 18
    whole = stride_measures(ax, az, gy, FS, hs)
    assert 262 <= whole.foot_flat_idx[1, 0] < 320  # the longest still run it sees
    tr = StrideLengthTracker(FS)
    parts = [tr.push(ax[a : a + 10], az[a : a + 10], gy[a : a + 10], hs[hs < a + 10])
             for a in range(0, n, 10)]  # fmt: skip
    parts.append(tr.finish())
    flats = np.concatenate([p.foot_flat_idx for p in parts])
    np.testing.assert_array_equal(flats, whole.foot_flat_idx)
