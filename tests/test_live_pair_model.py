"""The both-legs live model without Qt or devices: hand-built snapshots whose clocks, delays and
events are known, against the values computed here by hand."""

import math

import numpy as np
import pytest

from gaitmon.engine import Mode, RecordingStatus, Snapshot
from gaitmon.engine.buffers import SERIES
from gaitmon.engine.snapshot import GaitStatus
from gaitmon.live.pair import LegClock, LiveBilateral

FS = 100.0


def snapshot(t_s, host_s, hs=(), to=(), lost=None):
    n = len(t_s)
    series = {k: np.full((n, *shape), np.nan) for k, shape in SERIES.items()}
    series["t_s"] = np.asarray(t_s, float)
    series["host_time_s"] = np.asarray(host_s, float)
    series["lost"] = np.zeros(n) if lost is None else np.asarray(lost, float)
    series["settling"] = np.zeros(n)
    return Snapshot(
        series=series, heel_strike_t_s=np.asarray(hs, float), toe_off_t_s=np.asarray(to, float),
        markers=(), samples_total=n, frame_rate_hz=FS, last_data_age_s=0.0, link=None,
        link_state="connected", link_reason="", seconds_to_reconnect=None,
        recording=RecordingStatus(), gait=GaitStatus(), mode=Mode.RAW, calibrated=False,
    )  # fmt: skip


def link(t_s, host_at_zero_s, rate, rng, min_delay_s=0.004):
    """Receive times of samples taken at ``t_s`` (unit seconds; the unit's second is 1 / rate
    host seconds): the floor delay plus a random extra delay, frames read 1-5 at a time (a
    read's frames share the time of its last one)."""
    taken = host_at_zero_s + np.asarray(t_s) / rate
    arrive = taken + min_delay_s + rng.exponential(0.01, len(taken))
    ends = np.cumsum(rng.integers(1, 6, len(taken)))
    ends = ends[ends <= len(taken)]
    out = np.empty(len(taken))
    start = 0
    for end in [*ends.tolist(), len(taken)]:
        if end > start:
            out[start:end] = arrive[start:end].max()
        start = end
    # one sample a read is exactly on time plus the floor: the envelope touches it
    out[::97] = taken[::97] + min_delay_s
    return out


@pytest.mark.parametrize("rate", [1.0, 1.0 + 50e-6, 2.0])  # real time, a fast crystal, 2x sim
def test_a_legs_clock_is_the_lower_envelope_of_its_receive_times(rate):
    rng = np.random.default_rng(1)
    t = np.arange(1000) / FS + 30.0
    host = link(t, 500.0, rate, rng)
    clock = LegClock()
    clock.update(snapshot(t, host))
    # sample times taken at host 500 + t / rate, delivered at least 4 ms later
    expected = 500.0 + t / rate + 0.004
    np.testing.assert_allclose(clock.host_s(t), expected, atol=1.5e-3)
    assert clock.slope == pytest.approx(1.0 / rate, rel=2e-4)
    assert clock.unit_s(500.0 + 35.0 / rate + 0.004) == pytest.approx(35.0, abs=2e-3)


def test_the_measures_put_both_legs_on_one_clock_and_match_a_hand_computation():
    rng = np.random.default_rng(2)
    # the left unit started counting 0.7 s after the right (its t_s is 0.7 s behind);
    # true events in common seconds: right heel strikes every 1.1 s, left 0.5 s after each
    # (step times: left 0.5 s, right 0.6 s); toe offs at 62 % of each stride
    stride = 1.1
    hs_r = 20.0 + stride * np.arange(10)
    hs_l = hs_r + 0.5
    to_r, to_l = hs_r + 0.62 * stride, hs_l + 0.62 * stride
    offset_l = 0.7
    model = LiveBilateral()
    for tick in range(40):  # ticks sliding over the walk, 0.3 s apart
        end = 22.0 + tick * 0.3
        c = np.arange(end - 10.0, end, 1 / FS)  # common seconds of the window's samples
        snaps = {}
        for side, hs, to, off in (("L", hs_l, to_l, offset_l), ("R", hs_r, to_r, 0.0)):
            t = c - off
            host = link(t + off, 1000.0, 1.0, rng)  # both on one host clock
            keep = lambda ev, lo=c[0], hi=c[-1]: ev[(ev >= lo) & (ev <= hi)]  # noqa: E731
            snaps[side] = snapshot(t, host, keep(hs) - off, keep(to) - off)
        model.update(snaps)
    # the right unit's clock is 0.7 s ahead of the left one's
    assert model.r_to_l_s == pytest.approx(-offset_l, abs=2e-3)
    gait = model.gait()
    step = gait.symmetry_of("step_s")
    assert step.left == pytest.approx(0.5, abs=2e-3)
    assert step.right == pytest.approx(0.6, abs=2e-3)
    assert step.ratio == pytest.approx(0.5 / 0.6, abs=0.01)
    # 60 / the mean of every step of both legs (the definition, docs/bilateral.md)
    n_l, n_r = (int(np.isfinite(gait.side(s).step_s).sum()) for s in ("L", "R"))
    assert n_l >= 5 and n_r >= 5
    mean_step = (0.5 * n_l + 0.6 * n_r) / (n_l + n_r)
    assert gait.cadence_steps_min == pytest.approx(60.0 / mean_step, abs=0.2)
    # initial double support of the left: its heel strike to the right toe off
    ds = gait.side("L").initial_double_support_s
    ds = ds[np.isfinite(ds)]
    assert len(ds) >= 5
    np.testing.assert_allclose(ds, 0.62 * stride - 0.5, atol=2e-3)


def test_a_legs_steps_before_its_gap_are_left_out():
    model = LiveBilateral()
    t = np.arange(0.0, 10.0, 1 / FS)
    host = 100.0 + t + 0.005
    lost = ((t > 4.0) & (t < 5.0)).astype(float)
    hs = np.array([1.0, 2.1, 3.2, 5.5, 6.6, 7.7, 8.8])
    model.update({"L": snapshot(t, host, hs, hs + 0.7, lost), "R": snapshot(t, host, hs + 0.55,
                                                                            hs + 0.55 + 0.7)})
    gait = model.gait()
    kept = gait.side("L").heel_strike_s
    assert kept.min() > 5.0 and len(kept) == 4  # only after the gap
    assert math.isfinite(gait.symmetry_of("step_s").ratio)
