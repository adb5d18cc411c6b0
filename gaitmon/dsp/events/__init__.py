"""Gait-event sources as plugins: one class in one file each, one registry listing them.

:mod:`gaitmon.dsp.events.base` says what a source is (:class:`EventSource`, its streaming
:class:`EventStage`); :mod:`gaitmon.dsp.events.registry` lists them. The pipeline builds its
primary and fallback sources from the registry, the engine's status names them by it, and
``gaitmon lab accuracy`` judges every registered source.

A new source: a file beside these with an :class:`EventSource` subclass, and one line below
(and, for the pipeline to take its events from it, its name as ``PRIMARY`` or ``FALLBACK``).
"""

from __future__ import annotations

from gaitmon.dsp.events.base import (
    EventInput,
    EventRecord,
    Events,
    EventSettings,
    EventSource,
    EventStage,
)
from gaitmon.dsp.events.foot_gyro import FootGyro
from gaitmon.dsp.events.fsr import ForceSensors
from gaitmon.dsp.events.registry import (
    EVENT_SOURCES,
    event_sources,
    get_event_source,
    register_event_source,
    unregister_event_source,
)

# the built-in sources, in the lab table's order
for _source in (
    FootGyro(),
    ForceSensors(),
):
    register_event_source(_source)

# where the pipeline takes its events from, and the source it switches to from the row a force
# sensor is flagged faulty (with PipelineConfig.fsr_check)
PRIMARY = ForceSensors.name
FALLBACK = FootGyro.name

__all__ = [
    "EVENT_SOURCES",
    "FALLBACK",
    "PRIMARY",
    "EventInput",
    "EventRecord",
    "EventSettings",
    "EventSource",
    "EventStage",
    "Events",
    "event_sources",
    "get_event_source",
    "register_event_source",
    "unregister_event_source",
]
