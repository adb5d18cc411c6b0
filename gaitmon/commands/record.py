"""``gaitmon record``: record a session from the unit (or the simulator) to an HDF5 file."""

from __future__ import annotations

import argparse
import math
import signal
import sys
import threading
import time
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING

from gaitmon.commands.simulate import add_simulator_options, sim_config_from_args
from gaitmon.errors import UserError
from gaitmon.text import count

if TYPE_CHECKING:
    from gaitmon.engine import Engine, RecordingStatus
    from gaitmon.io.device import LinkStats

EPILOG = """\
examples:
  gaitmon record --simulate --duration 10 -o s.h5
  gaitmon record --port /dev/rfcomm0 --mode joint --duration 60 -o walk.h5 --patient P017

The recording is crash-safe: if the process dies, the next `gaitmon info FILE` recovers it.
Ctrl-C stops early and still leaves a complete file.
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.epilog = EPILOG
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--simulate", action="store_true", help="record from the simulated unit")
    src.add_argument("--port", metavar="PORT", help="serial port of the unit (see gaitmon ports)")
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
    p.add_argument("--overwrite", action="store_true", help="replace FILE if it exists")
    p.add_argument("--patient", default="", metavar="ID", help="patient identifier (no names)")
    p.add_argument("--operator", default="", help="who ran the session")
    p.add_argument("--side", choices=("L", "R", ""), default="", help="leg side of the unit")
    p.add_argument("--notes", default="", metavar="TEXT", help="free-text notes")
    p.add_argument(
        "--zero",
        action="store_true",
        help="zero the standing pose first (the subject must stand still for 1.5 s)",
    )
    p.add_argument(
        "--quiet", action="store_true", help="no progress lines on standard error"
    )
    p.add_argument(
        "--status-lines",
        action="store_true",
        help=argparse.SUPPRESS,  # for tests: 'ROWS <n> <monotonic s>' on stdout per block
    )
    sim = p.add_argument_group("simulated unit (with --simulate)")
    add_simulator_options(sim, side=False)


def run(args: argparse.Namespace) -> int:
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.engine import Engine, EngineError
    from gaitmon.io.device import Device
    from gaitmon.io.session import SessionMeta
    from gaitmon.io.transport import InProcessTransport, LinkError, SerialTransport, Transport

    if args.port is not None and not args.port.strip():
        raise UserError("--port needs a port name; `gaitmon ports` lists the ports")
    if not (math.isfinite(args.duration) and args.duration > 0):
        raise UserError(f"--duration must be a positive number of seconds, got {args.duration}")
    out = Path(args.output)
    if out.exists() and not args.overwrite:
        raise UserError(f"{out} already exists; choose another name or pass --overwrite")
    if not out.parent.is_dir():
        raise UserError(f"folder {out.parent} does not exist")
    meta = SessionMeta(
        patient_id=args.patient, side=args.side, operator=args.operator, notes=args.notes
    )
    unit = None
    transport: Transport
    if args.simulate:
        from gaitmon.io.sim.config import build_unit

        sim = sim_config_from_args(args)
        unit = build_unit(sim)
        transport = InProcessTransport(unit)
        label = "simulated"
        speed = sim.speed
    else:
        transport = SerialTransport(args.port, baudrate=args.baud)
        label = args.port
        speed = 1.0
    engine = Engine(Device(transport), args.mode, PipelineConfig(), transport_label=label)
    try:
        engine.start()
    except (EngineError, LinkError) as exc:
        raise UserError(str(exc)) from None

    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    reason = "duration"
    try:
        if args.zero:
            _zero(engine, stop)
        if stop.is_set():  # Ctrl-C while zeroing: the user wants no recording at all
            raise UserError("stopped before the recording started; nothing was recorded")
        try:
            engine.start_recording(out, meta, overwrite=args.overwrite)
        except EngineError as exc:
            raise UserError(str(exc)) from None
        start_samples = engine.samples_total
        lost0 = engine.device.stats.decoder.frames_lost
        wall_limit = time.monotonic() + args.duration / min(speed, 1e6) + 10.0
        last_print = 0.0
        last_rows = -1
        while True:
            if stop.wait(0.01):
                reason = "user"
                break
            # only counters here: a display snapshot (ring-buffer copies) is not needed
            rec = engine.recording
            link = engine.device.stats
            got = engine.samples_total - start_samples
            if args.status_lines and got != last_rows:
                last_rows = got
                print(f"ROWS {got} {time.monotonic():.6f}", flush=True)
            recorded_s = (got + link.decoder.frames_lost - lost0) / engine.fs_hz
            if rec.error:
                print(f"gaitmon record: {rec.error}", file=sys.stderr)
                reason = "error"
                break
            now = time.monotonic()
            if not args.quiet and now - last_print >= 1.0:
                last_print = now
                _progress(out, recorded_s, args.duration, rec, link)
            if recorded_s >= args.duration:
                break
            if now > wall_limit:
                print(
                    "gaitmon record: the unit stopped sending data; stopping early",
                    file=sys.stderr,
                )
                reason = "error: no data from the unit"
                break
    finally:
        status = engine.stop_recording(reason)  # after a write error the file is closed already
        stats = engine.device.stats
        engine.stop()
        for s, h in old.items():
            signal.signal(s, h)
    if unit is not None and status.rows and not status.error:
        from gaitmon.io.sim.truth import attach_ground_truth

        attach_ground_truth(out, unit)
    d = stats.decoder
    print(
        f"gaitmon record: wrote {count(status.rows, 'frame')} to {out} "
        f"({status.file_bytes / 1e6:.1f} MB); {count(d.frames_lost, 'frame')} lost, "
        f"{count(d.crc_failures, 'CRC failure')}, {count(stats.reconnects, 'reconnect')}",
        file=sys.stderr,
    )
    if status.error:
        raise UserError(status.error)
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
