"""The one list of gait-event sources; the pipeline, the engine's status and the lab read it
(gaitmon.dsp.events fills it and names the pipeline's ``PRIMARY`` and ``FALLBACK``)."""

from __future__ import annotations

from gaitmon.dsp.events.base import EventSource
from gaitmon.dsp.registry import Registry

EVENT_SOURCES: Registry[EventSource] = Registry("event source")


def register_event_source(source: EventSource) -> EventSource:
    return EVENT_SOURCES.add(source)


def unregister_event_source(name: str) -> None:
    EVENT_SOURCES.remove(name)


def get_event_source(name: str) -> EventSource:
    return EVENT_SOURCES.get(name)


def event_sources() -> tuple[EventSource, ...]:
    """Every registered source, in registration order."""
    return EVENT_SOURCES.all()
