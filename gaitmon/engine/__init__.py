"""The headless engine: a Device through the pipeline into display buffers and a recording.

``Engine`` (``core``) wires the parts: display ring buffers (``buffers``), the frozen values a
viewer pulls (``snapshot``), the engine thread's sample count and the unit's true clock
(``stream``), the single recorder thread (``recorder``) and the messages it takes
(``messages``), the engine thread's map of its samples to file rows (``rows``), markers
stamped with a host time placed on the sample taken at that instant (``markers``), the live
gait panel (``live_gait``) and what its listeners get after each block (``taps``:
``Engine.add_listener``).
"""

from gaitmon.engine.buffers import RingBuffer
from gaitmon.engine.core import Engine, EngineError
from gaitmon.engine.snapshot import GaitStatus, Mode, RecordingStatus, Snapshot

__all__ = [
    "Engine",
    "EngineError",
    "GaitStatus",
    "Mode",
    "RecordingStatus",
    "RingBuffer",
    "Snapshot",
]
