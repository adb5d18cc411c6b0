"""Live gait for the display: event times, the last strides and their normalised cycles.

Three owners, three objects:

- ``GaitEvents`` turns the unit's own contact flags (TILT/JOINT modes) into events, and the
  events of every mode into strides at engine sample indices, with the function a recording's
  readers use (``gaitmon.dsp.gait.strides_from_events``, streamed): the live strides are the
  file's. Only the engine thread uses it, outside any lock.
- ``LiveGait`` keeps what the gait panel and the event markers show. The engine thread writes
  it and a viewer's snapshot reads it, both with the engine's lock held: it has no lock of its
  own, and every method must be called under that lock.
- ``FootStrideLengths`` measures stride lengths from the foot IMU (the panel's speed) in raw
  mode. Only the engine thread uses it, outside any lock.
"""

from __future__ import annotations

import dataclasses
from collections import deque
from collections.abc import Iterable

import numpy as np

from gaitmon.analysis import stride_exclusion
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, SEGMENTS, ChannelTable
from gaitmon.dsp.gait import ContactEdges, Stride, StrideTracker, normalise_cycles
from gaitmon.dsp.pipeline import PipelineBlock, settling_ranges
from gaitmon.dsp.stride_length import StrideLengthTracker
from gaitmon.engine.buffers import RingBuffer
from gaitmon.engine.snapshot import GaitStatus
from gaitmon.engine.taps import BlockOut
from gaitmon.io.device import SampleBlock

_FOOT = SEGMENTS.index("foot")
# the line "current stride" is dropped after this many mean strides without a heel strike
CURRENT_MAX_STRIDES = 2.0
_FOOT_IMU_COLS = [int(ACC_X_IDX[_FOOT]), int(ACC_Z_IDX[_FOOT])]  # raw columns of the foot board


class GaitEvents:
    """Heel strikes and toe offs from the unit's contact flags, and strides from the events of
    any mode (engine thread only).

    The strides are made from the engine's event indices, which are the recording's rows (the
    samples received), by :class:`~gaitmon.dsp.gait.StrideTracker`: the streamed
    ``strides_from_events`` that ``gaitmon.analysis`` applies to a file's events. So a stride
    across a link cut (its opening heel strike and toe off before the cut, its closing heel
    strike after it) is a stride live as in the file, where the one stride rule excludes it
    ("crosses a gap"). The pipeline reports events only; its strides are made here."""

    def __init__(self, fs_hz: float) -> None:
        self._edges = ContactEdges()
        self._strides = StrideTracker(fs_hz)

    def from_contacts(self, block: SampleBlock, start_idx: int) -> tuple[np.ndarray, np.ndarray]:
        """The unit's events (engine indices; the block's first sample is ``start_idx``)."""
        if block.heel_loaded is not None and block.toe_loaded is not None:
            return self._edges.process(block.heel_loaded, block.toe_loaded, start_idx)
        empty = np.empty(0, np.int64)
        return empty, empty

    def strides(self, hs_idx: np.ndarray, to_idx: np.ndarray) -> list[Stride]:
        """The strides a block's events (engine indices, in the order confirmed) close."""
        return self._strides.process(hs_idx, to_idx)

    def reset_strides(self) -> None:
        """Forget the open stride (a block that was not processed: its events may come again,
        and a stride may not span what is not in the file)."""
        self._strides.reset()


class FootStrideLengths:
    """Stride lengths from the foot IMU, at engine sample indices (engine thread only)."""

    def __init__(self, fs_hz: float) -> None:
        self._tracker = StrideLengthTracker(fs_hz)
        self._base = 0  # the engine index of the tracker's sample 0

    def push(
        self, adc: np.ndarray, p: PipelineBlock, hs_idx: np.ndarray, start_idx: int,
        table: ChannelTable, lost_before: np.ndarray | None = None,
    ) -> list[tuple[int, float]]:  # fmt: skip
        """Feed the foot board's samples (unfiltered acceleration, the pipeline's
        bias-corrected gyro: what gaitmon.dsp.stride_length.foot_imu_from_counts makes of a
        file's raw counts) and the frames lost before each (the bridged losses are filled in,
        as the file's strides fill them) to the stride length tracker; the strides it
        finished, (opening heel strike, m), engine indices."""
        tr = self._tracker
        if self._base + tr.n_seen != start_idx:  # samples not processed: start afresh
            tr.reset()
            self._base = start_idx
        cols = _FOOT_IMU_COLS
        phys = (adc[:, cols].astype(np.float64) - table.zero_counts[cols]) * (
            table.units_per_count[cols]
        )
        m = tr.push(phys[:, 0], phys[:, 1], p.gyro_rad_s[:, _FOOT], hs_idx - self._base,
                    lost_before)  # fmt: skip
        base = self._base
        return [(int(h) + base, float(v)) for h, v in zip(m.heel_strike_idx, m.stride_length_m,
                                                           strict=True)]  # fmt: skip


class LiveGait:
    """The gait panel's state; see the module doc for its lock (the engine's).

    Strides are timed on the true timeline (``t_s`` of the ring, which counts lost frames),
    and whether one counts in the panel's "last strides" is decided by
    :func:`gaitmon.analysis.stride_exclusion`, the rule ``info``, review, the report and the
    exports apply to a recording: live, the first stride since the start, strides crossing a
    long gap and strides overlapping the filters' settling after one are left out.
    """

    def __init__(self, fs_hz: float, cycle_strides: int) -> None:
        self.fs_hz = fs_hz
        self._events_hs: deque[float] = deque(maxlen=512)  # times (t_s) of recent events
        self._events_to: deque[float] = deque(maxlen=512)
        self._strides: deque[Stride] = deque(maxlen=cycle_strides)  # the last included ones
        self._cycles: deque[np.ndarray] = deque(maxlen=cycle_strides)
        self._cycles_deg = np.empty((0, 101, 3))  # np.stack(_cycles), rebuilt once per stride
        self._n_strides = 0
        self._last: Stride | None = None  # the last stride, counted or not
        self._last_hs_idx: int | None = None
        self._gap_rows: deque[int] = deque(maxlen=64)  # engine indices where data resumed
        self.excluded: deque[tuple[Stride, str]] = deque(maxlen=64)  # recent, with the reason
        # stride length (m) by opening heel strike (engine index), from the foot IMU; known a
        # little after the stride ends (the foot-flat after its closing heel strike)
        self._lengths: dict[int, float] = {}
        # every stride's opening heel strike (engine index): a buffer grown by doubling, and
        # the view of its filled part that snapshots hand out (an 8-hour session has ~26 000
        # strides: no copy of all of them per stride)
        self._starts_buf = np.empty(64, np.int64)
        self._starts_arr = self._starts_buf[:0]
        self._last_end_t_s = float("nan")

    def add(
        self,
        hs_idx: np.ndarray,
        to_idx: np.ndarray,
        strides: Iterable[Stride],
        restarts: np.ndarray,
        ring: RingBuffer,
        samples_total: int,
    ) -> None:
        """A block's events and finished strides (engine indices) and the engine indices where
        data resumed after a long gap, once the block is in ``ring``."""
        self._gap_rows.extend(int(r) for r in restarts)
        for idx, dest in ((hs_idx, self._events_hs), (to_idx, self._events_to)):
            if len(idx):
                t = ring.times_of(idx)
                dest.extend(float(x) for x in t[np.isfinite(t)])
        if len(hs_idx):
            self._last_hs_idx = int(hs_idx[-1])
        for s in strides:
            self._add_stride(s, ring)

    def _add_stride(self, s: Stride, ring: RingBuffer) -> None:
        """Time a finished stride on the true timeline, apply the one stride rule, and
        normalise an included stride's joint angles from the ring buffer."""
        t0, t_off, t1 = ring.times_of(np.array([s.start_idx, s.toe_off_idx, s.end_idx]))
        if np.isfinite([t0, t_off, t1]).all() and t1 > t0:
            s = dataclasses.replace(
                s,
                stride_time_s=float(t1 - t0),
                stance_time_s=float(t_off - t0),
                swing_time_s=float(t1 - t_off),
                stance_pct=100.0 * float(t_off - t0) / float(t1 - t0),
                swing_pct=100.0 * float(t1 - t_off) / float(t1 - t0),
            )
        gaps = np.asarray(self._gap_rows, dtype=np.int64)
        reason = stride_exclusion(s, self._n_strides, None, gaps, settling_ranges(gaps, self.fs_hz))
        self._n_strides += 1
        self._last = s
        self._last_end_t_s = float(t1) if np.isfinite(t1) else float("nan")
        n = len(self._starts_arr)
        if n == len(self._starts_buf):
            self._starts_buf = np.concatenate([self._starts_buf, np.empty(n, np.int64)])
        self._starts_buf[n] = int(s.start_idx)
        self._starts_arr = self._starts_buf[: n + 1]
        if reason:
            self.excluded.append((s, reason))
            return
        self._strides.append(s)
        rows = ring.since_index(s.start_idx)
        # the file's rows are the received samples: normalise over those, as analysis does
        real = np.isfinite(rows["idx"]) & (rows["idx"] <= s.end_idx)
        seg = rows["joint_kalman_deg"][real]
        k = len(seg) - 1
        if k > 0 and not np.isnan(seg).all():
            self._cycles.append(normalise_cycles(seg, np.array([0, k]))[0])
            self._cycles_deg = np.stack(self._cycles)

    def add_lengths(self, lengths: Iterable[tuple[int, float]]) -> None:
        """Stride lengths found by the foot-IMU tracker: (opening heel strike, metres)."""
        for start, length in lengths:
            self._lengths[start] = length
        if len(self._lengths) > 256:  # keep the recent ones (the panel uses the last strides)
            for k in sorted(self._lengths)[: len(self._lengths) - 128]:
                del self._lengths[k]

    def _spatial(self) -> tuple[float, float]:
        """(mean gait speed m/s, mean stride length m) over the last included strides."""
        pairs = [(self._lengths[s.start_idx], s.stride_time_s) for s in self._strides
                 if np.isfinite(self._lengths.get(s.start_idx, np.nan))]  # fmt: skip
        if not pairs:
            return float("nan"), float("nan")
        length = np.array([p[0] for p in pairs])
        time_s = np.array([p[1] for p in pairs])
        return float(np.mean(length / time_s)), float(np.mean(length))

    def events_since(self, t0_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Times of the heel strikes and toe offs at or after ``t0_s``."""
        hs = np.array([x for x in self._events_hs if x >= t0_s])
        to = np.array([x for x in self._events_to if x >= t0_s])
        return hs, to

    def _current(self, series: dict[str, np.ndarray], mean_stride: float
                 ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """The current stride so far: (% of the mean stride, joint angles) from the last heel
        strike on; none when that heel strike has left the display window, when a long gap
        came after it (data resumed: the stride is broken, and nothing from before the gap may
        be drawn as the stride in progress), or when it has run for more than
        ``CURRENT_MAX_STRIDES`` mean strides without a heel strike (the subject stands)."""
        none = np.empty(0), np.empty((0, 3))
        hs = self._last_hs_idx
        if hs is None or not len(series["t_s"]):
            return none
        if any(r > hs for r in self._gap_rows):
            return none
        at = np.flatnonzero(series["idx"] == hs)
        if not len(at):
            return none
        t = series["t_s"][int(at[0]) :]
        pct = (t - t[0]) / mean_stride * 100.0
        if not len(pct) or pct[-1] > 100.0 * CURRENT_MAX_STRIDES:
            return none
        return pct, series["joint_kalman_deg"][int(at[0]) :]

    def status(self, series: dict[str, np.ndarray], samples_total: int) -> GaitStatus:
        """The panel for a snapshot whose display series are ``series``."""
        last = self._last
        if last is None:
            return GaitStatus()
        if not self._strides:
            return GaitStatus(
                n_strides=self._n_strides,
                last_stride_time_s=last.stride_time_s,
                last_stance_pct=last.stance_pct,
                stride_start_idx=self._starts_arr,
                last_stride_end_t_s=self._last_end_t_s,
            )
        mean_stride = float(np.mean([s.stride_time_s for s in self._strides]))
        cur_pct, cur = self._current(series, mean_stride)
        speed, length = self._spatial()
        return GaitStatus(
            n_strides=self._n_strides,
            last_stride_time_s=last.stride_time_s,
            last_stance_pct=last.stance_pct,
            cadence_derived_steps_per_min=120.0 / mean_stride,
            speed_mean_m_s=speed,
            stride_length_mean_m=length,
            cycles_deg=self._cycles_deg,
            current_pct=cur_pct,
            current_deg=cur,
            stride_start_idx=self._starts_arr,
            last_stride_end_t_s=self._last_end_t_s,
        )


class RecordingStart:
    """An engine listener (``Engine.add_listener``) that knows where the running recording
    began: ``start_idx``, the engine index of its row 0, or None when none is running (or its
    first block is not processed yet). With :attr:`GaitStatus.stride_start_idx` a viewer counts
    the strides of the recording, those the file will have: from its first heel strike on.
    Written on the engine thread, read by the viewer: one reference, assigned whole."""

    def __init__(self) -> None:
        self.start_idx: int | None = None

    def __call__(self, out: BlockOut) -> None:
        if out.recording_stopped or out.last:
            self.start_idx = None
        if out.recording_started and len(out.idx):
            self.start_idx = int(out.idx[0])

    def strides(self, gait: GaitStatus) -> int | None:
        """The strides of the running recording so far (None: not recording)."""
        start = self.start_idx
        if start is None:
            return None
        starts = gait.stride_start_idx
        return int(len(starts) - np.searchsorted(starts, start, side="left"))
