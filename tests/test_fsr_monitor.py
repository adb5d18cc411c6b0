"""The streaming FSR check by hand: strides built from the gyro's events, a sensor that never
unloads flagged on its third failing stride, in any chunking (module doc of gaitmon.dsp.fsr_check).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from gaitmon.dsp.fsr_check import FsrFault, FsrMonitor

STRIDE = 100  # samples per gyro stride
N_STRIDES = 12
BROKEN_FROM = 5  # the heel reads loaded all the time from this stride on


def _walk() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    n = STRIDE * N_STRIDES
    hs = np.arange(0, n, STRIDE)
    to = hs + 60  # stance 60 %, swing 40 %
    heel = np.zeros(n, bool)
    toe = np.zeros(n, bool)
    for h in hs:
        heel[h : h + 40] = True  # heel loads at heel strike
        toe[h + 20 : h + 62] = True  # toe loads until just after toe off
    heel[BROKEN_FROM * STRIDE :] = True
    # a second toe-off inside stride 3, before its real one: the first after the heel strike
    # counts (stance 300..325, swing 325..400: still no fault)
    to = np.sort(np.r_[to, 325])
    return heel, toe, hs, to


def _run(cuts: list[int]) -> list[FsrFault]:
    heel, toe, hs, to = _walk()
    m = FsrMonitor(100.0, decision_delay=7)
    found: list[FsrFault] = []
    for a, b in itertools.pairwise(cuts):
        in_block = slice(a, b)
        found += m.process(heel[in_block], toe[in_block], hs[(hs >= a) & (hs < b)],
                           to[(to >= a) & (to < b)])  # fmt: skip
    assert m.faults == found
    return found


@pytest.mark.parametrize("step", [1, 37, 250, 10_000])
def test_a_heel_that_never_unloads_is_flagged_on_its_third_failing_stride(step) -> None:
    n = STRIDE * N_STRIDES
    faults = _run([*range(0, n, step), n])
    # strides from BROKEN_FROM on: heel loaded through the whole swing (> 90 %); the third
    # one (BROKEN_FROM + 2) closes at its next heel strike, and the flag is decided
    # decision_delay samples after it. The toe is fine throughout.
    first = BROKEN_FROM * STRIDE
    closing = (BROKEN_FROM + 3) * STRIDE
    assert faults == [FsrFault("heel", "never unloads", first, closing + 7)]
