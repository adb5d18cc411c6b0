"""Signal processing: numpy and scipy only, never Qt.

The evaluation entry points are exported here (imported on first use): ``estimate_tilt`` (one
segment's tilt by a named method, gaitmon.dsp.estimate), ``gyro_gait_events`` (heel strike and
toe off from the foot gyro, gaitmon.dsp.gyro_events) and ``stride_lengths`` /
``stride_measures`` / ``StrideLengthTracker`` (stride length, gait speed and foot clearance from
the foot IMU, gaitmon.dsp.stride_length).

Tilt methods and gait-event sources are plugins, one class per file, each listed once in its
registry: gaitmon.dsp.methods and gaitmon.dsp.events.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gaitmon.lazy import lazy_exports

if TYPE_CHECKING:
    from gaitmon.dsp.estimate import estimate_tilt
    from gaitmon.dsp.gyro_events import gyro_gait_events
    from gaitmon.dsp.stride_length import StrideLengthTracker, stride_lengths, stride_measures

__getattr__ = lazy_exports(__name__, {
    "estimate_tilt": "estimate", "gyro_gait_events": "gyro_events",
    "stride_lengths": "stride_length", "stride_measures": "stride_length",
    "StrideLengthTracker": "stride_length",
})  # fmt: skip

__all__ = [
    "StrideLengthTracker",
    "estimate_tilt",
    "gyro_gait_events",
    "stride_lengths",
    "stride_measures",
]
