"""Gait-event sources as plugins: one class in one file each, one registry listing them.

:mod:`gaitmon.dsp.events.base` says what a source is (:class:`EventSource`, its streaming
:class:`EventStage`); :mod:`gaitmon.dsp.events.registry` lists them. The pipeline builds its
primary and fallback sources from the registry, the engine's status names them by it, and
``gaitmon lab accuracy`` judges every registered source.

A new source: a file beside these with an :class:`EventSource` subclass, and its builder below
(and, for the pipeline to take its events from it, its name as ``PRIMARY`` or ``FALLBACK``).
The built-in sources are registered by name and label, each module imported when its source is
first asked for: a reader saying where a file's events came from (``gaitmon info``) loads none.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gaitmon.dsp.events.registry import (
    EVENT_SOURCES,
    event_source_label,
    event_sources,
    get_event_source,
    register_event_source,
    register_event_source_lazy,
    unregister_event_source,
)
from gaitmon.lazy import keep

if TYPE_CHECKING:
    from gaitmon.dsp.events.base import (
        EventInput,
        EventRecord,
        Events,
        EventSettings,
        EventSource,
        EventStage,
    )


def _foot_gyro() -> EventSource:
    from gaitmon.dsp.events.foot_gyro import FootGyro

    return FootGyro()


def _force_sensors() -> EventSource:
    from gaitmon.dsp.events.fsr import ForceSensors

    return ForceSensors()


# the built-in sources, in the lab table's order: name, label (the class's, checked when it is
# built), builder
register_event_source_lazy("foot gyro", "the foot gyro", _foot_gyro)
register_event_source_lazy("fsr", "the force sensors", _force_sensors)

# where the pipeline takes its events from, and the source it switches to from the row a force
# sensor is flagged faulty (with PipelineConfig.fsr_check)
PRIMARY = "fsr"
FALLBACK = "foot gyro"

_BASE_NAMES = ("EventInput", "EventRecord", "Events", "EventSettings", "EventSource",
               "EventStage")  # fmt: skip


def __getattr__(name: str) -> object:
    """The base's names (:mod:`gaitmon.dsp.events.base`), imported on first use (PEP 562)."""
    if name in _BASE_NAMES:
        from gaitmon.dsp.events import base

        return keep(globals(), name, base)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    "event_source_label",
    "event_sources",
    "get_event_source",
    "register_event_source",
    "register_event_source_lazy",
    "unregister_event_source",
]
