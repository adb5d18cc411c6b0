"""The one list of gait-event sources; the pipeline, the engine's status and the lab read it
(gaitmon.dsp.events fills it and names the pipeline's ``PRIMARY`` and ``FALLBACK``)."""

from __future__ import annotations

from gaitmon.dsp.events.base import EventSource

EVENT_SOURCES: dict[str, EventSource] = {}


def register_event_source(source: EventSource) -> EventSource:
    if source.name in EVENT_SOURCES:
        raise ValueError(f"an event source named {source.name!r} is registered already")
    EVENT_SOURCES[source.name] = source
    return source


def unregister_event_source(name: str) -> None:
    EVENT_SOURCES.pop(name, None)


def get_event_source(name: str) -> EventSource:
    try:
        return EVENT_SOURCES[name]
    except KeyError:
        raise ValueError(
            f"unknown event source {name!r}; use one of {sorted(EVENT_SOURCES)}"
        ) from None


def event_sources() -> tuple[EventSource, ...]:
    """Every registered source, in registration order."""
    return tuple(EVENT_SOURCES.values())
