"""``fsr``: heel strikes and toe offs from the force sensors (the pipeline's first source).

The contact detector (gaitmon.dsp.gait.GaitEventDetector) confirms threshold crossings of the
low-passed FSR counts; this source moves them back by the low-pass's delay
(``PipelineConfig.event_delay_samples``), never before the last restart.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from gaitmon.dsp.events.base import EventInput, Events, EventSettings, EventSource, EventStage


class FsrEventStage:
    def __init__(self, delay_samples: int) -> None:
        self.delay = int(delay_samples)
        self.reset()

    def reset(self) -> None:
        self._floor = 0  # events are never dated before the last restart

    def restart(self, at: int) -> None:
        self._floor = int(at)

    @property
    def latency_samples(self) -> int:
        return 0

    def process(self, block: EventInput, /) -> Events:
        # back-dating by a constant keeps the order in which events are confirmed
        c = block.contacts
        return Events(np.maximum(c.heel_strike_idx - self.delay, self._floor),
                      np.maximum(c.toe_off_idx - self.delay, self._floor))  # fmt: skip


@dataclass(frozen=True)
class ForceSensors(EventSource):
    name: ClassVar[str] = "fsr"
    label: ClassVar[str] = "the force sensors"
    lab_key: ClassVar[str] = "fsr"
    lab_label: ClassVar[str] = "FSR (reference)"
    lab_goal: ClassVar[str] = "(reference)"

    def stage(self, settings: EventSettings) -> EventStage:
        return FsrEventStage(settings.event_delay_samples)
