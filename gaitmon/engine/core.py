"""The headless engine: a Device through the pipeline into display buffers and a recording.

Data flows one way::

    Device (its own rx thread) -> engine thread: Pipeline (or the unit's own angles)
        -> ring buffers (the GUI pulls snapshots, ~30 Hz)
        -> bounded queue -> recorder thread (the only code that touches the session file)

Acquisition never waits for the recorder or a viewer: a full recorder queue is counted
(``RecordingStatus.dropped_blocks``), never silent, and a write error (full disk) stops the
recording with a message while acquisition and display carry on. No Qt here: the command line,
the tests and the desktop window all drive this same object.

This module owns the lifecycle (start, stop, the engine thread's loop), recording start and
stop, zeroing, settings and snapshots. The parts it wires together live beside it: the engine
thread's work on each part of a block (``blocks``), the calibration schedule, held rows and
the zero search (``schedule``, ``zeroing``), opening a session file and handing rows to the
recorder (``handover``), display buffers (``buffers``), snapshot types (``snapshot``), the
engine thread's sample count and the unit's true clock (``stream``), the recorder thread
(``recorder``) and its messages (``messages``), the map of engine samples to file rows
(``rows``), the live gait panel and stride lengths (``live_gait``) and the force-sensor
check's findings (``sensor_checks``).
Listeners (``add_listener``: the Lab Streaming Layer outlets, say) get each processed block as
a plain value (``taps``).
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from gaitmon.dsp import kernels
from gaitmon.dsp.calibration import Calibration, zero_source
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.engine.blocks import BlockHandler
from gaitmon.engine.buffers import (
    RingBuffer,
    on_event_time,
)
from gaitmon.engine.errors import EngineError as EngineError  # re-exported
from gaitmon.engine.handover import open_recorder
from gaitmon.engine.live_gait import FootStrideLengths, GaitEvents, LiveGait
from gaitmon.engine.markers import TimedMarkerCounts, TimedMarkers
from gaitmon.engine.messages import AddMarker, UpdateLink
from gaitmon.engine.recorder import Recorder
from gaitmon.engine.schedule import (
    HeldRows,
    PendingChanges,
    ZeroControl,
)
from gaitmon.engine.sensor_checks import SensorChecks
from gaitmon.engine.snapshot import (
    EVENTS_UNIT,
    UNIT_ANGLE_METHOD,
    Mode,
    RecordingStatus,
    Snapshot,
)
from gaitmon.engine.stream import StreamHealth, StreamPosition, UnitClockMark, stalled_s
from gaitmon.engine.taps import BlockListener, Taps
from gaitmon.engine.warmup import prepare_filters
from gaitmon.engine.zeroing import ZERO_MARGIN_S, ZeroSearch, still_window
from gaitmon.io.device import Device, DeviceError
from gaitmon.io.protocol import Identity
from gaitmon.io.transport import LinkError
from gaitmon.text import clean_label

if TYPE_CHECKING:
    from gaitmon.io.session.header import SessionMeta


class Engine:
    """Runs one Device in one mode; see the module doc.

    Ownership: ``_lock`` guards ``_pending``, ``_recorder``, ``_markers``, ``_health``,
    ``_gait``, ``_checks`` and the zero search (``_zeroing.search``), and the engine thread's
    writes of ``config`` and ``calibration``; only the engine thread (``_blocks``, a
    ``BlockHandler`` on this object's state) writes ``_stream``, ``_pipeline``, ``_held`` and
    ``_events`` (no lock); the caller's thread writes ``_last_recording``, ``_identity``
    and ``_thread``.
    """

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
        self._phase_lag = self.config.phase_lag_samples if self.mode is Mode.RAW else 0
        self._stream = StreamPosition()
        self._ring = RingBuffer(int(display_seconds * self.fs_hz))
        self._events = GaitEvents(self.fs_hz)  # the unit's events; every mode's strides
        self._recorder_queue_blocks = recorder_queue_blocks
        self._lock = threading.Lock()  # guards the small mutable state below
        self._markers: deque[tuple[float, str]] = deque(maxlen=512)
        self._timed = TimedMarkers(self.fs_hz)  # markers stamped with a host time, waiting
        self._gait = LiveGait(self.fs_hz, cycle_strides)
        self._spatial = FootStrideLengths(self.fs_hz)
        self._checks = SensorChecks()
        self._health = StreamHealth()
        self._pending = PendingChanges()
        self._recorder: Recorder | None = None
        self._last_recording = RecordingStatus()
        self._identity: Identity | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._taps = Taps(self.mode.value, self.fs_hz, self._note_error)  # add_listener
        # a recording started while this is set holds the rows of its first record_limit_s
        # seconds of the unit's clock (lost frames count), not what arrived until it was
        # stopped: ``gaitmon record --duration`` gets the same rows however loaded the host is
        self.record_limit_s: float | None = None
        # a zero or a recording start scheduled at a sample the engine thread had already
        # processed (a machine far behind) took effect from the next block: one line each
        self.timing_notes: deque[str] = deque(maxlen=64)
        # engine thread: the parts processed from a found zero's sample on, for a recording
        # to start there (``request_zero(hold=True)``)
        self._held = HeldRows(self.fs_hz)
        self._zeroing = ZeroControl(self._lock, self._pending, self._held,
                                    lambda: self.calibration, self.fs_hz)  # fmt: skip
        self._blocks = BlockHandler(self)  # the engine thread's work on each part

    # -- lifecycle ----------------------------------------------------------------------

    @property
    def identity(self) -> Identity | None:
        return self._identity

    def start(self, before_stream: Callable[[], None] | None = None) -> None:
        """Connect (if needed), identify, select the mode's frames and start streaming.

        ``before_stream`` runs once the unit is identified and before the first frame is
        requested: ``gaitmon record`` starts its recording there, so the file and journal
        exist before any data does (a crash can then lose nothing already received)."""
        if self._thread is not None:
            return
        # the filters' tables built before any data flows (their loops run interpreted: no
        # compile), and numba's cache filled in the background for a long recording's close
        prepare_filters(self.config, self._pipeline.table)
        try:
            self.device.connect()
            self._identity = self.device.identify()
            self.device.select_kind(self.mode.frame_kind)
            if before_stream is not None:
                before_stream()
            self.device.start_stream()
        except (DeviceError, LinkError) as exc:
            with contextlib.suppress(Exception):
                self.stop_recording("error: the unit could not start streaming")
                self.device.close()
            raise EngineError(str(exc)) from exc
        except BaseException:
            with contextlib.suppress(Exception):
                self.stop_recording("error: start-up failed")
                self.device.close()
            raise
        self._stop.clear()
        self._stream.last_data_s = time.monotonic()
        self._timed.reopen()
        self._thread = threading.Thread(target=self._run, name="gaitmon-engine", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop recording (the file is completed), streaming and the threads. Idempotent."""
        self.stop_recording()
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
            self._timed.close()  # a marker given from now on arrived after the recording
            if self._taps:  # the engine thread is gone: this thread tells them the end
                self._taps.engine_stopped()
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
        return self._stream.samples

    def clock_mark(self) -> UnitClockMark:
        """The unit's clock now, to measure from (``seconds_since``)."""
        return UnitClockMark(self._stream.samples, self.device.stats.decoder.frames_lost)

    def seconds_since(self, mark: UnitClockMark | None = None) -> float:
        """Seconds of the unit's clock since ``mark`` (None: since the start): samples
        processed and frames lost."""
        mark = mark or UnitClockMark()
        lost = self.device.stats.decoder.frames_lost - mark.frames_lost
        return (self._stream.samples - mark.samples + lost) / self.fs_hz

    # -- recording ------------------------------------------------------------------------

    def start_recording(
        self, path: str | Path, meta: SessionMeta | None = None, *, overwrite: bool = False,
        from_idx: int | None = None,
    ) -> None:  # fmt: skip
        """Open a session file and record every sample from the next block on, or with
        ``from_idx`` (an engine sample index, e.g. the one where a zero takes effect:
        ``zero_at``) from that sample on: the file's first row is then decided by the data,
        not by when this thread ran. If that sample has already been processed (a machine far
        behind), from the next block, and ``timing_notes`` says so."""
        with self._lock:
            if self._recorder is not None:
                raise EngineError("already recording; stop the current recording first")
            # a zeroing still waiting for the next block is the calibration the file starts with
            # (the engine thread takes pending changes and applies them under this same lock,
            # so the header is exactly what the first recorded block is processed with); one
            # scheduled at a sample is, if the file starts at or after that sample (the engine
            # thread logs the calibration in force at row 0 if it is not the header's)
            calibration = self._pending.header_calibration(
                self.calibration, from_idx, self._stream.samples
            )
            limit = self.record_limit_s
            recorder = open_recorder(
                path, meta, overwrite=overwrite, mode=self.mode.value, fs_hz=self.fs_hz,
                identity=self._identity, transport_label=self.transport_label,
                config=self._pending.config or self.config, calibration=calibration,
                queue_blocks=self._recorder_queue_blocks,
                limit_samples=None if limit is None else round(limit * self.fs_hz),
            )  # fmt: skip
            # row 0 is the first sample of the next block the engine thread starts on (it
            # sets the row map's record_offset then): never half a block, never one too late
            recorder.reconnects_base = self.device.stats.reconnects
            self._recorder = recorder
            self._recorder.start_idx = from_idx
            self._timed.recording_started()
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
        if rec is not None:  # the engine thread places the markers waiting, before "stop"
            self._timed.flush(self._thread)
        with self._lock:
            rec = self._recorder
            self._recorder = None
            if rec is not None:  # (under the lock: a marker placed next sees both)
                self._timed.recording_ended()
        if rec is None:
            return self._last_recording
        self._last_recording = rec.finish(reason, timeout_s, lambda: self.device.stats)
        return self._last_recording

    def _recording_status(self, rec: Recorder | None) -> RecordingStatus:
        return self._last_recording if rec is None else rec.status()

    @property
    def recording(self) -> RecordingStatus:
        return self._recording_status(self._recorder)

    def recorded_unit_s(self) -> float | None:
        """Seconds of the unit's clock from the recording's first row through the last sample
        handed to it (lost frames count; 0 before its first row); None: not recording."""
        with self._lock:
            rec = self._recorder
        return None if rec is None else rec.unit_samples() / self.fs_hz

    def add_marker(self, label: str = "", host_time_s: float | None = None) -> None:
        """A marker on the latest sample (the next row of a recording), or with
        ``host_time_s`` (``time.monotonic()``'s clock) on the sample taken at that instant,
        placed once that sample has been processed (``engine/markers.py``). One stamped before
        the recording's first row or after its last is not recorded (``timed_markers``).
        The label is cleaned here, where every marker enters (``gaitmon.text.clean_label``:
        control characters escaped, at most 256 characters): whatever a sender puts in it,
        the recorder can store it."""
        label = clean_label(label)
        if host_time_s is not None:
            self._timed.add(label, float(host_time_s))
            return
        t = self._latest_t()
        with self._lock:
            self._markers.append((t, label))
            self._taps.marker(label)
            if self._recorder is not None:
                self._recorder.put(AddMarker(label))

    @property
    def timed_markers(self) -> TimedMarkerCounts:
        """What became of the markers given a host time: recorded, outside a recording."""
        return self._timed.counts

    @property
    def timed_marker_overflow(self) -> int:
        """Markers given a host time that were refused: too many waiting at once."""
        return self._timed.overflow

    def _place_timed_markers(self) -> None:
        """The engine thread: markers whose sample has been processed go to the display and,
        on a row of the recording, to the recorder (``engine/markers.py``)."""
        with self._timed.placing() as placed:
            if not placed:
                return
            with self._lock:  # the recorder cannot stop in between: a marker precedes "stop"
                rec = self._recorder
                rows = self._timed.rows(placed, None if rec is None else rec.row_map)
                for m, row in zip(placed, rows, strict=True):
                    if m.k is not None:
                        self._markers.append((m.k / self.fs_hz, m.label))
                    if rec is not None and row is not None:
                        rec.put(AddMarker(m.label, row))

    def add_listener(self, listener: BlockListener) -> None:
        """Call ``listener(BlockOut)`` on the engine thread after each block (``taps``)."""
        self._taps.add(listener)

    def remove_listener(self, listener: BlockListener) -> None:
        """No more calls from the next block on (one already under way may still finish)."""
        self._taps.remove(listener)

    # -- settings and calibration --------------------------------------------------------

    def apply_config(self, config: PipelineConfig) -> None:
        """New filter settings from the next block on; logged in a running recording."""
        if config.fs_hz != self.fs_hz:
            raise EngineError("the sample rate is fixed by the unit; it cannot change live")
        with self._lock:
            self._pending.config = config

    def zero(
        self, window_s: float = 1.5, *, apply: bool = True, since_idx: int | None = None
    ) -> Calibration:
        """Standing calibration from the last ``window_s`` of data; refuses while moving.
        ``apply=False`` (raw mode) only computes it; ``use_calibration`` applies it.

        ``since_idx`` (an engine sample index): from the earliest still ``window_s`` among the
        rows held from that sample on instead (windows ending every 0.1 s of the unit's
        clock): what is zeroed then depends on the unit's samples, not on when this thread
        got to run (a busy machine, a simulator faster than real time).

        Applied, it takes effect at the sample ``ZERO_MARGIN_S`` after the end of its window
        (``zero_at``), exactly there whichever block holds it."""
        cal, at = self.zero_at(window_s, since_idx=since_idx)
        return self.use_calibration(cal, at_idx=at) if apply and at is not None else cal

    def zero_at(
        self, window_s: float = 1.5, *, since_idx: int | None = None
    ) -> tuple[Calibration, int | None]:
        """``zero``'s calibration (not applied) and the engine index from which it is to take
        effect: ``ZERO_MARGIN_S`` of the unit's clock after its window's last sample (None:
        a unit in tilt/joint mode, which zeroed itself and keeps ``calibration``)."""
        if self.mode is not Mode.RAW:
            try:
                self.device.zero()
            except (DeviceError, LinkError) as exc:
                raise EngineError(f"the unit refused to zero: {exc}") from exc
            return self.calibration, None
        n = int(window_s * self.fs_hz)
        found, refused = still_window(
            self._ring, n, since_idx, self.fs_hz, self.calibration.gyro_bias_rad_s
        )
        if found is not None:
            return found[0], found[1] + round(ZERO_MARGIN_S * self.fs_hz)
        if refused is None:
            raise EngineError(f"need {window_s:g} s of data from the unit to zero; wait and retry")
        raise EngineError(str(refused)) from refused

    def request_zero(
        self, window_s: float = 1.5, *, since_idx: int = 0, apply: bool = True,
        hold: bool = False,
    ) -> ZeroSearch:  # fmt: skip
        """Raw mode: the engine thread looks for the earliest still ``window_s`` from engine
        index ``since_idx`` on, each window as soon as its last sample is processed, and
        (``apply``) applies what it finds at its sample (``engine.zeroing``); ``hold``: and
        keeps the processed rows from that sample on (up to ``HOLD_MAX_S``) for a recording
        asked to start there (``start_recording(from_idx=...)``) however late. Poll
        ``zero_search``; ``cancel_zero`` ends it."""
        if self.mode is not Mode.RAW:
            raise EngineError("the unit zeroes itself in this mode")
        return self._zeroing.request(window_s, since_idx, apply, hold)

    def zero_search(
        self, search: ZeroSearch
    ) -> tuple[tuple[Calibration, int] | None, str, int]:
        """Where ``search`` is: (its calibration and first sample, or None; the last window's
        refusal, "" if none was refused; the engine index after the last window looked at)."""
        return self._zeroing.status(search)

    def cancel_zero(
        self, search: ZeroSearch, *, withdraw: bool = False
    ) -> tuple[Calibration, int] | None:
        """Stop looking; what it found meanwhile (applied, if it was to be), or None. With
        ``withdraw``, what it found is not applied (or, already applied, the calibration
        before it is again from the next block)."""
        return self._zeroing.cancel(search, withdraw)

    def use_calibration(self, cal: Calibration, at_idx: int | None = None) -> Calibration:
        """From the next block on, or from engine index ``at_idx`` (the next block if that
        sample has been processed already: ``timing_notes`` says so); logged in a running
        recording."""
        with self._lock:
            self._pending.calibration = cal
            self._pending.calibration_at = at_idx
        return cal

    # -- snapshots ------------------------------------------------------------------------

    def snapshot(self, window_s: float = 10.0) -> Snapshot:
        n = int(window_s * self.fs_hz)
        series = on_event_time(self._ring.latest(n), self._phase_lag)
        t = series["t_s"]
        t0 = t[0] if len(t) else 0.0
        with self._lock:
            hs, to = self._gait.events_since(t0)
            markers = tuple(m for m in self._markers if m[0] >= t0)
            rate = self._health.frame_rate_hz()
            gait = self._gait.status(series, self._stream.samples)
            rec = self._recording_status(self._recorder)
            engine_error, engine_errors = self._health.error, self._health.errors
            method = self.config.tilt_method_label
            fsr_faults = tuple(self._checks.faults)
            event_source = self._checks.event_source
        if self.mode is not Mode.RAW:
            method = UNIT_ANGLE_METHOD
            event_source = EVENTS_UNIT if self.mode is Mode.JOINT else ""
        try:
            link = self.device.stats
        except Exception:  # a vanished device must not break the viewer
            link = None
        status = link.transport if link is not None else None
        age_s = time.monotonic() - self._stream.last_data_s
        return Snapshot(
            series=series,
            heel_strike_t_s=hs,
            toe_off_t_s=to,
            markers=markers,
            samples_total=self._stream.samples,
            frame_rate_hz=rate,
            last_data_age_s=age_s,
            link=link,
            link_state=status.state.value if status is not None else "closed",
            link_reason=(status.reason or "") if status is not None else engine_error,
            seconds_to_reconnect=status.seconds_to_next_attempt() if status is not None else None,
            recording=rec,
            gait=gait,
            mode=self.mode,
            calibrated=self.calibration.zeroed,
            zero_source=zero_source(self.calibration, mode=self.mode.value),
            engine_error=engine_error,
            engine_errors=engine_errors,
            angle_method=method,
            fsr_faults=fsr_faults,
            event_source=event_source,
            stalled_s=stalled_s(age_s, link is not None and link.streaming),
        )

    def _latest_t(self) -> float:
        last = self._ring.latest(1)["t_s"]
        return float(last[0]) if len(last) else 0.0

    # -- the engine thread ------------------------------------------------------------------

    def _run(self) -> None:
        with kernels.live():  # (the interpreted loops, whatever a recording's close loaded)
            self._acquire()

    def _acquire(self) -> None:
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
                self._stream.last_data_s = now
            rest = block if block is not None and len(block) else None
            while rest is not None:
                part, rest = self._blocks.next_part(rest)
                try:
                    self._blocks.handle(part)
                except Exception as exc:  # never let one block kill acquisition
                    try:
                        self._blocks.failed(part, exc)
                    except Exception as again:
                        self._note_error(f"processing error: {type(again).__name__}: {again}")
                try:
                    self._zeroing.look(self._ring, self._stream.samples)
                except Exception as exc:  # a zero must never stop acquisition
                    self._note_error(f"zero error: {type(exc).__name__}: {exc}")
            try:
                self._place_timed_markers()
            except Exception as exc:  # a marker must never stop acquisition
                self._note_error(f"marker error: {type(exc).__name__}: {exc}")
            if now - last_link_push >= 1.0:
                last_link_push = now
                with self._lock:
                    if self._recorder is not None:
                        with contextlib.suppress(Exception):
                            self._recorder.put(UpdateLink(self.device.stats))

    def _note_error(self, text: str) -> None:
        with self._lock:
            self._health.note_error(text)

