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

This module is the method's public home and its one description; the code is in its parts,
re-exported here: the foot-flat search (step 1, ``stride_anchors``), one stride's integration
(steps 2-6, ``stride_integrate``), the first steps (step 7, ``stride_first_steps``), the result
and its flags (``stride_flags``), a whole record (``stride_zupt``) and block-wise / live
(``stride_streaming``), all in gaitmon.dsp.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.dsp.channels import (
    ACC_X_IDX,
    ACC_Z_IDX,
    GYRO_IDX,
    SEGMENTS,
)
from gaitmon.dsp.stride_anchors import (
    MAX_STRIDE_S,
    MIN_STILL_SAMPLES,
    NEAR_STILL,
    SEARCH_FRACTION,
    STILL_ACC_MS2,
    STILL_GYRO_RAD_S,
    STILL_HALF_WIDTH,
    search_spans,
    stride_data_end,
)
from gaitmon.dsp.stride_first_steps import (
    STANDING_S,
    STANDING_SEARCH_S,
)
from gaitmon.dsp.stride_flags import (
    FLAG_FIRST_STEP,
    FLAG_NEAR_STILL,
    FLAG_NO_FOOT_FLAT,
    FLAG_OUT_OF_PLANE,
    FLAG_PAUSE,
    FLAG_REASONS,
    FLAG_UNTRUSTED,
    StrideMeasures,
)
from gaitmon.dsp.stride_integrate import (
    ANCHOR_LEVER_M,
    MOUNT_COS_MIN,
    MOUNT_ITERATIONS,
    MOUNT_MIN_VEL_M_S,
    OUT_OF_PLANE_PITCH_RAD,
    OUT_OF_PLANE_VEL_M_S,
)
from gaitmon.dsp.stride_method import METHOD as METHOD
from gaitmon.dsp.stride_method import METHOD_VERSION as METHOD_VERSION
from gaitmon.dsp.stride_streaming import (
    STRIDES_PER_BLOCK,
    StrideLengthTracker,
    record_stride_measures,
)
from gaitmon.dsp.stride_zupt import (
    stride_measures,
)

if TYPE_CHECKING:
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import ChannelTable

__all__ = [
    "ANCHOR_LEVER_M",
    "FLAG_FIRST_STEP",
    "FLAG_NEAR_STILL",
    "FLAG_NO_FOOT_FLAT",
    "FLAG_OUT_OF_PLANE",
    "FLAG_PAUSE",
    "FLAG_REASONS",
    "FLAG_UNTRUSTED",
    "MAX_STRIDE_S",
    "METHOD",
    "METHOD_VERSION",
    "MIN_STILL_SAMPLES",
    "MOUNT_COS_MIN",
    "MOUNT_ITERATIONS",
    "MOUNT_MIN_VEL_M_S",
    "NEAR_STILL",
    "OUT_OF_PLANE_PITCH_RAD",
    "OUT_OF_PLANE_VEL_M_S",
    "SEARCH_FRACTION",
    "STANDING_S",
    "STANDING_SEARCH_S",
    "STILL_ACC_MS2",
    "STILL_GYRO_RAD_S",
    "STILL_HALF_WIDTH",
    "STRIDES_PER_BLOCK",
    "StrideLengthTracker",
    "StrideMeasures",
    "foot_imu_from_counts",
    "record_stride_measures",
    "search_spans",
    "stride_data_end",
    "stride_lengths",
    "stride_measures",
]




def foot_imu_from_counts(
    adc: np.ndarray, first_row: int, table: ChannelTable, calibration: Calibration,
    calibration_changes: Sequence[tuple[int, Calibration]],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The foot board's acc x, acc z (m/s^2, unfiltered) and gyro (rad/s, the calibration in
    force at each row removed: ``calibration`` from row 0, each change from its row on), float64,
    of the raw counts ``adc`` (M, 14) of rows ``first_row`` .. ``first_row + M``, as the live
    pipeline sees them."""
    foot = SEGMENTS.index("foot")
    counts = np.asarray(adc)
    # each column on its own (contiguous), (count - zero) * scale in place
    ax, az, gy = (np.subtract(counts[:, c], table.zero_counts[c], dtype=np.float64)
                  for c in (int(ACC_X_IDX[foot]), int(ACC_Z_IDX[foot]), int(GYRO_IDX[foot])))
    for x, c in ((ax, ACC_X_IDX[foot]), (az, ACC_Z_IDX[foot]), (gy, GYRO_IDX[foot])):
        x *= table.units_per_count[int(c)]
    # the bias in force from each row on: the calibration's, then each change's in row order
    # (of two at one row, the later), subtracted a run of rows at a time
    changes = sorted(calibration_changes, key=lambda x: x[0])
    starts = [0] + [max(0, row - first_row) for row, _ in changes] + [len(gy)]
    biases = [calibration, *(cal for _, cal in changes)]
    for a, b, cal in zip(starts[:-1], starts[1:], biases, strict=True):
        gy[a:b] -= float(cal.gyro_bias_rad_s[foot])
    return ax, az, gy


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

