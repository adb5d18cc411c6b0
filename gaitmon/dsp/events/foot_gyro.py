"""``foot gyro``: heel strikes and toe offs from the foot gyro (gaitmon.dsp.gyro_events), the
pipeline's fallback once a force sensor is flagged (gaitmon.dsp.fsr_check). Decided
~0.75 s behind the samples; a gap does not restart it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from gaitmon.dsp.channels import SEGMENTS
from gaitmon.dsp.events.base import (
    EventInput,
    EventRecord,
    Events,
    EventSettings,
    EventSource,
    EventStage,
)
from gaitmon.dsp.gyro_events import GyroEventDetector, GyroEventRule, gyro_gait_events

FOOT = SEGMENTS.index("foot")


class FootGyroStage:
    def __init__(self, rule: GyroEventRule) -> None:
        self.rule = rule
        self._detector = GyroEventDetector(rule)

    def reset(self) -> None:
        self._detector.reset()

    def restart(self, at: int) -> None:
        pass  # the gyro's events carry on across a gap (as they always have)

    @property
    def latency_samples(self) -> int:
        """The closing heel strike is decided at most this long after it."""
        return self.rule.latency + self.rule.search

    def process(self, block: EventInput, /) -> Events:
        return Events(*self._detector.process(block.gyro_rad_s[:, FOOT]))


@dataclass(frozen=True)
class FootGyro(EventSource):
    name: ClassVar[str] = "foot gyro"
    label: ClassVar[str] = "the foot gyro"
    lab_key: ClassVar[str] = "gyro"
    lab_label: ClassVar[str] = "foot-gyro"
    lab_goal: ClassVar[str] = "≤ 20 / 40"

    def stage(self, settings: EventSettings) -> EventStage:
        return FootGyroStage(GyroEventRule(fs_hz=settings.fs_hz))

    def offline(self, record: EventRecord, settings: EventSettings) -> Events:
        return Events(*gyro_gait_events(record.gyro_rad_s[:, FOOT], record.fs_hz))
