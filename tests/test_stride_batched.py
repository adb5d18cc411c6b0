"""The stride measures computed a batch of strides at a time (gaitmon.dsp.stride_anchors
``_foot_flats``, stride_integrate ``_strides``: padded 2-D arrays, issue 28) give every number
the per-stride computation gave, to the bit: stride length, clearance, anchors, flags, on
simulated walks and the real recordings, through the bisection of the board's yaw, strides
without a foot-flat, pauses, near-still stances, first steps, lost frames and batches cut small.

The reference below (``_ref_*``) is the per-stride implementation as it stood before the
change (gaitmon.dsp.stride_anchors._foot_flat, stride_integrate._integrate / _stride,
stride_first_steps._with_first_steps, stride_zupt.stride_measures' loop), copied here as the
spec: the change had to preserve its outputs exactly. It also counts the strides that took the
bisection, so the tests can show that each path was exercised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from gaitmon.dsp import stride_anchors
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX, STANDARD_GRAVITY_MS2
from gaitmon.dsp.gyro_events import gyro_gait_events
from gaitmon.dsp.stride_length import (
    ANCHOR_LEVER_M,
    FLAG_FIRST_STEP,
    FLAG_NEAR_STILL,
    FLAG_NO_FOOT_FLAT,
    FLAG_OUT_OF_PLANE,
    FLAG_PAUSE,
    MAX_STRIDE_S,
    MIN_STILL_SAMPLES,
    MOUNT_COS_MIN,
    MOUNT_ITERATIONS,
    MOUNT_MIN_VEL_M_S,
    NEAR_STILL,
    OUT_OF_PLANE_PITCH_RAD,
    OUT_OF_PLANE_VEL_M_S,
    STANDING_S,
    STANDING_SEARCH_S,
    STILL_ACC_MS2,
    STILL_GYRO_RAD_S,
    STILL_HALF_WIDTH,
    StrideMeasures,
    record_stride_measures,
    search_spans,
    stride_measures,
)
from gaitmon.dsp.stride_zupt import _filled_in
from gaitmon.io.sim import GaitConfig, GaitModel
from gaitmon.io.sim.sensors import SensorModel, realistic_sensors

FS = 100.0


# ---- the reference: the per-stride implementation before issue 28 ---------------------------
def _ref_moving_max(x, half):
    n = len(x)
    out = x.copy()
    for s in range(1, half + 1):
        out[s:] = np.maximum(out[s:], x[: n - s])
        out[: n - s] = np.maximum(out[: n - s], x[s:])
    return out


def _ref_rate_at(w, i):
    return float(np.mean(w[max(i - STILL_HALF_WIDTH, 0) : i + STILL_HALF_WIDTH + 1]))


@dataclass(frozen=True)
class _RefFlat:
    anchor: int
    acc_x_ms2: float
    acc_z_ms2: float
    gyro_bias_rad_s: float
    roll_rad_s: float
    near_still: bool = False

    def pitch_rad(self, mount_cos=1.0):
        return float(np.arctan2(self.acc_z_ms2 / mount_cos, self.acc_x_ms2))

    def g_ms2(self, mount_cos=1.0):
        return float(np.hypot(self.acc_x_ms2, self.acc_z_ms2 / mount_cos))


def _ref_foot_flat(ax, az, gy, start, stop):
    stop = min(stop, len(gy))
    if stop - start < MIN_STILL_SAMPLES:
        return None
    x, z, w = ax[start:stop], az[start:stop], gy[start:stop]
    dev = np.maximum(np.abs(w) / STILL_GYRO_RAD_S,
                     np.abs(np.hypot(x, z) - STANDARD_GRAVITY_MS2) / STILL_ACC_MS2)  # fmt: skip
    mdev = _ref_moving_max(dev, STILL_HALF_WIDTH)
    still = mdev < 1.0
    if still.any():
        edges = np.diff(np.concatenate([[0], still.astype(np.int8), [0]]))
        runs_a, runs_b = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        k = int(np.argmax(runs_b - runs_a))
        a, b = int(runs_a[k]), int(runs_b[k])
    else:
        a = b = 0
    if b - a < MIN_STILL_SAMPLES:
        k = int(np.argmin(mdev[: max(len(mdev) // 2, 1)]))
        if mdev[k] >= NEAR_STILL:
            return None
        a, b = max(k - STILL_HALF_WIDTH, 0), min(k + STILL_HALF_WIDTH + 1, len(w))
        return _RefFlat(start + k, float(np.mean(x[a:b])), float(np.mean(z[a:b])), 0.0,
                        _ref_rate_at(w, k), near_still=True)  # fmt: skip
    return _RefFlat(start + (a + b - 1) // 2, float(np.mean(x[a:b])), float(np.mean(z[a:b])),
                    float(np.mean(w[a:b])), _ref_rate_at(w, (a + b - 1) // 2))  # fmt: skip


def _ref_cumtrapz(y, dt):
    out = np.zeros_like(y)
    out[1:] = np.cumsum(0.5 * (y[1:] + y[:-1])) * dt
    return out


def _ref_integrate(ax, az, gy, fs_hz, f0, f1, mount_cos):
    a, b = f0.anchor, f1.anchor
    dt = 1.0 / fs_hz
    u = np.arange(b - a + 1) / (b - a)
    bias = 0.5 * (f0.gyro_bias_rad_s + f1.gyro_bias_rad_s)
    rate = (gy[a : b + 1] - bias) / mount_cos
    p0, p1 = f0.pitch_rad(mount_cos), f1.pitch_rad(mount_cos)
    pitch = p0 + _ref_cumtrapz(rate, dt)
    pitch_misfit = float(pitch[-1] + bias / mount_cos * (b - a) * dt - p1)
    pitch -= (pitch[-1] - p1) * u
    s, c = np.sin(pitch), np.cos(pitch)
    x, z = ax[a : b + 1], az[a : b + 1] / mount_cos
    acc_f = z * c - x * s
    acc_u = x * c + z * s - 0.5 * (f0.g_ms2(mount_cos) + f1.g_ms2(mount_cos))
    v_ends = ((-ANCHOR_LEVER_M * f0.roll_rad_s / mount_cos,
               -ANCHOR_LEVER_M * f1.roll_rad_s / mount_cos), (0.0, 0.0))  # fmt: skip
    out, misfit = [], []
    for acc, (v0, v1) in zip((acc_f, acc_u), v_ends, strict=True):
        v = v0 + _ref_cumtrapz(acc, dt)
        misfit.append(float(v[-1] - v1))
        v -= (v[-1] - v1) * u
        out.append(_ref_cumtrapz(v, dt))
    fwd, up = out
    up -= up[-1] * u
    return float(fwd[-1]), float(np.max(up)), pitch_misfit, (misfit[0], misfit[1])


def _ref_stride(ax, az, gy, fs_hz, f0, f1, counts):
    p = _ref_integrate(ax, az, gy, fs_hz, f0, f1, 1.0)
    hi_sign = np.sign(p[3][1])
    lo, hi = MOUNT_COS_MIN, 1.0
    if abs(p[3][1]) > MOUNT_MIN_VEL_M_S and (
        np.sign(_ref_integrate(ax, az, gy, fs_hz, f0, f1, lo)[3][1]) == -hi_sign
    ):
        counts["bisection"] += 1
        for _ in range(MOUNT_ITERATIONS):
            mid = 0.5 * (lo + hi)
            if np.sign(_ref_integrate(ax, az, gy, fs_hz, f0, f1, mid)[3][1]) == hi_sign:
                hi = mid
            else:
                lo = mid
        p = _ref_integrate(ax, az, gy, fs_hz, f0, f1, 0.5 * (lo + hi))
    out_of_plane = abs(p[2]) > OUT_OF_PLANE_PITCH_RAD or abs(p[3][0]) > OUT_OF_PLANE_VEL_M_S
    return p[0], p[1], out_of_plane


def _ref_standing(ax, az, gy, start, stop, fs_hz):
    start, stop = max(start, 0), min(stop, len(gy))
    if stop - start < MIN_STILL_SAMPLES:
        return None
    x, z, w = ax[start:stop], az[start:stop], gy[start:stop]
    dev = np.maximum(np.abs(w) / STILL_GYRO_RAD_S,
                     np.abs(np.hypot(x, z) - STANDARD_GRAVITY_MS2) / STILL_ACC_MS2)  # fmt: skip
    still = _ref_moving_max(dev, STILL_HALF_WIDTH) < 1.0
    edges = np.diff(np.concatenate([[0], still.astype(np.int8), [0]]))
    runs_a, runs_b = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    n_min = max(MIN_STILL_SAMPLES, round(STANDING_S * fs_hz))
    long_runs = np.flatnonzero(runs_b - runs_a >= n_min)
    if len(long_runs) == 0:
        return None
    b = int(runs_b[long_runs[-1]])
    a = b - n_min
    return _RefFlat(start + b - 1, float(np.mean(x[a:b])), float(np.mean(z[a:b])),
                    float(np.mean(w[a:b])), _ref_rate_at(w, b - 1))  # fmt: skip


def _ref_measures(ax, az, gy, fs_hz, hs, first_steps, counts):
    """The per-stride stride_measures on consecutive samples (``hs``: sample indices)."""
    hs = np.asarray(hs, dtype=np.int64)
    n_strides = max(len(hs) - 1, 0)
    spans = search_spans(hs)
    flats = [_ref_foot_flat(ax, az, gy, int(h), int(h + sp)) if 0 <= h < len(gy) else None
             for h, sp in zip(hs, spans, strict=True)]  # fmt: skip
    rows = []
    for j in range(n_strides):
        f0, f1 = flats[j], flats[j + 1]
        anchors = (f0.anchor if f0 else -1, f1.anchor if f1 else -1)
        length = clearance = np.nan
        if f0 is None or f1 is None:
            fl = FLAG_NO_FOOT_FLAT
        elif not 0 < f1.anchor - f0.anchor <= MAX_STRIDE_S * fs_hz:
            fl = FLAG_PAUSE
        else:
            length, clearance, oop = _ref_stride(ax, az, gy, fs_hz, f0, f1, counts)
            fl = (FLAG_OUT_OF_PLANE if oop else 0) | (
                FLAG_NEAR_STILL if f0.near_still or f1.near_still else 0)  # fmt: skip
        rows.append((int(hs[j]), length, clearance, (hs[j + 1] - hs[j]) / fs_hz, *anchors, fl))
    if first_steps:
        gap = MAX_STRIDE_S * fs_hz
        for j in reversed(range(len(hs))):
            f1 = flats[j]
            if not ((j == 0 or hs[j] - hs[j - 1] > gap) and f1 is not None):
                continue
            lo = int(hs[j] - STANDING_SEARCH_S * fs_hz)
            if j > 0:
                lo = max(lo, int(hs[j - 1] + spans[j - 1]))
            f0 = _ref_standing(ax, az, gy, lo, int(hs[j]), fs_hz)
            if f0 is None or not 0 < f1.anchor - f0.anchor <= gap:
                continue
            length, clearance, oop = _ref_stride(ax, az, gy, fs_hz, f0, f1, counts)
            fl = FLAG_FIRST_STEP | (FLAG_OUT_OF_PLANE if oop else 0) | (
                FLAG_NEAR_STILL if f1.near_still else 0)  # fmt: skip
            rows.insert(j, (f0.anchor, length, clearance, (hs[j] - f0.anchor) / fs_hz,
                            f0.anchor, f1.anchor, fl))  # fmt: skip
    r = list(zip(*rows, strict=True)) if rows else [[]] * 7
    return StrideMeasures(
        heel_strike_idx=np.asarray(r[0], dtype=np.int64),
        stride_length_m=np.asarray(r[1], dtype=np.float64),
        foot_clearance_m=np.asarray(r[2], dtype=np.float64),
        stride_time_s=np.asarray(r[3], dtype=np.float64),
        foot_flat_idx=np.stack([np.asarray(r[4], np.int64), np.asarray(r[5], np.int64)], axis=1),
        flag=np.asarray(r[6], dtype=np.int64),
    )


def reference(ax, az, gy, fs_hz, hs, *, first_steps=False, lost_before=None, counts=None):
    """The per-stride stride_measures (the module doc's spec); the lost frames filled in by
    the unchanged gaitmon.dsp.stride_zupt._filled_in."""
    counts = {"bisection": 0} if counts is None else counts
    ax, az, gy = (np.asarray(a, dtype=np.float64) for a in (ax, az, gy))
    if lost_before is not None:
        filled = _filled_in(np.stack([ax, az, gy], axis=1), lost_before, fs_hz, None)
        if filled is not None:
            ext, rows = filled
            m = _ref_measures(ext[:, 0], ext[:, 1], ext[:, 2], fs_hz, rows.samples_of(hs),
                              first_steps, counts)  # fmt: skip
            return rows.measures_in_rows(m)
    return _ref_measures(ax, az, gy, fs_hz, hs, first_steps, counts)


# ---- the comparisons ---------------------------------------------------------------------------
def _assert_same(got: StrideMeasures, want: StrideMeasures) -> None:
    for name in ("heel_strike_idx", "stride_length_m", "foot_clearance_m", "stride_time_s",
                 "foot_flat_idx", "flags"):  # fmt: skip
        a, b = getattr(got, name), getattr(want, name)
        assert a.shape == b.shape, name
        assert a.dtype.kind == b.dtype.kind, name
        np.testing.assert_array_equal(a, b, err_msg=name, strict=True)  # bits, NaN where NaN


def _walk(seed: int, stop_s: float | None = None, **opts):
    """A simulated walk's foot board (acc x, acc z, gyro less its standing zero) and the app's
    foot-gyro heel strikes; ``stop_s``: with a stop of that long mid-walk."""
    gait = GaitModel(GaitConfig(seed=seed, **opts))
    sensors = SensorModel(gait, realistic_sensors(seed))
    blocks = [sensors.next_block(6000 if stop_s is None else 2500)]
    if stop_s is not None:  # it stops within ~3 strides and walks on after stop_s
        gait.stand(25.0)
        blocks.append(sensors.next_block(round(stop_s * FS)))
        gait.walk(sensors.position / FS + 2.0)
        blocks.append(sensors.next_block(2500))
    ph = DEFAULT_TABLE.to_physical(np.concatenate([b.counts for b in blocks]))
    gy = ph[:, GYRO_IDX[3]] - ph[100:450, GYRO_IDX[3]].mean()
    hs, _ = gyro_gait_events(gy, FS)
    return ph[:, ACC_X_IDX[3]], ph[:, ACC_Z_IDX[3]], gy, hs


def _variants(ax, az, gy, hs, seed):
    """(name, args, kwargs, what it must exercise) of one walk: as it is, the board yawed
    30 deg on the foot (the bisection), heel strikes dropped and added (pauses, walks opening
    after them, spans in swing without a foot-flat, one past the end), a stance that keeps
    rolling (near-still), and lost frames."""
    rng = np.random.default_rng(seed)
    c = np.cos(np.radians(30.0))
    keep = np.ones(len(hs), bool)
    keep[len(hs) // 3 : len(hs) // 3 + 4] = False  # a gap of ~4 strides: > MAX_STRIDE_S
    extra = rng.integers(0, len(gy), 6)
    messy = np.unique(np.concatenate([hs[keep], extra, [len(gy) + 5]]))
    tremor = 0.5 * np.where(np.arange(len(gy)) % 2 == 0, 1.0, -1.0)
    lost = np.zeros(len(gy), np.int64)
    lost[rng.integers(1, len(gy), 40)] = rng.integers(1, 4, 40)
    return [
        ((ax, az, gy, FS, hs), {}),
        ((ax, az, gy, FS, hs), {"first_steps": True}),
        ((ax, c * az, c * gy, FS, hs), {"first_steps": True}),
        ((ax, az, gy, FS, messy), {"first_steps": True}),
        ((ax, az, gy + tremor, FS, hs), {}),
        ((ax, az, gy, FS, hs), {"first_steps": True, "lost_before": lost}),
    ]


# every flag: what the variants must have exercised between them
ALL_FLAGS = FLAG_NO_FOOT_FLAT | FLAG_PAUSE | FLAG_OUT_OF_PLANE | FLAG_NEAR_STILL | FLAG_FIRST_STEP


def _check(variants) -> tuple[int, int, int]:
    """Each variant's measures equal the reference's; (strides, bisected strides, the flags
    seen) in all."""
    n = n_bisected = seen = 0
    for args, kwargs in variants:
        counts = {"bisection": 0}
        want = reference(*args, counts=counts, **kwargs)
        _assert_same(stride_measures(*args, **kwargs), want)
        n += len(want)
        n_bisected += counts["bisection"]
        seen |= int(np.bitwise_or.reduce(want.flags, initial=0))
    return n, n_bisected, seen


@pytest.mark.parametrize(("seed", "opts"), [
    (41, {"turn_every_strides": 6.0, "turn_in_swing": True}),
    (42, {"stance_micro_rad": 0.15, "stride_length_cv": 0.05, "cadence_steps_min": 130.0}),
])  # fmt: skip
def test_simulated_walks_give_the_per_stride_numbers(seed, opts):
    ax, az, gy, hs = _walk(seed, **opts)
    n, n_bisected, seen = _check(_variants(ax, az, gy, hs, seed))
    assert n >= 200 and n_bisected >= 5
    assert seen == ALL_FLAGS


def test_small_batches_and_a_long_pause_give_the_same_numbers(monkeypatch):
    """Batches of one or two strides and a heel strike whose search span (after a 40 s pause)
    is longer than a batch: the same numbers; and read a few strides at a time from a record
    (record_stride_measures) with lost frames too."""
    ax, az, gy, hs = _walk(43, stop_s=40.0)
    long_span = search_spans(hs) > 1000
    assert long_span.sum() == 1
    lost = np.zeros(len(gy), np.int64)
    lost[[900, 2500, 2501, 5000]] = [1, 3, 2, 1]
    want = reference(ax, az, gy, FS, hs, first_steps=True)
    assert np.any(want.flags & FLAG_PAUSE) and np.any(want.flags & FLAG_FIRST_STEP)
    want_lost = reference(ax, az, gy, FS, hs, lost_before=lost)
    monkeypatch.setattr(stride_anchors, "BATCH_CELLS", 150)  # ~1 stride, ~2 spans a batch
    _assert_same(stride_measures(ax, az, gy, FS, hs, first_steps=True), want)

    def read(a, b):
        return ax[a:b], az[a:b], gy[a:b]

    blocks = record_stride_measures(read, len(gy), FS, hs, strides_per_block=7, lost_before=lost)
    _assert_same(blocks, want_lost)


def test_batches_cover_every_row_once_within_their_size(monkeypatch):
    rng = np.random.default_rng(3)
    widths = np.concatenate([rng.integers(5, 300, 2000), [5000, 70000, 1]])
    for cells in (1 << 16, 1000, 10):
        monkeypatch.setattr(stride_anchors, "BATCH_CELLS", cells)
        groups = stride_anchors._batches(widths)
        np.testing.assert_array_equal(np.sort(np.concatenate(groups)), np.arange(len(widths)))
        for g in groups:
            assert len(g) == 1 or len(g) * widths[g].max() <= cells
        assert len(groups) <= len(widths) * 301 // cells + 3  # not needlessly small either


def test_real_recordings_give_the_per_stride_numbers(shared_data):
    """The gdins footprint walks (16 trials, three with the board yawed ~25 deg on the foot)
    and the x-io loops, as `gaitmon lab accuracy` reads them, in every variant."""
    from gaitmon.lab import datasets
    from gaitmon.lab.real_gait import gyro_bias_at_start

    trials = datasets.read_gdins(shared_data) + datasets.read_xio(shared_data)
    if len(trials) < 18:
        pytest.skip("gdins_footprints or xio_closed_loop_walks is not complete")
    n = n_bisected = seen = 0
    for k, t in enumerate(trials):
        gy = t.gyro_y - gyro_bias_at_start(t)
        hs, _ = gyro_gait_events(gy, t.fs_hz)
        assert t.fs_hz == FS
        got = _check(_variants(t.acc_x, t.acc_z, gy, hs, k))
        n, n_bisected, seen = n + got[0], n_bisected + got[1], seen | got[2]
    assert n >= 5000 and n_bisected >= 500
    assert seen == ALL_FLAGS
