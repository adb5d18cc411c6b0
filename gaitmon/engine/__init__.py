"""The headless engine: a Device through the pipeline into display buffers and a recording."""

from gaitmon.engine.core import (
    Engine,
    EngineError,
    GaitStatus,
    Mode,
    RecordingStatus,
    RingBuffer,
    Snapshot,
)

__all__ = [
    "Engine",
    "EngineError",
    "GaitStatus",
    "Mode",
    "RecordingStatus",
    "RingBuffer",
    "Snapshot",
]
