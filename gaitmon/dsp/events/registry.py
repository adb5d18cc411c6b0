"""The one list of gait-event sources; the pipeline, the engine's status and the lab read it
(gaitmon.dsp.events fills it and names the pipeline's ``PRIMARY`` and ``FALLBACK``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from gaitmon.dsp.registry import Registry

if TYPE_CHECKING:  # a source's module imports it when it is built
    from gaitmon.dsp.events.base import EventSource

EVENT_SOURCES: Registry[EventSource] = Registry("event source")
# the label of each source registered by name and not built yet (its class's ``label``, checked
# when it is built): a reader says where a file's events came from without building a source
_LABELS: dict[str, str] = {}


def register_event_source(source: EventSource) -> EventSource:
    return EVENT_SOURCES.add(source)


def register_event_source_lazy(name: str, label: str, build: Callable[[], EventSource]) -> None:
    """Add the source called ``name``, built by ``build()`` when first asked for (its module
    imported then); ``label``: its class's, said before it is built."""

    def checked() -> EventSource:
        source = build()
        if source.label != label:
            raise ValueError(f"event source {name!r} is registered as {label!r}, its class "
                             f"says {source.label!r}")  # fmt: skip
        return source

    EVENT_SOURCES.add_lazy(name, checked)
    _LABELS[name] = label


def unregister_event_source(name: str) -> None:
    EVENT_SOURCES.remove(name)
    _LABELS.pop(name, None)


def event_source_label(name: str) -> str:
    """How people are told of the source called ``name`` ("the force sensors"), without
    building it (ValueError naming the choices for an unknown name)."""
    source = EVENT_SOURCES.built(name)
    if source is None and name in _LABELS:
        return _LABELS[name]
    return get_event_source(name).label


def get_event_source(name: str) -> EventSource:
    return EVENT_SOURCES.get(name)


def event_sources() -> tuple[EventSource, ...]:
    """Every registered source, in registration order."""
    return EVENT_SOURCES.all()
