"""Foot tilt on the real walks in ../shared/data (gdins_footprints, 16 walks; xio closed-loop
walks, 2): the live gait-aware filter against the paper's, trial by trial (issue 24: never
worse, +1 deg), and the offline smoother. Skips without ../shared/data.

There is no orientation reference in these sets: the reference is a 3-D 6-axis estimate from
the same IMU (all three gyro and accelerometer axes, anchored at every still phase, forward and
backward; ``benchmarks/tilt_real.py``, ``reference_foot_tilt``), while the filters see only the
unit's planar channels. RMS error with the constant offset removed.
"""

import sys
from pathlib import Path

import pytest

from gaitmon.dsp.estimate import estimate_tilt

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import tilt_real

WALKS = [f"gdins/exp{i}" for i in range(31, 47)] + ["xio/long_walk", "xio/short_walk"]


@pytest.mark.parametrize("walk", WALKS)
def test_live_foot_tilt_is_never_worse_than_the_papers_on_real_walks(shared_data, walk):
    d = tilt_real.load_walks(shared_data, cache=False, only=walk)[walk]
    # the reference itself: its rate is the planar gyro's while the foot stays level (only
    # exp35, running-like with 11 g impacts, is looser)
    assert d["ref_rate_corr"] > (0.9 if walk == "gdins/exp35" else 0.99)

    def rms(method, offline=False):
        est = estimate_tilt(d["ax"], d["az"], d["gy"], 100.0, segment="foot", method=method,
                            offline=offline)  # fmt: skip
        return tilt_real.rms_deg(est, d["ref"], d["valid"], offset=True)

    paper, live, offline = rms("paper"), rms("gait-aware"), rms("gait-aware", True)
    print(f"\n{walk}: foot tilt RMS paper {paper:.1f}, live {live:.1f}, offline {offline:.1f} deg")
    assert live <= paper + 1.0
    assert offline <= live + 0.5  # the smoother sees the whole record
    if walk != "gdins/exp35":  # (today 1.9-6.4 deg live: a regression guard)
        assert live < 7.0
