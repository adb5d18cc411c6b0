"""Signal processing: numpy and scipy only, never Qt.

The evaluation entry points are exported here (imported on first use): ``estimate_tilt`` (one
segment's tilt by a named method, gaitmon.dsp.estimate) and ``gyro_gait_events`` (heel strike and
toe off from the foot gyro, gaitmon.dsp.gyro_events).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gaitmon.lazy import lazy_exports

if TYPE_CHECKING:
    from gaitmon.dsp.estimate import estimate_tilt
    from gaitmon.dsp.gyro_events import gyro_gait_events

__getattr__ = lazy_exports(
    __name__, {"estimate_tilt": "estimate", "gyro_gait_events": "gyro_events"}
)

__all__ = ["estimate_tilt", "gyro_gait_events"]
