"""The PC pipeline's force-sensor check as a viewer sees it: the faults found, when each was
decided, and where the gait events come from now.

The pipeline flags a sensor (gaitmon.dsp.fsr_check) a little before the sample from which it
takes its events from the foot gyro (the fault's ``decided_idx``, ~1 s after the closing heel
strike of the third failing stride). A fault is shown from that sample on, dated by it, so the
notice, the event source and the events themselves change at the same instant.

``SensorChecks`` has no lock of its own: the engine thread writes it and a viewer's snapshot
reads it, both with the engine's lock held (as ``LiveGait``).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from gaitmon.dsp.fsr_check import FsrFault
from gaitmon.engine.buffers import RingBuffer
from gaitmon.engine.snapshot import EVENTS_FSR, EVENTS_GYRO, FsrFaultNotice


class SensorChecks:
    """Faults found so far and the event source; every method under the engine's lock."""

    def __init__(self) -> None:
        self._pending: list[tuple[int, FsrFault]] = []  # (engine index decided, fault)
        self._gyro_from_idx: int | None = None  # the current pipeline's switch (engine index)
        self.faults: list[FsrFaultNotice] = []
        self.event_source = EVENTS_FSR

    def pipeline_rebuilt(self, gyro_from_start: bool) -> None:
        """A new pipeline (new settings, or after a block it could not take): it keeps the
        sensors flagged before when it reads the FSRs the same way (``gyro_from_start``: its
        events come from the foot gyro at once, ``Pipeline.successor``); new FSR settings are
        checked afresh, events from the force sensors until it flags one again. The faults
        already found stay listed either way."""
        self._gyro_from_idx = None
        self.event_source = EVENTS_GYRO if gyro_from_start else EVENTS_FSR

    def add(
        self, faults: Iterable[FsrFault], offset: int, samples_total: int, ring: RingBuffer
    ) -> None:
        """A block's new faults (pipeline indices; the pipeline's sample 0 is engine index
        ``offset``), once the block is in ``ring`` and ``samples_total`` samples are in."""
        for f in faults:
            at = f.decided_idx + offset
            self._pending.append((at, f))
            if self._gyro_from_idx is None:
                self._gyro_from_idx = at  # the pipeline switches at its first fault
        due = [(at, f) for at, f in self._pending if at < samples_total]
        if due:
            self._pending = [(at, f) for at, f in self._pending if at >= samples_total]
            t = ring.times_of(np.array([at for at, _ in due]))
            last = ring.times_of(np.array([samples_total - 1]))[0]
            seen = {(n.sensor, n.reason) for n in self.faults}
            for (_, f), t_s in zip(due, t, strict=True):
                if (f.sensor, f.reason) in seen:
                    continue  # found again by a pipeline built since
                seen.add((f.sensor, f.reason))
                when = float(t_s) if np.isfinite(t_s) else float(last)
                self.faults.append(FsrFaultNotice(f.sensor, f.reason, f.message(), when))
        if self._gyro_from_idx is not None and self._gyro_from_idx < samples_total:
            self.event_source = EVENTS_GYRO
