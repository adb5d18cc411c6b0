"""The stride-length method's constants and :data:`METHOD`, the stamp a stored ``/strides``
carries (:mod:`gaitmon.finish.strides` recomputes measures stored by another method): apart
from the method's steps (:mod:`gaitmon.dsp.stride_length`, :mod:`.stride_anchors`,
:mod:`.stride_integrate`, which re-export these), so that a reader of stored measures
(``gaitmon info``) checks their stamp without loading the computation.
"""

from __future__ import annotations

import math

from gaitmon.dsp.channels import STANDARD_GRAVITY_MS2

# the foot-flat (anchor) search (gaitmon.dsp.stride_anchors; stride_length's module doc, step 1)
STILL_GYRO_RAD_S = 0.35
STILL_ACC_MS2 = 0.8
STILL_HALF_WIDTH = 2  # samples either side that must be still too
MIN_STILL_SAMPLES = 3
NEAR_STILL = 5.0  # in units of the still thresholds: the stillest sample is taken below it
SEARCH_FRACTION = 0.6  # of a stride, after its heel strike (foot-flat ends by ~40 %)
MAX_STRIDE_S = 3.0

# the strapdown integration (gaitmon.dsp.stride_integrate; steps 2-6)
# a stride's own consistency (step 6): flagged out of plane past either
OUT_OF_PLANE_PITCH_RAD = math.radians(6.0)
OUT_OF_PLANE_VEL_M_S = 0.5
ANCHOR_LEVER_M = 0.08  # the board's height above a rolling stance foot's ground pivot
MOUNT_COS_MIN = math.cos(math.radians(40.0))  # the board's yaw on the foot: at most 40 deg
MOUNT_MIN_VEL_M_S = 0.05  # ... looked for where the vertical velocity misses 0 by more
MOUNT_ITERATIONS = 10  # bisection steps for it (to 0.0002 in its cosine)

# Raise with any change to the method that changes its numbers (the constants imported above are
# part of METHOD already): stored measures computed by another version are then recomputed when read
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
