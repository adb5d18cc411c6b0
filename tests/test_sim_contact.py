"""The simulated foot on the ground (gaitmon.io.sim.contact): the body walks forward, the stance
foot lies still while flat, and the truth's stride length is what the foot sensor really
travels, consistent with its accelerometer."""

import itertools

import numpy as np
import pytest

from gaitmon.io.sim import GaitConfig, GaitModel
from gaitmon.io.sim.contact import FLAT_END, FLAT_START
from gaitmon.io.sim.sensors import SensorConfig, impact_shape, simulate

FS = 100.0


def _mid_flat_samples(model: GaitModel, kin, n: int) -> np.ndarray:
    """The sample nearest the middle of each foot-flat of a whole stride in [0, n)."""
    p = kin.phase
    out = []
    for k in range(1, int(p[-1])):
        at = k + 0.5 * (FLAT_START + FLAT_END)
        i = int(np.searchsorted(p, at))
        if 0 < i < n and p[i] - at < 0.02:
            out.append(i)
    return np.asarray(out)


@pytest.mark.parametrize(
    "opts",
    [{}, {"cadence_steps_min": 85.0}, {"pattern": "stiff-knee"}, {"pattern": "long-stance"}],
)
def test_the_flat_foot_is_still_and_moves_one_stride_length_per_stride(opts):
    model = GaitModel(GaitConfig(seed=7, **opts))
    n = 4000
    kin = model.evaluate(0, n)
    q = np.mod(kin.phase, 1.0)
    flat = (q > FLAT_START + 0.005) & (q < FLAT_END - 0.005) & (kin.phase > 1.0)
    assert flat.sum() > 300
    assert np.all(kin.tilt_rad[flat, 3] == pytest.approx(0.0, abs=1e-12))  # lies flat
    assert np.abs(kin.lin_acc_ms2[flat, 3]).max() < 1e-9  # the foot sensor does not move
    # ... nor its place, within each foot-flat
    pos = kin.position_m[:, 3]
    mids = _mid_flat_samples(model, kin, n)
    for i in mids:
        near = flat & (np.abs(kin.phase - kin.phase[i]) < 0.1)
        assert np.ptp(pos[near], axis=0).max() < 1e-9
    # from one foot-flat to the next the sensor moves the true stride length, at ground level
    truth = model.strides(0, n)
    step = np.diff(pos[mids], axis=0)
    first = int(np.searchsorted(truth.heel_strike_idx, mids[0])) - 1
    want = truth.stride_length_m[first : first + len(step)]
    np.testing.assert_allclose(step[:, 0], want, atol=1e-9)
    np.testing.assert_allclose(step[:, 1], 0.0, atol=1e-9)
    # once walking: the configured stride length, and speed = length / stride time
    steady = want[2:]
    assert np.all(steady == pytest.approx(model.config.stride_len_m))
    speed = truth.speed_m_s[3:-1]
    np.testing.assert_allclose(speed, model.config.stride_len_m / truth.stride_time_s[3:-1])
    assert np.median(speed) == pytest.approx(
        model.config.stride_len_m / model.config.stride_s, rel=0.02
    )


def test_the_foot_sensors_acceleration_integrates_to_the_stride():
    """Double-integrate the true horizontal acceleration of the foot sensor (sampled, as the
    sensor model uses it) from one foot-flat to the next: it starts and ends at rest, and
    travels the truth's stride length."""
    model = GaitModel(GaitConfig(seed=3))
    n = 3000
    kin = model.evaluate(0, n)
    truth = model.strides(0, n)
    mids = _mid_flat_samples(model, kin, n)
    acc = kin.lin_acc_ms2[:, 3]
    dt = 1.0 / FS
    checked = 0
    for a, b in itertools.pairwise(mids):
        seg = acc[a : b + 1]
        v = np.concatenate([[[0.0, 0.0]], np.cumsum(0.5 * (seg[1:] + seg[:-1]), axis=0) * dt])
        d = np.sum(0.5 * (v[1:] + v[:-1]), axis=0) * dt
        j = int(np.searchsorted(truth.heel_strike_idx, a)) - 1
        assert np.abs(v[-1]).max() < 0.02  # back at rest (m/s)
        assert d[0] == pytest.approx(truth.stride_length_m[j], rel=0.005)
        assert abs(d[1]) < 0.01
        checked += 1
    assert checked >= 15


def test_the_body_moves_forward_smoothly():
    model = GaitModel(GaitConfig(seed=2))
    kin = model.evaluate(0, 4000)
    walking = kin.phase > 2.0
    v_hip = np.gradient(kin.position_m[:, 0, 0], 1.0 / FS)[walking]
    assert v_hip.min() > 0.5  # never stops or steps back while walking
    assert v_hip.max() < 2.0
    assert np.abs(kin.lin_acc_ms2[walking, 0]).max() < 8.0  # a pelvis, not a foot (m/s^2)
    hip_up = kin.position_m[walking, 0, 1]
    assert 0.02 < np.ptp(hip_up) < 0.08  # a few centimetres of bob


def test_truth_strides_follow_the_configured_stride_length_and_ramp_in():
    cfg = GaitConfig(seed=1, stride_length_m=1.1, cadence_steps_min=90.0, stride_cv=0.0)
    model = GaitModel(cfg)
    truth = model.strides(0, 6000)
    assert truth.stride_length_m[0] < 1.1  # the walk ramps in
    np.testing.assert_allclose(truth.stride_length_m[2:], 1.1, rtol=1e-9)
    np.testing.assert_allclose(truth.speed_m_s[2:], 1.1 / (120.0 / 90.0), rtol=0.01)
    assert np.all((truth.foot_clearance_m > 0.03) & (truth.foot_clearance_m < 0.15))


def test_impacts_and_tissue_slides_leave_no_net_velocity():
    t = np.linspace(0.0, 0.3, 300001)
    a = impact_shape(t, 20.0, 0.02)
    assert np.abs(a).max() == pytest.approx(1.0, rel=1e-3)
    v = np.cumsum(a) * (t[1] - t[0])
    assert abs(v[-1]) < 1e-6 and abs(np.sum(v) * (t[1] - t[0])) < 1e-6
    # the sensor model: only impacts on top of the true motion, which the foot's samples
    # then integrate the same as without them
    plain = SensorConfig(seed=1, acc_noise_ms2=0.0, impact_peak_ms2=(0.0, 0.0, 0.0, 0.0))
    hit = SensorConfig(seed=1, acc_noise_ms2=0.0, impact_peak_ms2=(5.0, 10.0, 30.0, 50.0))
    a0 = simulate(3000, GaitModel(GaitConfig(seed=1)), plain).physical
    a1 = simulate(3000, GaitModel(GaitConfig(seed=1)), hit).physical
    diff = a1 - a0
    assert np.abs(diff).max() > 20.0  # the impacts are there
    fine = np.abs(np.sum(diff[600:], axis=0)) / FS  # summed over ~20 heel strikes, m/s
    assert fine.max() < 0.05


def test_a_stride_length_the_angles_cannot_walk_is_refused():
    # the normative joint angles do not shrink with the stride: a 0.5 m stride would have the
    # hip step back between foot-flats
    with pytest.raises(ValueError, match="stride length"):
        GaitConfig(stride_length_m=0.5)
    with pytest.raises(ValueError, match="stride length"):
        GaitConfig(stride_length_m=2.5)
    GaitConfig(stride_length_m=0.7)  # the shortest that still walks forward (1.70 m tall)


def test_the_motion_does_not_depend_on_how_it_is_asked_for():
    """The hip's curves are cached per foot-flat: any chunking and order, and a stop asked for
    mid-walk, give the same positions and accelerations as one evaluation."""
    whole = GaitModel(GaitConfig(seed=4)).evaluate(0, 6000)
    model = GaitModel(GaitConfig(seed=4))
    later = model.evaluate(4000, 6000)  # the end first
    pieces = [model.evaluate(a, min(a + 333, 4000)) for a in range(0, 4000, 333)]
    for name in ("position_m", "lin_acc_ms2"):
        got = np.concatenate([getattr(p, name) for p in pieces] + [getattr(later, name)])
        np.testing.assert_array_equal(got, getattr(whole, name))
    # a stop changes nothing already produced, and the stopped foot stands where it was flat
    ref = GaitModel(GaitConfig(seed=4, standing_s=1.0))
    g = GaitModel(GaitConfig(seed=4, standing_s=1.0))
    before = g.evaluate(0, 800)
    t_stand = g.stand(8.0)
    np.testing.assert_array_equal(g.evaluate(0, 800).position_m, ref.evaluate(0, 800).position_m)
    np.testing.assert_array_equal(before.lin_acc_ms2, ref.evaluate(0, 800).lin_acc_ms2)
    stood = g.evaluate(int(np.ceil(t_stand * FS)), int(np.ceil(t_stand * FS)) + 200)
    assert np.all(stood.lin_acc_ms2 == 0) and np.ptp(stood.position_m, axis=0).max() == 0
