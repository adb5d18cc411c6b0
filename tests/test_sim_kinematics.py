"""The simulated gait: normative shapes, timing, patterns, reproducibility, conventions."""

import itertools

import numpy as np
import pytest

from gaitmon.dsp.angles import joint_angles
from gaitmon.io.sim.gait_curves import NORMATIVE_KEY_POINTS_DEG, normative_joint_deg
from gaitmon.io.sim.kinematics import GaitConfig, GaitModel

FS = 100.0


def _walk(cfg: GaitConfig, seconds: float = 60.0):
    model = GaitModel(cfg)
    n = int(seconds * FS)
    kin = model.evaluate(0, n)
    hs, to = model.events(0, n)
    return model, kin, hs, to


def _strides(hs, to):
    """(hs_k, to_k, hs_k+1) for every complete stride."""
    out = []
    for a, b in itertools.pairwise(hs):
        t = to[(to > a) & (to < b)]
        assert len(t) == 1, "exactly one toe off per stride"
        out.append((a, int(t[0]), b))
    return out


@pytest.mark.parametrize("joint", ["hip", "knee", "ankle"])
def test_fourier_curves_follow_winter_key_points(joint):
    pts = np.array(NORMATIVE_KEY_POINTS_DEG[joint], dtype=float)
    col = ("hip", "knee", "ankle").index(joint)
    got = normative_joint_deg(pts[:, 0] / 100.0)[:, col]
    assert np.max(np.abs(got - pts[:, 1])) < 2.0


def test_normal_gait_knee_peak_stance_fraction_and_cadence():
    cfg = GaitConfig(cadence_steps_min=110.0, seed=3)
    _, kin, hs, to = _walk(cfg, 90.0)
    strides = _strides(hs, to)[2:]  # skip the ramp-in
    assert len(strides) > 40
    knee_deg = np.rad2deg(kin.joint_rad[:, 1])
    hip_deg = np.rad2deg(kin.joint_rad[:, 0])
    ankle_deg = np.rad2deg(kin.joint_rad[:, 2])
    stance = []
    for a, t, b in strides:
        swing_peak = knee_deg[t:b].max()
        assert 55.0 <= swing_peak <= 75.0
        assert knee_deg[a:b].argmax() + a >= t, "knee peak is in swing"
        assert 10.0 <= knee_deg[a : a + int(0.25 * (b - a))].max() <= 25.0  # loading response
        assert 25.0 <= hip_deg[a - 3 : a + 3].mean() <= 35.0  # flexed at heel strike
        assert -15.0 <= hip_deg[a:t].min() <= -5.0  # extended late in stance
        assert -22.0 <= ankle_deg[t - 5 : t + 10].min() <= -12.0  # plantarflexion at toe off
        stance.append((t - a) / (b - a))
    assert np.mean(stance) == pytest.approx(0.60, abs=0.01)
    stride_s = np.diff([s[0] for s in strides]).mean() / FS
    assert 120.0 / stride_s == pytest.approx(110.0, rel=0.01)


@pytest.mark.parametrize("cadence", [80.0, 125.0])
def test_cadence_follows_config(cadence):
    _, _, hs, _ = _walk(GaitConfig(cadence_steps_min=cadence, stride_cv=0.0), 60.0)
    stride_s = np.diff(hs[1:]) / FS
    assert 120.0 / stride_s.mean() == pytest.approx(cadence, rel=0.01)


def test_long_stance_and_stiff_knee_patterns():
    _, _, hs, to = _walk(GaitConfig(pattern="long-stance", seed=1), 60.0)
    frac = [(t - a) / (b - a) for a, t, b in _strides(hs, to)[2:]]
    assert np.mean(frac) == pytest.approx(0.70, abs=0.01)

    _, kin, hs, to = _walk(GaitConfig(pattern="stiff-knee", seed=1), 60.0)
    knee_deg = np.rad2deg(kin.joint_rad[:, 1])
    peaks = [knee_deg[t:b].max() for a, t, b in _strides(hs, to)[2:]]
    assert max(peaks) < 40.0
    assert min(peaks) > 20.0  # reduced, not abolished


def test_segment_tilts_follow_the_clinical_convention():
    _, kin, _, _ = _walk(GaitConfig(seed=5), 20.0)
    # thigh = body + hip, shank = thigh - knee, foot = shank + ankle <=> dsp.angles.joint_angles
    np.testing.assert_allclose(joint_angles(kin.tilt_rad), kin.joint_rad, atol=1e-12)


def test_rates_and_accelerations_are_the_derivatives():
    model = GaitModel(GaitConfig(seed=2))
    kin = model.evaluate(0, 3000)
    dt = 1.0 / FS
    num_rate = (kin.tilt_rad[2:] - kin.tilt_rad[:-2]) / (2 * dt)
    # central difference error ~ dt^2/6 * third derivative: a few hundredths of a rad/s here
    assert np.max(np.abs(num_rate - kin.rate_rad_s[1:-1])) < 0.1
    pos = kin.position_m
    num_acc = (pos[2:] - 2 * pos[1:-1] + pos[:-2]) / dt**2
    err = np.abs(num_acc - kin.lin_acc_ms2[1:-1])
    scale = np.abs(kin.lin_acc_ms2).max()
    assert scale > 10.0  # the foot really accelerates (m/s^2)
    assert err.max() < 0.05 * scale


def test_standing_period_is_still_and_upright():
    cfg = GaitConfig(standing_s=4.0, seed=0)
    _, kin, hs, to = _walk(cfg, 10.0)
    still = slice(0, int(4.0 * FS))
    assert np.all(kin.tilt_rad[still] == 0.0)
    assert np.all(kin.rate_rad_s[still] == 0.0)
    assert np.all(kin.lin_acc_ms2[still] == 0.0)
    assert hs[0] > 4.0 * FS and to[0] > 4.0 * FS
    assert np.abs(kin.joint_rad[-300:]).max() > np.deg2rad(30.0)  # and then it walks


def test_seed_reproducibility_and_variability():
    _, k1, hs1, _ = _walk(GaitConfig(seed=11, stride_cv=0.03), 120.0)
    _, k2, hs2, _ = _walk(GaitConfig(seed=11, stride_cv=0.03), 120.0)
    _, _k3, hs3, _ = _walk(GaitConfig(seed=12, stride_cv=0.03), 120.0)
    np.testing.assert_array_equal(k1.tilt_rad, k2.tilt_rad)
    np.testing.assert_array_equal(hs1, hs2)
    assert not np.array_equal(hs1[:20], hs3[:20])
    stride = np.diff(hs1[1:]) / FS
    cv = stride.std() / stride.mean()
    assert 0.02 < cv < 0.04  # sampled to 10 ms, so only roughly the configured 0.03
    _, _, hs0, _ = _walk(GaitConfig(seed=11, stride_cv=0.0), 60.0)
    assert np.ptp(np.diff(hs0[1:])) <= 1  # no variability: strides equal to the sample


def test_any_chunking_and_order_gives_the_same_motion():
    whole = GaitModel(GaitConfig(seed=4)).evaluate(0, 20000)
    model = GaitModel(GaitConfig(seed=4))
    later = model.evaluate(15000, 20000)  # ask for the end first
    pieces = [model.evaluate(a, min(a + 777, 15000)) for a in range(0, 15000, 777)]
    tilt = np.concatenate([p.tilt_rad for p in pieces] + [later.tilt_rad])
    np.testing.assert_array_equal(tilt, whole.tilt_rad)


def test_bad_config_is_rejected_with_a_message():
    with pytest.raises(ValueError, match="pattern"):
        GaitConfig(pattern="moonwalk")
    with pytest.raises(ValueError, match="cadence"):
        GaitConfig(cadence_steps_min=0.0)
