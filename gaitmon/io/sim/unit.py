"""The simulated dsPIC unit: a byte-level stand-in for the real device, faults and truth included.

This module owns the device's behaviour on the link: it answers the commands of
``gaitmon.io.protocol`` and emits encoded frames, so every simulated session goes through the
real frame decoder (and, over ``pty.py``, through pyserial). Behind it sit the gait model
(``kinematics.py``), the sensor model (``sensors.py``) and the device's own processing
(``gaitmon.dsp.pipeline.Pipeline`` on its own counts, for TILT and JOINT frames).

Byte interface (what a transport uses)
--------------------------------------
``unit.write(data: bytes) -> None``
    PC -> device bytes, any chunking. Commands are decoded by ``protocol.CommandDecoder`` and
    take effect at the device time they arrive (everything due before is produced first).
``unit.read(max_bytes: int | None = None) -> bytes``
    Device -> PC bytes that are due by now: frames of every sample tick up to
    floor((clock() - t0) * fs * speed), plus command answers. Never blocks; b"" when nothing is
    due. At most ``max_bytes`` are returned; the rest stays queued for the next read.
``unit.wait_readable(timeout_s: float) -> bool``
    Sleep (on a condition, woken by write/close) until bytes are due, at most timeout_s.
``unit.seconds_until_next_sample() -> float``
    For a transport thread to sleep until something can be due (0.0 when running flat out).
``unit.close()``
    Stops the unit; read() returns b"" and write() is ignored afterwards.

Pacing
------
Sample n belongs to device time n / fs. With ``speed`` = 1 the unit runs in real time on
``clock`` (default ``time.monotonic``); any other positive factor runs faster or slower; with
``speed=math.inf`` ("as fast as possible") device time only advances when there is work: each
read() produces up to ``afap_block`` samples while streaming, or as many ticks as pending
REQUEST_FRAME / ZERO need. The number of samples ever produced is computed from the clock, never
by sleeping per sample, so it cannot drift. With ``start_on_request`` (``build_unit``: the
command line's and the window's simulated unit) device time 0 is the moment a client first asks
for samples (REQUEST_FRAME, START_STREAM or ZERO), not the unit's construction: the first
streamed sample, the subject's standing start and every frame after are then the same for the
same seed however long the host took to start (a loaded machine took long enough at
``--speed 10`` to stream from sample 500 instead of 300, or to miss the standing start).
With a ``crystal_clock`` (one unit of a bilateral pair, ``bilateral.py``) sample n is taken at
common time ``offset + n / (fs (1 + ppm 1e-6))`` (``clock.py``), common time running ``speed``
times as fast as ``clock`` from ``epoch``.

Commands (see protocol.Command)
-------------------------------
SELECT_KIND (ACK, or NAK BAD_ARGUMENT), REQUEST_FRAME (one frame of the selected kind at the next
sample tick), START_STREAM / STOP_STREAM (ACK; frames of the selected kind every tick),
IDENTIFY (IDENTITY frame), ZERO (averages the next ``zero_samples`` samples, calls
``dsp.calibration.standing_calibration`` and installs it in the device pipeline; ACK when done,
NAK BUSY if the subject was not still). Unknown codes get NAK UNKNOWN_COMMAND.

The subject (not part of the protocol: the operator's remote control of the simulation)
-----------------------------------------------------------------------------------------
``unit.stand_still()`` makes the simulated subject stop at the next mid-stance (slowing over
one stride) and stand upright and still, so the standing pose can be zeroed, until
``unit.walk()``; ``unit.walk()`` during the first ``standing_s`` starts walking at once. Both
take effect at the unit's current device time, in process or behind the pty alike.

``unit.set_foot_sensor_fault(heel_dead=True, toe_stuck=False)`` breaks the force sensors from
the current sample on (the heel sensor reads ~0 counts and never loads; the toe sensor stays
loaded), ``set_foot_sensor_fault(False, False)`` repairs them. Only the FSR counts change (the
unit's own contacts follow them); the gait and its true events (``truth``) do not.

Faults and the ledger
---------------------
``FaultConfig`` says what goes wrong on the link and ``unit.ledger`` (a ``FaultLedger``) records
each fault injected, frame by frame: ``faults.py``. A stall (``FaultConfig.stalls``, or
``unit.stall(duration_s)`` from now) holds the frames and sends the backlog when it ends: read()
gives nothing meanwhile, no frame is lost (a paced unit only).

Ground truth
------------
``unit.truth(start, stop)`` gives the true tilts and joint angles (rad, clinical convention, no
mounting offset), gyro bias, gait phase, heel-strike / toe-off sample indices and each stride's
length, time and foot clearance (from its heel strike to the next) for a sample range;
``unit.frame_log()`` maps every data frame's number and sequence to its sample index.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from gaitmon.dsp import kernels
from gaitmon.dsp.calibration import CalibrationError, standing_calibration
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX
from gaitmon.dsp.pipeline import Pipeline, PipelineBlock, PipelineConfig
from gaitmon.io import protocol as P
from gaitmon.io.sim.clock import CrystalClock
from gaitmon.io.sim.faults import FaultConfig, FaultLedger, LedgerEntry, flip_bits
from gaitmon.io.sim.frame_log import FrameLog
from gaitmon.io.sim.ground_truth import GroundTruth as GroundTruth  # re-exported
from gaitmon.io.sim.ground_truth import ground_truth
from gaitmon.io.sim.kinematics import GaitConfig, GaitModel, StrideTruth
from gaitmon.io.sim.sensors import SensorBlock, SensorConfig, SensorModel

DEVICE_NAME = "gaitmon-sim"
FIRMWARE_VERSION = "1.0.0"
_OUT_QUEUE_LIMIT_BYTES = 1 << 20  # a UART/Bluetooth buffer would overflow long before this


class SimulatedUnit:
    """One simulated gait unit. Thread-safe: a transport thread and a test may share it."""

    def __init__(
        self,
        gait: GaitConfig | None = None,
        sensors: SensorConfig | None = None,
        faults: FaultConfig | None = None,
        *,
        speed: float = 1.0,
        clock: Callable[[], float] = time.monotonic,
        pipeline_config: PipelineConfig | None = None,
        serial: int = 1,
        side: str = "R",
        afap_block: int = 100,
        zero_samples: int = 100,
        gait_model: GaitModel | None = None,
        crystal_clock: CrystalClock | None = None,
        epoch: float | None = None,
        start_on_request: bool = False,
    ) -> None:
        if not speed > 0:
            raise ValueError(f"speed must be > 0 (math.inf = as fast as possible), got {speed}")
        # gait_model: the leg's motion when it is not the unit's own (a bilateral pair's legs
        # share one walk, gaitmon.io.sim.bilateral); its config replaces ``gait``.
        # crystal_clock: when each sample is taken on the common time line (gaitmon.io.sim.clock);
        # epoch: the ``clock()`` reading at common time 0 (a pair shares it; default: now).
        # start_on_request: device time 0 is when a client first asks for samples (module
        # doc, "Pacing"), not now.
        if gait_model is not None:
            gait = gait_model.config
        self.gait_config = gait or GaitConfig()
        self.sensor_config = sensors or SensorConfig(seed=self.gait_config.seed)
        self.faults = faults or FaultConfig()
        self.fs_hz = self.gait_config.fs_hz
        self.speed = float(speed)
        self._clock = clock
        self.identity = P.Identity(
            name=DEVICE_NAME,
            firmware=FIRMWARE_VERSION,
            serial=serial,
            side=side,
            sample_rate_hz=round(self.fs_hz),
        )
        self.afap_block = afap_block
        self.zero_samples = zero_samples
        self.gait = gait_model or GaitModel(self.gait_config)
        self.crystal_clock = crystal_clock
        self.sensors = SensorModel(self.gait, self.sensor_config)
        self.pipeline = Pipeline(pipeline_config or PipelineConfig(fs_hz=self.fs_hz))
        self.ledger = FaultLedger()
        self._lock = threading.RLock()
        self._cond = threading.Condition(self._lock)  # wait_readable sleeps on it
        self._commands = P.CommandDecoder()
        seeds = np.random.SeedSequence(self.faults.seed, spawn_key=(4,)).spawn(2)
        self._rng = np.random.default_rng(seeds[0])  # which frames are hit
        self._bits_rng = np.random.default_rng(seeds[1])  # which bits a corruption flips
        self._out = bytearray()
        # [frame_no, sample_idx, kind, bytes still queued, logged] per frame in _out, oldest first,
        # so bytes thrown away at a link cut or overflow are logged frame by frame
        self._out_frames: deque[list[int]] = deque()
        self._kind = P.FrameKind.RAW
        self._streaming = False
        self._pending_requests = 0
        self._zero_left = 0
        self._zero_acc: list[np.ndarray] = []
        self._zero_gyro: list[np.ndarray] = []
        self._burst_left = 0
        self._frame_no = 0
        self._manual_link_down = False
        self._stall_until = 0  # sample index: a manual stall holds the frames until then
        # compact logs (8 + 8 + 1 bytes per data frame: ~6 MB for an hour of streaming)
        self._log = FrameLog()
        self._closed = False
        self._walk_after_stream: float | None = None  # stand_until_streamed's standing (s)
        self._t0 = clock() if epoch is None else epoch
        self._clock_running = not start_on_request

    # ---- byte interface ---------------------------------------------------------------------
    def write(self, data: bytes | bytearray | memoryview) -> None:
        with self._lock:
            if self._closed:
                return
            self._advance_to_now()
            if self._link_down():
                return  # nobody hears commands sent into a dead link
            for req in self._commands.feed(data):
                self._handle(req.command, req.arg)
            self._cond.notify_all()

    def read(self, max_bytes: int | None = None) -> bytes:
        with self._lock:
            if self._closed:
                return b""
            if math.isinf(self.speed):
                self._advance_afap(max_bytes)
            else:
                self._advance_to_now()
            if self._link_down():
                self._discard_queue()  # whatever was queued died with the link
                return b""
            if self._stalled():
                return b""  # held: the backlog leaves when the stall ends
            n = len(self._out) if max_bytes is None else min(max_bytes, len(self._out))
            data = bytes(self._out[:n])
            self._pop_bytes(n, fault="")
            return data

    def wait_readable(self, timeout_s: float) -> bool:
        """Sleep until read() has bytes (or a sample with a frame is due), at most timeout_s.

        For ``InProcessTransport``: it sleeps on a condition (woken by write/close), never
        polls. Returns whether bytes are ready to read.
        """
        with self._cond:
            if self._closed:
                return False
            if math.isinf(self.speed):
                return bool(self._out or self._streaming or self._pending_requests)
            self._advance_to_now()
            if not self._out or self._stalled():
                busy = self._streaming or self._pending_requests or self._zero_left
                wait_s = min(timeout_s, self.seconds_until_next_sample()) if busy else timeout_s
                if wait_s > 0:
                    self._cond.wait(wait_s)
                self._advance_to_now()
            return bool(self._out) and not self._stalled()

    def seconds_until_next_sample(self) -> float:
        with self._lock:
            if math.isinf(self.speed):
                return 0.0
            if not self._clock_running:
                return 1.0 / (self.fs_hz * self.speed)  # nothing is due before a request
            n_next = self.sensors.position + 1
            if self.crystal_clock is None:
                t_next = self._t0 + n_next / (self.fs_hz * self.speed)
            else:
                common_s = self.crystal_clock.common_time_s(n_next, self.fs_hz)
                t_next = self._t0 + common_s / self.speed
            return max(0.0, t_next - self._clock())

    def close(self) -> None:
        with self._lock:
            self._closed = True
            self._out.clear()
            self._cond.notify_all()

    @property
    def closed(self) -> bool:
        return self._closed

    # ---- the subject --------------------------------------------------------------------------
    def stand_still(self) -> float:
        """The subject stops at the next mid-stance and stands still until ``walk()``.

        Returns the device time (s) from which they stand. Samples already produced never change.
        """
        with self._lock:
            if not self._closed and not math.isinf(self.speed):
                self._advance_to_now()
            return self.gait.stand(self.sensors.position / self.fs_hz)

    def stand_until_streamed(self, standing_s: float) -> None:
        """The subject stands until the unit is told to stream and then ``standing_s`` more of
        device time before walking (from rest): the standing a recording starts with (to zero
        on) is then the same samples however long the PC took to get to streaming (imports, a
        busy machine; at ``speed`` 10, 5 s of standing is 0.5 s of wall time, gone before a
        slow start streamed its first frame). For a unit made standing until told (its gait's
        ``standing_s`` = inf), before it streams."""
        with self._lock:
            self._walk_after_stream = float(standing_s)

    def walk(self) -> None:
        """The subject walks again (at once if standing; no effect while walking)."""
        with self._lock:
            if not self._closed and not math.isinf(self.speed):
                self._advance_to_now()
            self.gait.walk(self.sensors.position / self.fs_hz)

    def set_foot_sensor_fault(self, heel_dead: bool = True, toe_stuck: bool = False) -> int:
        """Break (or repair) the foot's force sensors from now on; returns the first sample
        index with the new state. Samples already produced never change."""
        with self._lock:
            if not self._closed and not math.isinf(self.speed):
                self._advance_to_now()
            at = self.sensors.position
            self.sensors.set_fsr_fault(at, heel_dead, toe_stuck)
            return at

    @property
    def foot_sensor_fault(self) -> tuple[bool, bool]:
        """(heel dead, toe stuck loaded) for the next sample."""
        with self._lock:
            heel, toe = self.sensors.fsr_fault_at(np.array([self.sensors.position]))
            return bool(heel[0]), bool(toe[0])

    @property
    def standing(self) -> bool:
        """Whether the subject stands still now, or is stopping to."""
        with self._lock:
            return self.gait.standing_at(self.sensors.position / self.fs_hz)

    # ---- state a transport or test may look at ----------------------------------------------
    @property
    def samples_produced(self) -> int:
        return self.sensors.position

    @property
    def device_time_s(self) -> float:
        return self.sensors.position / self.fs_hz

    @property
    def streaming(self) -> bool:
        return self._streaming

    @property
    def kind(self) -> P.FrameKind:
        return self._kind

    @property
    def queued_bytes(self) -> int:
        return len(self._out)

    def link_is_down(self) -> bool:
        """True while a scheduled link drop (or a manual ``set_link_down``) is in effect."""
        with self._lock:
            if not self._closed and not math.isinf(self.speed):
                self._advance_to_now()
            return self._link_down()

    def set_link_down(self, down: bool) -> None:
        """Manual link cut (PtySimulator.cut): frames produced meanwhile are dropped and logged."""
        with self._lock:
            if not self._closed and not math.isinf(self.speed):
                self._advance_to_now()
            self._manual_link_down = bool(down)
            if down:
                self._discard_queue()

    def stall(self, duration_s: float) -> None:
        """Hold every frame for ``duration_s`` of device time from now, then send the backlog
        at once: nothing is lost (``FaultConfig.stalls`` schedules the same)."""
        with self._lock:
            self._advance_to_now()
            self._stall_until = self.sensors.position + round(duration_s * self.fs_hz)

    def frame_log(self, copy: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(frame_no, sample_idx, kind) of every data frame produced, delivered or not (new
        arrays, 17 bytes a frame: :meth:`samples_of` maps frames without them)."""
        with self._lock:
            return self._log.arrays(copy)

    def samples_of(self, frame_nos: np.ndarray) -> np.ndarray:
        """The sample index of each data frame numbered ``frame_nos`` (-1: none such)."""
        with self._lock:
            return self._log.samples_of(frame_nos)

    def true_events(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray, StrideTruth]:
        """(heel strikes, toe-offs, the strides they open) in samples start .. stop-1: the
        events of :meth:`truth` without the per-sample motion (a long record's events are
        gathered piece by piece, gaitmon.io.sim.truth)."""
        with self._lock:
            hs, to = self.gait.events(start, stop)
            return hs, to, self.gait.strides(start, stop)

    def truth(self, start: int = 0, stop: int | None = None) -> GroundTruth:
        """True motion for samples start .. stop-1 (default: everything produced so far)."""
        with self._lock:
            stop = self.sensors.position if stop is None else stop
            return ground_truth(self.gait, self.sensors, start, stop)

    # ---- time -------------------------------------------------------------------------------
    def _advance_to_now(self) -> None:
        if math.isinf(self.speed) or not self._clock_running:
            return
        elapsed = self._clock() - self._t0
        if self.crystal_clock is None:
            due = math.floor(elapsed * self.fs_hz * self.speed)
        else:
            due = self.crystal_clock.samples_due(elapsed * self.speed, self.fs_hz)
        self._tick(due - self.sensors.position)

    def _advance_afap(self, max_bytes: int | None) -> None:
        need = max(self._pending_requests, self._zero_left)
        if need:
            self._tick(need)
        if self._streaming:
            if max_bytes is None:
                n = self.afap_block
            else:
                n = -(-(max_bytes - len(self._out)) // P.FRAME_LEN[self._kind])
            if n > 0:
                self._tick(n)

    def _tick(self, n: int) -> None:
        """Produce n samples: sensors, device pipeline, due frames, fault injection."""
        while n > 0:
            # Bounded blocks keep an hour's catch-up from building an hour of frames at once.
            m = min(n, 4096)
            n -= m
            start = self.sensors.position
            block = self.sensors.next_block(m)
            with kernels.live():  # (the unit's own computing: live, whatever the thread)
                pb = self.pipeline.process(block.counts)
            if self._zero_left:
                self._collect_zero(block)
            if not (self._streaming or self._pending_requests):
                continue
            if self._streaming:
                self._pending_requests = 0  # the streamed frame answers any request
                idx = np.arange(m)
            else:
                k = min(self._pending_requests, m)
                self._pending_requests -= k
                idx = np.arange(k)
            self._emit_data(start, block, pb, idx)

    # ---- commands ---------------------------------------------------------------------------
    def _handle(self, cmd: object, arg: int) -> None:
        C = P.Command
        if not self._clock_running and cmd in (C.REQUEST_FRAME, C.START_STREAM, C.ZERO):
            self._clock_running = True  # device time 0 is now (start_on_request)
            self._t0 = self._clock()
        if cmd == C.SELECT_KIND:
            if arg in {int(k) for k in P.DATA_KINDS}:
                self._kind = P.FrameKind(arg)
                self._answer(P.AckFrame(0, C.SELECT_KIND, P.AckStatus.OK, arg))
            else:
                self._answer(P.AckFrame(0, C.SELECT_KIND, P.AckStatus.BAD_ARGUMENT, arg))
        elif cmd == C.REQUEST_FRAME:
            self._pending_requests += 1
        elif cmd == C.START_STREAM:
            self._streaming = True
            if self._walk_after_stream is not None:  # stand_until_streamed: walk later
                self.gait.walk(self.sensors.position / self.fs_hz + self._walk_after_stream)
                self._walk_after_stream = None
            self._answer(P.AckFrame(0, C.START_STREAM, P.AckStatus.OK, arg))
        elif cmd == C.STOP_STREAM:
            self._streaming = False
            self._answer(P.AckFrame(0, C.STOP_STREAM, P.AckStatus.OK, arg))
        elif cmd == C.IDENTIFY:
            self._answer(P.IdentityFrame(0, self.identity))
        elif cmd == C.ZERO:
            if self._zero_left:
                self._answer(P.AckFrame(0, C.ZERO, P.AckStatus.BUSY, arg))
            else:
                self._zero_left = self.zero_samples
                self._zero_acc, self._zero_gyro = [], []
        else:
            code = int(cmd)  # type: ignore[call-overload]
            self._answer(P.AckFrame(0, code, P.AckStatus.UNKNOWN_COMMAND, arg))

    def _collect_zero(self, block: SensorBlock) -> None:
        phys = DEFAULT_TABLE.to_physical(block.counts[: self._zero_left])
        self._zero_acc.append(np.stack([phys[:, ACC_X_IDX], phys[:, ACC_Z_IDX]], axis=-1))
        self._zero_gyro.append(phys[:, GYRO_IDX])
        self._zero_left -= len(phys)
        if self._zero_left:
            return
        acc = np.concatenate(self._zero_acc)
        gyro = np.concatenate(self._zero_gyro)
        try:
            cal = standing_calibration(acc, gyro, fs_hz=self.fs_hz)
        except CalibrationError:
            self._answer(P.AckFrame(0, P.Command.ZERO, P.AckStatus.BUSY, 0))
            return
        self.pipeline.set_calibration(cal)
        self._answer(P.AckFrame(0, P.Command.ZERO, P.AckStatus.OK, 0))

    # ---- frames and faults ------------------------------------------------------------------
    def _link_down_at(self, sample_idx: int) -> bool:
        return self._manual_link_down or self.faults.link_down_at(sample_idx / self.fs_hz)

    def _silent_at(self, sample_idx: int) -> bool:
        return self.faults.silent_at(sample_idx / self.fs_hz)

    def _stalled(self) -> bool:
        """Holding its frames now (a scheduled or a manual stall; never as fast as possible:
        device time only moves there when the client reads)."""
        at = self.sensors.position
        if math.isinf(self.speed):
            return False
        return at < self._stall_until or self.faults.stalled_at(at / self.fs_hz)

    def _link_down(self) -> bool:
        return self._link_down_at(self.sensors.position)

    def _discard_queue(self, fault: str = "link_down") -> None:
        self._pop_bytes(len(self._out), fault)

    def _pop_bytes(self, n: int, fault: str) -> None:
        """Remove n bytes from the head of the queue: read (fault "") or thrown away."""
        del self._out[:n]
        self.ledger.take_bytes(self._out_frames, n, fault)

    def _next_frame_no(self) -> int:
        no = self._frame_no
        self._frame_no += 1
        self.ledger.frames_produced += 1
        return no

    def _answer(self, frame: P.Frame) -> None:
        """Answers (ACK, IDENTITY) suffer only the scheduled outages, never random faults."""
        no = self._next_frame_no()
        frame = replace(frame, seq=no)
        at = self.sensors.position
        outage = "link_down" if self._link_down_at(at) else "silent" if self._silent_at(at) else ""
        if outage:
            self.ledger.dropped.append(
                LedgerEntry(no, no % P.SEQ_MODULO, -1, int(frame.kind), outage)
            )
            return
        self._queue(P.encode_frame(frame), no, -1, int(frame.kind))

    def _emit_data(
        self, start: int, block: SensorBlock, pb: PipelineBlock, idx: np.ndarray
    ) -> None:
        kind = self._kind
        f = self.faults
        n = len(idx)
        frame_nos = np.arange(self._frame_no, self._frame_no + n, dtype=np.int64)
        self._frame_no += n
        self.ledger.frames_produced += n
        self.ledger.data_frames_produced += n
        self._log.extend(frame_nos, start + idx, kind)
        # Three uniforms per data frame, always drawn, so which frames are hit depends on the
        # seed and the frame number only, not on how the frames were batched.
        u = self._rng.random((n, 3))
        raw_wire = b""
        if kind == P.FrameKind.RAW and n:
            # one call for the whole block (consecutive sequence numbers), sliced per frame
            raw_wire = P.encode_raw_block(int(frame_nos[0]), block.counts[idx])
        flen = P.FRAME_LEN[kind]
        for j, i in enumerate(idx):
            no = int(frame_nos[j])
            sample = start + int(i)
            fault = ""
            if self._link_down_at(sample):
                fault = "link_down"
            elif self._silent_at(sample):
                fault = "silent"
            elif self._burst_left > 0:
                self._burst_left -= 1
                fault = "burst"
            elif u[j, 0] * 100.0 < f.burst_pct:
                self._burst_left = f.burst_len_frames - 1
                fault = "burst"
            elif u[j, 1] * 100.0 < f.loss_pct:
                fault = "loss"
            if fault:
                self.ledger.dropped.append(
                    LedgerEntry(no, no % P.SEQ_MODULO, sample, int(kind), fault)
                )
                continue
            if raw_wire:
                wire = raw_wire[j * flen : (j + 1) * flen]
            else:
                wire = P.encode_frame(self._data_frame(kind, no, block, pb, int(i)))
            if u[j, 2] * 100.0 < f.corrupt_pct:
                wire, bits = flip_bits(wire, self._bits_rng, self.faults.max_bit_flips)
                self.ledger.corrupted.append(
                    LedgerEntry(no, no % P.SEQ_MODULO, sample, int(kind), "corrupt", bits)
                )
            self._queue(wire, no, sample, int(kind))

    def _data_frame(
        self, kind: P.FrameKind, no: int, block: SensorBlock, pb: PipelineBlock, i: int
    ) -> P.Frame:
        if kind == P.FrameKind.RAW:
            return P.RawFrame(no, block.counts[i])
        if kind == P.FrameKind.TILT:
            return P.TiltFrame(
                no, np.rad2deg(pb.tilt_acc_rad[i]), np.rad2deg(pb.tilt_kalman_rad[i])
            )
        return P.JointFrame(
            no,
            np.rad2deg(pb.joint_acc_rad[i]),
            np.rad2deg(pb.joint_kalman_rad[i]),
            heel_loaded=bool(pb.heel_loaded[i]),
            toe_loaded=bool(pb.toe_loaded[i]),
            phase=int(pb.phase[i]),
        )

    def _queue(self, wire: bytes, frame_no: int, sample_idx: int, kind: int) -> None:
        self._out += wire
        self._out_frames.append([frame_no, sample_idx, kind, len(wire), False])
        self.ledger.bytes_queued += len(wire)
        excess = len(self._out) - _OUT_QUEUE_LIMIT_BYTES
        if excess > 0:
            # Nobody is reading: like a UART FIFO, the oldest bytes are lost.
            self._pop_bytes(excess, "overflow")
