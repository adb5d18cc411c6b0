"""The headless engine: a Device through the pipeline into display buffers and a recording.

Data flows one way::

    Device (its own rx thread) -> engine thread: Pipeline (or the unit's own angles)
        -> ring buffers (the GUI pulls snapshots, ~30 Hz)
        -> bounded queue -> recorder thread (the only code that touches the session file)

Acquisition never waits for the recorder or a viewer: a full recorder queue is counted
(``RecordingStatus.dropped_blocks``), never silent, and a write error (full disk) stops the
recording with a message while acquisition and display carry on. No Qt here: the command line,
the tests and the desktop window all drive this same object.
"""

from __future__ import annotations

import contextlib
import dataclasses
import enum
import itertools
import queue
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gaitmon.dsp.angles import joint_angles
from gaitmon.dsp.calibration import Calibration, CalibrationError, standing_calibration
from gaitmon.dsp.gait import (
    ContactEdges,
    Stride,
    StrideTracker,
    normalise_cycles,
    phase_from_contacts,
)
from gaitmon.dsp.pipeline import Pipeline, PipelineBlock, PipelineConfig
from gaitmon.io.device import Device, DeviceError, LinkStats, SampleBlock
from gaitmon.io.protocol import FrameKind, Identity
from gaitmon.io.transport import LinkError


class Mode(enum.StrEnum):
    RAW = "raw"  # raw ADC frames, everything computed on the PC
    TILT = "tilt"  # the unit's own accelerometer and Kalman tilts
    JOINT = "joint"  # the unit's own joint angles, contacts and gait phase

    @property
    def frame_kind(self) -> FrameKind:
        return {Mode.RAW: FrameKind.RAW, Mode.TILT: FrameKind.TILT, Mode.JOINT: FrameKind.JOINT}[
            self
        ]


class EngineError(Exception):
    """A one-line, actionable problem (no device data, a refused zeroing, ...)."""


# ------------------------------------------------------------------------------------------
# Display buffers
# ------------------------------------------------------------------------------------------

# name -> per-sample shape; every series is float64 (bools as 0/1) so a snapshot is uniform
SERIES: dict[str, tuple[int, ...]] = {
    "t_s": (),
    "host_time_s": (),
    "tilt_acc_deg": (4,),
    "tilt_gyro_deg": (4,),
    "tilt_kalman_deg": (4,),
    "joint_acc_deg": (3,),
    "joint_gyro_deg": (3,),
    "joint_kalman_deg": (3,),
    "acc_ms2": (4, 2),
    "gyro_rad_s": (4,),
    "fsr_counts": (2,),
    "heel_loaded": (),
    "toe_loaded": (),
    "phase": (),
}


class RingBuffer:
    """Fixed-capacity, multi-series ring of the most recent samples (one writer, one reader)."""

    def __init__(self, capacity: int) -> None:
        self.capacity = int(capacity)
        self._data = {k: np.full((self.capacity, *s), np.nan) for k, s in SERIES.items()}
        self._write = 0  # total samples ever written
        self._lock = threading.Lock()

    def append(self, cols: dict[str, np.ndarray]) -> None:
        n = len(cols["t_s"])
        if n == 0:
            return
        if n > self.capacity:
            cols = {k: v[-self.capacity :] for k, v in cols.items()}
            skipped = n - self.capacity
            n = self.capacity
        else:
            skipped = 0
        with self._lock:
            start = (self._write + skipped) % self.capacity
            first = min(n, self.capacity - start)
            for k, arr in self._data.items():
                v = cols.get(k)
                if v is None:
                    arr[start : start + first] = np.nan
                    arr[: n - first] = np.nan
                    continue
                arr[start : start + first] = v[:first]
                arr[: n - first] = v[first:]
            self._write += n + skipped

    def latest(self, n: int) -> dict[str, np.ndarray]:
        """Copies of the last ``n`` samples (fewer if fewer were written), oldest first."""
        with self._lock:
            n = int(min(n, self.capacity, self._write))
            end = self._write % self.capacity
            idx = (np.arange(end - n, end)) % self.capacity
            return {k: arr[idx] for k, arr in self._data.items()}


# ------------------------------------------------------------------------------------------
# Snapshots and status
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RecordingStatus:
    active: bool = False
    path: str = ""
    started_monotonic_s: float = 0.0
    elapsed_s: float = 0.0
    rows: int = 0
    file_bytes: int = 0
    dropped_blocks: int = 0  # recorder queue overflows (never expected; never silent)
    error: str = ""  # why the last recording stopped on its own ("" if it did not)


@dataclass(frozen=True)
class GaitStatus:
    """The live gait panel: latest strides and the cycle overlay."""

    n_strides: int = 0
    last_stride_time_s: float = float("nan")
    last_stance_pct: float = float("nan")
    cadence_derived_steps_per_min: float = float("nan")
    cycles_deg: np.ndarray = field(default_factory=lambda: np.empty((0, 101, 3)))  # last N strides
    current_pct: np.ndarray = field(default_factory=lambda: np.empty(0))  # current stride so far
    current_deg: np.ndarray = field(default_factory=lambda: np.empty((0, 3)))


@dataclass(frozen=True)
class Snapshot:
    """What a viewer needs, copied out under a short lock. Angles in degrees."""

    series: dict[str, np.ndarray]
    heel_strike_t_s: np.ndarray
    toe_off_t_s: np.ndarray
    markers: tuple[tuple[float, str], ...]
    samples_total: int
    frame_rate_hz: float
    last_data_age_s: float
    link: LinkStats | None
    link_state: str
    link_reason: str
    seconds_to_reconnect: float | None
    recording: RecordingStatus
    gait: GaitStatus
    mode: Mode
    calibrated: bool
    # the last block the engine could not read or process ("" if none) and how many; such a
    # block is not shown, and a recording gets a gap in its place
    engine_error: str = ""
    engine_errors: int = 0


# ------------------------------------------------------------------------------------------
# Recorder
# ------------------------------------------------------------------------------------------


class _Recorder:
    """The single thread that owns the session writer.

    Only sample blocks are bounded (``queue_max`` of them waiting): a stalled disk drops blocks,
    never a settings change, a calibration, a marker or the stop. The fields under "engine
    thread" are the engine's bookkeeping for this recording; only the engine thread uses them.
    """

    def __init__(
        self,
        writer: Any,
        queue_max: int,
        header_config: PipelineConfig | None = None,
        header_calibration: Calibration | None = None,
    ) -> None:
        self.writer = writer
        self.queue: queue.Queue[tuple[str, Any]] = queue.Queue()
        self.queue_max = queue_max
        self._blocks_waiting = 0
        self._count_lock = threading.Lock()
        self.dropped = 0
        self.error = ""
        self.rows = 0
        self.file_bytes = 0
        self.finished = False  # the thread ended on the stop item (not by a BaseException)
        # engine thread: engine sample index of row 0 (set at the first block handed over),
        # engine index ranges [start, end) processed but dropped from the file (a full queue),
        # frames the unit sent that will not be rows (carried into the next row's lost_before)
        # and why, event rows waiting for the next block, and what the header already holds
        # (a change pending at the start is not logged again)
        self.record_offset: int | None = None
        self.drop_starts: list[int] = []
        self.drop_ends: list[int] = []
        self.drop_cum: list[int] = []  # samples dropped up to and including each range
        self.carry_lost = 0
        self.carry_reason = ""
        self.carry_events: dict[str, list[int]] = {"heel_strike_idx": [], "toe_off_idx": []}
        self.header_config = header_config
        self.header_calibration = header_calibration
        self.thread = threading.Thread(target=self._run, name="gaitmon-recorder", daemon=True)
        self.started_monotonic_s = time.monotonic()
        self.thread.start()

    def put(self, item: tuple[str, Any]) -> None:
        """Queue a control item (never refused: they are few and small)."""
        self.queue.put_nowait(item)

    def put_block(self, item: tuple[str, Any]) -> bool:
        """Queue a block; False (and counted) if ``queue_max`` blocks are already waiting."""
        with self._count_lock:
            if self._blocks_waiting >= self.queue_max:
                self.dropped += 1
                return False
            self._blocks_waiting += 1
        self.queue.put_nowait(item)
        return True

    @property
    def alive(self) -> bool:
        return self.thread.is_alive()

    def _append(
        self,
        w: Any,
        samples: SampleBlock,
        processed: PipelineBlock | None,
        offset: int,
        gap_reason: str,
        first_gap_reason: str = "",
    ) -> None:
        """Write a block, logging a gap at each row where frames were lost before it
        (``first_gap_reason``, if given, is the reason of a gap before the block's first row)."""
        lost = samples.lost_before
        if lost is not None and w.rows == 0 and lost[0]:
            lost = lost.copy()  # frames lost before the first recorded row are not in the session
            lost[0] = 0
        cuts = [] if lost is None else [int(i) for i in np.flatnonzero(lost)]
        if not cuts:
            w.append(samples, processed, event_offset=offset)
            return
        assert lost is not None
        fs = w.header.sample_rate_hz
        bounds = [0, *cuts, len(samples)] if cuts[0] != 0 else [*cuts, len(samples)]
        for k, (a, b) in enumerate(itertools.pairwise(bounds)):
            if a == b:
                continue
            if lost[a]:
                why = (first_gap_reason if a == 0 else "") or gap_reason or "frames lost"
                w.add_gap(int(lost[a]), float(lost[a]) / fs, why)
            part_p = None if processed is None else _slice_pipeline(processed, a, b, k == 0)
            w.append(_slice_samples(samples, a, b), part_p, event_offset=offset)

    def _run(self) -> None:
        from gaitmon.io.session import SessionError

        w = self.writer
        failed = False
        while True:
            try:
                kind, payload = self.queue.get(timeout=0.05)
            except queue.Empty:
                kind, payload = "tick", None
            if kind == "append":
                with self._count_lock:
                    self._blocks_waiting -= 1
            if failed:
                if kind == "stop":
                    self.finished = True
                    return
                continue
            try:
                if kind == "append":
                    self._append(w, *payload)
                elif kind == "marker":
                    w.add_marker(payload)
                elif kind == "config":
                    w.log_config(payload)
                elif kind == "calibration":
                    w.log_calibration(payload)
                elif kind == "link":
                    w.update_link(payload)
                elif kind == "stop":
                    w.close(stop_reason=payload)
                    self.rows, self.file_bytes = w.rows, w.bytes_written
                    self.finished = True
                    return
                w.maybe_flush()
                self.rows, self.file_bytes = w.rows, w.bytes_written
            except Exception as exc:  # any failure must stop the recording visibly
                failed = True
                if isinstance(exc, (SessionError, OSError)):
                    self.error = str(exc)
                    with contextlib.suppress(Exception):
                        w.close(stop_reason=f"error: {exc}")
                else:
                    # a bug, not the disk: the writer's state is unknown, so do not finish the
                    # file; the journal (the truth) stays and the next open recovers every row
                    self.error = w.abort(exc)
                self.rows = w.rows
                if kind == "stop":  # the stop itself failed: it is over all the same
                    self.finished = True
                    return


# ------------------------------------------------------------------------------------------
# Engine
# ------------------------------------------------------------------------------------------


class Engine:
    """Runs one Device in one mode; see the module doc."""

    def __init__(
        self,
        device: Device,
        mode: Mode | str = Mode.RAW,
        config: PipelineConfig | None = None,
        calibration: Calibration | None = None,
        *,
        display_seconds: float = 60.0,
        recorder_queue_blocks: int = 60_000,
        cycle_strides: int = 10,
        transport_label: str = "",
    ) -> None:
        self.device = device
        self.mode = Mode(mode)
        self.config = config or PipelineConfig()
        self.calibration = calibration or Calibration.identity()
        self.fs_hz = self.config.fs_hz
        self.transport_label = transport_label
        self._pipeline = Pipeline(self.config, self.calibration)
        self._pipeline_offset = 0  # engine sample index of the current pipeline's sample 0
        self._handed_over = False  # _handle: the current block is with the recorder
        self._block_start = 0  # _handle: engine index of the current block's first sample
        self._ring = RingBuffer(int(display_seconds * self.fs_hz))
        self._recorder_queue_blocks = recorder_queue_blocks
        self._lock = threading.Lock()  # guards the small mutable state below
        self._events_hs: deque[float] = deque(maxlen=512)  # times (t_s) of recent events
        self._events_to: deque[float] = deque(maxlen=512)
        self._markers: deque[tuple[float, str]] = deque(maxlen=512)
        self._rate_times: deque[tuple[float, int]] = deque(maxlen=64)
        self._strides: deque[Stride] = deque(maxlen=cycle_strides)
        self._cycles: deque[np.ndarray] = deque(maxlen=cycle_strides)
        self._cycles_deg = np.empty((0, 101, 3))  # np.stack(_cycles), rebuilt once per stride
        self._device_strides = StrideTracker(self.fs_hz)
        self._device_edges = ContactEdges()  # events from the unit's contacts (JOINT mode)
        self._n_strides = 0
        self._last_hs_idx: int | None = None
        self._seq0: int | None = None
        self._reconnects_seen = 0
        self._samples = 0  # samples processed since start (the pipeline's index)
        self._last_data_s = time.monotonic()
        self._pending_config: PipelineConfig | None = None
        self._pending_calibration: Calibration | None = None
        self._recorder: _Recorder | None = None
        self._last_recording = RecordingStatus()
        self._identity: Identity | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._error = ""  # the last device or processing error (Snapshot.engine_error)
        self._errors = 0  # blocks that could not be read or processed (Snapshot.engine_errors)

    # -- lifecycle ----------------------------------------------------------------------

    @property
    def identity(self) -> Identity | None:
        return self._identity

    def start(self) -> None:
        """Connect (if needed), identify, select the mode's frames and start streaming."""
        if self._thread is not None:
            return
        try:
            self.device.connect()
            self._identity = self.device.identify()
            self.device.select_kind(self.mode.frame_kind)
            self.device.start_stream()
        except (DeviceError, LinkError) as exc:
            with contextlib.suppress(Exception):
                self.device.close()
            raise EngineError(str(exc)) from exc
        self._stop.clear()
        self._last_data_s = time.monotonic()
        self._thread = threading.Thread(target=self._run, name="gaitmon-engine", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop recording (the file is completed), streaming and the threads. Idempotent."""
        self.stop_recording()
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        with contextlib.suppress(Exception):
            self.device.close()

    def __enter__(self) -> Engine:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    @property
    def samples_total(self) -> int:
        return self._samples

    # -- recording ------------------------------------------------------------------------

    def start_recording(
        self, path: str | Path, meta: Any = None, *, overwrite: bool = False
    ) -> None:
        """Open a session file and record every sample from the next block on."""
        from gaitmon.io.session import (
            SessionError,
            SessionHeader,
            SessionMeta,
            SessionWriter,
            device_info,
        )

        with self._lock:
            if self._recorder is not None:
                raise EngineError("already recording; stop the current recording first")
            # a zeroing still waiting for the next block is the calibration the file starts with
            # (the engine thread takes pending changes and applies them under this same lock,
            # so the header is exactly what the first recorded block is processed with)
            calibration = self._pending_calibration or self.calibration
            header = SessionHeader(
                mode=self.mode.value,
                sample_rate_hz=self.fs_hz,
                meta=meta or SessionMeta(),
                device=device_info(self._identity, self.transport_label),
                config=self._pending_config or self.config,
                calibration=calibration,
            )
            try:
                writer = SessionWriter(path, header, overwrite=overwrite)
            except SessionError as exc:
                raise EngineError(str(exc)) from exc
            except OSError as exc:
                raise EngineError(f"cannot create {path}: {exc.strerror or exc}") from exc
            # row 0 is the first sample of the next block the engine thread starts on (it
            # sets the recorder's record_offset then): never half a block, never one too late
            self._recorder = _Recorder(
                writer, self._recorder_queue_blocks, header.config, calibration
            )
            self._last_recording = RecordingStatus()

    def stop_recording(self, reason: str = "user", timeout_s: float = 30.0) -> RecordingStatus:
        """Finish the file (complete, journal removed) and return the final status.

        Waits up to ``timeout_s`` for the recorder to write what is queued and close the file.
        If it has not finished by then (a stalled disk), the status says so in ``error``; the
        recorder carries on in the background, and if the process ends first the journal
        keeps every row handed over (the next open recovers the file).
        """
        with self._lock:
            rec = self._recorder
            self._recorder = None
        if rec is None:
            return self._last_recording
        with contextlib.suppress(Exception):
            rec.put(("link", self.device.stats))
        rec.put(("stop", reason))  # control items are never refused, even by a full queue
        rec.thread.join(timeout=max(0.0, timeout_s))
        status = self._recording_status(rec)
        if rec.alive and not status.error:
            name = Path(status.path).name
            status = dataclasses.replace(
                status,
                error=(
                    f"the recording to {name} was not finished after {timeout_s:g} s (slow "
                    "disk?); it finishes in the background, and if gaitmon quits first the "
                    "file is recovered from its journal when next opened"
                ),
            )
        self._last_recording = dataclasses.replace(status, active=False)
        return self._last_recording

    def _recording_status(self, rec: _Recorder | None) -> RecordingStatus:
        if rec is None:
            return self._last_recording
        error = rec.error
        if not error and not rec.alive and not rec.finished:
            error = "the recorder stopped unexpectedly"  # only a BaseException gets here
        return RecordingStatus(
            active=not error,
            path=str(rec.writer.path),
            started_monotonic_s=rec.started_monotonic_s,
            elapsed_s=time.monotonic() - rec.started_monotonic_s,
            rows=rec.rows,
            file_bytes=rec.file_bytes,
            dropped_blocks=rec.dropped,
            error=error,
        )

    @property
    def recording(self) -> RecordingStatus:
        return self._recording_status(self._recorder)

    def add_marker(self, label: str = "") -> None:
        t = self._latest_t()
        with self._lock:
            self._markers.append((t, label))
            if self._recorder is not None:
                self._recorder.put(("marker", label))

    # -- settings and calibration --------------------------------------------------------

    def apply_config(self, config: PipelineConfig) -> None:
        """New filter settings from the next block on; logged in a running recording."""
        if config.fs_hz != self.fs_hz:
            raise EngineError("the sample rate is fixed by the unit; it cannot change live")
        with self._lock:
            self._pending_config = config

    def zero(self, window_s: float = 1.5) -> Calibration:
        """Standing calibration from the last ``window_s`` of data; refuses while moving."""
        if self.mode is not Mode.RAW:
            try:
                self.device.zero()
            except (DeviceError, LinkError) as exc:
                raise EngineError(f"the unit refused to zero: {exc}") from exc
            return self.calibration
        n = int(window_s * self.fs_hz)
        data = self._ring.latest(n)
        if len(data["t_s"]) < n or np.isnan(data["acc_ms2"]).any():
            raise EngineError(
                f"need {window_s:g} s of data from the unit to zero; wait a moment and retry"
            )
        # the ring holds bias-corrected rates: add the bias in force back to see the true rate
        gyro = data["gyro_rad_s"] + self.calibration.gyro_bias_rad_s
        try:
            cal = standing_calibration(data["acc_ms2"], gyro, fs_hz=self.fs_hz)
        except CalibrationError as exc:
            raise EngineError(str(exc)) from exc
        with self._lock:
            self._pending_calibration = cal
        return cal

    # -- snapshots ------------------------------------------------------------------------

    def snapshot(self, window_s: float = 10.0) -> Snapshot:
        n = int(window_s * self.fs_hz)
        series = self._ring.latest(n)
        t = series["t_s"]
        t0 = t[0] if len(t) else 0.0
        with self._lock:
            hs = np.array([x for x in self._events_hs if x >= t0])
            to = np.array([x for x in self._events_to if x >= t0])
            markers = tuple(m for m in self._markers if m[0] >= t0)
            rates = list(self._rate_times)
            gait = self._gait_status(series)
            rec = self._recording_status(self._recorder)
            engine_error, engine_errors = self._error, self._errors
        rate = 0.0
        if len(rates) >= 2 and rates[-1][0] > rates[0][0]:
            rate = (rates[-1][1] - rates[0][1]) / (rates[-1][0] - rates[0][0])
        try:
            link = self.device.stats
        except Exception:  # a vanished device must not break the viewer
            link = None
        status = link.transport if link is not None else None
        return Snapshot(
            series=series,
            heel_strike_t_s=hs,
            toe_off_t_s=to,
            markers=markers,
            samples_total=self._samples,
            frame_rate_hz=rate,
            last_data_age_s=time.monotonic() - self._last_data_s,
            link=link,
            link_state=status.state.value if status is not None else "closed",
            link_reason=(status.reason or "") if status is not None else engine_error,
            seconds_to_reconnect=status.seconds_to_next_attempt() if status is not None else None,
            recording=rec,
            gait=gait,
            mode=self.mode,
            calibrated=bool(np.any(self.calibration.tilt_offset_rad != 0)),
            engine_error=engine_error,
            engine_errors=engine_errors,
        )

    def _gait_status(self, series: dict[str, np.ndarray]) -> GaitStatus:
        if not self._strides:
            return GaitStatus()
        last = self._strides[-1]
        mean_stride = float(np.mean([s.stride_time_s for s in self._strides]))
        cur_pct = np.empty(0)
        cur = np.empty((0, 3))
        if self._last_hs_idx is not None:
            k = self._samples - self._last_hs_idx
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

    def _latest_t(self) -> float:
        last = self._ring.latest(1)["t_s"]
        return float(last[0]) if len(last) else 0.0

    # -- the engine thread ------------------------------------------------------------------

    def _run(self) -> None:
        last_link_push = time.monotonic()
        while not self._stop.is_set():
            try:
                block = self.device.read_block(timeout_s=0.05)
            except Exception as exc:  # the device died under us: keep the reason, keep running
                self._note_error(f"device error: {exc}")
                time.sleep(0.05)
                continue
            now = time.monotonic()
            if block is not None and len(block):
                self._last_data_s = now
                try:
                    self._handle(block)
                except Exception as exc:  # never let one block kill acquisition
                    try:
                        self._block_failed(block, exc)
                    except Exception as again:
                        self._note_error(f"processing error: {type(again).__name__}: {again}")
            if now - last_link_push >= 1.0:
                last_link_push = now
                with self._lock:
                    if self._recorder is not None:
                        with contextlib.suppress(Exception):
                            self._recorder.put(("link", self.device.stats))

    def _note_error(self, text: str) -> None:
        with self._lock:
            self._errors += 1
            self._error = " ".join(text.split())[:300]

    def _handle(self, block: SampleBlock) -> None:
        self._handed_over = False
        self._block_start = self._samples
        with self._lock:
            # take pending changes and make them current in one step, so a recording started
            # meanwhile puts exactly what this block is processed with into its header
            cfg, self._pending_config = self._pending_config, None
            cal, self._pending_calibration = self._pending_calibration, None
            if cfg is not None:
                self.config = cfg
            if cal is not None:
                self.calibration = cal
            rec = self._recorder
        start_idx = self._samples
        first = rec is not None and rec.record_offset is None
        if first:
            assert rec is not None
            rec.record_offset = start_idx  # row 0 = this block's first sample
        if cfg is not None:
            self._pipeline = Pipeline(cfg, self.calibration)
            self._pipeline_offset = start_idx
            if rec is not None and not (first and cfg is rec.header_config):
                rec.put(("config", cfg))
        if cal is not None:
            self._pipeline.set_calibration(cal)
            if rec is not None and not (first and cal is rec.header_calibration):
                rec.put(("calibration", cal))
        if self._seq0 is None:
            self._seq0 = int(block.seq[0])
        if block.kind != self.mode.frame_kind:
            # not this session's frames (a unit that restarted into its default kind before
            # the setup was sent again): neither shown nor recorded; the file gets a gap
            self._note_error(
                f"the unit sent {FrameKind(block.kind).name} frames in {self.mode.value} mode; "
                f"{len(block)} frames ignored"
            )
            self._not_recorded(rec, block, f"frames lost: {FrameKind(block.kind).name} frames")
            return
        reconnects = self.device.stats.transport.reconnects
        gap_reason = ""
        if reconnects != self._reconnects_seen:
            self._reconnects_seen = reconnects
            gap_reason = "link lost: reconnected"
        t_s = (block.seq - self._seq0) / self.fs_hz
        if block.kind == FrameKind.RAW and block.adc is not None:
            p = self._pipeline.process(block.adc)
            offset = self._pipeline_offset
            cols = _cols_from_pipeline(p, t_s, block.host_time_s)
            hs_idx = p.heel_strike_idx + offset
            to_idx = p.toe_off_idx + offset
            strides = [_shift(s, offset) for s in p.strides]
            if rec is not None:
                self._hand_over(rec, block, p, gap_reason)
        else:
            cols = _cols_from_device(block, t_s)
            if block.heel_loaded is not None and block.toe_loaded is not None:
                hs_idx, to_idx = self._device_edges.process(
                    block.heel_loaded, block.toe_loaded, start_idx
                )
            else:
                hs_idx = to_idx = np.empty(0, np.int64)
            strides = self._device_strides.process(hs_idx, to_idx)
            if rec is not None:
                self._hand_over(rec, block, None, gap_reason)
        self._handed_over = True
        self._ring.append(cols)
        self._samples += len(block)
        with self._lock:
            self._rate_times.append((float(block.host_time_s[-1]), self._samples))
            for idx in hs_idx:
                self._events_hs.append(float(t_s[0] + (idx - start_idx) / self.fs_hz))
            for idx in to_idx:
                self._events_to.append(float(t_s[0] + (idx - start_idx) / self.fs_hz))
            if len(hs_idx):
                self._last_hs_idx = int(hs_idx[-1])
            for s in strides:
                self._add_stride(s)

    def _hand_over(
        self, rec: _Recorder, block: SampleBlock, p: PipelineBlock | None, gap_reason: str
    ) -> None:
        """Queue a block for the recorder, with the frames not recorded before it as lost.

        Raw mode: the pipeline's events are turned into file rows here (the engine alone knows
        which of its samples the file holds), so the writer gets them with offset 0."""
        first_reason = ""
        out = block
        if rec.carry_lost and block.lost_before is not None:
            lost = block.lost_before.copy()
            lost[0] += rec.carry_lost
            out = dataclasses.replace(block, lost_before=lost)
            first_reason = rec.carry_reason
        p_rows = p
        if p is not None:
            hs, to = (
                np.concatenate(
                    [
                        np.asarray(rec.carry_events[k], np.int64),
                        self._event_rows(rec, getattr(p, k) + self._pipeline_offset),
                    ]
                )
                for k in ("heel_strike_idx", "toe_off_idx")
            )
            p_rows = dataclasses.replace(p, heel_strike_idx=hs, toe_off_idx=to)
        if rec.put_block(("append", (out, p_rows, 0, gap_reason, first_reason))):
            rec.carry_lost, rec.carry_reason = 0, ""
            if p is not None:
                rec.carry_events = {k: [] for k in rec.carry_events}
            return
        # the queue is full (a stalled disk): these rows will not exist; the frames become a
        # gap before the next row that is recorded, and events this block confirmed on rows
        # already recorded go with the next block
        assert rec.record_offset is not None
        start = self._samples
        if p is not None:
            for k in rec.carry_events:
                idx = getattr(p, k) + self._pipeline_offset
                rec.carry_events[k].extend(self._event_rows(rec, idx[idx < start]).tolist())
        n = len(block)
        n_lost = 0 if block.lost_before is None else int(block.lost_before.sum())
        rec.carry_lost += n + n_lost
        rec.carry_reason = rec.carry_reason or "frames lost: recorder queue full"
        rec.drop_starts.append(start)
        rec.drop_ends.append(start + n)
        rec.drop_cum.append((rec.drop_cum[-1] if rec.drop_cum else 0) + n)

    @staticmethod
    def _event_rows(rec: _Recorder, idx: np.ndarray) -> np.ndarray:
        """File rows of events at engine indices ``idx`` (those on samples the file holds)."""
        assert rec.record_offset is not None
        idx = np.asarray(idx, np.int64)
        rows = idx - rec.record_offset
        keep = rows >= 0
        if rec.drop_starts:
            ends = np.asarray(rec.drop_ends)
            k = np.searchsorted(ends, idx, side="right")  # dropped ranges wholly before idx
            cum = np.concatenate([[0], np.asarray(rec.drop_cum)])
            rows = rows - cum[k]
            starts = np.asarray([*rec.drop_starts, np.iinfo(np.int64).max])
            keep &= ~(starts[k] <= idx)  # inside a dropped range: not in the file
        return rows[keep]

    def _not_recorded(self, rec: _Recorder | None, block: SampleBlock, why: str) -> None:
        """A block that got no engine indices (not processed): its frames become a gap."""
        if rec is None:
            return
        lost = 0 if block.lost_before is None else int(block.lost_before.sum())
        rec.carry_lost += len(block) + lost
        rec.carry_reason = rec.carry_reason or why

    def _block_failed(self, block: SampleBlock, exc: Exception) -> None:
        """``_handle`` raised (a bug, or a block the pipeline cannot take): say so, keep the
        indices of the display, the pipeline and the recording consistent, carry on."""
        self._note_error(f"processing error: {type(exc).__name__}: {exc}")
        with self._lock:
            rec = self._recorder
        if rec is not None and rec.record_offset is None:
            rec = None  # the recording had not started with this block
        if self._handed_over:
            # the block is in the file: only the display bookkeeping after it failed
            if self._samples == self._block_start:
                self._samples += len(block)
            return
        # the block is not in the file and may have left the pipeline half-updated: a fresh
        # pipeline starts with the next block, and the file logs it as a settings change at
        # that row (so reprocessing restarts there too) after a gap for this block
        self._samples = self._block_start
        self._not_recorded(rec, block, "frames lost: processing error")
        if self.mode is Mode.RAW:
            self._pipeline = Pipeline(self.config, self.calibration)
            self._pipeline_offset = self._samples
            if rec is not None:
                rec.put(("config", self.config))

    def _add_stride(self, s: Stride) -> None:
        """Normalise a finished stride's joint angles from the ring buffer (lock held)."""
        self._n_strides += 1
        self._strides.append(s)
        length = self._samples - s.start_idx
        if length > self._ring.capacity or length <= 0:
            return
        joints = self._ring.latest(length)["joint_kalman_deg"]
        k = s.end_idx - s.start_idx
        seg = joints[: k + 1]
        if len(seg) == k + 1 and not np.isnan(seg).all():
            self._cycles.append(normalise_cycles(seg, np.array([0, k]))[0])
            self._cycles_deg = np.stack(self._cycles)


def _slice_samples(b: SampleBlock, a: int, z: int) -> SampleBlock:
    changes = {
        f.name: getattr(b, f.name)[a:z]
        for f in dataclasses.fields(b)
        if isinstance(getattr(b, f.name), np.ndarray)
    }
    return dataclasses.replace(b, **changes)


def _slice_pipeline(p: PipelineBlock, a: int, z: int, with_events: bool) -> PipelineBlock:
    """Rows a:z of a pipeline block; its (absolute-index) events go with the first part."""
    changes: dict[str, Any] = {
        f.name: getattr(p, f.name)[a:z]
        for f in dataclasses.fields(p)
        if isinstance(getattr(p, f.name), np.ndarray)
        and f.name not in ("heel_strike_idx", "toe_off_idx", "kalman_bias_rad_s")
    }
    if not with_events:
        changes["heel_strike_idx"] = p.heel_strike_idx[:0]
        changes["toe_off_idx"] = p.toe_off_idx[:0]
    return dataclasses.replace(p, start_idx=p.start_idx + a, **changes)


def _shift(s: Stride, offset: int) -> Stride:
    if offset == 0:
        return s
    return dataclasses.replace(
        s,
        start_idx=s.start_idx + offset,
        end_idx=s.end_idx + offset,
        toe_off_idx=s.toe_off_idx + offset,
    )


def _cols_from_pipeline(
    p: PipelineBlock, t_s: np.ndarray, host: np.ndarray
) -> dict[str, np.ndarray]:
    deg = np.degrees
    return {
        "t_s": t_s,
        "host_time_s": host,
        "tilt_acc_deg": deg(p.tilt_acc_rad),
        "tilt_gyro_deg": deg(p.tilt_gyro_rad),
        "tilt_kalman_deg": deg(p.tilt_kalman_rad),
        "joint_acc_deg": deg(p.joint_acc_rad),
        "joint_gyro_deg": deg(p.joint_gyro_rad),
        "joint_kalman_deg": deg(p.joint_kalman_rad),
        "acc_ms2": p.acc_ms2,
        "gyro_rad_s": p.gyro_rad_s,
        "fsr_counts": p.fsr_counts,
        "heel_loaded": p.heel_loaded.astype(np.float64),
        "toe_loaded": p.toe_loaded.astype(np.float64),
        "phase": p.phase.astype(np.float64),
    }


def _cols_from_device(b: SampleBlock, t_s: np.ndarray) -> dict[str, np.ndarray]:
    cols: dict[str, np.ndarray] = {"t_s": t_s, "host_time_s": b.host_time_s}
    if b.kind == FrameKind.TILT and b.acc_tilt_deg is not None and b.kalman_tilt_deg is not None:
        cols["tilt_acc_deg"] = b.acc_tilt_deg
        cols["tilt_kalman_deg"] = b.kalman_tilt_deg
        cols["joint_acc_deg"] = np.degrees(joint_angles(np.radians(b.acc_tilt_deg)))
        cols["joint_kalman_deg"] = np.degrees(joint_angles(np.radians(b.kalman_tilt_deg)))
    elif b.kind == FrameKind.JOINT and b.kalman_joint_deg is not None:
        # SampleBlock.from_frames sets all of a JOINT block's arrays together
        assert b.acc_joint_deg is not None
        assert b.heel_loaded is not None and b.toe_loaded is not None and b.phase is not None
        cols["joint_acc_deg"] = b.acc_joint_deg
        cols["joint_kalman_deg"] = b.kalman_joint_deg
        cols["heel_loaded"] = b.heel_loaded.astype(np.float64)
        cols["toe_loaded"] = b.toe_loaded.astype(np.float64)
        cols["phase"] = phase_from_contacts(b.heel_loaded, b.toe_loaded).astype(np.float64)
    return cols


__all__ = [
    "Engine",
    "EngineError",
    "GaitStatus",
    "Mode",
    "RecordingStatus",
    "RingBuffer",
    "Snapshot",
]
