"""Stride length, gait speed and foot clearance from the foot IMU (zero-velocity updates).

Method: planar strapdown integration of the foot board, reset at every foot-flat.

1. **Foot-flat.** After each heel strike the foot lies flat on the ground for a while (loading
   response to heel rise). In a search span after the heel strike (``SEARCH_FRACTION`` of the
   stride before it; of the stride after it for the first heel strike) a sample is *still* when,
   over +-2 samples, the gyro stays within ``STILL_GYRO_RAD_S`` of zero and the accelerometer's
   magnitude within ``STILL_ACC_MS2`` of g. The longest still run is the foot-flat; its middle
   sample is the anchor where the foot's velocity is taken as zero. Where no sample is still
   (fast walking: on real feet at ~2 m/s the stance foot keeps rolling at 0.5-1.2 rad/s and
   |a| - g stays 1-3 m/s^2), the stillest sample of the span's first half (the stance) is the
   anchor if its deviation is below ``NEAR_STILL`` times the thresholds (flag FLAG_NEAR_STILL).
2. **Pitch.** At each foot-flat the board's pitch from vertical is the accelerometer tilt
   atan2(mean a_z, mean a_x) over the run (gravity alone acts on a still foot: no calibration
   or mounting offset needed), and the gyro's mean over the run is its residual bias. Between
   two anchors the pitch is the first anchor's plus the integral of the gyro (less the mean of
   the two biases), with its remaining mismatch at the second anchor spread linearly.
3. **Acceleration.** The specific force is rotated into the world (forward, up) by the pitch,
   and the local gravity (the mean |a| at the two foot-flats) is removed.
4. **Zero-velocity update.** Velocity is integrated from 0 at the first anchor; its value at the
   second anchor (which should be 0) is removed linearly over the stride (the standard ZUPT
   de-drift: a constant acceleration error, e.g. from a pitch offset, leaves no trace). Position
   is integrated from the velocity; its height at the second anchor is removed linearly too
   (level ground). A stance foot that still rolls at the anchor (fast walking) is not at rest:
   the board, ``ANCHOR_LEVER_M`` above the ground pivot it rolls on, moves forward at that
   height times the roll rate (the gyro around the anchor), which is the forward velocity the
   integration starts from and must end at.
5. **The board's yaw on the foot.** A unit strapped on the instep at a yaw psi to the foot's
   long axis sees cos(psi) of the foot's pitch rate and forward acceleration (its lateral
   motion aside): read as it is, every stride is short by 1 - cos(psi) (three gdins walks,
   psi 23-30 deg from the 3-D gyro's rotation axis, read 8-13 % short). Rotated by a pitch
   that is cos(psi) of the true one, the forward acceleration leaks into the vertical, so the
   foot ends the stride moving up or down. Where that vertical velocity misses zero by more
   than ``MOUNT_MIN_VEL_M_S`` and changes sign in [``MOUNT_COS_MIN``, 1], the stride is
   integrated again with the gyro and a_z divided by the cosine at which it closes
   (bisection). Per stride, so the tracker and the offline function agree.
6. **Per stride** (heel strike j to j + 1, the swing between them): the stride length is the
   forward displacement from the foot-flat after heel strike j to the foot-flat after heel
   strike j + 1, the foot clearance the sensor's highest point above its foot-flat height over
   that interval, the gait speed the stride length over the stride time (heel strike to heel
   strike). NaN where a foot-flat is not found or the two anchors are more than
   ``MAX_STRIDE_S`` apart (the subject stood still mid-stride: no speed to speak of), with
   the reason in ``StrideMeasures.flag``. A stride whose own planar model does not close (a
   turn or a roll takes rotation off the board's one gyro axis) keeps its value but is flagged
   FLAG_OUT_OF_PLANE: the gyro's pitch misses the next foot-flat's accelerometer pitch by
   more than ``OUT_OF_PLANE_PITCH_RAD`` or the forward velocity misses zero by more than
   ``OUT_OF_PLANE_VEL_M_S`` (gdins: 93 % of the strides turning > 60 deg flagged, 6 % of
   those turning < 15 deg).
7. **First steps** (``first_steps=True``): before a heel strike that opens a walk (the first,
   or one more than ``MAX_STRIDE_S`` after the one before) the last standing (still for
   ``STANDING_S``, ending within ``STANDING_SEARCH_S`` of it) is the first anchor of one more
   stride, to the foot-flat after that heel strike, flagged FLAG_FIRST_STEP.

Assumptions (module doc of gaitmon.dsp.channels for the frames): the foot board lies in the
foot's sagittal plane, x up and z forward when standing (any pitch offset on the foot is fine),
the gyro measures the rate about the board's y axis (to the subject's right), positive when the
toe goes up (the tilt convention of gaitmon.dsp.angles), in rad/s with its standing bias
removed (gaitmon's calibration; a residual of a few hundredths of a rad/s is estimated at each
foot-flat); the accelerometer in m/s^2 with its gain right (the local g is taken from it).
Walking is straight (one gyro axis cannot see turns: they are flagged, step 6) and on level
ground (clearance only; the stride length holds on slopes). The foot is still, or nearly, for
at least ~50 ms each stance. No
leg length, height or other anthropometry is needed.

The same stride needs only the samples from its heel strike to the foot-flat after the next one
(or to the end of its own foot-flat search, if a long stride before makes it end later:
``stride_data_end``): :class:`StrideLengthTracker` gives each stride as soon as those have
arrived, with the same numbers as :func:`stride_measures` on the whole record.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.dsp.channels import (
    ACC_X_IDX,
    ACC_Z_IDX,
    GYRO_IDX,
    SEGMENTS,
    STANDARD_GRAVITY_MS2,
)

if TYPE_CHECKING:
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import ChannelTable

STILL_GYRO_RAD_S = 0.35
STILL_ACC_MS2 = 0.8
STILL_HALF_WIDTH = 2  # samples either side that must be still too
MIN_STILL_SAMPLES = 3
NEAR_STILL = 5.0  # in units of the still thresholds: the stillest sample is taken below it
SEARCH_FRACTION = 0.6  # of a stride, after its heel strike (foot-flat ends by ~40 %)
MAX_STRIDE_S = 3.0
# a stride's own consistency (module doc, step 6): flagged out of plane past either
OUT_OF_PLANE_PITCH_RAD = float(np.radians(6.0))
OUT_OF_PLANE_VEL_M_S = 0.5
ANCHOR_LEVER_M = 0.08  # the board's height above a rolling stance foot's ground pivot
MOUNT_COS_MIN = float(np.cos(np.radians(40.0)))  # the board's yaw on the foot: at most 40 deg
MOUNT_MIN_VEL_M_S = 0.05  # ... looked for where the vertical velocity misses 0 by more
MOUNT_ITERATIONS = 10  # bisection steps for it (to 0.0002 in its cosine)
STANDING_S = 0.3  # a first step's standing: still at least this long
STANDING_SEARCH_S = 1.5  # ... and ending within this before the step's heel strike

# StrideMeasures.flag bits
FLAG_NO_FOOT_FLAT = 1  # NaN: a foot-flat was not found
FLAG_PAUSE = 2  # NaN: the foot-flats are more than MAX_STRIDE_S apart
FLAG_OUT_OF_PLANE = 4  # a turn or roll: the planar model does not close (a value, not trusted)
FLAG_NEAR_STILL = 8  # a foot-flat is the stillest sample of a stance that never rests
FLAG_FIRST_STEP = 16  # a first step from standing (first_steps=True), not a heel-strike stride
FLAG_REASONS: dict[int, str] = {
    FLAG_NO_FOOT_FLAT: "no foot-flat",
    FLAG_PAUSE: "pause",
    FLAG_OUT_OF_PLANE: "turn or roll (out of plane)",
    FLAG_NEAR_STILL: "foot never still",
    FLAG_FIRST_STEP: "first step from standing",
}
FLAG_UNTRUSTED = FLAG_NO_FOOT_FLAT | FLAG_PAUSE | FLAG_OUT_OF_PLANE
# Raise with any change to the method that changes its numbers (the constants above are part of
# METHOD already): stored measures computed by another version are then recomputed when read
# (gaitmon.finish.strides).
METHOD_VERSION = 2
METHOD: dict[str, float | int | str] = {
    "method": "foot IMU strapdown with zero-velocity updates",
    "version": METHOD_VERSION,
    "still_gyro_rad_s": STILL_GYRO_RAD_S,
    "still_acc_ms2": STILL_ACC_MS2,
    "still_half_width": STILL_HALF_WIDTH,
    "min_still_samples": MIN_STILL_SAMPLES,
    "search_fraction": SEARCH_FRACTION,
    "max_stride_s": MAX_STRIDE_S,
    "near_still": NEAR_STILL,
    "out_of_plane_pitch_rad": OUT_OF_PLANE_PITCH_RAD,
    "out_of_plane_vel_m_s": OUT_OF_PLANE_VEL_M_S,
    "mount_cos_min": MOUNT_COS_MIN,
    "anchor_lever_m": ANCHOR_LEVER_M,
    "mount_iterations": MOUNT_ITERATIONS,
    "mount_min_vel_m_s": MOUNT_MIN_VEL_M_S,
    "standard_gravity_ms2": STANDARD_GRAVITY_MS2,
}


@dataclass(frozen=True)
class StrideMeasures:
    """One entry per stride (heel strike j to j + 1); NaN where it cannot be computed."""

    heel_strike_idx: np.ndarray  # (K,) the stride's opening heel strike
    stride_length_m: np.ndarray  # (K,)
    foot_clearance_m: np.ndarray  # (K,)
    stride_time_s: np.ndarray  # (K,)
    foot_flat_idx: np.ndarray  # (K, 2) anchor samples (-1: not found) the stride runs between
    # (K,) int FLAG_* bits (0: a plain stride); None: not known (built by an older reader)
    flag: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.flag is None:
            object.__setattr__(self, "flag", np.zeros(len(self.heel_strike_idx), dtype=np.int64))

    @property
    def flags(self) -> np.ndarray:
        """(K,) int FLAG_* bits of each stride."""
        assert self.flag is not None
        return self.flag

    @property
    def trusted(self) -> np.ndarray:
        """(K,) bool: a value that no flag puts in doubt (no turn, foot-flats found)."""
        return np.isfinite(self.stride_length_m) & (self.flags & FLAG_UNTRUSTED == 0)

    def reasons(self, k: int) -> list[str]:
        """Why stride k is flagged (empty: a plain stride)."""
        f = int(self.flags[k])
        return [text for bit, text in FLAG_REASONS.items() if f & bit]

    @property
    def speed_m_s(self) -> np.ndarray:
        return self.stride_length_m / self.stride_time_s

    def __len__(self) -> int:
        return len(self.heel_strike_idx)


def _check(acc_x: np.ndarray, acc_z: np.ndarray, gyro: np.ndarray, fs_hz: float) -> None:
    if not (acc_x.ndim == acc_z.ndim == gyro.ndim == 1):
        raise ValueError("stride lengths need 1-D foot acc x, acc z and gyro arrays")
    if not (len(acc_x) == len(acc_z) == len(gyro)):
        raise ValueError(
            f"foot acc x, acc z and gyro differ in length ({len(acc_x)}, {len(acc_z)}, "
            f"{len(gyro)}): pass the same samples of each"
        )
    if not fs_hz > 0:
        raise ValueError(f"sampling rate must be > 0 Hz, got {fs_hz}")


class _RowSamples:
    """Where each row is among the samples once the bridged losses are filled in (``pos``,
    increasing), and back: a filled-in frame maps to the row after it (as the pipeline maps
    its indices). Rows past the end lie as far past the last sample; negative ones stay."""

    def __init__(self, pos: np.ndarray) -> None:
        self.pos = np.asarray(pos, dtype=np.int64)
        self.extra = int(self.pos[-1]) - (len(self.pos) - 1) if len(self.pos) else 0

    def samples_of(self, rows: np.ndarray | Sequence[int]) -> np.ndarray:
        r = np.asarray(rows, dtype=np.int64)
        out = r.copy()
        inside = (r >= 0) & (r < len(self.pos))
        out[inside] = self.pos[r[inside]]
        out[r >= len(self.pos)] += self.extra
        return out

    def rows_of(self, samples: np.ndarray) -> np.ndarray:
        x = np.asarray(samples, dtype=np.int64)
        out = np.searchsorted(self.pos, x, side="left").astype(np.int64)
        past = x > (self.pos[-1] if len(self.pos) else -1)
        out[past] = x[past] - self.extra
        neg = x < 0
        out[neg] = x[neg]
        return out.reshape(x.shape)

    def measures_in_rows(self, m: StrideMeasures) -> StrideMeasures:
        """``m`` (sample indices) with its indices in rows; its times stay the samples'."""
        ff = m.foot_flat_idx
        return StrideMeasures(
            heel_strike_idx=self.rows_of(m.heel_strike_idx),
            stride_length_m=m.stride_length_m,
            foot_clearance_m=m.foot_clearance_m,
            stride_time_s=m.stride_time_s,
            foot_flat_idx=np.where(ff >= 0, self.rows_of(ff), -1),
            flag=m.flags,
        )


def _filled_in(
    rows: np.ndarray, lost_before: np.ndarray, fs_hz: float, prev: np.ndarray | None
) -> tuple[np.ndarray, _RowSamples] | None:
    """The rows (N, C) with the losses the pipeline bridges filled in as it fills them
    (``prev``: the row before the first, None: row 0 of a record, nothing filled before it),
    and the row <-> sample map; None when nothing is filled in."""
    from gaitmon.dsp.lost_frames import bridged_fill, fill_lost

    lost = np.asarray(lost_before, dtype=np.int64)
    if lost.shape != (len(rows),):
        raise ValueError(f"lost_before must have shape ({len(rows)},), got {lost.shape}")
    # a later block of a stream (``prev``): its first row is bridged from the block before
    fill = bridged_fill(lost, fs_hz) if prev is None else bridged_fill(np.r_[0, lost], fs_hz)[1:]
    ext, pos = fill_lost(rows, fill, prev)
    if pos is None:
        return None
    return ext, _RowSamples(pos)


def search_spans(heel_strike_idx: np.ndarray) -> np.ndarray:
    """(J,) samples after each heel strike searched for its foot-flat: SEARCH_FRACTION of the
    stride before it (of the stride after it for the first)."""
    hs = np.asarray(heel_strike_idx, dtype=np.int64)
    if len(hs) < 2:
        return np.zeros(len(hs), dtype=np.int64)
    d = np.diff(hs)
    before = np.concatenate([[d[0]], d])
    return np.maximum(np.round(SEARCH_FRACTION * before).astype(np.int64), 1)


def stride_data_end(heel_strike_idx: np.ndarray, j: int) -> int:
    """Exclusive end of the samples stride j (heel strike j to j + 1) needs: the end of both
    its foot-flat searches (after a long stride, heel strike j's reaches past j + 1's)."""
    hs = np.asarray(heel_strike_idx, dtype=np.int64)
    spans = search_spans(hs)
    return int(max(hs[j] + spans[j], hs[j + 1] + spans[j + 1]))


def _moving_max(x: np.ndarray, half: int) -> np.ndarray:
    n = len(x)
    out = x.copy()
    for s in range(1, half + 1):
        out[s:] = np.maximum(out[s:], x[: n - s])
        out[: n - s] = np.maximum(out[: n - s], x[s:])
    return out


@dataclass(frozen=True)
class _FootFlat:
    anchor: int  # absolute sample index
    acc_x_ms2: float  # the accelerometer's mean there (gravity alone)
    acc_z_ms2: float
    gyro_bias_rad_s: float
    roll_rad_s: float  # the gyro around the anchor (within the search: block-invariant)
    near_still: bool = False

    def pitch_rad(self, mount_cos: float = 1.0) -> float:
        """The board's pitch from vertical, its a_z read as mount_cos of the foot's (step 5)."""
        return float(np.arctan2(self.acc_z_ms2 / mount_cos, self.acc_x_ms2))

    def g_ms2(self, mount_cos: float = 1.0) -> float:
        return float(np.hypot(self.acc_x_ms2, self.acc_z_ms2 / mount_cos))


def _foot_flat(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, start: int, stop: int
) -> _FootFlat | None:
    """The foot-flat (module doc, step 1) in samples [start, stop) of the arrays given."""
    stop = min(stop, len(gy))
    if stop - start < MIN_STILL_SAMPLES:
        return None
    x, z, w = ax[start:stop], az[start:stop], gy[start:stop]
    dev = np.maximum(np.abs(w) / STILL_GYRO_RAD_S,
                     np.abs(np.hypot(x, z) - STANDARD_GRAVITY_MS2) / STILL_ACC_MS2)  # fmt: skip
    mdev = _moving_max(dev, STILL_HALF_WIDTH)
    still = mdev < 1.0
    if still.any():
        edges = np.diff(np.concatenate([[0], still.astype(np.int8), [0]]))
        runs_a, runs_b = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        k = int(np.argmax(runs_b - runs_a))
        a, b = int(runs_a[k]), int(runs_b[k])
    else:
        a = b = 0
    if b - a < MIN_STILL_SAMPLES:
        # no still run (fast walking: a short stance in which the foot keeps rolling): the
        # stillest sample of the span's first half (the stance, not a slow moment of swing),
        # if it is nearly still
        k = int(np.argmin(mdev[: max(len(mdev) // 2, 1)]))
        if mdev[k] >= NEAR_STILL:
            return None
        a, b = max(k - STILL_HALF_WIDTH, 0), min(k + STILL_HALF_WIDTH + 1, len(w))
        return _FootFlat(
            anchor=start + k,
            acc_x_ms2=float(np.mean(x[a:b])),
            acc_z_ms2=float(np.mean(z[a:b])),
            gyro_bias_rad_s=0.0,
            roll_rad_s=_rate_at(w, k),
            near_still=True,
        )
    mx, mz = float(np.mean(x[a:b])), float(np.mean(z[a:b]))
    return _FootFlat(
        anchor=start + (a + b - 1) // 2,
        acc_x_ms2=mx,
        acc_z_ms2=mz,
        gyro_bias_rad_s=float(np.mean(w[a:b])),
        roll_rad_s=_rate_at(w, (a + b - 1) // 2),
    )


def _cumtrapz(y: np.ndarray, dt: float) -> np.ndarray:
    out = np.zeros_like(y)
    out[1:] = np.cumsum(0.5 * (y[1:] + y[:-1])) * dt
    return out


@dataclass(frozen=True)
class _Pass:
    forward_m: float
    clearance_m: float
    pitch_misfit_rad: float  # the gyro's pitch at the second foot-flat less the accelerometer's
    vel_misfit_m_s: tuple[float, float]  # (forward, up) velocity at the second foot-flat


def _rate_at(w: np.ndarray, i: int) -> float:
    """The mean of w over +-STILL_HALF_WIDTH samples around w[i] (those inside w)."""
    return float(np.mean(w[max(i - STILL_HALF_WIDTH, 0) : i + STILL_HALF_WIDTH + 1]))


def _integrate(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, fs_hz: float, f0: _FootFlat, f1: _FootFlat,
    mount_cos: float,
) -> _Pass:  # fmt: skip
    """Steps 2-4 of the module doc between two foot-flats, the board's forward axis and gyro
    taken as ``mount_cos`` of the foot's (step 5)."""
    a, b = f0.anchor, f1.anchor
    dt = 1.0 / fs_hz
    u = np.arange(b - a + 1) / (b - a)  # 0 at the first anchor, 1 at the second
    bias = 0.5 * (f0.gyro_bias_rad_s + f1.gyro_bias_rad_s)
    rate = (gy[a : b + 1] - bias) / mount_cos
    p0, p1 = f0.pitch_rad(mount_cos), f1.pitch_rad(mount_cos)
    pitch = p0 + _cumtrapz(rate, dt)
    # the gyro's own closure (its standing bias is removed by the calibration; the residual
    # estimated at a foot-flat is not used here: a rolling stance foot would fake one)
    pitch_misfit = float(pitch[-1] + bias / mount_cos * (b - a) * dt - p1)
    pitch -= (pitch[-1] - p1) * u
    s, c = np.sin(pitch), np.cos(pitch)
    x, z = ax[a : b + 1], az[a : b + 1] / mount_cos
    acc_f = z * c - x * s
    acc_u = x * c + z * s - 0.5 * (f0.g_ms2(mount_cos) + f1.g_ms2(mount_cos))
    # a stance foot that still rolls (step 1) moves the board forward by its height above the
    # ground pivot times the roll rate (toe-down, negative rate: forward)
    v_ends = ((-ANCHOR_LEVER_M * f0.roll_rad_s / mount_cos,
               -ANCHOR_LEVER_M * f1.roll_rad_s / mount_cos), (0.0, 0.0))  # fmt: skip
    out = []
    misfit = []
    for acc, (v0, v1) in zip((acc_f, acc_u), v_ends, strict=True):
        v = v0 + _cumtrapz(acc, dt)
        misfit.append(float(v[-1] - v1))
        v -= (v[-1] - v1) * u
        p = _cumtrapz(v, dt)
        out.append(p)
    fwd, up = out
    up -= up[-1] * u
    return _Pass(float(fwd[-1]), float(np.max(up)), pitch_misfit, (misfit[0], misfit[1]))


def _stride(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, fs_hz: float, f0: _FootFlat, f1: _FootFlat
) -> tuple[float, float, bool]:
    """(forward displacement, clearance, out of plane) between two foot-flats (module doc,
    steps 2-6)."""
    p = _integrate(ax, az, gy, fs_hz, f0, f1, 1.0)
    # a board yawed on the foot sees only cos(yaw) of the pitch rate and forward acceleration
    # (step 5): the cosine in [MOUNT_COS_MIN, 1] at which the foot ends the stride with no
    # vertical velocity, if it misses by more than MOUNT_MIN_VEL_M_S and changes sign there
    hi_sign = np.sign(p.vel_misfit_m_s[1])
    lo, hi = MOUNT_COS_MIN, 1.0
    if abs(p.vel_misfit_m_s[1]) > MOUNT_MIN_VEL_M_S and (
        np.sign(_integrate(ax, az, gy, fs_hz, f0, f1, lo).vel_misfit_m_s[1]) == -hi_sign
    ):
        for _ in range(MOUNT_ITERATIONS):
            mid = 0.5 * (lo + hi)
            if np.sign(_integrate(ax, az, gy, fs_hz, f0, f1, mid).vel_misfit_m_s[1]) == hi_sign:
                hi = mid
            else:
                lo = mid
        p = _integrate(ax, az, gy, fs_hz, f0, f1, 0.5 * (lo + hi))
    out_of_plane = (
        abs(p.pitch_misfit_rad) > OUT_OF_PLANE_PITCH_RAD
        or abs(p.vel_misfit_m_s[0]) > OUT_OF_PLANE_VEL_M_S
    )
    return p.forward_m, p.clearance_m, out_of_plane


def _standing(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, start: int, stop: int, fs_hz: float
) -> _FootFlat | None:
    """The end of the last standing (still for STANDING_S) in samples [start, stop): the anchor
    of a first step (module doc, step 7)."""
    start, stop = max(start, 0), min(stop, len(gy))
    if stop - start < MIN_STILL_SAMPLES:
        return None
    x, z, w = ax[start:stop], az[start:stop], gy[start:stop]
    dev = np.maximum(np.abs(w) / STILL_GYRO_RAD_S,
                     np.abs(np.hypot(x, z) - STANDARD_GRAVITY_MS2) / STILL_ACC_MS2)  # fmt: skip
    still = _moving_max(dev, STILL_HALF_WIDTH) < 1.0
    edges = np.diff(np.concatenate([[0], still.astype(np.int8), [0]]))
    runs_a, runs_b = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    n_min = max(MIN_STILL_SAMPLES, round(STANDING_S * fs_hz))
    long_runs = np.flatnonzero(runs_b - runs_a >= n_min)
    if len(long_runs) == 0:
        return None
    b = int(runs_b[long_runs[-1]])
    a = b - n_min
    mx, mz = float(np.mean(x[a:b])), float(np.mean(z[a:b]))
    return _FootFlat(
        anchor=start + b - 1,
        acc_x_ms2=mx,
        acc_z_ms2=mz,
        gyro_bias_rad_s=float(np.mean(w[a:b])),
        roll_rad_s=_rate_at(w, b - 1),
    )


def stride_measures(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_y_rad_s: np.ndarray, fs_hz: float,
    heel_strike_idx: np.ndarray, *, first_steps: bool = False,
    lost_before: np.ndarray | None = None,
) -> StrideMeasures:  # fmt: skip
    """Stride length, foot clearance, stride time and speed of every stride between consecutive
    heel strikes, from the foot board's samples (module doc: method and assumptions), with a
    quality flag each (``StrideMeasures.flag``).

    ``first_steps``: also the step from standing to each heel strike that opens a walk (the
    first, or one more than MAX_STRIDE_S after the one before), placed before the strides from
    that heel strike and flagged FLAG_FIRST_STEP (module doc, step 7). Its ``heel_strike_idx``
    is the last standing sample and its stride time runs from there to the heel strike.

    ``lost_before`` ((N,) frames lost just before each row; None: the rows are consecutive
    frames): the losses the pipeline bridges are filled in as it fills them
    (gaitmon.dsp.lost_frames.bridged_fill / fill_lost) before the integration, so that lost
    frames count as time; every index given and returned is a row (a filled-in frame maps to
    the row after it) and the stride times are on the true timeline."""
    ax = np.asarray(acc_x_ms2, dtype=np.float64)
    az = np.asarray(acc_z_ms2, dtype=np.float64)
    gy = np.asarray(gyro_y_rad_s, dtype=np.float64)
    _check(ax, az, gy, fs_hz)
    if lost_before is not None:
        filled = _filled_in(np.stack([ax, az, gy], axis=1), lost_before, fs_hz, None)
        if filled is not None:
            ext, rows = filled
            hs_s = rows.samples_of(heel_strike_idx)
            m = stride_measures(ext[:, 0], ext[:, 1], ext[:, 2], fs_hz, hs_s,
                                first_steps=first_steps)  # fmt: skip
            return rows.measures_in_rows(m)
    hs = np.asarray(heel_strike_idx, dtype=np.int64)
    if hs.ndim != 1 or np.any(np.diff(hs) <= 0):
        raise ValueError("heel strikes must be a 1-D increasing array of sample indices")
    n_strides = max(len(hs) - 1, 0)
    spans = search_spans(hs)
    flats = [
        _foot_flat(ax, az, gy, int(h), int(h + sp)) if 0 <= h < len(gy) else None
        for h, sp in zip(hs, spans, strict=True)
    ]
    length = np.full(n_strides, np.nan)
    clearance = np.full(n_strides, np.nan)
    anchors = np.full((n_strides, 2), -1, dtype=np.int64)
    flag = np.zeros(n_strides, dtype=np.int64)
    for j in range(n_strides):
        f0, f1 = flats[j], flats[j + 1]
        if f0 is not None:
            anchors[j, 0] = f0.anchor
        if f1 is not None:
            anchors[j, 1] = f1.anchor
        if f0 is None or f1 is None:
            flag[j] = FLAG_NO_FOOT_FLAT
            continue
        if not 0 < f1.anchor - f0.anchor <= MAX_STRIDE_S * fs_hz:
            # (the same foot-flat for both heel strikes: no stride between them)
            flag[j] = FLAG_PAUSE
            continue
        length[j], clearance[j], out_of_plane = _stride(ax, az, gy, fs_hz, f0, f1)
        flag[j] = (FLAG_OUT_OF_PLANE if out_of_plane else 0) | (
            FLAG_NEAR_STILL if f0.near_still or f1.near_still else 0)  # fmt: skip
    m = StrideMeasures(
        heel_strike_idx=hs[:n_strides],
        stride_length_m=length,
        foot_clearance_m=clearance,
        stride_time_s=np.diff(hs).astype(np.float64) / fs_hz,
        foot_flat_idx=anchors,
        flag=flag,
    )
    return _with_first_steps(ax, az, gy, fs_hz, hs, spans, flats, m) if first_steps else m


def _with_first_steps(
    ax: np.ndarray, az: np.ndarray, gy: np.ndarray, fs_hz: float, hs: np.ndarray,
    spans: np.ndarray, flats: list[_FootFlat | None], m: StrideMeasures,
) -> StrideMeasures:  # fmt: skip
    """``m`` with the first step from standing before each heel strike opening a walk."""
    rows: list[tuple[int, float, float, float, int, int, int]] = []
    gap = MAX_STRIDE_S * fs_hz
    opens = [j for j in range(len(hs))
             if (j == 0 or hs[j] - hs[j - 1] > gap) and flats[j] is not None]  # fmt: skip
    at = []
    for j in opens:
        f1 = flats[j]
        assert f1 is not None
        lo = int(hs[j] - STANDING_SEARCH_S * fs_hz)
        if j > 0:
            lo = max(lo, int(hs[j - 1] + spans[j - 1]))
        f0 = _standing(ax, az, gy, lo, int(hs[j]), fs_hz)
        if f0 is None or not 0 < f1.anchor - f0.anchor <= MAX_STRIDE_S * fs_hz:
            continue
        length, clearance, out_of_plane = _stride(ax, az, gy, fs_hz, f0, f1)
        fl = FLAG_FIRST_STEP | (FLAG_OUT_OF_PLANE if out_of_plane else 0) | (
            FLAG_NEAR_STILL if f1.near_still else 0)  # fmt: skip
        rows.append((f0.anchor, length, clearance, float(hs[j] - f0.anchor) / fs_hz,
                     f0.anchor, f1.anchor, fl))  # fmt: skip
        at.append(j)
    if not rows:
        return m
    pos = np.asarray(at, dtype=np.int64)
    r = list(zip(*rows, strict=True))

    def ins(old: np.ndarray, new: np.ndarray) -> np.ndarray:
        return np.insert(old, pos, new, axis=0)

    return StrideMeasures(
        heel_strike_idx=ins(m.heel_strike_idx, np.asarray(r[0], dtype=np.int64)),
        stride_length_m=ins(m.stride_length_m, np.asarray(r[1])),
        foot_clearance_m=ins(m.foot_clearance_m, np.asarray(r[2])),
        stride_time_s=ins(m.stride_time_s, np.asarray(r[3])),
        foot_flat_idx=ins(m.foot_flat_idx, np.stack([r[4], r[5]], axis=1).astype(np.int64)),
        flag=ins(m.flags, np.asarray(r[6], dtype=np.int64)),
    )


# strides computed at a time over a long record (~37 minutes of walking; a few MB of samples)
STRIDES_PER_BLOCK = 2048


def record_stride_measures(
    read_foot: Callable[[int, int], tuple[np.ndarray, np.ndarray, np.ndarray]],
    n_rows: int, fs_hz: float, heel_strike_idx: np.ndarray,
    strides_per_block: int = STRIDES_PER_BLOCK, lost_before: np.ndarray | None = None,
) -> StrideMeasures:  # fmt: skip
    """:func:`stride_measures` of a record of ``n_rows`` samples read a block of strides at a
    time: ``read_foot(a, b)`` gives the foot board's acc x, acc z and gyro of rows [a, b). The
    same numbers as :func:`stride_measures` over the whole record (each stride sees the same
    samples: from the heel strike before its first, which sets that one's search span, to the
    end of the last foot-flat search), with memory bounded by the block instead of the record.
    ``lost_before`` ((n_rows,)): as :func:`stride_measures`'s, the bridged losses filled in."""
    hs = np.asarray(heel_strike_idx, dtype=np.int64)
    if hs.ndim != 1 or np.any(np.diff(hs) <= 0):
        raise ValueError("heel strikes must be a 1-D increasing array of sample indices")
    if strides_per_block < 1:
        raise ValueError(f"strides_per_block must be >= 1, got {strides_per_block}")
    n_strides = max(len(hs) - 1, 0)
    if n_strides == 0:
        empty = np.empty(0)
        return stride_measures(empty, empty, empty, fs_hz, hs)
    lost = None if lost_before is None else np.asarray(lost_before, dtype=np.int64)
    if lost is not None and lost.shape != (n_rows,):
        raise ValueError(f"lost_before must have shape ({n_rows},), got {lost.shape}")
    if lost is not None:  # each row's place among the samples, the bridged losses filled in
        from gaitmon.dsp.lost_frames import bridged_fill

        pos = np.arange(n_rows, dtype=np.int64) + np.cumsum(bridged_fill(lost, fs_hz))
    else:
        pos = np.arange(n_rows, dtype=np.int64)
    rows = _RowSamples(pos)
    hs_s = rows.samples_of(hs)
    spans = search_spans(hs_s)
    parts: list[StrideMeasures] = []
    for j0 in range(0, n_strides, strides_per_block):
        j1 = min(n_strides, j0 + strides_per_block)  # strides j0 .. j1 - 1: heel strikes j0 .. j1
        lo = max(j0 - 1, 0)  # the heel strike before sets j0's search span
        sub = hs[lo : j1 + 1]
        a = min(max(int(sub[0]), 0), n_rows)
        # the rows holding the samples before the searches' end (a frame filled in needs the
        # row after it)
        end_s = int(np.max(hs_s[j0 : j1 + 1] + spans[j0 : j1 + 1]))
        b = max(a, min(n_rows, int(np.searchsorted(pos, end_s - 1, side="left")) + 1))
        m = stride_measures(*read_foot(a, b), fs_hz, sub - a,
                            lost_before=None if lost is None else lost[a:b])  # fmt: skip
        keep = slice(j0 - lo, None)
        ff = m.foot_flat_idx[keep]
        parts.append(StrideMeasures(
            heel_strike_idx=m.heel_strike_idx[keep] + a,
            stride_length_m=m.stride_length_m[keep],
            foot_clearance_m=m.foot_clearance_m[keep],
            stride_time_s=m.stride_time_s[keep],
            foot_flat_idx=np.where(ff >= 0, ff + a, -1),
            flag=m.flags[keep],
        ))  # fmt: skip
    return StrideMeasures(
        heel_strike_idx=hs[:n_strides],
        stride_length_m=np.concatenate([p.stride_length_m for p in parts]),
        foot_clearance_m=np.concatenate([p.foot_clearance_m for p in parts]),
        stride_time_s=np.concatenate([p.stride_time_s for p in parts]),
        foot_flat_idx=np.concatenate([p.foot_flat_idx for p in parts]),
        flag=np.concatenate([p.flags for p in parts]),
    )


def foot_imu_from_counts(
    adc: np.ndarray, first_row: int, table: ChannelTable, calibration: Calibration,
    calibration_changes: Sequence[tuple[int, Calibration]],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The foot board's acc x, acc z (m/s^2, unfiltered) and gyro (rad/s, the calibration in
    force at each row removed: ``calibration`` from row 0, each change from its row on), float64,
    of the raw counts ``adc`` (M, 14) of rows ``first_row`` .. ``first_row + M``, as the live
    pipeline sees them."""
    foot = SEGMENTS.index("foot")
    cols = [int(ACC_X_IDX[foot]), int(ACC_Z_IDX[foot]), int(GYRO_IDX[foot])]
    counts = np.asarray(adc)[:, cols].astype(np.float64)
    phys = (counts - table.zero_counts[cols]) * table.units_per_count[cols]
    bias = np.full(len(phys), float(calibration.gyro_bias_rad_s[foot]))
    for row, cal in sorted(calibration_changes, key=lambda x: x[0]):
        bias[max(0, row - first_row):] = float(cal.gyro_bias_rad_s[foot])
    return phys[:, 0], phys[:, 1], phys[:, 2] - bias


def stride_lengths(
    acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_y_rad_s: np.ndarray, fs_hz: float,
    heel_strike_idx: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """(len(heel_strike_idx) - 1,) stride lengths in m, NaN where one cannot be computed: the
    foot's forward displacement from the foot-flat after each heel strike to the foot-flat after
    the next (module doc). :func:`stride_measures` gives clearance and speed too."""
    return stride_measures(
        acc_x_ms2, acc_z_ms2, gyro_y_rad_s, fs_hz, heel_strike_idx
    ).stride_length_m


class StrideLengthTracker:
    """Strides as the samples come (the live Gait panel's gait speed).

    ``push`` takes the foot board's next rows, the frames lost before each (``lost_before``:
    the losses the pipeline bridges are filled in, as :func:`stride_measures` fills them) and
    the heel strikes known so far (absolute row indices; repeats are ignored), and returns the
    strides whose samples are all in (``stride_data_end``): the same numbers
    :func:`stride_measures` gives on the whole record, every index a row; ``finish`` gives the
    last ones at the record's end. It keeps only the samples from the oldest stride still to
    come.
    """

    def __init__(self, fs_hz: float) -> None:
        if not fs_hz > 0:
            raise ValueError(f"sampling rate must be > 0 Hz, got {fs_hz}")
        self.fs_hz = float(fs_hz)
        self.reset()

    def reset(self) -> None:
        self._buf = np.empty((0, 3))
        self._row = np.empty(0, dtype=np.int64)  # each kept sample's row (filled: the next row)
        self._buf_start = 0  # absolute sample index of the first kept sample
        self._n_seen = 0  # rows
        self._n_samples = 0  # samples: the rows and the frames filled in before them
        self._last: np.ndarray | None = None  # the last row, to fill from
        self._hs: list[int] = []  # sample indices
        self._next = 0  # index into _hs of the next stride to give

    @property
    def n_seen(self) -> int:
        """Rows pushed since the last reset (the next row's index)."""
        return self._n_seen

    def push(
        self, acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_y_rad_s: np.ndarray,
        heel_strike_idx: np.ndarray | list[int] | None = None,
        lost_before: np.ndarray | None = None,
    ) -> StrideMeasures:  # fmt: skip
        x = np.asarray(acc_x_ms2, dtype=np.float64)
        z = np.asarray(acc_z_ms2, dtype=np.float64)
        g = np.asarray(gyro_y_rad_s, dtype=np.float64)
        _check(x, z, g, self.fs_hz)
        block = np.stack([x, z, g], axis=1)
        rows = np.arange(self._n_seen, self._n_seen + len(x), dtype=np.int64)
        filled = None
        if lost_before is not None and len(x):
            filled = _filled_in(block, lost_before, self.fs_hz, self._last)
        if filled is not None:
            block, where = filled
            rows = self._n_seen + where.rows_of(np.arange(len(block)))
        if len(x):
            self._last = np.array([x[-1], z[-1], g[-1]])
        self._buf = np.concatenate([self._buf, block])
        self._row = np.concatenate([self._row, rows])
        self._n_seen += len(x)
        self._n_samples += len(block)
        new = np.empty(0) if heel_strike_idx is None else heel_strike_idx
        for h in self._samples_of(np.asarray(new, dtype=np.int64).ravel()):
            if not self._hs or h > self._hs[-1]:
                self._hs.append(int(h))
        return self._give(everything=False)

    def finish(self) -> StrideMeasures:
        """At the end of the record: the strides still open whose closing heel strike is known,
        from the samples there are (as :func:`stride_measures` does at a record's end)."""
        return self._give(everything=True)

    def _samples_of(self, rows: np.ndarray) -> np.ndarray:
        """Sample indices of absolute rows (a row before the kept ones, or not come yet: as
        far from the nearest kept row as it is in rows)."""
        out = np.empty(len(rows), dtype=np.int64)
        for k, r in enumerate(rows.tolist()):
            if len(self._row) and self._row[0] <= r <= self._row[-1]:
                out[k] = self._buf_start + int(np.searchsorted(self._row, r, side="right")) - 1
            elif r >= self._n_seen or not len(self._row):
                out[k] = r + (self._n_samples - self._n_seen)
            else:
                out[k] = r + (self._buf_start - int(self._row[0]))
        return out

    def _rows_of(self, samples: np.ndarray) -> np.ndarray:
        """Absolute rows of sample indices (-1 stays -1)."""
        x = np.asarray(samples, dtype=np.int64)
        out = x - (self._n_samples - self._n_seen)  # past the kept ones
        rel = x - self._buf_start
        inside = (rel >= 0) & (rel < len(self._row))
        out[inside] = self._row[rel[inside]]
        out[x < 0] = -1
        return out

    def _give(self, everything: bool) -> StrideMeasures:
        done = []
        hs = np.asarray(self._hs, dtype=np.int64)
        while self._next + 1 < len(hs) and (
            everything or stride_data_end(hs, self._next) <= self._n_samples
        ):
            done.append(self._next)
            self._next += 1
        out = self._measure(hs, done)
        self._trim(hs)
        return out

    def _measure(self, hs: np.ndarray, done: list[int]) -> StrideMeasures:
        if not done:
            empty = np.empty(0)
            return StrideMeasures(np.empty(0, np.int64), empty, empty, empty,
                                  np.empty((0, 2), np.int64))  # fmt: skip
        # The strides' heel strikes (and the one before the first, which sets its search span),
        # with the samples they need, relative to the buffer's start.
        lo = max(done[0] - 1, 0)
        sub = hs[lo : done[-1] + 2]
        # (the first heel strike's span, taken from the stride after it, ends before the next)
        end = min(int(np.max(sub + search_spans(sub))), self._n_samples)
        m = stride_measures(*self._padded(end), self.fs_hz, sub - self._buf_start)
        keep = slice(done[0] - lo, None)
        ff = m.foot_flat_idx[keep]
        return StrideMeasures(
            heel_strike_idx=self._rows_of(m.heel_strike_idx[keep] + self._buf_start),
            stride_length_m=m.stride_length_m[keep],
            foot_clearance_m=m.foot_clearance_m[keep],
            stride_time_s=m.stride_time_s[keep],
            foot_flat_idx=np.where(ff >= 0, self._rows_of(ff + self._buf_start), -1),
            flag=m.flags[keep],
        )

    def _padded(self, end_abs: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The kept samples up to ``end_abs`` (a heel strike before them finds no foot-flat)."""
        buf = self._buf[: end_abs - self._buf_start]
        return buf[:, 0], buf[:, 1], buf[:, 2]

    def _trim(self, hs: np.ndarray) -> None:
        """Drop samples no stride still to come needs: before the heel strike of the next
        stride (and the one before it, for its search span: only its index is needed)."""
        if self._next < len(hs):
            keep_from = min(int(hs[self._next]), self._n_samples)
        else:  # no stride open: keep enough for a heel strike that is reported late
            keep_from = self._n_samples - int(MAX_STRIDE_S * self.fs_hz)
        if keep_from > self._buf_start:
            self._buf = self._buf[keep_from - self._buf_start :]
            self._row = self._row[keep_from - self._buf_start :]
            self._buf_start = keep_from
