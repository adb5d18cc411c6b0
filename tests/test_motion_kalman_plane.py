"""The gait-aware filter's out-of-plane rule (gaitmon.dsp.motion_kalman, "Out of plane"): when
the planar |a| stays below ``plane_fraction`` g, gravity has a component along the board's y
axis, so the board is turned out of the sagittal plane and gyro_y is not the planar tilt's rate;
the accelerometer tilt (atan2 of gravity's projection, still the planar tilt) is followed and the
bias is left alone."""

import numpy as np
import pytest

from gaitmon.dsp.motion_kalman import GaitAwareKalman, SegmentTuning, steady_state_gain, tuning_for

FS = 100.0
G = 9.80665


def test_out_of_plane_follows_the_accelerometer_and_keeps_the_bias():
    n = 3000
    t = np.arange(n) / FS
    # held with y tilted 40 deg out of plane: the planar |a| is g cos 40 = 0.77 g; the planar
    # tilt sways slowly while gyro_y also reads 0.1 rad/s of a rotation about another axis
    tilt = 0.5 + 0.3 * np.sin(2 * np.pi * 0.2 * t)
    planar = G * np.cos(np.radians(40.0))
    ax, az = planar * np.cos(tilt), planar * np.sin(tilt)
    w = np.gradient(tilt, 1 / FS) + 0.1
    foot = tuning_for("foot")
    assert foot.plane_fraction is not None
    # the scheduled gains from the first sample (the start-up's exact gain is
    # tests/test_kalman_resolve.py's)
    kf = GaitAwareKalman(FS, segments=("foot",), start_prior=None)
    # the first second: the 0.5 Hz low-pass of |a| falls from 1 g below 0.95 g
    first = kf.process(ax[:100], az[:100], w[:100])
    learnt = kf.bias_rad_s[0]
    out = np.concatenate([first, kf.process(ax[100:], az[100:], w[100:])])
    assert kf.bias_rad_s[0] == learnt  # out of plane the bias is left alone
    err = np.degrees(out - tilt)[500:]
    # a complementary filter of gain K0 on a rate error d: steady error d dt (1 - K0) / K0
    k0 = steady_state_gain(foot.r_out_of_plane, 1 / FS, foot.q_angle, foot.q_bias)[0]
    np.testing.assert_allclose(err, np.degrees(0.1 / FS * (1 - k0) / k0), atol=0.1)
    # the same without the rule integrates the 0.1 rad/s (never still: | |a| - g | = 2.3 m/s^2)
    plain = GaitAwareKalman(FS, segments=("foot",),
                            tuning={"foot": SegmentTuning(plane_fraction=None)})  # fmt: skip
    assert np.degrees(np.abs(plain.process(ax, az, w) - tilt))[500:].max() > 30.0


def test_out_of_plane_gain_is_the_steady_state_gain_of_its_variance():
    """One sample after the low-pass has fallen below the threshold: theta = pred + K0 e with
    K0 the steady-state angle gain for r_out_of_plane, and the bias unchanged."""
    tun = SegmentTuning(plane_fraction=0.95, plane_cutoff_hz=1e3)  # the low-pass follows at once
    kf = GaitAwareKalman(FS, segments=("foot",), tuning={"foot": tun}, start_prior=None)
    a = 0.5 * G
    ax = np.array([a * np.cos(0.3), a * np.cos(0.1)])
    az = np.array([a * np.sin(0.3), a * np.sin(0.1)])
    theta = kf.process(ax, az, np.array([0.0, 0.4]))
    k0 = steady_state_gain(tun.r_out_of_plane, 1 / FS, tun.q_angle, tun.q_bias)[0]
    assert theta[0] == pytest.approx(0.3, abs=1e-12)  # starts at the first measurement
    pred = 0.3 + 0.4 / FS
    assert theta[1] == pytest.approx(pred + k0 * (0.1 - pred), abs=1e-12)
    assert kf.bias_rad_s[0] == 0.0


def test_walking_never_trips_the_out_of_plane_test():
    """A walking foot's planar |a| averages above 1 g (|a| is convex), so the rule never fires
    while walking: the foot filter equals one without it, bit for bit."""
    from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX
    from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
    from gaitmon.io.sim.sensors import simulate

    sb = simulate(4000, GaitModel(GaitConfig(seed=3)), SensorConfig(seed=3))
    ph = DEFAULT_TABLE.to_physical(sb.counts)
    ax, az, w = ph[:, ACC_X_IDX][:, 3], ph[:, ACC_Z_IDX][:, 3], ph[:, GYRO_IDX][:, 3]
    with_rule = GaitAwareKalman(FS, segments=("foot",)).process(ax, az, w)
    import dataclasses

    without = dataclasses.replace(tuning_for("foot"), plane_fraction=None)
    other = GaitAwareKalman(FS, segments=("foot",), tuning={"foot": without}).process(ax, az, w)
    np.testing.assert_array_equal(with_rule, other)


def test_bad_plane_settings_are_refused():
    with pytest.raises(ValueError, match="plane_fraction"):
        SegmentTuning(plane_fraction=1.2)
    with pytest.raises(ValueError, match="r_out_of_plane"):
        SegmentTuning(r_out_of_plane=0.0)


def _held_out_of_plane(n: int = 3000):
    # gyro_y also sees a rotation about another axis, back and forth at 0.2 Hz (0.3 rad/s)
    t = np.arange(n) / FS
    tilt = 0.5 + 0.3 * np.sin(2 * np.pi * 0.2 * t)
    planar = G * np.cos(np.radians(40.0))
    w = np.gradient(tilt, 1 / FS) + 0.3 * np.sin(2 * np.pi * 0.2 * t)
    return planar * np.cos(tilt), planar * np.sin(tilt), w, tilt


def test_smoother_follows_the_accelerometer_out_of_plane():
    """Offline, the same board: the smoother solves its gravity pass again with the
    accelerometer tilt where the board is out of plane, and reads the tilt within 2.5 deg (the
    gravity tilt alone keeps most of the gyro angle's 0.2 Hz error: 9 deg)."""
    import dataclasses

    from gaitmon.dsp.smoother import out_of_plane, smooth_tilt

    ax, az, w, tilt = _held_out_of_plane()
    foot = tuning_for("foot")
    mask = out_of_plane(ax, az, FS, foot)
    assert mask is not None and mask.all()
    off = smooth_tilt(ax, az, w, FS, "foot")
    assert np.degrees(np.abs(off - tilt))[100:-100].max() < 2.5
    plain = smooth_tilt(ax, az, w, FS, "foot",
                        tuning=dataclasses.replace(foot, plane_fraction=None))  # fmt: skip
    assert np.degrees(np.abs(plain - tilt))[100:-100].max() > 5.0


def test_smoother_is_unchanged_by_the_plane_test_while_walking():
    import dataclasses

    from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX
    from gaitmon.dsp.smoother import out_of_plane, smooth_tilt
    from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
    from gaitmon.io.sim.sensors import simulate

    sb = simulate(4000, GaitModel(GaitConfig(seed=3)), SensorConfig(seed=3))
    ph = DEFAULT_TABLE.to_physical(sb.counts)
    ax, az, w = ph[:, ACC_X_IDX][:, 3], ph[:, ACC_Z_IDX][:, 3], ph[:, GYRO_IDX][:, 3]
    foot = tuning_for("foot")
    assert out_of_plane(ax, az, FS, foot) is None
    without = dataclasses.replace(foot, plane_fraction=None)
    np.testing.assert_array_equal(smooth_tilt(ax, az, w, FS, "foot"),
                                  smooth_tilt(ax, az, w, FS, "foot", tuning=without))  # fmt: skip


def test_out_of_plane_filter_is_bit_exact_in_any_chunking():
    """The low-pass of |a| is carried between blocks: the same bits whole, a row at a time and
    in blocks cut anywhere, on a board that turns out of plane and back (all four segments)."""
    import itertools

    ax, az, w, _ = _held_out_of_plane(2000)
    level = slice(0, 600)  # level at first: the test fires only after it
    ax[level] /= np.cos(np.radians(40.0))
    az[level] /= np.cos(np.radians(40.0))
    cols = [np.tile(a[:, None], (1, 4)) for a in (ax, az, w)]
    whole = GaitAwareKalman(FS).process(*cols)
    k = GaitAwareKalman(FS)
    rows = np.vstack([k.process(*(c[i : i + 1] for c in cols)) for i in range(len(ax))])
    np.testing.assert_array_equal(whole, rows)
    rng = np.random.default_rng(5)
    cuts = np.r_[0, np.sort(rng.choice(np.arange(1, len(ax)), 30, replace=False)), len(ax)]
    k = GaitAwareKalman(FS)
    parts = np.vstack([k.process(*(c[a:b] for c in cols)) for a, b in itertools.pairwise(cuts)])
    np.testing.assert_array_equal(whole, parts)
    # and the rule did fire (the foot's column only), after the level start
    foot = GaitAwareKalman(FS, segments=("foot",))
    foot.process(ax[:650], az[:650], w[:650])  # (the low-pass falls below 0.95 g in 0.1 s)
    before = foot.bias_rad_s[0]
    foot.process(ax[650:], az[650:], w[650:])
    assert foot.bias_rad_s[0] == before
