"""Gait events, phases, strides and cycle normalisation against hand-built and closed-form cases."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from gaitmon.dsp.base import Stage
from gaitmon.dsp.gait import (
    GaitEventDetector,
    Phase,
    Stride,
    StrideTracker,
    cycle_mean_sd,
    gait_summary,
    normalise_cycles,
    normalise_strides,
    strides_from_events,
)

FS_HZ = 100.0
HI = 3000.0  # clearly loaded
LO = 0.0  # clearly unloaded


def _reference_contact(x: np.ndarray, thr: float, hyst: float, d: int):
    """Per-sample state machine written straight from the detector's docstring."""
    raw = False
    run_start = 0
    deb = -1
    loaded = np.zeros(len(x), dtype=bool)
    rises: list[int] = []
    falls: list[int] = []
    for i, v in enumerate(x):
        new_raw = True if v > thr else (False if v < thr - hyst else raw)
        if new_raw != raw:
            run_start = i
        raw = new_raw
        if i - run_start + 1 >= d and deb != int(raw):
            if deb >= 0:
                (rises if raw else falls).append(run_start)
            deb = int(raw)
        loaded[i] = deb == 1
    return loaded, np.array(rises, dtype=np.int64), np.array(falls, dtype=np.int64)


def _square(n: int, on_ranges: list[tuple[int, int]]) -> np.ndarray:
    x = np.full(n, LO)
    for a, b in on_ranges:
        x[a:b] = HI
    return x


def test_detector_follows_the_stage_protocol():
    assert isinstance(GaitEventDetector(), Stage)
    assert isinstance(StrideTracker(), Stage)


def test_hand_built_square_signal_exact_events_and_phases():
    # heel loaded on samples 10..59, toe on 30..79; D = round(0.03 * 100) = 3
    n = 100
    fsr = np.column_stack([_square(n, [(10, 60)]), _square(n, [(30, 80)])])
    det = GaitEventDetector(threshold=1000, hysteresis=50, min_duration_s=0.03, fs_hz=FS_HZ)
    blk = det.process(fsr)
    assert blk.heel_strike_idx.tolist() == [10]  # back-dated to the crossing sample
    assert blk.toe_off_idx.tolist() == [80]
    assert blk.heel_strike_idx.dtype == np.int64
    assert blk.toe_off_idx.dtype == np.int64
    # causal output lags by D - 1 = 2 samples
    expected_heel = np.zeros(n, bool)
    expected_heel[12:62] = True
    expected_toe = np.zeros(n, bool)
    expected_toe[32:82] = True
    assert np.array_equal(blk.heel_loaded, expected_heel)
    assert np.array_equal(blk.toe_loaded, expected_toe)
    expected_phase = np.full(n, Phase.SWING, dtype=np.int8)
    expected_phase[12:32] = Phase.LOADING
    expected_phase[32:62] = Phase.FOOT_FLAT
    expected_phase[62:82] = Phase.PUSH_OFF
    assert blk.phase.dtype == np.int8
    assert np.array_equal(blk.phase, expected_phase)


def test_without_debounce_events_and_state_coincide():
    n = 50
    fsr = np.column_stack([_square(n, [(5, 20)]), _square(n, [(10, 30)])])
    blk = GaitEventDetector(min_duration_s=0.0).process(fsr)
    assert blk.heel_strike_idx.tolist() == [5]
    assert blk.toe_off_idx.tolist() == [30]
    assert np.array_equal(blk.heel_loaded, fsr[:, 0] > 1000)
    assert np.array_equal(blk.toe_loaded, fsr[:, 1] > 1000)


def test_threshold_and_hysteresis_boundaries_are_strict():
    # exactly at threshold is not loaded; exactly at threshold - hysteresis does not unload
    heel = np.array([0, 1000, 1000.001, 950, 950, 949.999, 0], dtype=float)
    fsr = np.column_stack([heel, np.zeros_like(heel)])
    blk = GaitEventDetector(threshold=1000, hysteresis=50, min_duration_s=0.0).process(fsr)
    assert blk.heel_loaded.tolist() == [False, False, True, True, True, False, False]
    assert blk.heel_strike_idx.tolist() == [2]


def test_chatter_near_threshold_is_suppressed():
    thr, hyst = 1000.0, 50.0
    heel = np.concatenate(
        [
            np.zeros(20),
            np.tile([1001.0, 990.0], 20),  # first >thr loads; the 990s are inside the band
            np.full(20, 2000.0),
            np.tile([1040.0, 955.0], 10),  # still in the band: no unload
            [900.0, 900.0],  # a 2-sample dip below thr - hyst: shorter than D = 3
            np.full(20, 2000.0),
            np.zeros(20),  # real unload
        ]
    )
    toe = np.concatenate(
        [np.zeros(40), np.full(40, 2000.0), [940.0, 1200.0] * 5, np.full(20, 1500.0), np.zeros(32)]
    )
    fsr = np.column_stack([heel, toe])
    blk = GaitEventDetector(thr, hyst, min_duration_s=0.03).process(fsr)
    assert blk.heel_strike_idx.tolist() == [20]
    # the toe's single-sample dips below 950 never last 3 samples; it unloads at sample 110
    assert blk.toe_off_idx.tolist() == [110]
    # heel never unloads between 20 and the final drop at 122 (20+40+20+20+2+20)
    assert blk.heel_loaded[22:124].all() and not blk.heel_loaded[124:].any()
    # without hysteresis and debounce the same signal chatters: the features are what helps
    naive = GaitEventDetector(thr, 0.0, min_duration_s=0.0).process(fsr)
    assert naive.heel_strike_idx.size > 10
    assert naive.toe_off_idx.size > 3


def test_first_confirmed_state_is_not_an_event():
    # a foot already loaded at power-on: no heel strike until it lifts and lands again
    n = 60
    heel = _square(n, [(0, 20), (40, 60)])
    toe = _square(n, [(0, 25)])
    blk = GaitEventDetector().process(np.column_stack([heel, toe]))
    assert blk.heel_strike_idx.tolist() == [40]
    assert blk.toe_off_idx.tolist() == [25]
    assert blk.heel_loaded[:2].tolist() == [False, False]  # unconfirmed reads unloaded
    assert blk.heel_loaded[2]


@pytest.mark.parametrize(
    ("hyst", "min_duration_s"), [(50.0, 0.03), (0.0, 0.0), (100.0, 0.05), (20.0, 0.01)]
)
def test_detector_matches_per_sample_reference(hyst, min_duration_s):
    rng = np.random.default_rng(1)
    n = 4000
    # slow oscillations across the threshold plus noise, so there are many near-threshold runs
    t = np.arange(n)[:, None]
    x = 1000 + 150 * np.sin(2 * np.pi * t / np.array([150, 97])) + rng.normal(0, 60, (n, 2))
    x[rng.random(n) < 0.01, 0] = np.nan  # NaN holds the state
    det = GaitEventDetector(1000.0, hyst, min_duration_s, FS_HZ)
    blk = det.process(x)
    d = max(1, round(min_duration_s * FS_HZ))
    heel, hs, _ = _reference_contact(x[:, 0], 1000.0, hyst, d)
    toe, _, to = _reference_contact(x[:, 1], 1000.0, hyst, d)
    assert hs.size > 5 and to.size > 5  # the signal really crosses
    assert np.array_equal(blk.heel_loaded, heel)
    assert np.array_equal(blk.toe_loaded, toe)
    assert np.array_equal(blk.heel_strike_idx, hs)
    assert np.array_equal(blk.toe_off_idx, to)


def _random_chunks(n: int, rng: np.random.Generator) -> list[int]:
    """Chunk sizes summing to n, including empty and 1-sample chunks."""
    sizes: list[int] = []
    total = 0
    while total < n:
        kind = rng.integers(0, 4)
        size = [0, 1, int(rng.integers(2, 10)), int(rng.integers(10, 300))][kind]
        size = min(size, n - total)
        sizes.append(size)
        total += size
    return [0, *sizes, 0]


@pytest.mark.parametrize("seed", range(5))
def test_chunked_detector_and_tracker_equal_whole_record(seed):
    rng = np.random.default_rng(seed)
    n = 3000
    t = np.arange(n)
    period = 100 + 10 * seed
    phase = (t % period) / period
    heel = np.where(phase < 0.45, 2500.0, 100.0) + rng.normal(0, 300, n)
    toe = np.where((phase > 0.1) & (phase < 0.6), 2200.0, 100.0) + rng.normal(0, 300, n)
    fsr = np.column_stack([heel, toe])

    det = GaitEventDetector()
    whole = det.process(fsr)
    whole_strides = StrideTracker().process(whole.heel_strike_idx, whole.toe_off_idx)
    assert len(whole_strides) >= 20

    det.reset()
    tracker = StrideTracker()
    parts = []
    strides: list[Stride] = []
    pos = 0
    for size in _random_chunks(n, rng):
        blk = det.process(fsr[pos : pos + size])
        assert blk.heel_loaded.shape == (size,)
        parts.append(blk)
        strides += tracker.process(blk.heel_strike_idx, blk.toe_off_idx)
        pos += size
    for field in ("heel_loaded", "toe_loaded", "phase", "heel_strike_idx", "toe_off_idx"):
        assert np.array_equal(
            np.concatenate([getattr(b, field) for b in parts]), getattr(whole, field)
        ), field
    assert strides == whole_strides
    assert strides == strides_from_events(whole.heel_strike_idx, whole.toe_off_idx, FS_HZ)


def test_reset_returns_to_fresh_state():
    fsr = np.column_stack([_square(80, [(10, 50)]), _square(80, [(20, 60)])])
    det = GaitEventDetector()
    first = det.process(fsr)
    det.process(fsr[:15])  # leave it mid-stance
    det.reset()
    again = det.process(fsr)
    assert det.samples_seen == 80
    assert np.array_equal(first.heel_strike_idx, again.heel_strike_idx)
    assert np.array_equal(first.phase, again.phase)


def test_bad_input_shapes_raise():
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        GaitEventDetector().process(np.zeros((10, 3)))
    with pytest.raises(ValueError, match="hysteresis"):
        GaitEventDetector(hysteresis=-1)


def test_half_sine_periodic_signal_matches_closed_form():
    # heel = HI * sin(2 pi n / P) (half-wave), toe the same delayed by LAG samples. Closed forms:
    # heel strike = first n with sin > thr / HI; toe off = first n past the peak with
    # sin < (thr - hyst) / HI.
    p, lag, thr, hyst, n_cycles = 110, 30, 1000.0, 50.0, 12
    n = p * n_cycles + 5
    t = np.arange(n)

    def half_sine(k):
        return np.maximum(0.0, HI * np.sin(2 * np.pi * k / p))

    fsr = np.column_stack([half_sine(t), half_sine(t - lag)])
    blk = GaitEventDetector(thr, hyst, 0.03, FS_HZ).process(fsr)

    a_on = math.asin(thr / HI) * p / (2 * math.pi)  # rising crossing, in samples
    a_off = (math.pi - math.asin((thr - hyst) / HI)) * p / (2 * math.pi)  # falling crossing
    hs_first = math.floor(a_on) + 1
    to_first = lag + math.floor(a_off) + 1
    # the first heel rise starts at sample 0 from 0 N, so it is a real heel strike
    assert blk.heel_strike_idx.tolist() == [hs_first + k * p for k in range(n_cycles)]
    assert blk.toe_off_idx.tolist() == [
        to_first + k * p for k in range(n_cycles) if to_first + k * p + 2 < n
    ]

    strides = strides_from_events(blk.heel_strike_idx, blk.toe_off_idx, FS_HZ)
    assert len(strides) == n_cycles - 1
    stance_n = to_first - hs_first
    for s in strides:
        assert s.stride_time_s == pytest.approx(p / FS_HZ, abs=1e-12)
        assert s.stance_time_s == pytest.approx(stance_n / FS_HZ, abs=1e-12)
        assert s.swing_time_s == pytest.approx((p - stance_n) / FS_HZ, abs=1e-12)
        assert s.stance_pct == pytest.approx(100 * stance_n / p, abs=1e-9)
        assert s.stance_pct + s.swing_pct == pytest.approx(100.0, abs=1e-9)
        assert s.cadence_derived_steps_per_min == pytest.approx(120 / (p / FS_HZ), abs=1e-9)


def test_square_wave_gait_gives_sixty_percent_stance():
    # 1.1 s stride, heel loaded 0-45 %, toe 10-60 %: stance 60 %, swing 40 %, as in normal gait
    p, n_cycles = 110, 10
    n = p * n_cycles + 20
    ranges_h = [(20 + k * p, 20 + k * p + 50) for k in range(n_cycles)]
    ranges_t = [(20 + k * p + 11, 20 + k * p + 66) for k in range(n_cycles)]
    fsr = np.column_stack([_square(n, ranges_h), _square(n, ranges_t)])
    blk = GaitEventDetector().process(fsr)
    strides = strides_from_events(blk.heel_strike_idx, blk.toe_off_idx, FS_HZ)
    assert [s.start_idx for s in strides] == [a for a, _ in ranges_h[:-1]]
    assert [s.toe_off_idx for s in strides] == [b for _, b in ranges_t[:-1]]
    summary = gait_summary(strides)
    assert summary.n_strides == n_cycles - 1
    assert summary.stride_time_mean_s == pytest.approx(1.1, abs=1e-12)
    assert summary.stride_time_sd_s == pytest.approx(0.0, abs=1e-12)
    assert summary.stance_pct_mean == pytest.approx(60.0, abs=1e-9)
    assert summary.swing_pct_mean == pytest.approx(40.0, abs=1e-9)
    assert summary.cadence_derived_steps_per_min == pytest.approx(120 / 1.1, abs=1e-9)


def test_strides_need_exactly_one_toe_off_strictly_inside():
    hs = [0, 100, 200, 300, 400, 500]
    # stride 0-100: one toe off (60); 100-200: none; 200-300: two (250, 280);
    # 300-400: toe off at 300 is on the boundary (not inside) and 360 inside -> one;
    # 400-500: toe off at 500 only on the boundary -> none
    to = [60, 250, 280, 300, 360, 500]
    strides = strides_from_events(hs, to, FS_HZ)
    assert [(s.start_idx, s.end_idx, s.toe_off_idx) for s in strides] == [
        (0, 100, 60),
        (300, 400, 360),
    ]
    assert strides[0] == Stride(0, 100, 60, 1.0, 0.6, 0.4, 60.0, 40.0)


def test_pauses_longer_than_max_stride_time_are_not_strides():
    hs = [0, 100, 1100, 1200]
    to = [60, 1000, 1160]
    got = strides_from_events(hs, to, FS_HZ, max_stride_time_s=4.0)
    assert [(s.start_idx, s.end_idx) for s in got] == [(0, 100), (1100, 1200)]
    got_all = strides_from_events(hs, to, FS_HZ, max_stride_time_s=None)
    assert [(s.start_idx, s.end_idx) for s in got_all] == [(0, 100), (100, 1100), (1100, 1200)]


def test_stride_tracker_rejects_out_of_order_events():
    tr = StrideTracker(FS_HZ)
    tr.process([100], [])
    with pytest.raises(ValueError, match="order"):
        tr.process([], [50])  # a toe off older than the open heel strike
    tr = StrideTracker(FS_HZ)
    tr.process([], [160])
    with pytest.raises(ValueError, match="order"):
        tr.process([150], [])
    with pytest.raises(ValueError, match="increasing"):
        StrideTracker().process([5, 5], [])


def test_stride_tracker_emits_each_stride_when_its_closing_heel_strike_arrives():
    tr = StrideTracker(FS_HZ)
    assert tr.process([10], []) == []
    assert tr.process([], [70]) == []
    out = tr.process([120], [])
    assert [(s.start_idx, s.end_idx, s.toe_off_idx) for s in out] == [(10, 120, 70)]
    tr.reset()
    assert tr.process([200], []) == []  # after reset, 120 is forgotten


def test_normalise_cycles_sinusoid_equals_analytic_curve():
    # strides of 100 and 200 samples; within each, angle = sin(2 pi (n - start) / length), so
    # every normalised cycle is sin(2 pi j / 100) at j = 0..100 exactly (integer positions)
    hs = np.array([7, 107, 307, 407, 607])
    n = 620
    t = np.arange(n, dtype=float)
    ang = np.zeros(n)
    for s, e in itertools.pairwise(hs):
        ang[s : e + 1] = np.sin(2 * np.pi * (t[s : e + 1] - s) / (e - s))
    ang2 = np.column_stack([ang, 2 * ang + 1])
    cycles = normalise_cycles(ang2, hs)
    assert cycles.shape == (4, 101, 2)
    analytic = np.sin(2 * np.pi * np.arange(101) / 100)
    for c in cycles:
        np.testing.assert_allclose(c[:, 0], analytic, atol=1e-12)
        np.testing.assert_allclose(c[:, 1], 2 * analytic + 1, atol=1e-12)
    assert normalise_cycles(ang, hs).shape == (4, 101)  # 1-D in, (n, 101) out


def test_normalise_cycles_matches_np_interp_on_irregular_strides():
    rng = np.random.default_rng(3)
    n = 800
    ang = np.cumsum(rng.normal(size=(n, 3)), axis=0)
    hs = np.array([3, 90, 213, 300, 387, 520, 799, 900])  # the last cycle runs past the data
    cycles = normalise_cycles(ang, hs, n_points=101)
    assert cycles.shape == (6, 101, 3)
    grid = np.arange(n)
    for i, (s, e) in enumerate(itertools.pairwise(hs[:-1])):
        x_new = s + (e - s) * np.linspace(0.0, 1.0, 101)
        for k in range(3):
            np.testing.assert_allclose(
                cycles[i, :, k], np.interp(x_new, grid, ang[:, k]), atol=1e-12
            )


def test_normalise_strides_uses_absolute_indices_with_offset():
    n = 300
    ang = np.sin(np.arange(n) / 17.0)
    strides = [Stride(1010, 1110, 1070, 1.0, 0.6, 0.4, 60.0, 40.0)]
    got = normalise_strides(ang, strides, index_offset=1000)
    want = np.interp(10 + 100 * np.linspace(0, 1, 101), np.arange(n), ang)
    np.testing.assert_allclose(got[0], want, atol=1e-12)


def test_cycle_mean_sd_closed_form():
    base = np.sin(np.linspace(0, 2 * np.pi, 101))[:, None] * np.array([1.0, 3.0])
    cycles = np.stack([base - 1.0, base, base + 1.0])  # offsets -1, 0, +1 -> sample SD 1
    mean, sd = cycle_mean_sd(cycles)
    np.testing.assert_allclose(mean, base, atol=1e-12)
    np.testing.assert_allclose(sd, 1.0, atol=1e-12)
    mean1, sd1 = cycle_mean_sd(cycles[:1])
    np.testing.assert_allclose(mean1, base - 1.0)
    assert np.isnan(sd1).all()
    mean0, _ = cycle_mean_sd(cycles[:0])
    assert mean0.shape == (101, 2) and np.isnan(mean0).all()


def test_gait_summary_closed_form():
    strides = [
        Stride(0, 100, 60, 1.0, 0.6, 0.4, 60.0, 40.0),
        Stride(100, 220, 170, 1.2, 0.7, 0.5, 70.0 / 1.2, 50.0 / 1.2),
        Stride(220, 330, 286, 1.1, 0.66, 0.44, 60.0, 40.0),
    ]
    s = gait_summary(strides)
    assert s.n_strides == 3
    assert s.stride_time_mean_s == pytest.approx(1.1)
    assert s.stride_time_sd_s == pytest.approx(0.1)  # sample SD of 1.0, 1.2, 1.1
    assert s.stride_time_cv_pct == pytest.approx(100 * 0.1 / 1.1)
    assert s.stance_pct_mean == pytest.approx((60 + 70 / 1.2 + 60) / 3)
    assert s.cadence_derived_steps_per_min == pytest.approx(120 / 1.1)
    empty = gait_summary([])
    assert empty.n_strides == 0 and math.isnan(empty.stride_time_mean_s)


def test_contact_edges_from_unit_contacts_by_hand_and_in_chunks():
    from gaitmon.dsp.gait import ContactEdges

    heel = np.array([1, 1, 0, 0, 1, 1, 1, 0, 0, 1], dtype=bool)  # starts loaded: no event at 0
    toe = np.array([0, 1, 1, 0, 0, 1, 1, 1, 0, 0], dtype=bool)
    hs, to = ContactEdges().process(heel, toe, 100)
    np.testing.assert_array_equal(hs, [104, 109])  # heel rises at rows 4 and 9
    np.testing.assert_array_equal(to, [103, 108])  # toe falls at rows 3 and 8
    edges = ContactEdges()
    bounds = ((0, 3), (3, 3), (3, 4), (4, 10))
    parts = [edges.process(heel[a:b], toe[a:b], 100 + a) for a, b in bounds]
    np.testing.assert_array_equal(np.concatenate([p[0] for p in parts]), hs)
    np.testing.assert_array_equal(np.concatenate([p[1] for p in parts]), to)


def test_mean_sd_is_the_standard_librarys_over_the_finite_values() -> None:
    import math
    import statistics

    from gaitmon.dsp.gait import mean_sd

    v = [1.25, float("nan"), 0.5, 2.0, float("inf"), 1.0]
    finite = [x for x in v if math.isfinite(x)]
    m, sd, n = mean_sd(v)
    assert n == 4
    assert m == pytest.approx(statistics.fmean(finite), rel=1e-15)
    assert sd == pytest.approx(statistics.stdev(finite), rel=1e-14)  # sample SD (n - 1)
    m1, sd1, n1 = mean_sd([3.5, float("nan")])
    assert (m1, n1) == (3.5, 1) and math.isnan(sd1)  # no SD from one value
    m0, sd0, n0 = mean_sd([])
    assert n0 == 0 and math.isnan(m0) and math.isnan(sd0)
