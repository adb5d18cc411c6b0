"""Foot tilt on the real walks in ../shared/data (gdins_footprints, 16 walks; xio closed-loop
walks, 2): the live gait-aware filter against the paper's, trial by trial (issue 24: never
worse, +1 deg), and the offline smoother. Skips without ../shared/data.

There is no orientation reference in these sets: the reference is the lab's 3-D 6-axis estimate
from the same IMU (all three gyro and accelerometer axes, anchored at every still phase, forward
and backward: ``gaitmon.lab.reference.reference_foot_tilt``), while the filters see only the
unit's planar channels. RMS error with the constant offset removed, over the walking
(``gaitmon.lab.real_tilt.foot_tilt``, the rows ``gaitmon lab accuracy --data`` prints).
"""

import numpy as np
import pytest

from gaitmon.lab import datasets
from gaitmon.lab.real_tilt import foot_tilt, walking_span
from gaitmon.lab.reference import reference_foot_tilt

WALKS = [("gdins_footprints", f"exp{i}") for i in range(31, 47)] + [
    ("xio_closed_loop_walks", "long_walk"),
    ("xio_closed_loop_walks", "short_walk"),
]


def _trial(root, dataset, name):
    read = datasets.read_gdins if dataset == "gdins_footprints" else datasets.read_xio
    return next(t for t in read(root) if t.name == name)


@pytest.mark.parametrize(("dataset", "name"), WALKS, ids=[n for _, n in WALKS])
def test_live_foot_tilt_is_never_worse_than_the_papers_on_real_walks(shared_data, dataset, name):
    trial = _trial(shared_data, dataset, name)
    # the reference itself: its rate is the planar gyro's (only exp35, running-like with 11 g
    # impacts, is looser)
    ref = reference_foot_tilt(trial)
    a, b = walking_span(trial)
    ok = np.isfinite(ref[a:b])
    rate = np.gradient(np.unwrap(np.where(ok, ref[a:b], 0.0))) * trial.fs_hz
    gy = trial.gyro_y[a:b]
    corr = np.corrcoef(rate[ok], gy[ok])[0, 1]
    assert corr > (0.9 if name == "exp35" else 0.97)

    (row,) = foot_tilt([trial])
    paper, live, offline = (row.rmse_deg[k] for k in ("paper", "live", "offline"))
    print(f"\n{name}: foot tilt RMS paper {paper:.1f}, live {live:.1f}, offline {offline:.1f} deg")
    assert live <= paper + 1.0
    assert offline <= live + 0.5  # the smoother sees the whole record
    if name != "exp35":  # (today 2.2-7.8 deg live: a regression guard)
        assert live < 8.5
