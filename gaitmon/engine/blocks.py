"""The engine thread's work on each part of a block, for ``Engine`` (``engine/core.py``).

``Engine._run`` reads the unit's blocks and hands each to :class:`BlockHandler`: ``next_part``
cuts a block at the next scheduled sample (``engine/schedule.py``), ``handle`` takes the
pending changes, starts a recording at its first row (or from the rows held for it), runs
the pipeline (or takes the unit's own angles), hands the rows to the recorder
(``engine/handover.py``) and fills the display ring, the live gait panel and the sensor
checks; ``failed`` keeps the indices consistent after a part that raised. The handler owns no
state: it works on the engine's (:class:`EngineState`, the attributes it uses; ownership and
locking as in ``Engine``'s doc).
"""

from __future__ import annotations

import dataclasses
import threading
from collections import deque
from typing import Protocol

import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.fsr_check import FsrFault
from gaitmon.dsp.lost_frames import restart_rows
from gaitmon.dsp.pipeline import Pipeline, PipelineBlock, PipelineConfig
from gaitmon.engine.buffers import RingBuffer, cols_from_device, cols_from_pipeline, with_gap_rows
from gaitmon.engine.handover import hand_over
from gaitmon.engine.live_gait import FootStrideLengths, GaitEvents, LiveGait
from gaitmon.engine.markers import TimedMarkers
from gaitmon.engine.messages import LogCalibration, LogConfig
from gaitmon.engine.recorder import Recorder
from gaitmon.engine.schedule import HeldRows, PendingChanges, ZeroControl, split_at, timing_note
from gaitmon.engine.sensor_checks import SensorChecks
from gaitmon.engine.snapshot import EVENTS_GYRO, Mode
from gaitmon.engine.stream import StreamHealth, StreamPosition
from gaitmon.engine.taps import Taps
from gaitmon.engine.zeroing import HeldPart
from gaitmon.io.device import Device, SampleBlock
from gaitmon.io.protocol import FrameKind


class EngineState(Protocol):
    """What of ``Engine`` the engine thread's handler reads and writes."""

    device: Device
    mode: Mode
    config: PipelineConfig
    calibration: Calibration
    fs_hz: float
    timing_notes: deque[str]
    _pipeline: Pipeline
    _phase_lag: int
    _stream: StreamPosition
    _ring: RingBuffer
    _events: GaitEvents
    _lock: threading.Lock
    _gait: LiveGait
    _spatial: FootStrideLengths
    _checks: SensorChecks
    _health: StreamHealth
    _pending: PendingChanges
    _recorder: Recorder | None
    _timed: TimedMarkers
    _taps: Taps
    _held: HeldRows
    _zeroing: ZeroControl

    def _note_error(self, text: str) -> None: ...


class BlockHandler:
    """The engine thread's steps on one part of a block (module doc)."""

    def __init__(self, engine: EngineState) -> None:
        self.e = engine

    def next_part(self, block: SampleBlock) -> tuple[SampleBlock, SampleBlock | None]:
        """The block up to the next scheduled sample inside it (a calibration's, a
        recording's first row) and the rest (None: no such sample inside it). The pipeline is
        chunk-invariant, so cutting there changes no output: it only lets a change take
        effect at exactly its sample, whichever blocks the link delivered."""
        e = self.e
        start = e._stream.samples
        with e._lock:
            p = e._pending
            marks = [p.calibration_at if p.calibration is not None else None]
            marks.append(e._zeroing.next_end())
            rec = e._recorder
            if rec is not None and rec.row_map.record_offset is None:
                marks.append(rec.start_idx)
        return split_at(block, start, marks)

    def _note_timing(self, what: str, late_samples: int) -> None:
        e = self.e
        e.timing_notes.append(timing_note(what, late_samples, e.fs_hz))

    def handle(self, block: SampleBlock) -> None:
        e = self.e
        st = e._stream
        st.handed_over = False
        st.block_start = st.samples
        with e._lock:
            # take pending changes and make them current in one step, so a recording started
            # meanwhile puts exactly what this block is processed with into its header
            cfg, cal, cal_at = e._pending.take(st.samples)  # a scheduled cal waits for it
            if cfg is not None:
                e.config = cfg
            if cal is not None:
                e.calibration = cal
            rec = e._recorder
        start_idx = st.samples
        if cal is not None and cal_at is not None and cal_at < start_idx:
            self._note_timing("the zero took effect", start_idx - cal_at)
        from_idx = None if rec is None or rec.row_map.record_offset is not None else rec.start_idx
        if from_idx is not None and start_idx < from_idx:
            rec = None  # the recording starts at a later sample (``next_part`` cuts there)
        elif (
            rec is not None and from_idx is not None and start_idx > from_idx
            and not self._start_held(rec)  # processed before the caller got to it: held?
        ):  # fmt: skip
            self._note_timing("the recording started", start_idx - from_idx)
        first = rec is not None and rec.row_map.record_offset is None
        if first:
            assert rec is not None
            rec.row_map.record_offset = start_idx  # row 0 = this block's first sample
        if rec is not None:
            e._held.begin(None)
        if cfg is not None:
            e._pipeline = e._pipeline.successor(cfg)
            with e._lock:
                e._checks.pipeline_rebuilt(e._pipeline.event_source == EVENTS_GYRO)
            e._phase_lag = cfg.phase_lag_samples
            st.pipeline_offset = start_idx
            if rec is not None and not (first and cfg is rec.header_config):
                rec.put(LogConfig(cfg))
        if cal is not None:
            e._pipeline.set_calibration(cal)
            if rec is not None and not (first and cal is rec.header_calibration):
                rec.put(LogCalibration(cal))
        elif first and rec is not None and e.calibration is not rec.header_calibration:
            rec.put(LogCalibration(e.calibration))  # row 0 is processed with this one
        if block.kind != e.mode.frame_kind:
            # not this session's frames (a unit that restarted into its default kind before
            # the setup was sent again): neither shown nor recorded; the file gets a gap
            e._note_error(
                f"the unit sent {FrameKind(block.kind).name} frames in {e.mode.value} mode; "
                f"{len(block)} frames ignored"
            )
            if rec is not None:
                rec.row_map.not_recorded(block, f"frames lost: {FrameKind(block.kind).name} frames")
            st.not_processed(block)
            return
        reconnects = e.device.stats.transport.reconnects
        gap_reason = ""
        if reconnects != st.reconnects_seen:
            st.reconnects_seen = reconnects
            gap_reason = "link lost: reconnected"
        lost = st.lost(block)
        t_s = st.true_times(lost, e.fs_hz)
        restarts = np.empty(0, np.int64)
        faults: tuple[FsrFault, ...] = ()
        offset = st.pipeline_offset
        if block.kind == FrameKind.RAW and block.adc is not None:
            p = e._pipeline.process(block.adc, lost)
            faults = p.fsr_faults
            cols = cols_from_pipeline(p, t_s, block.host_time_s)
            hs_idx = p.heel_strike_idx + offset
            to_idx = p.toe_off_idx + offset
            restarts = p.restart_idx + offset
            lengths = e._spatial.push(block.adc, p, hs_idx, start_idx, e._pipeline.table,
                                      lost)  # fmt: skip
            p_rec = p
            if (first or (rec is None and not e._held.parts)) and len(
                e._pipeline.fsr_faults
            ) > len(p.fsr_faults):
                # sensors flagged before the recording started are faulty in it from row 0
                p_rec = dataclasses.replace(p, fsr_faults=e._pipeline.fsr_faults)
            if rec is not None:
                self._hand_over(rec, block, p_rec, gap_reason, t_s)
            elif e._held.from_idx is not None:
                e._held.hold(HeldPart(start_idx, offset, block, p_rec, gap_reason, t_s,
                                      e.calibration))  # fmt: skip
        else:
            cols = cols_from_device(block, t_s)
            hs_idx, to_idx = e._events.from_contacts(block, start_idx)
            restarts = start_idx + restart_rows(lost, e.fs_hz)
            lengths = []
            if rec is not None:
                self._hand_over(rec, block, None, gap_reason, t_s)
        st.handed_over = True
        strides = e._events.strides(hs_idx, to_idx)  # the file's strides (GaitEvents' doc)
        cols["idx"] = np.arange(start_idx, start_idx + len(block), dtype=np.float64)
        e._ring.append(with_gap_rows(cols, lost, e.fs_hz, e._ring.capacity))
        st.samples += len(block)
        e._timed.add_block(
            start_idx, np.rint(t_s * e.fs_hz).astype(np.int64), block.host_time_s
        )
        with e._lock:
            e._health.block_done(float(block.host_time_s[-1]), st.samples)
            e._gait.add(hs_idx, to_idx, strides, restarts, e._ring, st.samples)
            e._gait.add_lengths(lengths)
            e._checks.add(faults, offset, st.samples, e._ring)
        if e._taps:
            path = str(rec.writer.path) if first and rec is not None else ""
            e._taps.block(block, start_idx, t_s, lost, cols, (hs_idx, to_idx),
                          e._ring.times_of, gap_reason, (cfg, cal), (rec, path))  # fmt: skip

    def _hand_over(
        self, rec: Recorder, block: SampleBlock, p: PipelineBlock | None, gap_reason: str,
        t_s: np.ndarray, at: tuple[int, int] | None = None,
    ) -> None:  # fmt: skip
        """``handover.hand_over``; ``at``: (its pipeline's offset, its first engine index) for
        a held part; None: the block being processed."""
        e = self.e
        offset, start = at or (e._stream.pipeline_offset, e._stream.samples)
        hand_over(rec, block, p, gap_reason, t_s, e.fs_hz, offset, start)

    def _start_held(self, rec: Recorder) -> bool:
        """The engine thread: a recording that starts at a sample already processed and
        held: its rows from there, in order (True), or False (none held from there)."""
        e = self.e
        held = e._held.take(rec.start_idx)
        if not held:
            return False
        rec.row_map.record_offset = held[0].start
        if held[0].calibration is not rec.header_calibration:
            rec.put(LogCalibration(held[0].calibration))
        for h in held:
            self._hand_over(rec, h.block, h.p, h.gap_reason, h.t_s, (h.offset, h.start))
        return True

    def failed(self, block: SampleBlock, exc: Exception) -> None:
        """``handle`` raised (a bug, or a block the pipeline cannot take): say so, keep the
        indices of the display, the pipeline and the recording consistent, carry on."""
        e = self.e
        e._note_error(f"processing error: {type(exc).__name__}: {exc}")
        with e._lock:
            rec = e._recorder
        if rec is not None and rec.row_map.record_offset is None:
            rec = None  # the recording had not started with this block
        st = e._stream
        e._events.reset_strides()
        if st.handed_over:
            # the block is in the file: only the display bookkeeping after it failed
            if st.samples == st.block_start:
                st.samples += len(block)
            return
        # the block is not in the file and may have left the pipeline half-updated: a fresh
        # pipeline starts with the next block, and the file logs it as a settings change at
        # that row (so reprocessing restarts there too) after a gap for this block
        st.samples = st.block_start
        if rec is not None:
            rec.row_map.not_recorded(block, "frames lost: processing error")
        if e.mode is Mode.RAW:
            e._pipeline = e._pipeline.successor(e.config)
            st.pipeline_offset = st.samples
            with e._lock:
                e._checks.pipeline_rebuilt(e._pipeline.event_source == EVENTS_GYRO)
            if rec is not None:
                rec.put(LogConfig(e.config))
