"""What the engine hands the recorder thread: one frozen dataclass per kind of message.

The engine thread (and the caller's thread, for ``Stop``) queues these; the recorder thread
(``engine.recorder``) is the only reader. ``AppendBlock`` is the only bounded kind (a stalled
disk refuses it, counted); the others are control messages, few and small, never refused.
``RecorderMessage`` is the queue's item type: a new kind of message is a new class here, added
to the union, and a branch in ``Recorder._run`` (mypy's exhaustiveness check names a missing one).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.pipeline import PipelineBlock, PipelineConfig
    from gaitmon.io.device import LinkStats, SampleBlock


@dataclass(frozen=True, eq=False)
class AppendBlock:
    """A block to write as rows (``RowMap.outgoing`` made it): its raw samples, the pipeline's
    output in raw mode (events already file rows, so ``event_offset`` is 0), the reason of the
    gaps inside it, and of a gap before its first row ("" = ``gap_reason``)."""

    samples: SampleBlock
    processed: PipelineBlock | None = None
    event_offset: int = 0
    gap_reason: str = ""
    first_gap_reason: str = ""


@dataclass(frozen=True)
class AddMarker:
    """A marker on the next row (``row`` None) or on file row ``row``."""

    label: str
    row: int | None = None


@dataclass(frozen=True, eq=False)
class LogConfig:
    """Filter settings that took effect at the next row."""

    config: PipelineConfig


@dataclass(frozen=True, eq=False)
class LogCalibration:
    """A calibration that took effect at the next row."""

    calibration: Calibration


@dataclass(frozen=True, eq=False)
class UpdateLink:
    """The link's statistics so far (the file keeps the latest)."""

    stats: LinkStats


@dataclass(frozen=True)
class Stop:
    """Finish the file (``reason`` goes into it) and end the recorder thread."""

    reason: str = "user"


RecorderMessage = AppendBlock | AddMarker | LogConfig | LogCalibration | UpdateLink | Stop
