"""Standing calibration: the per-segment tilt offsets and gyro biases of the upright zero pose.

The subject stands upright with the leg straight (paper 000's initialisation). Whatever the
mounting, the mean accelerometer vector of each segment then gives the tilt that must read 0,
and the mean gyro rate is the bias. This module owns checking that the subject was really still
(:func:`check_stillness`), computing the offsets (:func:`standing_calibration`) and the
:class:`Calibration` record that is applied to every tilt and stored with every recording.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gaitmon.dsp.angles import accel_tilt, wrap_angle
from gaitmon.dsp.channels import SEGMENTS, STANDARD_GRAVITY_MS2

__all__ = [
    "DEFAULT_ACC_NORM_RANGE_MS2",
    "DEFAULT_ACC_STD_LIMIT_MS2",
    "DEFAULT_GYRO_RMS_LIMIT_RAD_S",
    "DEFAULT_MIN_DURATION_S",
    "Calibration",
    "CalibrationError",
    "StillnessResult",
    "check_stillness",
    "standing_calibration",
]

# Why these limits (device: 12-bit ADC on 3.3 V, 0.806 mV/LSB; see gaitmon.dsp.channels):
#
# * Gyro 0.05 rad/s (~2.9 deg/s) RMS about its mean. One LSB of the 2 mV/(deg/s) gyro is
#   0.40 deg/s = 0.007 rad/s, so this is ~7 LSB: far above quantisation and low-passed noise.
#   Quiet standing sway is a fraction of a degree at 0.1-1 Hz, i.e. well under 1-2 deg/s,
#   while walking, shifting weight or bending a knee gives RMS rates of 0.3-2 rad/s. The mean is
#   excluded because it is the bias being measured (an analog gyro's zero-rate offset can be
#   several deg/s and must not make a still subject fail).
# * Accelerometer 0.2 m/s^2 RMS deviation of the (x, z) vector from its mean. One LSB of the
#   300 mV/g accelerometer is 0.026 m/s^2, so this is ~8 LSB. A standing subject's segment
#   accelerations are a few hundredths of g at most; any step or swing gives several m/s^2.
#   As a tilt, 0.2 m/s^2 of sustained disturbance is 0.2 / 9.81 rad = 1.2 deg at worst, and the
#   mean over the window is far better than that.
# * Mean (x, z) acceleration magnitude within 0.7-1.3 g. Standing still it is 1 g times the
#   cosine of the sideways (out-of-plane) mounting tilt; 0.7 g allows 45 deg of that. Outside
#   the range the sensor is disconnected, saturated or on the wrong channel, and atan2 of the
#   vector would be meaningless.
# * At least 1 s of data: averaging 100 samples cuts noise 10x, and stillness judged over less
#   than one period of postural sway (~1 s) says little.
DEFAULT_GYRO_RMS_LIMIT_RAD_S = 0.05
DEFAULT_ACC_STD_LIMIT_MS2 = 0.2
DEFAULT_ACC_NORM_RANGE_MS2 = (0.7 * STANDARD_GRAVITY_MS2, 1.3 * STANDARD_GRAVITY_MS2)
DEFAULT_MIN_DURATION_S = 1.0

_N_SEGMENTS = len(SEGMENTS)


class CalibrationError(ValueError):
    """The standing calibration could not be done; the message says why and what to do.

    The message is for the clinician ("Ask the patient to stand still: the thigh is moving");
    ``detail`` holds the figures behind it (for a tooltip or a log)."""

    def __init__(self, message: str, detail: str = "") -> None:
        super().__init__(message)
        self.detail = detail or message


def _frozen_vector(value: np.ndarray, name: str) -> np.ndarray:
    a = np.array(value, dtype=np.float64)  # a private copy, so freezing it affects no caller
    if a.shape != (_N_SEGMENTS,):
        raise ValueError(f"{name} must have shape ({_N_SEGMENTS},) {SEGMENTS}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {a}")
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Calibration:
    """Per-segment (body, thigh, shank, foot) offsets from the standing pose."""

    tilt_offset_rad: np.ndarray  # (4,) subtracted from every tilt so standing is 0
    gyro_bias_rad_s: np.ndarray  # (4,) subtracted from the gyro rate

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "tilt_offset_rad", _frozen_vector(self.tilt_offset_rad, "tilt_offset_rad")
        )
        object.__setattr__(
            self, "gyro_bias_rad_s", _frozen_vector(self.gyro_bias_rad_s, "gyro_bias_rad_s")
        )

    @classmethod
    def identity(cls) -> Calibration:
        """No correction (all zeros)."""
        return cls(np.zeros(_N_SEGMENTS), np.zeros(_N_SEGMENTS))

    @property
    def zeroed(self) -> bool:
        """Whether a standing Zero set the tilt offsets (identity: not zeroed)."""
        return bool(np.any(self.tilt_offset_rad != 0))

    def apply_tilt(self, tilt_rad: np.ndarray) -> np.ndarray:
        """(N, 4) tilts -> calibrated tilts, wrapped to (-pi, pi]."""
        return wrap_angle(np.asarray(tilt_rad, dtype=np.float64) - self.tilt_offset_rad)

    def apply_gyro(self, gyro_rad_s: np.ndarray) -> np.ndarray:
        """(N, 4) gyro rates -> bias-corrected rates."""
        return np.asarray(gyro_rad_s, dtype=np.float64) - self.gyro_bias_rad_s

    def as_dict(self) -> dict[str, object]:
        """Plain-Python form for recording metadata (segment order = ``SEGMENTS``)."""
        return {
            "segments": list(SEGMENTS),
            "tilt_offset_rad": self.tilt_offset_rad.tolist(),
            "gyro_bias_rad_s": self.gyro_bias_rad_s.tolist(),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Calibration:
        """Inverse of :meth:`as_dict`."""
        segments = d.get("segments", list(SEGMENTS))
        if list(segments) != list(SEGMENTS):
            raise ValueError(f"calibration segments {segments} do not match {list(SEGMENTS)}")
        return cls(
            np.asarray(d["tilt_offset_rad"], dtype=np.float64),
            np.asarray(d["gyro_bias_rad_s"], dtype=np.float64),
        )


@dataclass(frozen=True, eq=False)
class StillnessResult:
    """Outcome of :func:`check_stillness`. ``reason`` (the figures that failed, technical) and
    ``message`` (what to do, in a clinician's words) are empty when still."""

    still: bool
    reason: str
    gyro_rms_rad_s: np.ndarray  # (4,) RMS of the rate about its mean, per segment
    acc_std_ms2: np.ndarray  # (4,) RMS deviation of the (x, z) vector from its mean, per segment
    message: str = ""

    def __post_init__(self) -> None:
        if not self.message and self.reason:
            object.__setattr__(self, "message", self.reason)


def _moving_message(excess: np.ndarray) -> str:
    """"Ask the patient to stand still: the thigh is moving", naming the segments that move
    most (those at least half as far over their limit as the worst one)."""
    worst = float(excess.max())
    names = [SEGMENTS[i] for i in np.argsort(-excess, kind="stable")
             if excess[i] > 1.0 and excess[i] >= 0.5 * worst]  # fmt: skip
    if len(names) == 1:
        who = f"the {names[0]} is moving"
    else:
        who = "the " + ", ".join(names[:-1]) + f" and {names[-1]} are moving"
    return f"Ask the patient to stand still: {who}"


def _check_shapes(acc_ms2: np.ndarray, gyro_rad_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    acc = np.asarray(acc_ms2, dtype=np.float64)
    gyro = np.asarray(gyro_rad_s, dtype=np.float64)
    if acc.ndim != 3 or acc.shape[1:] != (_N_SEGMENTS, 2):
        raise ValueError(f"acc_ms2 must have shape (N, {_N_SEGMENTS}, 2) (x, z), got {acc.shape}")
    if gyro.shape != (acc.shape[0], _N_SEGMENTS):
        raise ValueError(
            f"gyro_rad_s must have shape ({acc.shape[0]}, {_N_SEGMENTS}), got {gyro.shape}"
        )
    return acc, gyro


def _longest_run(mask: np.ndarray) -> int:
    """The longest run of True in a 1-D bool array (0 if none)."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return int((stops - starts).max()) if len(starts) else 0


def check_stillness(
    acc_ms2: np.ndarray,
    gyro_rad_s: np.ndarray,
    *,
    gyro_rms_limit_rad_s: float = DEFAULT_GYRO_RMS_LIMIT_RAD_S,
    acc_std_limit_ms2: float = DEFAULT_ACC_STD_LIMIT_MS2,
    acc_norm_range_ms2: tuple[float, float] = DEFAULT_ACC_NORM_RANGE_MS2,
    min_duration_s: float = DEFAULT_MIN_DURATION_S,
    fs_hz: float = 100.0,
    lost: np.ndarray | None = None,
) -> StillnessResult:
    """Was every segment still (and its sensors plausible) over this window?

    ``acc_ms2`` is (N, 4, 2): per segment (body, thigh, shank, foot) the accelerometer x and z;
    ``gyro_rad_s`` is (N, 4). The reason names every failing segment and the figure that failed.

    ``lost`` ((N,) bool): rows standing for frames the link lost (the live display's rows,
    one per frame of the unit's clock; their values are not looked at). Losses are not
    movement: the window is judged on the samples received, provided they cover
    ``min_duration_s`` and no loss is longer than the pipeline bridges
    (gaitmon.dsp.pipeline.BRIDGE_MAX_S: longer, movement could hide in it).
    """
    acc, gyro = _check_shapes(acc_ms2, gyro_rad_s)
    nan4 = np.full(_N_SEGMENTS, np.nan)
    if lost is not None:
        gone = np.asarray(lost, dtype=bool)
        if gone.shape != (acc.shape[0],):
            raise ValueError(f"lost must have shape ({acc.shape[0]},), got {gone.shape}")
        longest = _longest_run(gone)
        from gaitmon.dsp.lost_frames import bridge_max_samples

        if longest > bridge_max_samples(fs_hz):
            return StillnessResult(
                False,
                f"the link lost {longest / fs_hz:.2f} s of data in the calibration window "
                "(movement cannot be ruled out there); stand still and retry",
                nan4,
                nan4.copy(),
            )
        acc, gyro = acc[~gone], gyro[~gone]
    n = acc.shape[0]
    min_n = max(2, int(np.ceil(min_duration_s * fs_hz)))
    if n < min_n:
        return StillnessResult(
            False,
            f"calibration window too short: {n} samples ({n / fs_hz:.2f} s), need at least "
            f"{min_n} ({min_n / fs_hz:.2f} s); stand still for longer and retry",
            nan4,
            nan4.copy(),
        )
    bad_acc = ~np.all(np.isfinite(acc), axis=(0, 2))
    bad_gyro = ~np.all(np.isfinite(gyro), axis=0)
    if np.any(bad_acc | bad_gyro):
        names = ", ".join(SEGMENTS[i] for i in np.flatnonzero(bad_acc | bad_gyro))
        return StillnessResult(
            False,
            f"calibration data contains NaN or infinite values ({names}); check the sensors",
            nan4,
            nan4.copy(),
        )

    gyro_rms = gyro.std(axis=0)
    acc_std = np.sqrt(acc.var(axis=0).sum(axis=1))
    acc_norm = np.linalg.norm(acc.mean(axis=0), axis=1)

    problems: list[str] = []
    for i, seg in enumerate(SEGMENTS):
        if gyro_rms[i] > gyro_rms_limit_rad_s:
            problems.append(
                f"{seg} gyro {gyro_rms[i]:.3g} rad/s RMS exceeds {gyro_rms_limit_rad_s:.3g}"
            )
        if acc_std[i] > acc_std_limit_ms2:
            problems.append(
                f"{seg} acceleration {acc_std[i]:.3g} m/s^2 RMS exceeds {acc_std_limit_ms2:.3g}"
            )
    if problems:
        reason = "subject is moving: " + "; ".join(problems) + "; stand still and retry"
        excess = np.maximum(gyro_rms / gyro_rms_limit_rad_s, acc_std / acc_std_limit_ms2)
        return StillnessResult(False, reason, gyro_rms, acc_std, _moving_message(excess))

    lo, hi = acc_norm_range_ms2
    implausible = [
        f"{seg} reads {acc_norm[i]:.3g} m/s^2"
        for i, seg in enumerate(SEGMENTS)
        if not (lo <= acc_norm[i] <= hi)
    ]
    if implausible:
        reason = (
            "accelerometer does not see gravity (expected "
            f"{lo:.3g}-{hi:.3g} m/s^2 in the x-z plane): "
            + "; ".join(implausible)
            + "; check the sensor's connection and mounting"
        )
        return StillnessResult(False, reason, gyro_rms, acc_std)
    return StillnessResult(True, "", gyro_rms, acc_std)


def standing_calibration(
    acc_ms2: np.ndarray,
    gyro_rad_s: np.ndarray,
    lost: np.ndarray | None = None,
    **limits: Any,
) -> Calibration:
    """Calibration from a window of upright standing; raises :class:`CalibrationError`.

    Tilt offset per segment = ``accel_tilt`` of the mean (x, z) acceleration (the mean vector,
    not the mean of per-sample angles, so noise cannot bias it through the nonlinearity);
    gyro bias = mean rate. ``limits`` are passed to :func:`check_stillness`; so is ``lost``
    (rows standing for lost frames: the samples received make the calibration).
    """
    result = check_stillness(acc_ms2, gyro_rad_s, lost=lost, **limits)
    if not result.still:
        raise CalibrationError(result.message, result.reason)
    acc, gyro = _check_shapes(acc_ms2, gyro_rad_s)
    if lost is not None:
        keep = ~np.asarray(lost, dtype=bool)
        acc, gyro = acc[keep], gyro[keep]
    mean_acc = acc.mean(axis=0)
    return Calibration(
        tilt_offset_rad=accel_tilt(mean_acc[:, 0], mean_acc[:, 1]),
        gyro_bias_rad_s=gyro.mean(axis=0),
    )


# Where the angles' zero comes from (zero_source): the phrases people read
ZERO_STANDING = "standing calibration"
ZERO_ESTIMATED = "estimated (no standing Zero: sensor axes; gyro bias learnt online)"
ZERO_UNIT = "the unit's own Zero"


def zero_source(
    calibration: Calibration,
    changes: Sequence[tuple[int, Calibration]] = (),
    fs_hz: float = 100.0,
    mode: str = "raw",
) -> str:
    """Where the angles' zero comes from, in one phrase: the one source of what the live window
    (status bar and guide), ``gaitmon info``, the review window and the report say beside the
    method that made the angles.

    ``calibration`` is the one in force at the start (a session's header, or the engine's now),
    ``changes`` the (row, calibration) zeroings logged after it. "standing calibration" when the
    angles start zeroed; "estimated (...)" when no standing Zero ever set the offsets (angles
    relative to the sensor axes, the gyro bias learnt by the filter from the data); "estimated
    until T s, then standing calibration" when a Zero came later. In the unit's own modes
    (``mode`` tilt or joint) the unit zeroes itself."""
    if mode != "raw":
        return ZERO_UNIT
    if calibration.zeroed:
        return ZERO_STANDING
    later = [row for row, cal in changes if cal.zeroed]
    if later:
        return f"estimated until {min(later) / fs_hz:.1f} s, then {ZERO_STANDING}"
    return ZERO_ESTIMATED
