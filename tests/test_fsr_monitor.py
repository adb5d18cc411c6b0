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


def _strides_by_the_loop(hs: list[int], to: list[int], seen_at: list[int], tol: int):
    """The strides (HS_k, its toe-off, HS_k+1) checked after each block, by the per-stride loop
    the monitor ran before it took them in whole arrays (its reference): a stride is checked
    once the flags reach 2 tol past its closing heel strike; its toe-off is the first after
    HS_k (toe-offs passed are never counted again), if before HS_k+1."""
    out: list[list[tuple[int, int, int]]] = []
    h: list[int] = []
    t_left: list[int] = []
    for hs_new, to_new, seen in zip(hs, to, seen_at, strict=True):
        h += hs_new
        t_left = sorted(t_left + to_new)
        strides = []
        k = t = 0
        while len(h) - k >= 2 and h[k + 1] + 2 * tol <= seen:
            while t < len(t_left) and t_left[t] <= h[k]:
                t += 1
            if t < len(t_left) and t_left[t] < h[k + 1]:
                strides.append((h[k], t_left[t], h[k + 1]))
            k += 1
        del h[:k], t_left[:t]
        out.append(strides)
    return out


@pytest.mark.parametrize("seed", range(6))
def test_the_strides_checked_are_the_per_stride_loops(seed, monkeypatch) -> None:
    """Random gyro events (missed toe-offs, two in one stride, toe-offs late in another block)
    fed in random blocks: the strides the monitor checks after each block are the loop's."""
    rng = np.random.default_rng(seed)
    n = 6000
    hs = np.cumsum(rng.integers(60, 160, size=60))
    hs = hs[hs < n]
    to = np.concatenate([h + rng.integers(20, 80, size=rng.integers(0, 3)) for h in hs])
    cuts = np.unique(np.r_[0, np.sort(rng.integers(1, n, size=12)), n])
    mon = FsrMonitor(100.0)
    checked: list[list[tuple[int, int, int]]] = []
    real_check = FsrMonitor._check
    monkeypatch.setattr(FsrMonitor, "_check",
                        lambda self, st: (checked[-1].extend(map(tuple, st.tolist())),
                                          real_check(self, st))[1])  # fmt: skip
    blocks_hs, blocks_to, seen_at = [], [], []
    for a, b in itertools.pairwise(cuts):
        # events arrive with a block once the detector has decided them (some blocks later)
        hi = b - 40 if b < n else n
        h = [int(x) for x in hs if a - 40 <= x < hi]
        t = sorted(int(x) for x in to if a - 40 <= x < hi)
        blocks_hs.append(h)
        blocks_to.append(t)
        seen_at.append(int(b))
        checked.append([])
        loaded = np.ones(b - a, dtype=bool)
        mon.process(loaded, loaded, np.array(h, dtype=np.int64), np.array(t, dtype=np.int64))
    want = _strides_by_the_loop(blocks_hs, blocks_to, seen_at, mon.tol)
    assert checked == want
    assert sum(map(len, want)) > 20
