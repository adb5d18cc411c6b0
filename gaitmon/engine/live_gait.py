"""Live gait for the display: event times, the last strides and their normalised cycles.

Two owners, two objects:

- ``UnitGaitEvents`` turns the unit's own contact flags (TILT/JOINT modes) into events and
  strides at engine sample indices. Only the engine thread uses it, outside any lock.
- ``LiveGait`` keeps what the gait panel and the event markers show. The engine thread writes
  it and a viewer's snapshot reads it, both with the engine's lock held: it has no lock of its
  own, and every method must be called under that lock.
"""

from __future__ import annotations

import dataclasses
from collections import deque
from collections.abc import Iterable

import numpy as np

from gaitmon.dsp.gait import ContactEdges, Stride, StrideTracker, normalise_cycles
from gaitmon.engine.buffers import RingBuffer
from gaitmon.engine.snapshot import GaitStatus
from gaitmon.io.device import SampleBlock


class UnitGaitEvents:
    """Heel strikes, toe offs and strides from the unit's contact flags (engine thread only)."""

    def __init__(self, fs_hz: float) -> None:
        self._edges = ContactEdges()
        self._strides = StrideTracker(fs_hz)

    def process(
        self, block: SampleBlock, start_idx: int
    ) -> tuple[np.ndarray, np.ndarray, list[Stride]]:
        """Events (engine indices; the block's first sample is ``start_idx``) and strides."""
        if block.heel_loaded is not None and block.toe_loaded is not None:
            hs_idx, to_idx = self._edges.process(block.heel_loaded, block.toe_loaded, start_idx)
        else:
            hs_idx = to_idx = np.empty(0, np.int64)
        return hs_idx, to_idx, self._strides.process(hs_idx, to_idx)


class LiveGait:
    """The gait panel's state; see the module doc for its lock (the engine's)."""

    def __init__(self, fs_hz: float, cycle_strides: int) -> None:
        self.fs_hz = fs_hz
        self._events_hs: deque[float] = deque(maxlen=512)  # times (t_s) of recent events
        self._events_to: deque[float] = deque(maxlen=512)
        self._strides: deque[Stride] = deque(maxlen=cycle_strides)
        self._cycles: deque[np.ndarray] = deque(maxlen=cycle_strides)
        self._cycles_deg = np.empty((0, 101, 3))  # np.stack(_cycles), rebuilt once per stride
        self._n_strides = 0
        self._last_hs_idx: int | None = None

    def add(
        self,
        hs_idx: np.ndarray,
        to_idx: np.ndarray,
        strides: Iterable[Stride],
        t0_s: float,
        start_idx: int,
        ring: RingBuffer,
        samples_total: int,
    ) -> None:
        """A block's events (engine indices; its first sample, index ``start_idx``, is at
        ``t0_s``) and finished strides, once the block is in ``ring``."""
        for idx in hs_idx:
            self._events_hs.append(float(t0_s + (idx - start_idx) / self.fs_hz))
        for idx in to_idx:
            self._events_to.append(float(t0_s + (idx - start_idx) / self.fs_hz))
        if len(hs_idx):
            self._last_hs_idx = int(hs_idx[-1])
        for s in strides:
            self._add_stride(s, ring, samples_total)

    def _add_stride(self, s: Stride, ring: RingBuffer, samples_total: int) -> None:
        """Normalise a finished stride's joint angles from the ring buffer."""
        self._n_strides += 1
        self._strides.append(s)
        length = samples_total - s.start_idx
        if length > ring.capacity or length <= 0:
            return
        joints = ring.latest(length)["joint_kalman_deg"]
        k = s.end_idx - s.start_idx
        seg = joints[: k + 1]
        if len(seg) == k + 1 and not np.isnan(seg).all():
            self._cycles.append(normalise_cycles(seg, np.array([0, k]))[0])
            self._cycles_deg = np.stack(self._cycles)

    def events_since(self, t0_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Times of the heel strikes and toe offs at or after ``t0_s``."""
        hs = np.array([x for x in self._events_hs if x >= t0_s])
        to = np.array([x for x in self._events_to if x >= t0_s])
        return hs, to

    def status(self, series: dict[str, np.ndarray], samples_total: int) -> GaitStatus:
        """The panel for a snapshot whose display series are ``series``."""
        if not self._strides:
            return GaitStatus()
        last = self._strides[-1]
        mean_stride = float(np.mean([s.stride_time_s for s in self._strides]))
        cur_pct = np.empty(0)
        cur = np.empty((0, 3))
        if self._last_hs_idx is not None:
            k = samples_total - self._last_hs_idx
            if 0 < k <= len(series["t_s"]):
                cur = series["joint_kalman_deg"][-k:]
                cur_pct = np.arange(k) / (mean_stride * self.fs_hz) * 100.0
        return GaitStatus(
            n_strides=self._n_strides,
            last_stride_time_s=last.stride_time_s,
            last_stance_pct=last.stance_pct,
            cadence_derived_steps_per_min=120.0 / mean_stride,
            cycles_deg=self._cycles_deg,
            current_pct=cur_pct,
            current_deg=cur,
        )


def shift_stride(s: Stride, offset: int) -> Stride:
    """``s`` with its indices moved by ``offset`` (pipeline indices -> engine indices)."""
    if offset == 0:
        return s
    return dataclasses.replace(
        s,
        start_idx=s.start_idx + offset,
        end_idx=s.end_idx + offset,
        toe_off_idx=s.toe_off_idx + offset,
    )
