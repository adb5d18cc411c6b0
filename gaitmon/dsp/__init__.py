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

from gaitmon.lazy import keep

if TYPE_CHECKING:
    from gaitmon.dsp.estimate import estimate_tilt
    from gaitmon.dsp.gyro_events import gyro_gait_events
    from gaitmon.dsp.stride_length import StrideLengthTracker, stride_lengths, stride_measures


def __getattr__(name: str) -> object:
    """A name of the package, imported from its module on first use (PEP 562): a plain
    import here, so the layer test sees the arrow; later lookups find it in the package."""
    if name == "estimate_tilt":
        from gaitmon.dsp import estimate

        return keep(globals(), name, estimate)
    if name == "gyro_gait_events":
        from gaitmon.dsp import gyro_events

        return keep(globals(), name, gyro_events)
    if name in ("stride_lengths", "stride_measures", "StrideLengthTracker"):
        from gaitmon.dsp import stride_length

        return keep(globals(), name, stride_length)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")



__all__ = [
    "StrideLengthTracker",
    "estimate_tilt",
    "gyro_gait_events",
    "stride_lengths",
    "stride_measures",
]
