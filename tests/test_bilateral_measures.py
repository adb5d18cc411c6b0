"""gaitmon.dsp.bilateral against hand-computed walks (not against the simulator)."""

import numpy as np
import pytest

from gaitmon.dsp.bilateral import bilateral_gait, symmetry_index_pct, symmetry_ratio

nan = np.nan


def test_symmetric_walk_by_hand():
    # stride 1 s; right heel strikes on the second, left ones half a stride later;
    # each leg's toe off 0.6 s after its heel strike (the left's first from the stride before)
    g = bilateral_gait(
        [0.5, 1.5, 2.5], [0.1, 1.1, 2.1, 3.1], [0.0, 1.0, 2.0, 3.0], [0.6, 1.6, 2.6, 3.6]
    )
    r, left = g.right, g.left
    np.testing.assert_allclose(r.step_s, [nan, 0.5, 0.5, 0.5])  # no left strike before 0
    np.testing.assert_allclose(r.stride_s, [1.0, 1.0, 1.0, nan])
    np.testing.assert_allclose(r.stance_s, [0.6, 0.6, 0.6, nan])
    np.testing.assert_allclose(r.swing_s, [0.4, 0.4, 0.4, nan])
    np.testing.assert_allclose(r.initial_double_support_s, [0.1, 0.1, 0.1, nan])
    np.testing.assert_allclose(r.single_support_s, [0.4, 0.4, 0.4, nan])
    np.testing.assert_allclose(r.terminal_double_support_s, [0.1, 0.1, 0.1, nan])
    np.testing.assert_allclose(left.step_s, [0.5, 0.5, 0.5])
    np.testing.assert_allclose(left.stance_s, [0.6, 0.6, nan])
    np.testing.assert_allclose(left.pct("stance_s"), [60.0, 60.0, nan])
    for row in g.symmetry:
        assert row.ratio == pytest.approx(1.0) and row.index_pct == pytest.approx(0.0, abs=1e-9)
    assert g.cadence_steps_min == pytest.approx(120.0)


def test_asymmetric_walk_by_hand():
    # stride 1.2 s: left step 0.5 s, right step 0.7 s; right stance 0.8 s, left stance 0.85 s
    hs_r, to_r = [0.0, 1.2, 2.4], [0.8, 2.0]
    hs_l, to_l = [0.5, 1.7], [0.15, 1.35]
    g = bilateral_gait(hs_l, to_l, hs_r, to_r)
    r, left = g.right, g.left
    np.testing.assert_allclose(r.step_s, [nan, 0.7, 0.7])
    np.testing.assert_allclose(r.stance_s, [0.8, 0.8, nan])
    np.testing.assert_allclose(r.initial_double_support_s, [0.15, 0.15, nan])  # to the L toe off
    np.testing.assert_allclose(r.single_support_s, [0.35, 0.35, nan])  # the left leg's swing
    np.testing.assert_allclose(r.terminal_double_support_s, [0.3, 0.3, nan])
    np.testing.assert_allclose(left.step_s, [0.5, 0.5])
    np.testing.assert_allclose(left.stride_s, [1.2, nan])
    np.testing.assert_allclose(left.stance_s, [0.85, nan])
    np.testing.assert_allclose(left.swing_s, [0.35, nan])
    np.testing.assert_allclose(left.initial_double_support_s, [0.3, nan])  # = R terminal
    np.testing.assert_allclose(left.single_support_s, [0.4, nan])  # = R swing
    np.testing.assert_allclose(left.terminal_double_support_s, [0.15, nan])
    step = g.symmetry_of("step_s")
    assert (step.left, step.right) == pytest.approx((0.5, 0.7))
    assert step.ratio == pytest.approx(0.5 / 0.7)
    assert step.ratio_of("L") == pytest.approx(0.5 / 0.7)
    assert step.ratio_of("R") == pytest.approx(1.4)
    assert step.index_pct == pytest.approx(200.0 * 0.2 / 1.2)  # 33.3 %
    stance = g.symmetry_of("stance_s")
    assert stance.ratio == pytest.approx(0.85 / 0.8)
    assert stance.index_pct == pytest.approx(200.0 * 0.05 / 1.65)
    ds = g.symmetry_of("initial_double_support_s")
    assert (ds.left, ds.right, ds.ratio) == pytest.approx((0.3, 0.15, 2.0))
    assert g.cadence_steps_min == pytest.approx(100.0)  # 60 / mean(0.5, 0.5, 0.7, 0.7)


def test_missing_events_and_gaps_leave_holes_not_wrong_numbers():
    hs_r, to_r = [0.0, 1.2, 2.4], [0.8, 2.0]
    hs_l, to_l = [0.5, 1.7], [0.15]  # the left toe off at 1.35 was missed
    g = bilateral_gait(hs_l, to_l, hs_r, to_r)
    assert np.isnan(g.left.stance_s[0]) and np.isnan(g.left.swing_s[0])
    assert g.left.stride_s[0] == pytest.approx(1.2)  # the stride itself is still known
    assert np.isnan(g.right.initial_double_support_s[1])
    assert np.isnan(g.right.single_support_s[1])
    assert g.right.stance_s[1] == pytest.approx(0.8)
    # a stride across a gap is no stride, and neither is the step that ends after it
    g = bilateral_gait([0.5, 1.5, 9.5], [], [0.0, 1.0, 9.0, 10.0], [], max_stride_s=2.0)
    np.testing.assert_allclose(g.right.stride_s, [1.0, nan, 1.0, nan])
    np.testing.assert_allclose(g.right.step_s, [nan, 0.5, nan, 0.5])
    # unsorted input with NaNs is the same walk
    a = bilateral_gait([1.7, nan, 0.5], [1.35, 0.15], [2.4, 0.0, 1.2], [2.0, 0.8, nan])
    b = bilateral_gait([0.5, 1.7], [0.15, 1.35], [0.0, 1.2, 2.4], [0.8, 2.0])
    np.testing.assert_array_equal(a.right.stance_s, b.right.stance_s)
    assert a.symmetry == b.symmetry


def test_ratio_and_index_definitions():
    assert symmetry_ratio(0.5, 0.7) == pytest.approx(0.714285714)
    assert symmetry_index_pct(0.5, 0.7) == pytest.approx(33.333333)
    assert symmetry_index_pct(0.7, 0.5) == symmetry_index_pct(0.5, 0.7)
    assert np.isnan(symmetry_ratio(1.0, 0.0)) and np.isnan(symmetry_index_pct(nan, 1.0))
    empty = bilateral_gait([], [], [], [])
    assert np.isnan(empty.cadence_steps_min) and np.isnan(empty.symmetry_of("step_s").ratio)
    with pytest.raises(ValueError, match="affected side"):
        empty.symmetry_of("step_s").ratio_of("X")
