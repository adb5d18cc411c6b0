"""The unit as one object over any transport: commands, acquisition thread, sample blocks, stats.

This module owns the conversation with a unit (hardware over `SerialTransport`, or the simulator
over a pty or `InProcessTransport`: the same code path), turning decoded frames into
`SampleBlock`s with unwrapped sequence numbers and host receive times.

Threading: `connect()` starts one daemon thread that reads the transport, feeds the decoder and
routes frames: ACK and IDENTITY frames wake the command that waits for them; data frames go to a
bounded queue that `read_block()` drains (or to a pending `request_frame()` when polling). The
caller's thread sends commands and waits for the answers. No Qt.

Reconnects: when the transport reports a new connection (its `status.connections` grew), the
thread drops the decoder's partial bytes and re-sends the streaming setup (SELECT_KIND, and
START_STREAM if streaming was on) without waiting for the ACKs, which it cannot read while it
is sending; if they are lost, the silence watchdog trips and the cycle repeats.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import TypedDict

import numpy as np

from gaitmon.dsp.channel_table import N_CHANNELS, N_JOINTS, N_SEGMENTS
from gaitmon.io.decoder import DecoderStats, FrameDecoder
from gaitmon.io.protocol import (
    DATA_KINDS,
    SAMPLE_RATE_HZ_DEFAULT,
    SEQ_MODULO,
    AckFrame,
    Command,
    DataFrame,
    Frame,
    FrameKind,
    Identity,
    IdentityFrame,
    JointFrame,
    RawFrame,
    TiltFrame,
    encode_command,
)
from gaitmon.io.transport import LinkError, LinkState, Transport, TransportStatus
from gaitmon.text import count, implausible_text


class DeviceError(Exception):
    """The unit did not answer, or refused a command; one-line message."""


# --------------------------------------------------------------------------------------------
# Blocks
# --------------------------------------------------------------------------------------------


class _CommonFields(TypedDict):
    """The SampleBlock fields every frame kind has (from_frames builds them once)."""

    kind: FrameKind
    seq: np.ndarray
    host_time_s: np.ndarray
    wall_offset_s: float
    lost_before: np.ndarray
    overflow_before: np.ndarray | None


@dataclass(frozen=True, eq=False)
class SampleBlock:
    """Consecutive received samples of one frame kind.

    seq           (N,) int64, unwrapped sequence numbers (strictly increasing; gaps = frames not
                  received, or control frames that shared the counter).
    host_time_s   (N,) float64, time.monotonic() when the bytes were read (frames decoded from
                  one read share a time).
    wall_offset_s wall-clock anchor: time.time() = host_time_s + wall_offset_s.
    lost_before   (N,) int64, frames the unit sent just before this sample that never arrived
                  (sequence gap minus the control frames that did arrive, plus any dropped by
                  this Device's own queue overflow): where a recording puts its gaps.
    overflow_before (N,) int64 or None, the part of ``lost_before`` this Device's own queue
                  dropped (nobody read blocks fast enough): a gap of its own reason.
    The kind's arrays are set, the others are None: RAW -> adc (N, 14) uint16; TILT ->
    acc_tilt_deg, kalman_tilt_deg (N, 4) float64; JOINT -> acc_joint_deg, kalman_joint_deg
    (N, 3) float64, heel_loaded, toe_loaded (N,) bool, phase (N,) uint8.
    """

    kind: FrameKind
    seq: np.ndarray
    host_time_s: np.ndarray
    wall_offset_s: float
    lost_before: np.ndarray | None = None
    adc: np.ndarray | None = None
    acc_tilt_deg: np.ndarray | None = None
    kalman_tilt_deg: np.ndarray | None = None
    acc_joint_deg: np.ndarray | None = None
    kalman_joint_deg: np.ndarray | None = None
    heel_loaded: np.ndarray | None = None
    toe_loaded: np.ndarray | None = None
    phase: np.ndarray | None = None
    overflow_before: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.seq.shape[0])

    @property
    def wall_time_s(self) -> np.ndarray:
        return self.host_time_s + self.wall_offset_s

    @staticmethod
    def from_frames(
        kind: FrameKind,
        frames: list[DataFrame],
        seq: list[int],
        host_time_s: list[float],
        wall_offset_s: float,
        lost_before: list[int] | None = None,
        overflow_before: list[int] | None = None,
    ) -> SampleBlock:
        n = len(frames)
        common: _CommonFields = {
            "kind": kind,
            "seq": np.asarray(seq, dtype=np.int64),
            "host_time_s": np.asarray(host_time_s, dtype=np.float64),
            "wall_offset_s": wall_offset_s,
            "lost_before": np.asarray(
                lost_before if lost_before is not None else [0] * n, dtype=np.int64
            ),
            "overflow_before": (
                None if overflow_before is None or not any(overflow_before)
                else np.asarray(overflow_before, dtype=np.int64)
            ),
        }
        if kind == FrameKind.RAW:
            adc = np.empty((n, N_CHANNELS), dtype=np.uint16)
            for i, f in enumerate(frames):
                adc[i] = f.adc  # type: ignore[union-attr]
            return SampleBlock(**common, adc=adc)
        if kind == FrameKind.TILT:
            acc = np.empty((n, N_SEGMENTS))
            kal = np.empty((n, N_SEGMENTS))
            for i, f in enumerate(frames):
                acc[i] = f.acc_tilt_deg  # type: ignore[union-attr]
                kal[i] = f.kalman_tilt_deg  # type: ignore[union-attr]
            return SampleBlock(**common, acc_tilt_deg=acc, kalman_tilt_deg=kal)
        acc = np.empty((n, N_JOINTS))
        kal = np.empty((n, N_JOINTS))
        for i, f in enumerate(frames):
            acc[i] = f.acc_joint_deg  # type: ignore[union-attr]
            kal[i] = f.kalman_joint_deg  # type: ignore[union-attr]
        return SampleBlock(
            **common,
            acc_joint_deg=acc,
            kalman_joint_deg=kal,
            heel_loaded=np.array([f.heel_loaded for f in frames], dtype=bool),  # type: ignore[union-attr]
            toe_loaded=np.array([f.toe_loaded for f in frames], dtype=bool),  # type: ignore[union-attr]
            phase=np.array([f.phase for f in frames], dtype=np.uint8),  # type: ignore[union-attr]
        )


class SequenceUnwrapper:
    """16-bit sequence numbers -> int64 that never wraps and strictly increases.

    A forward step below 2**15 is taken as is (frames lost in between). A step of 2**15 or more
    (the number went backwards or repeated) is taken as a unit restart: numbering continues
    after the last value. After a link outage, pass the expected advance (elapsed time x rate)
    so an outage longer than 2**16 frames is unwrapped to the right cycle.
    """

    def __init__(self) -> None:
        self.last: int | None = None

    def unwrap(self, seq16: int, expected_advance: float | None = None) -> int:
        last = self.last
        if last is None:
            value = seq16
        else:
            step = (seq16 - last - 1) % SEQ_MODULO + 1  # 1 .. 65536
            if expected_advance is not None and expected_advance > SEQ_MODULO / 2:
                cycles = round((expected_advance - step) / SEQ_MODULO)
                value = last + step + max(cycles, 0) * SEQ_MODULO
            elif step <= SEQ_MODULO // 2:
                value = last + step
            else:
                value = last + 1 + seq16  # restart: the new numbering began at 0
        self.last = value
        return value


# --------------------------------------------------------------------------------------------
# Stats
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class LinkStats:
    decoder: DecoderStats
    transport: TransportStatus
    streaming: bool
    kind: FrameKind
    queue_overflow_frames: int  # data frames dropped because nobody read blocks fast enough
    queued_frames: int
    rx_errors: int = 0  # unexpected exceptions the receive thread survived
    rx_error: str = ""  # the last of them, one line ("" if none)

    @property
    def reconnects(self) -> int:
        return self.transport.reconnects

    def describe(self) -> str:
        d = self.decoder
        return (
            f"{self.transport.describe()} | {count(d.frames_ok, 'frame')}, {d.frames_lost} lost, "
            f"{count(d.crc_failures, 'CRC error')}, {implausible_text(d.implausible_frames)}"
            f"{count(self.reconnects, 'reconnect')}"
        )


# --------------------------------------------------------------------------------------------
# Device
# --------------------------------------------------------------------------------------------


@dataclass
class _PendingCommand:
    """What the caller's thread waits for; filled by the acquisition thread."""

    command: int
    ack: AckFrame | None = None
    identity: Identity | None = None
    data: DataFrame | None = None
    done: threading.Event = field(default_factory=threading.Event)


class Device:
    """A gait unit over any `Transport`. Use as a context manager, or connect()/close()."""

    def __init__(
        self,
        transport: Transport,
        *,
        command_timeout_s: float = 0.5,
        command_attempts: int = 3,
        sample_rate_hz: float = SAMPLE_RATE_HZ_DEFAULT,
        max_queued_frames: int = 60 * SAMPLE_RATE_HZ_DEFAULT,
        read_chunk_timeout_s: float = 0.05,
    ) -> None:
        self.transport = transport
        self.command_timeout_s = command_timeout_s
        self.command_attempts = command_attempts
        self.sample_rate_hz = sample_rate_hz
        self._read_timeout_s = read_chunk_timeout_s
        self._decoder = FrameDecoder(frame_rate_hz=sample_rate_hz)
        self._dec_lock = threading.Lock()
        self._unwrapper = SequenceUnwrapper()
        # (frame, unwrapped seq, host time, frames lost just before it)
        # (frame, seq, receive time, frames lost before it, of which this queue dropped)
        self._queue: deque[tuple[DataFrame, int, float, int, int]] = deque()
        self._last_seq: int | None = None  # last unwrapped seq of any delivered frame
        self._max_queued = max_queued_frames
        self._overflow = 0
        self._cond = threading.Condition()
        self._pending: _PendingCommand | None = None
        self._cmd_lock = threading.Lock()  # one command in flight at a time
        self._kind = FrameKind.RAW
        self._streaming = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._connections_seen = 0
        self._last_rx_s = time.monotonic()
        self._wall_offset_s = time.time() - time.monotonic()
        self._thread_error: BaseException | None = None
        self._rx_errors = 0
        self._rx_error = ""

    # -- lifecycle ------------------------------------------------------------------------

    def connect(self) -> None:
        """Open the transport and start the acquisition thread (PortOpenError if it fails)."""
        if self._thread is not None:
            return
        self.transport.open()
        self._connections_seen = self.transport.status.connections
        self._wall_offset_s = time.time() - time.monotonic()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="gaitmon-device-rx", daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Stop streaming (best effort), stop the thread, close the transport. Idempotent."""
        if self._thread is not None and self._streaming:
            with contextlib.suppress(LinkError):
                self.transport.write(encode_command(Command.STOP_STREAM))
        self._streaming = False
        self._stop.set()
        self.transport.close()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None

    def __enter__(self) -> Device:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def streaming(self) -> bool:
        return self._streaming

    @property
    def kind(self) -> FrameKind:
        return self._kind

    # -- commands -------------------------------------------------------------------------

    def _command(
        self, cmd: Command, arg: int = 0, *, timeout_s: float | None = None
    ) -> _PendingCommand:
        if self._thread is None:
            raise DeviceError("device not connected: call connect() first")
        timeout_s = self.command_timeout_s if timeout_s is None else timeout_s
        wire = encode_command(cmd, arg)
        with self._cmd_lock:
            for _ in range(self.command_attempts):
                pending = _PendingCommand(int(cmd))
                with self._cond:
                    self._pending = pending
                try:
                    self.transport.write(wire)
                    answered = pending.done.wait(timeout_s)
                finally:
                    with self._cond:
                        self._pending = None
                if answered:
                    if pending.ack is not None and not pending.ack.ok:
                        raise DeviceError(f"unit refused {cmd.name}: {pending.ack.status.name}")
                    return pending
            raise DeviceError(
                _unanswered(cmd, self.command_attempts, timeout_s, self.transport.status)
            )

    def identify(self, timeout_s: float | None = None) -> Identity:
        """Ask the unit who it is."""
        ident = self._command(Command.IDENTIFY, timeout_s=timeout_s).identity
        assert ident is not None
        return ident

    def select_kind(self, kind: FrameKind) -> None:
        if kind not in DATA_KINDS:
            raise ValueError(f"not a data frame kind: {kind!r}")
        self._command(Command.SELECT_KIND, int(kind))
        self._kind = FrameKind(kind)

    def start_stream(self) -> None:
        self._command(Command.START_STREAM)
        self._streaming = True
        self.transport.arm_watchdog(True)

    def stop_stream(self) -> None:
        self.transport.arm_watchdog(False)
        self._streaming = False
        self._command(Command.STOP_STREAM)

    def zero(self, timeout_s: float = 3.0) -> None:
        """Standing calibration on the unit (the subject stands upright, leg straight)."""
        self._command(Command.ZERO, timeout_s=timeout_s)

    def request_frame(self, timeout_s: float | None = None) -> DataFrame:
        """Poll one frame of the selected kind (as in the paper); not while streaming."""
        if self._streaming:
            raise DeviceError("cannot poll while streaming: call stop_stream() first")
        data = self._command(Command.REQUEST_FRAME, timeout_s=timeout_s).data
        assert data is not None
        return data

    # -- data -----------------------------------------------------------------------------

    def read_block(self, timeout_s: float = 0.1, max_frames: int = 1 << 16) -> SampleBlock | None:
        """Queued data frames as one block (stops at a change of kind); None on timeout."""
        with self._cond:
            if not self._queue and not self._cond.wait_for(lambda: bool(self._queue), timeout_s):
                return None
            first = self._queue[0][0]
            kind = first.kind
            frames: list[DataFrame] = []
            seqs: list[int] = []
            times: list[float] = []
            lost: list[int] = []
            overflow: list[int] = []
            while self._queue and len(frames) < max_frames and self._queue[0][0].kind == kind:
                f, s, t, n_lost, n_over = self._queue.popleft()
                frames.append(f)
                seqs.append(s)
                times.append(t)
                lost.append(n_lost)
                overflow.append(n_over)
        return SampleBlock.from_frames(kind, frames, seqs, times, self._wall_offset_s, lost,
                                       overflow)  # fmt: skip

    @property
    def stats(self) -> LinkStats:
        with self._dec_lock:
            dec = self._decoder.stats
        with self._cond:
            queued, overflow = len(self._queue), self._overflow
        return LinkStats(
            decoder=dec,
            transport=self.transport.status,
            streaming=self._streaming,
            kind=self._kind,
            queue_overflow_frames=overflow,
            queued_frames=queued,
            rx_errors=self._rx_errors,
            rx_error=self._rx_error,
        )

    # -- acquisition thread ---------------------------------------------------------------

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                try:
                    self._receive()
                except Exception as exc:
                    # An unexpected failure (a transport that raised although it should not, a
                    # decoding bug) must not end acquisition for the rest of the session:
                    # count it, show it in stats, drop the partial bytes and carry on. The
                    # frames it cost appear as a sequence gap like any other loss.
                    self._rx_errors += 1
                    self._rx_error = f"{type(exc).__name__}: {' '.join(str(exc).split())}"[:300]
                    with self._dec_lock:
                        self._decoder.discard_buffer()
                    self._stop.wait(self._read_timeout_s)  # never spin on a lasting fault
        except BaseException as exc:  # keep the reason; stats and commands report the link down
            self._thread_error = exc
            raise

    def _receive(self) -> None:
        """One read from the transport, decoded and routed."""
        data = self.transport.read(self._read_timeout_s)
        now = time.monotonic()
        connections = self.transport.status.connections
        expected_advance = None
        if connections != self._connections_seen:
            self._connections_seen = connections
            expected_advance = (now - self._last_rx_s) * self.sample_rate_hz
            self._after_reconnect()
        if not data:
            return
        with self._dec_lock:
            frames = self._decoder.feed(data, now)
        for frame in frames:
            gap_hint = expected_advance if self._streaming else None
            seq = self._unwrapper.unwrap(frame.seq, gap_hint)
            expected_advance = None
            self._route(frame, seq, now)
        if frames:
            self._last_rx_s = now

    def _after_reconnect(self) -> None:
        with self._dec_lock:
            self._decoder.discard_buffer()
        try:
            self.transport.write(encode_command(Command.SELECT_KIND, int(self._kind)))
            if self._streaming:
                self.transport.write(encode_command(Command.START_STREAM))
        except LinkError:
            pass  # lost again; the transport retries and we come back here

    def _route(self, frame: Frame, seq: int, now: float) -> None:
        # control frames share the unit's counter: a gap is counted from the last frame of any kind
        lost = 0 if self._last_seq is None else max(0, seq - self._last_seq - 1)
        self._last_seq = seq
        with self._cond:
            pending = self._pending
            if isinstance(frame, AckFrame):
                if pending is not None and pending.command == int(frame.command):
                    pending.ack = frame
                    pending.done.set()
                return
            if isinstance(frame, IdentityFrame):
                if pending is not None and pending.command == Command.IDENTIFY:
                    pending.identity = frame.identity
                    pending.done.set()
                return
            assert isinstance(frame, RawFrame | TiltFrame | JointFrame)
            if pending is not None and pending.command == Command.REQUEST_FRAME:
                pending.data = frame
                pending.done.set()
                return
            over = 0
            if len(self._queue) >= self._max_queued:
                dropped = self._queue.popleft()
                self._overflow += 1
                if self._queue:  # the next frame now has these missing before it
                    f, s, t, n, m = self._queue[0]
                    self._queue[0] = (f, s, t, n + dropped[3] + 1, m + dropped[4] + 1)
                else:
                    lost += dropped[3] + 1
                    over = dropped[4] + 1
            self._queue.append((frame, seq, now, lost, over))
            self._cond.notify_all()


def _unanswered(cmd: Command, attempts: int, timeout_s: float, status: TransportStatus) -> str:
    """One line for a command nobody answered: what was asked, where, and what to check."""
    where = f" on {status.port}" if status.port else ""
    asked = f"no answer to {cmd.name} after {attempts} attempts of {timeout_s:g} s{where}"
    if status.state == LinkState.CONNECTED:
        return (
            f"{asked}: the port is open but nothing answers; check that it is the gait unit's "
            "port and that the unit is switched on and charged, then connect again"
        )
    return f"{asked}: the link is down ({status.describe()}); connect again once the unit is back"
