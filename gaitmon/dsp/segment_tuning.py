"""The gait-aware Kalman filter's per-segment tuning: :class:`SegmentTuning`, the table of it
(``SEGMENT_TUNING``, :func:`tuning_for`) and the measurement variance it sets
(:func:`measurement_variance`). :mod:`gaitmon.dsp.motion_kalman`'s module doc describes the filter
("the module doc" below).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gaitmon.dsp.channel_table import SEGMENT_TABLE, SEGMENTS


@dataclass(frozen=True)
class SegmentTuning:
    """How one segment's motion sets the accelerometer's weight (see the module doc)."""

    static_acc_ms2: float = 1.5
    static_rate_rad_s: float = 1.0
    window_s: float = 0.05
    r_static: float = 1e-3  # rad^2, measurement variance when quasi-static
    r_moving: float | None = None  # rad^2 at |a| = g while moving; None = not used then
    acc_scale_ms2: float = 2.0
    # while moving, R also grows as (1 + (rate / scale)^2): a fast-swinging segment's
    # accelerometer carries more of its own acceleration (None = no growth)
    moving_rate_scale_rad_s: float | None = None
    q_angle: float = 1e-7  # rad^2 per step, angle random walk (gyro noise)
    q_bias: float = 1e-8  # (rad/s)^2 per step, bias random walk
    # offline smoother only: the angle's process noise grows as (1 + (|omega| / scale)^2)
    rate_scale_rad_s: float = 1.0
    # offline smoother only, its gravity passes (gaitmon.dsp.smoother): the length of the
    # boxcar (applied three times) over which the specific force, turned into the world frame by
    # the previous pass's tilt, must average to vertical (None = no gravity pass), the variance
    # (rad^2) given to that gravity-referenced tilt, and how many passes
    gravity_window_s: float | None = 1.5
    r_gravity: float = 3e-4
    gravity_passes: int = 1
    # causal filter: the cut-off of the 2nd-order Butterworth low-pass that averages the
    # gyro-turned specific force (None = the accelerometer tilt as above) and the variance (rad^2)
    # of the tilt it gives (see the module doc, "Gravity measurement")
    live_gravity_hz: float | None = None
    r_live_gravity: float = 1e-2
    # causal filter, out of the sagittal plane (module doc, "Out of plane"): when the planar
    # |a| low-passed (one pole at ``plane_cutoff_hz``) falls below ``plane_fraction`` g, the
    # accelerometer tilt is used with variance ``r_out_of_plane`` and the bias is left alone
    # (None = no such test)
    plane_fraction: float | None = None
    plane_cutoff_hz: float = 0.5
    r_out_of_plane: float = 1e-4
    # causal filter, start-up only (module doc, "Start-up"): the factor on R for the exact
    # gain, and c (rad s) in the gravity tilt's R + (c / t)^2, t the time since its (re)start
    start_r_factor: float = 1.0
    start_gravity_rad_s: float = 0.1
    # whether the quasi-static samples are used in the start-up, and the SD (rad) of a
    # segment's tilt change over a stride for the stride-periodic bias (0 = none)
    start_static: bool = True
    stride_sigma_rad: float = 0.0

    def __post_init__(self) -> None:
        for name in ("static_acc_ms2", "static_rate_rad_s", "window_s", "r_static",
                     "acc_scale_ms2", "q_angle", "q_bias", "rate_scale_rad_s",
                     "start_r_factor"):  # fmt: skip
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value}")
        if self.gravity_window_s is not None and not (
            np.isfinite(self.gravity_window_s) and self.gravity_window_s > 0
        ):
            raise ValueError(
                f"gravity_window_s must be a positive number or None, got {self.gravity_window_s}"
            )
        if self.live_gravity_hz is not None and not (
            np.isfinite(self.live_gravity_hz) and self.live_gravity_hz > 0
        ):
            raise ValueError(
                f"live_gravity_hz must be a positive number or None, got {self.live_gravity_hz}"
            )
        if not (np.isfinite(self.start_gravity_rad_s) and self.start_gravity_rad_s >= 0):
            raise ValueError(
                f"start_gravity_rad_s must be a number >= 0, got {self.start_gravity_rad_s}"
            )
        if not (np.isfinite(self.r_live_gravity) and self.r_live_gravity > 0):
            raise ValueError(f"r_live_gravity must be a positive number, got {self.r_live_gravity}")
        if not (np.isfinite(self.r_gravity) and self.r_gravity > 0):
            raise ValueError(f"r_gravity must be a positive number, got {self.r_gravity}")
        if not (isinstance(self.gravity_passes, int) and self.gravity_passes >= 1):
            raise ValueError(f"gravity_passes must be an integer >= 1, got {self.gravity_passes}")
        if self.r_moving is not None and not (np.isfinite(self.r_moving) and self.r_moving > 0):
            raise ValueError(f"r_moving must be a positive number or None, got {self.r_moving}")
        if self.plane_fraction is not None and not (0 < self.plane_fraction < 1):
            raise ValueError(f"plane_fraction must be in (0, 1) or None, got {self.plane_fraction}")
        for name in ("plane_cutoff_hz", "r_out_of_plane"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value}")

    def window_samples(self, fs_hz: float) -> int:
        return max(1, round(self.window_s * fs_hz))


# Body, thigh and shank (chosen on the simulator, docs/filters.md): never still while walking,
# they take the gravity measurement live.
_WEIGHTED = SegmentTuning(
    static_acc_ms2=0.5, static_rate_rad_s=0.3, r_moving=0.01, rate_scale_rad_s=100.0,
    live_gravity_hz=0.25, stride_sigma_rad=0.03,
)  # fmt: skip
# The foot (issue 24, chosen on the real walks and BROAD in ../shared/data with the simulator
# kept; docs/filters.md, benchmarks/tilt_real.py): the accelerometer trusted at foot-flat
# (r_static 1e-4), the gravity measurement while moving (r_moving is then unused: the
# accelerometer weighted by the motion left fast walks without a foot-flat on the gyro alone)
# and the out-of-plane test (BROAD's 3-D motion).
_GATED = SegmentTuning(
    r_static=1e-4, r_moving=1.0, live_gravity_hz=0.25, r_live_gravity=3e-3, plane_fraction=0.95,
    start_r_factor=10.0,
)  # fmt: skip
SEGMENT_TUNING: dict[str, SegmentTuning] = {
    s.name: _GATED if s.still_in_stance else _WEIGHTED for s in SEGMENT_TABLE
}
# the swinging shank's own acceleration is the largest: its gravity tilt needs whole strides
SEGMENT_TUNING["shank"] = replace(_WEIGHTED, start_gravity_rad_s=0.3)
SEGMENT_TUNING["body"] = replace(_WEIGHTED, start_static=False)


def tuning_for(segment: str) -> SegmentTuning:
    try:
        return SEGMENT_TUNING[segment]
    except KeyError:
        raise ValueError(f"unknown segment {segment!r}; use one of {list(SEGMENTS)}") from None


def measurement_variance(
    dev_ms2: np.ndarray, rate_rad_s: np.ndarray, tuning: SegmentTuning
) -> np.ndarray:
    """R (rad^2) from the window maxima of | |a| - g | and |omega| (inf = not trusted)."""
    static = (dev_ms2 < tuning.static_acc_ms2) & (rate_rad_s < tuning.static_rate_rad_s)
    if tuning.r_moving is None:
        moving = np.full(np.shape(dev_ms2), np.inf)
    else:
        moving = tuning.r_moving * (1.0 + (dev_ms2 / tuning.acc_scale_ms2) ** 2)
        if tuning.moving_rate_scale_rad_s is not None:
            moving = moving * (1.0 + (rate_rad_s / tuning.moving_rate_scale_rad_s) ** 2)
    return np.where(static, tuning.r_static, moving)
