"""``gaitmon record``: record a session from the unit (or the simulator) to an HDF5 file."""

from __future__ import annotations

import argparse
import contextlib
import math
import signal
import sys
import threading
import time
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING

from gaitmon.commands import add_force, add_quiet, record_lsl
from gaitmon.commands.simulate import (
    add_bilateral_options,
    add_simulator_options,
    sim_config_from_args,
)
from gaitmon.errors import UserError
from gaitmon.text import count

if TYPE_CHECKING:
    from gaitmon.engine import Engine, RecordingStatus
    from gaitmon.io.device import LinkStats
    from gaitmon.io.session import SessionMeta
    from gaitmon.lsl.outlets import LslOutlets

EPILOG = """\
examples:
  gaitmon record --simulate --duration 10 -o s.h5
  gaitmon record --simulate-bilateral --duration 60 -o both.h5
  gaitmon record --ports /dev/rfcomm0,/dev/rfcomm1 --duration 600 -o both.h5 --patient P017
  gaitmon record --port /dev/rfcomm0 --mode joint --duration 60 -o walk.h5 --patient P017
  gaitmon record --simulate --duration 600 -o s.h5 --lsl-control LabControl --lsl-markers Stim
  gaitmon record --simulate --lsl --duration 60 -o walk.h5   (LabRecorder sees the streams)

With --lsl-control the unit streams while gaitmon waits for 'start' on the LSL marker stream,
and the recording ends on 'stop'; --lsl-markers records a marker stream's samples on the rows
sampled at their timestamps (docs/lsl.md).
The recording is crash-safe: if the process dies, the next `gaitmon info FILE` recovers it.
Ctrl-C stops early and still leaves a complete file.
"""


# Seconds without a single new frame after which the unit is taken to have stopped sending
# (a dropped link that comes back sooner is a gap in the same recording). A real unit's
# Bluetooth link gets longer to come back than the simulator, which never drops on its own.
STALL_S = 10.0
STALL_PORT_S = 30.0


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.epilog = EPILOG
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--simulate", action="store_true", help="record from the simulated unit")
    src.add_argument(
        "--simulate-bilateral",
        action="store_true",
        help="record both legs from a simulated pair of units into one session "
        "(docs/bilateral.md)",
    )
    src.add_argument(
        "--ports",
        metavar="LEFT,RIGHT",
        help="record both legs: the left and the right unit's ports, into one session",
    )
    src.add_argument(
        "--port",
        metavar="PORT",
        help="serial port of the unit (see gaitmon ports), or on Linux a paired unit's "
        "address: bt://AA:BB:CC:DD:EE:FF[/CHANNEL]",
    )
    p.add_argument("--baud", type=int, default=115200, help="serial baud rate (default 115200)")
    p.add_argument(
        "--mode",
        choices=("raw", "tilt", "joint"),
        default="raw",
        help="raw: compute everything on the PC (default); tilt/joint: the unit's own angles",
    )
    p.add_argument(
        "--duration", type=float, required=True, metavar="S", help="seconds of data to record"
    )
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="session file (.h5)")
    add_force(p, "FILE")
    p.add_argument("--patient", default="", metavar="ID", help="patient identifier (no names)")
    p.add_argument("--operator", default="", help="who ran the session")
    p.add_argument(
        "--side", choices=("L", "R"), default="", help="leg side of the unit (default: not given)"
    )
    p.add_argument("--notes", default="", metavar="TEXT", help="free-text notes")
    p.add_argument(
        "--zero",
        action="store_true",
        help="zero the standing pose first (the subject must stand still for 1.5 s)",
    )
    add_quiet(p, "no progress lines on standard error")
    lsl = p.add_argument_group("Lab Streaming Layer output (needs gaitmon[lsl]; docs/lsl.md)")
    lsl.add_argument(
        "--lsl",
        action="store_true",
        help="also stream the angles, the gait events (and in raw mode the raw counts) to LSL "
        "for LabRecorder; off by default (no LSL socket is opened without it)",
    )
    lsl.add_argument(
        "--lsl-patient-id",
        action="store_true",
        help="let the patient id (--patient) into the LSL streams' description (default: left out)",
    )
    p.add_argument(
        "--status-lines",
        action="store_true",
        help=argparse.SUPPRESS,  # for tests: 'ROWS <n> <monotonic s>' on stdout per block
    )
    record_lsl.add_arguments(p)
    sim = p.add_argument_group("simulated unit (with --simulate)")
    add_simulator_options(sim, side=False)
    add_bilateral_options(
        p.add_argument_group("simulated pair of units (with --simulate-bilateral)"), serve=False
    )


def run(args: argparse.Namespace) -> int:
    from gaitmon.io.session import SessionMeta

    if args.port is not None and not args.port.strip():
        raise UserError("--port needs a port name; `gaitmon ports` lists the ports")
    if not (math.isfinite(args.duration) and args.duration > 0):
        raise UserError(f"--duration must be a positive number of seconds, got {args.duration}")
    out = Path(args.output)
    if out.exists() and not args.force:
        raise UserError(f"{out} already exists; choose another name or pass --force")
    if not out.parent.is_dir():
        raise UserError(f"folder {out.parent} does not exist")
    meta = SessionMeta(
        patient_id=args.patient, side=args.side, operator=args.operator, notes=args.notes
    )
    if args.lsl_patient_id and not args.lsl:
        raise UserError("--lsl-patient-id needs --lsl")
    if args.lsl:
        from gaitmon.lsl.outlets import require_pylsl

        require_pylsl()  # before anything starts: one line saying what to install
    defaults = argparse.ArgumentParser()
    add_bilateral_options(defaults, serve=False)
    pair_options = vars(defaults.parse_args([]))
    given = [n for n, v in pair_options.items() if getattr(args, n, v) != v]
    if given and not args.simulate_bilateral:
        names = ", ".join("--" + n.replace("_", "-") for n in given)
        raise UserError(f"{names}: only with --simulate-bilateral")
    if args.simulate_bilateral or args.ports is not None:
        from gaitmon.commands import record_bilateral

        return record_bilateral.run(args, out, meta)
    lsl = record_lsl.open_inputs(args)  # the streams are found before the unit is touched
    try:
        return _record(args, out, meta, lsl)
    finally:
        if lsl is not None:
            lsl.close()


def _record(
    args: argparse.Namespace, out: Path, meta: SessionMeta, lsl: record_lsl.LslInputs | None
) -> int:
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.engine import Engine, EngineError
    from gaitmon.io.device import Device
    from gaitmon.io.ports import make_transport
    from gaitmon.io.session import journal_path
    from gaitmon.io.transport import InProcessTransport, LinkError, Transport

    control = lsl.control if lsl is not None else None
    unit = None
    transport: Transport
    if args.simulate:
        from gaitmon.io.sim.config import build_unit

        sim = sim_config_from_args(args)
        unit = build_unit(sim)
        transport = InProcessTransport(unit)
        label = "simulated"
    else:
        transport = make_transport(args.port, args.baud)  # serial, or bt://ADDRESS
        label = args.port
    engine = Engine(Device(transport), args.mode, PipelineConfig(), transport_label=label)
    # The file and its journal are created once the unit is identified and before the first
    # frame is requested, so nothing received is ever outside the file (a crash during start-up
    # lost everything received until the file existed: seconds on a loaded machine). With
    # --zero the stream must run first (zeroing needs data); the recording starts after it,
    # and with --lsl-control once the start word arrives.
    started_early = False
    later = args.zero or control is not None
    outlets: LslOutlets | None = None

    def before_stream() -> None:
        nonlocal started_early, outlets
        if not later:
            engine.start_recording(out, meta, overwrite=args.force)
            started_early = True
        if args.lsl:  # the outlets exist before the first frame: a recorder misses none
            from gaitmon.lsl.outlets import LslOutlets

            try:
                outlets = LslOutlets.attach(engine, meta, allow_patient_id=args.lsl_patient_id)
            except Exception as exc:  # liblsl could not open its sockets
                raise EngineError(f"could not open the LSL streams: {exc}") from None
            if not args.quiet:
                names = ", ".join(repr(n) for n in outlets.names)
                print(f"gaitmon record: streaming to LSL as {names}", file=sys.stderr)

    try:
        engine.start(before_stream=before_stream)
    except (EngineError, LinkError) as exc:
        if started_early:  # an empty file of a recording that never began
            for p in (out, journal_path(out)):
                with contextlib.suppress(OSError):
                    p.unlink()
        if outlets is not None:
            outlets.detach()
        raise UserError(str(exc)) from None

    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    reason = "duration"
    stall_s = STALL_S if args.simulate else STALL_PORT_S
    stalled_at_s: float | None = None
    try:
        if lsl is not None:
            record_lsl.start_markers(lsl, engine)
        if args.zero:
            _zero(engine, stop)
        if stop.is_set():  # Ctrl-C while zeroing: the user wants no recording at all
            raise UserError("stopped before the recording started; nothing was recorded")
        if control is not None:
            record_lsl.wait_for_start(control, engine, stop, stall_s, args.quiet)
        if not started_early:
            try:
                engine.start_recording(out, meta, overwrite=args.force)
            except EngineError as exc:
                raise UserError(str(exc)) from None
        start_samples = engine.samples_total
        lost0 = engine.device.stats.decoder.frames_lost
        # The watchdog measures silence, not the whole recording: a total wall-time budget
        # (duration / speed + 10 s) ended `--speed max` after ~10 s, since "max" is only as
        # fast as this machine can decode and record, not infinitely fast.
        last_data = time.monotonic()
        last_seen = -1.0
        last_print = 0.0
        last_rows = -1
        while True:
            if stop.wait(0.01):
                reason = "user"
                break
            if control is not None and control.stopped.is_set():
                reason = f"remote: {control.words.stop!r} on LSL stream {control.name!r}"
                break
            # only counters here: a display snapshot (ring-buffer copies) is not needed
            rec = engine.recording
            link = engine.device.stats
            got = engine.samples_total - start_samples
            if args.status_lines and got != last_rows:
                last_rows = got
                print(f"ROWS {got} {time.monotonic():.6f}", flush=True)
            recorded_s = (got + link.decoder.frames_lost - lost0) / engine.fs_hz
            now = time.monotonic()
            if recorded_s != last_seen:
                last_seen, last_data = recorded_s, now
            if rec.error:  # said once, below, as the command's error
                reason = "error"
                break
            if not args.quiet and now - last_print >= 1.0:
                last_print = now
                _progress(out, recorded_s, args.duration, rec, link)
            if recorded_s >= args.duration:
                break
            if now - last_data > stall_s:
                reason = "error: no data from the unit"
                stalled_at_s = recorded_s
                break
    finally:
        status = engine.stop_recording(reason)  # after a write error the file is closed already
        stats = engine.device.stats
        engine.stop()
        if outlets is not None:  # after the engine's last event; a recorder takes the rest
            outlets.detach(linger_s=0.5)
        for s, h in old.items():
            signal.signal(s, h)
    if unit is not None and status.rows and not status.error:
        from gaitmon.io.sim.truth import attach_ground_truth

        attach_ground_truth(out, unit)
    if status.error:  # one message: the writer's, which states the rows a reader gets
        raise UserError(status.error)
    if stalled_at_s is not None:  # the request was not completed: say so, and exit non-zero
        raise UserError(
            f"the unit sent no data for {stall_s:g} s, so the recording stopped after "
            f"{stalled_at_s:.1f} of {args.duration:g} s; {out} holds what was received "
            "(check the unit's power and link)"
        )
    d = stats.decoder
    print(
        f"gaitmon record: wrote {count(status.rows, 'frame')} to {out} "
        f"({status.file_bytes / 1e6:.1f} MB); {count(d.frames_lost, 'frame')} lost, "
        f"{count(d.crc_failures, 'CRC failure')}, {count(stats.reconnects, 'reconnect')}",
        file=sys.stderr,
    )
    markers = record_lsl.summary(lsl, engine)
    if markers:
        print(f"gaitmon record: {markers}", file=sys.stderr)
    return 0


def _zero(engine: Engine, stop: threading.Event) -> None:
    from gaitmon.engine import EngineError

    deadline = time.monotonic() + 10.0
    while not stop.is_set():
        try:
            engine.zero()
            print("gaitmon record: standing pose zeroed", file=sys.stderr)
            return
        except EngineError as exc:
            if time.monotonic() > deadline:
                raise UserError(f"could not zero: {exc}") from None
            time.sleep(0.02)  # the simulator may run faster than real time


def _progress(
    out: Path, recorded_s: float, duration_s: float, rec: RecordingStatus, link: LinkStats
) -> None:
    d = link.decoder
    print(
        f"recording {out.name}: {min(recorded_s, duration_s):6.1f} / {duration_s:g} s, "
        f"{rec.rows} frames, {d.frames_lost} lost, {d.crc_failures} CRC errors, "
        f"link {link.transport.state.value}",
        file=sys.stderr,
        flush=True,
    )
