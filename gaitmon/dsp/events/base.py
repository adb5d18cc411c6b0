"""What a gait-event source is: where heel strikes and toe offs come from.

An :class:`EventSource` is one frozen dataclass in one file, like a tilt method
(gaitmon.dsp.methods): ``name`` is the key the pipeline reports (``PipelineBlock.event_source``,
the live status), ``label`` says it to people, and :meth:`EventSource.stage` gives the streaming
:class:`EventStage` the pipeline runs: an :class:`EventInput` per block (the force sensors'
debounced contacts and the gyro) in, :class:`Events` (absolute indices) out.
:meth:`EventSource.offline` finds the events of a whole record at once (the lab's judges).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from gaitmon.dsp.base import Stage
from gaitmon.dsp.gait import GaitBlock


@dataclass(frozen=True)
class EventInput:
    """One block as the pipeline hands it to an event stage: the FSR contact detector's output
    (debounced loaded flags, phases, and the threshold crossings it confirmed, absolute
    indices, not yet moved for the low-pass delay) and the (N, 4) bias-corrected gyro (rad/s,
    body, thigh, shank, foot)."""

    contacts: GaitBlock
    gyro_rad_s: np.ndarray


@dataclass(frozen=True)
class Events:
    """Heel strikes and toe offs (absolute sample indices, int64) decided in one block."""

    heel_strike_idx: np.ndarray
    toe_off_idx: np.ndarray


@runtime_checkable
class EventStage(Stage[EventInput, Events], Protocol):
    """A source's streaming detector. ``restart(at)``: a long gap ended at absolute index
    ``at`` (no event is dated before it); ``latency_samples``: how long after an event it may
    be decided."""

    def restart(self, at: int) -> None: ...

    @property
    def latency_samples(self) -> int: ...


class EventSettings(Protocol):
    """The pipeline settings an event source may read (gaitmon.dsp.pipeline.PipelineConfig)."""

    @property
    def fs_hz(self) -> float: ...

    @property
    def event_delay_samples(self) -> int: ...


@dataclass(frozen=True)
class EventRecord:
    """A whole record for :meth:`EventSource.offline`: the low-passed FSR counts (N, 2), the
    contact detector's output over them, the (N, 4) bias-corrected gyro and the rate."""

    contacts: GaitBlock
    gyro_rad_s: np.ndarray
    fs_hz: float


@dataclass(frozen=True)
class EventSource:
    """The base of every gait-event source (module doc)."""

    name: ClassVar[str]
    label: ClassVar[str]
    # the lab's table: its key, its row's name and goal (gaitmon lab accuracy)
    lab_key: ClassVar[str]
    lab_label: ClassVar[str]
    lab_goal: ClassVar[str] = ""

    def stage(self, settings: EventSettings) -> EventStage:
        raise NotImplementedError

    def offline(self, record: EventRecord, settings: EventSettings) -> Events:
        """The events of a whole record (by default the stage over it in one block)."""
        return self.stage(settings).process(EventInput(record.contacts, record.gyro_rad_s))
