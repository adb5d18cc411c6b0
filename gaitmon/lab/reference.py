"""A 3-D 6-axis reference of the foot's planar tilt, for real walks without an optical one.

**3-D 6-axis reference, not optical.** gdins_footprints and xio_closed_loop_walks have no
orientation reference, but they carry all six channels (``acc_xyz``, ``gyr_xyz``: foot frame x
forward, y left, z up). A planar filter sees three of them; this reference uses all six,
offline, with zero-velocity (stance) aiding:

1. **Still samples.** A sample is still when, over +-2 samples, |gyro| < ``STILL_GYRO_RAD_S``
   and | |acc| - g | < ``STILL_ACC_MS2`` (g: the median |acc| where |gyro| < 0.3 rad/s). Runs
   of at least ``MIN_STILL`` samples are the stances (foot-flat) and the standing.
2. **Anchors.** In each still run, one anchor per ``ANCHOR_CHUNK`` samples (one for a short
   run) at the chunk's centre, with the chunk's mean specific force, normalised, as the first
   guess of the earth-up direction in foot axes. Fast strides have no still sample: where two
   such anchors are more than ``LOOSE_GAP_S`` apart, the quietest sample of each looser run
   (|gyro| < ``LOOSE_GYRO_RAD_S``, | |acc| - g | < ``LOOSE_ACC_MS2``) is an anchor too; where
   there is still such a gap (the fastest strides), the local minima of that measure below
   ``FAST_DEV`` times the loose thresholds, at least 0.6 s apart, are.
3. **Gyro bias.** The mean 3-D gyro over each still run of at least ``BIAS_RUN`` samples
   (standing), linearly interpolated in time between them (constant before the first and after
   the last; zero if there is none). The short foot-flats of walking are not used: a foot that
   rolls slowly would pass for bias.
4. **Zero-velocity aiding.** Between two anchors (at most ``MAX_GAP_S`` apart) the foot's
   attitude is propagated in 3-D with the bias-corrected gyro (exact rotation per sample, the
   mean rate of its two ends), forwards from the first and backwards from the second. The foot
   is still at both, so its velocity change between them is zero; a tilt error d leaks gravity
   into the horizontal velocity, dv = -g T (d x e_z), and each pass (anchors at least
   ``MIN_ZUPT_S`` apart) is turned by the constant rotation that zeroes it (two iterations).
   A loose anchor's up vector is the mean of what the passes of its two strides make of it
   (this removes its own error, ~4 deg for a foot that is not quite still, to first order); a
   still anchor keeps the accelerometer's. A stride whose vertical velocity change exceeds
   ``MAX_DV_UP_M_S`` or that needed a turn of more than ``MAX_ZUPT_TURN_DEG`` is not
   stance-to-stance: NaN (and a loose anchor with no good stride is dropped).
5. **Between two anchors** the up vector is propagated forwards from the first and backwards
   from the second (final anchor values, no more turning) and the two are blended linearly in
   time (weight 1 at their own anchor): it meets both anchors, and each pass's drift is halved.
6. **Planar tilt in board frame.** The unit's board has x up (= foot z), z forward (= foot x),
   y to the right, and its tilt convention (BROAD's in ../shared/data/README.md) is
   atan2(u_z, u_x) of the up vector in board axes: here atan2(u_fx, u_fz) in foot axes, about
   0 with the foot flat, toe-up positive.

NaN before the first anchor, after the last, across longer gaps and in rejected strides.
Where every anchor is still (most trials) it is the accelerometer at stance with the 3-D
gyro between, blended; loose anchors carry the fast trials (exp34, exp35, exp38, exp43, exp44:
13-49 of 34-77 anchors). Checks (tests/test_lab_real.py): standing, it equals the board
accelerometer's tilt within 1 deg; where the foot turns only about its pitch axis, its rate
matches gyro_y (median difference 0.005-0.015 rad/s). It cannot see an error of the
dataset's sensor-to-foot rotation (neither can the methods: they read the same axes). It is a
proxy: a planar method's error against it is what seeing three of the six channels, and its
filtering, cost.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from gaitmon.lab.datasets import ImuTrial

STILL_GYRO_RAD_S = 0.6
STILL_ACC_MS2 = 0.6
STILL_HALF_WIDTH = 2
MIN_STILL = 3
ANCHOR_CHUNK = 25
BIAS_RUN = 50
MAX_GAP_S = 2.5
LOOSE_GYRO_RAD_S = 1.5
LOOSE_ACC_MS2 = 2.5
MIN_ZUPT_S = 0.5
ZUPT_ITERATIONS = 2
LOOSE_GAP_S = 1.6  # (s)
FAST_DEV = 2.0  # in units of the loose thresholds
MAX_DV_UP_M_S = 0.3
MAX_ZUPT_TURN_DEG = 10.0
LABEL = "3-D 6-axis reference, not optical"


def _moving_max(x: np.ndarray, half: int) -> np.ndarray:
    out = x.copy()
    n = len(x)
    for s in range(1, half + 1):
        out[s:] = np.maximum(out[s:], x[: n - s])
        out[: n - s] = np.maximum(out[: n - s], x[s:])
    return out


def _gravity(acc: np.ndarray, gyr: np.ndarray) -> float:
    a = np.linalg.norm(acc, axis=1)
    quiet = np.linalg.norm(gyr, axis=1) < 0.3
    return float(np.median(a[quiet])) if quiet.any() else 9.81


def _runs(mask: np.ndarray, min_len: int = 1) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(int(s), int(e)) for s, e in zip(starts, stops, strict=True) if e - s >= min_len]


def still_runs(acc: np.ndarray, gyr: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of every still run (module doc, step 1)."""
    w = np.linalg.norm(gyr, axis=1)
    a = np.linalg.norm(acc, axis=1)
    dev = np.maximum(w / STILL_GYRO_RAD_S, np.abs(a - _gravity(acc, gyr)) / STILL_ACC_MS2)
    return _runs(_moving_max(dev, STILL_HALF_WIDTH) < 1.0, MIN_STILL)


def _bias(gyr: np.ndarray, runs: list[tuple[int, int]]) -> np.ndarray:
    """(N, 3) gyro bias (module doc, step 3)."""
    long = [(a, b) for a, b in runs if b - a >= BIAS_RUN]
    n = len(gyr)
    if not long:
        return np.zeros((n, 3))
    t = np.array([0.5 * (a + b - 1) for a, b in long])
    m = np.array([gyr[a:b].mean(axis=0) for a, b in long])
    i = np.arange(n)
    return np.stack([np.interp(i, t, m[:, k]) for k in range(3)], axis=1)


def _anchors(
    acc: np.ndarray, gyr: np.ndarray, runs: list[tuple[int, int]], fs_hz: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(anchor samples, up vectors there, strict flags): module doc, step 2."""
    idx, up, strict = [], [], []
    for a, b in runs:
        k = max(1, (b - a) // ANCHOR_CHUNK)
        edges = np.linspace(a, b, k + 1).round().astype(int)
        for c0, c1 in itertools.pairwise(edges):
            idx.append((c0 + c1 - 1) // 2)
            up.append(acc[c0:c1].mean(axis=0))
            strict.append(True)
    # the quietest sample of each looser run that holds no strict one (fast strides)
    w = np.linalg.norm(gyr, axis=1)
    a_dev = np.abs(np.linalg.norm(acc, axis=1) - _gravity(acc, gyr))
    dev = _moving_max(np.maximum(w / LOOSE_GYRO_RAD_S, a_dev / LOOSE_ACC_MS2), STILL_HALF_WIDTH)
    strict_idx = np.asarray(sorted(idx), dtype=np.int64)
    for a, b in _runs(dev < 1.0):
        # only in a gap longer than LOOSE_GAP_S between strict anchors, if any
        k = int(np.searchsorted(strict_idx, a))
        lo = strict_idx[k - 1] if k > 0 else -(10**9)
        hi = strict_idx[k] if k < len(strict_idx) else 10**9
        if hi - lo <= LOOSE_GAP_S * fs_hz or a <= lo or b > hi:
            continue
        j = a + int(np.argmin(dev[a:b]))
        idx.append(j)
        up.append(acc[max(j - 2, 0) : j + 3].mean(axis=0))
        strict.append(False)
    # the very fast strides: the quietest sample of each stride in a gap still that long
    from scipy.signal import find_peaks

    have = np.asarray(sorted(idx), dtype=np.int64)
    bounds = np.concatenate([[0], have, [len(acc) - 1]])
    for lo, hi in itertools.pairwise(bounds):
        if hi - lo <= LOOSE_GAP_S * fs_hz or (lo == 0 and not len(have)):
            continue
        a, b = int(lo) + int(0.3 * fs_hz), int(hi) - int(0.3 * fs_hz)
        if b - a < 3:
            continue
        pk, _ = find_peaks(-dev[a:b], height=-FAST_DEV, distance=int(0.6 * fs_hz))
        for j in pk + a:
            idx.append(int(j))
            up.append(acc[max(j - 2, 0) : j + 3].mean(axis=0))
            strict.append(False)
    order = np.argsort(idx, kind="stable")
    u = np.asarray(up, dtype=np.float64).reshape(-1, 3)[order]
    return (np.asarray(idx, dtype=np.int64)[order], u / np.linalg.norm(u, axis=1)[:, None],
            np.asarray(strict, dtype=bool)[order])  # fmt: skip


def _propagate(c0: np.ndarray, w: np.ndarray, dt: float, sign: float) -> np.ndarray:
    """(len(w), 3, 3): the three world axes in body coordinates (rows of ``c0`` at the first
    sample), each obeying v' = sign * (v x w) at rate w (rad/s): every step rotates them by
    -sign * |w_mid| dt about w_mid (Rodrigues), w_mid the mean rate of the step's two ends."""
    n = len(w)
    mid = 0.5 * (w[1:] + w[:-1])
    rate = np.linalg.norm(mid, axis=1)
    th = -sign * rate * dt
    k = mid / np.where(rate > 0, rate, 1.0)[:, None]
    c, s = np.cos(th).tolist(), np.sin(th).tolist()
    kx, ky, kz = k[:, 0].tolist(), k[:, 1].tolist(), k[:, 2].tolist()
    out = np.empty((n, 3, 3))
    for r in range(3):
        x, y, z = (float(v) for v in c0[r])
        rows = [(x, y, z)]
        for j in range(n - 1):
            a, b, e, cj, sj = kx[j], ky[j], kz[j], c[j], s[j]
            dot = (a * x + b * y + e * z) * (1.0 - cj)
            cx, cy, cz = b * z - e * y, e * x - a * z, a * y - b * x  # k x v
            x, y, z = (x * cj + cx * sj + a * dot, y * cj + cy * sj + b * dot,
                       z * cj + cz * sj + e * dot)  # fmt: skip
            rows.append((x, y, z))
        out[:, r, :] = rows
    return out


def _frame(up: np.ndarray) -> np.ndarray:
    """World axes (rows: east-ish, north-ish, up) in body coordinates, up given, yaw arbitrary
    (the foot's forward axis projected on the horizontal)."""
    ex = np.array([1.0, 0.0, 0.0]) - up[0] * up
    ex /= np.linalg.norm(ex)
    return np.stack([ex, np.cross(up, ex), up])


def _rot(v: np.ndarray) -> np.ndarray:
    """Rotation matrix of the rotation vector v (Rodrigues)."""
    th = float(np.linalg.norm(v))
    if th == 0.0:
        return np.eye(3)
    k = v / th
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(th) * kx + (1.0 - np.cos(th)) * kx @ kx


def _pass(up0: np.ndarray, f: np.ndarray, w: np.ndarray, dt: float, g: float,
          sign: float) -> tuple[np.ndarray, bool]:  # fmt: skip
    """Up vector (n, 3) in body axes over one stride, from ``up0`` at its start (``sign`` -1:
    the arrays run backwards in time), turned by the constant world rotation that makes the
    foot's horizontal velocity change over the stride zero (module doc, step 4); and whether
    the stride passes the checks (vertical velocity change, size of the turn)."""
    axes = _propagate(_frame(up0), w, dt, sign)
    fw = np.einsum("nij,nj->ni", axes, f)  # specific force in world axes
    t_s = (len(f) - 1) * dt
    corr = np.eye(3)
    ok = True
    if t_s >= MIN_ZUPT_S:
        turned = 0.0
        for _ in range(ZUPT_ITERATIONS):
            acc_w = fw @ corr.T - np.array([0.0, 0.0, g])
            dv = (acc_w[1:] + acc_w[:-1]).sum(axis=0) * 0.5 * dt  # (time order: no sign)
            # a world tilt error d leaks gravity: dv = -g T (d x e_z) = -g T (d_y, -d_x, 0)
            d = np.array([dv[1], -dv[0], 0.0]) / (g * t_s)
            turned += float(np.linalg.norm(d))
            corr = _rot(d) @ corr
        ok = abs(float(dv[2])) <= MAX_DV_UP_M_S and turned <= np.radians(MAX_ZUPT_TURN_DEG)
    return np.asarray(np.einsum("j,njk->nk", corr[2], axes)), ok


def reference_up(acc_xyz: np.ndarray, gyr_xyz: np.ndarray, fs_hz: float) -> np.ndarray:
    """(N, 3) earth-up unit vector in foot axes (x fwd, y left, z up), NaN where there is no
    reference (module doc)."""
    acc = np.asarray(acc_xyz, dtype=np.float64)
    gyr = np.asarray(gyr_xyz, dtype=np.float64)
    n = len(acc)
    runs = still_runs(acc, gyr)
    w = gyr - _bias(gyr, runs)
    idx, up, strict = _anchors(acc, gyr, runs, fs_hz)
    g = _gravity(acc, gyr)
    dt = 1.0 / fs_hz
    # 1. zero-velocity aiding: each stride's passes check it and estimate its loose anchors
    segs = [i for i in range(len(idx) - 1) if idx[i + 1] - idx[i] <= MAX_GAP_S * fs_hz]
    est: list[list[np.ndarray]] = [[] for _ in idx]
    good = []
    for i in segs:
        p, q = int(idx[i]), int(idx[i + 1])
        seg, f = w[p : q + 1], acc[p : q + 1]
        fwd, ok_f = _pass(up[i], f, seg, dt, g, 1.0)
        bwd, ok_b = _pass(up[i + 1], f[::-1], seg[::-1], dt, g, -1.0)
        if ok_f and ok_b:
            good.append(i)
            est[i].append(fwd[0])
            est[i + 1].append(bwd[0])
    final = up.copy()
    usable = strict.copy()
    for k in np.flatnonzero(~strict):
        if est[k]:
            v = np.mean(est[k], axis=0)
            final[k], usable[k] = v / np.linalg.norm(v), True
    # 2. forwards and backwards from the anchors, blended
    out = np.full((n, 3), np.nan)
    for i in good:
        if not (usable[i] and usable[i + 1]):
            continue
        p, q = int(idx[i]), int(idx[i + 1])
        seg = w[p : q + 1]
        fwd = _propagate(_frame(final[i]), seg, dt, 1.0)[:, 2, :]
        bwd = _propagate(_frame(final[i + 1]), seg[::-1], dt, -1.0)[::-1, 2, :]
        s = (np.arange(q - p + 1) / (q - p))[:, None]
        v = (1.0 - s) * fwd + s * bwd
        out[p : q + 1] = v / np.linalg.norm(v, axis=1)[:, None]
    return out


def tilt_from_up(up: np.ndarray) -> np.ndarray:
    """Planar tilt in board frame (rad) of foot-frame up vectors (module doc, step 5)."""
    return np.arctan2(up[:, 0], up[:, 2])


def reference_foot_tilt(trial: ImuTrial) -> np.ndarray:
    """(N,) the foot's planar tilt in the unit's board frame (rad, toe-up positive, NaN where
    undefined) from the trial's 3-D accelerometer and gyro: the 3-D 6-axis reference of the
    module doc (**not optical**). Needs a trial with ``acc_xyz`` and ``gyr_xyz`` in foot axes
    (gdins_footprints, xio_closed_loop_walks)."""
    if trial.acc_xyz is None or trial.gyr_xyz is None:
        raise ValueError(f"{trial.dataset}/{trial.name} has no 3-D foot arrays for a reference")
    return tilt_from_up(reference_up(trial.acc_xyz, trial.gyr_xyz, trial.fs_hz))
