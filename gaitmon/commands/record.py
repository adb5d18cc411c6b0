"""``gaitmon record``: record a session of one or two units (one leg, or both legs with
``--simulate-bilateral`` / ``--ports LEFT,RIGHT``; docs/bilateral.md) from the unit or the
simulator to an HDF5 file."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import math
import signal
import sys
import threading
import time
from collections.abc import Callable
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
    from gaitmon.engine.pair import EnginePair
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
        return _record_units(args, out, meta)
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


# ---- both legs (--simulate-bilateral, --ports LEFT,RIGHT) ----


def _refuse_single_options(args: argparse.Namespace) -> None:
    both = "--simulate-bilateral" if args.simulate_bilateral else "--ports"
    if args.side:
        raise UserError(f"--side names the leg of one unit; with {both} both legs are recorded")
    if any(getattr(args, n, None) is not None for n in ("lsl_control", "lsl_markers")):
        raise UserError(
            f"--lsl-control and --lsl-markers are not available with {both} yet; leave them "
            "out (--lsl streams both legs)"
        )
    if args.simulate_bilateral and math.isinf(args.speed):
        raise UserError(
            "--speed max is not available with --simulate-bilateral: the units' clocks are "
            "mapped from the host's receive times, so they must run paced (give a factor, "
            "e.g. --speed 4)"
        )


def _record_units(args: argparse.Namespace, out: Path, meta: SessionMeta) -> int:
    """Both legs into one session: one engine per unit (``gaitmon.engine.pair.EnginePair``),
    each recording a crash-safe part beside FILE; at the stop the parts are combined into FILE
    with both units' clock fits (``docs/bilateral.md``)."""
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.engine import Engine, EngineError
    from gaitmon.engine.pair import EnginePair
    from gaitmon.io.device import Device
    from gaitmon.io.transport import LinkError, Transport

    _refuse_single_options(args)
    transports: list[tuple[Transport, str]] = []
    sim = None
    if args.simulate_bilateral:
        from gaitmon.commands.simulate import bilateral_config_from_args
        from gaitmon.io.sim.bilateral import BilateralSim
        from gaitmon.io.transport import InProcessTransport

        sim = BilateralSim(bilateral_config_from_args(args))
        transports = [
            (InProcessTransport(u, name=f"simulated {s}"), "simulated")
            for s, u in zip(("L", "R"), sim.units, strict=True)
        ]
    else:
        from gaitmon.io.ports import make_transport

        ports = [p.strip() for p in str(args.ports).split(",")]
        if len(ports) != 2 or not all(ports) or ports[0] == ports[1]:
            raise UserError(
                f"--ports needs two different ports, left first: LEFT,RIGHT (got {args.ports!r})"
            )
        transports = [(make_transport(p, args.baud), p) for p in ports]
    left, right = (
        Engine(Device(t), args.mode, PipelineConfig(), transport_label=label)
        for t, label in transports
    )
    pair = EnginePair(left, right)
    outlets: dict[str, LslOutlets] = {}
    before_stream = _lsl_opener(args, meta, outlets) if args.lsl else None
    stop = threading.Event()
    try:
        # with --zero both units stream first (zeroing needs data), and both parts start
        # after it, with each unit's calibration in its header
        pair.start(out, meta, overwrite=args.force, record=not args.zero,
                   before_stream=before_stream)  # fmt: skip
        if args.zero:
            _zero_pair(pair, stop)
    except (EngineError, LinkError) as exc:
        pair.stop("error: start-up failed")
        _close_outlets(outlets)
        raise UserError(str(exc)) from None
    except BaseException:
        pair.stop("error: start-up failed")
        _close_outlets(outlets)
        raise

    for side, eng in pair.engines.items():  # a unit says which leg it is configured for
        said = eng.identity.side if eng.identity is not None else ""
        if said in ("L", "R") and said != side:
            print(
                f"gaitmon record: warning: the unit recorded as the {side} leg (serial "
                f"{eng.identity.serial if eng.identity else '?'}) says it is worn on {said}; "
                "check the order of --ports (left first)",
                file=sys.stderr,
            )

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    stall_s = STALL_S if sim is not None else STALL_PORT_S
    reason, stalled = _wait_units(pair, args, out, stop, stall_s)
    try:
        statuses = pair.stop(reason)
    finally:
        _close_outlets(outlets, linger_s=0.5)  # after the last event; a recorder takes the rest
        for s, h in old.items():
            signal.signal(s, h)
    if sim is not None:
        from gaitmon.io.session.parts import part_path
        from gaitmon.io.sim.truth import attach_ground_truth

        for side, unit in zip(("L", "R"), sim.units, strict=True):
            if statuses[side].rows and not statuses[side].error:
                attach_ground_truth(part_path(out, side), unit)
    errors = [f"{side}: {st.error}" for side, st in statuses.items() if st.error]
    from gaitmon.io.session import SessionError

    try:
        pair.finish()
    except SessionError as exc:
        errors.append(str(exc))
    if errors:
        raise UserError("; ".join(errors))
    from gaitmon.finish.bilateral import missing_legs

    for line in missing_legs(out):
        print(f"gaitmon record: warning: {line}", file=sys.stderr)
    if stalled:
        raise UserError(stalled)
    for side, eng in pair.engines.items():
        d = eng.device.stats.decoder
        print(
            f"gaitmon record: {side} {count(statuses[side].rows, 'frame')}, "
            f"{count(d.frames_lost, 'frame')} lost, {count(d.crc_failures, 'CRC failure')}, "
            f"{count(eng.device.stats.reconnects, 'reconnect')}",
            file=sys.stderr,
        )
    print(f"gaitmon record: wrote both legs to {out} ({out.stat().st_size / 1e6:.1f} MB)",
          file=sys.stderr)  # fmt: skip
    return 0


def _zero_pair(pair: EnginePair, stop: threading.Event) -> None:
    """Both units zeroed from the same moment, or one line naming the leg that could not be."""
    from gaitmon.engine import EngineError

    try:
        pair.zero(stop)
    except EngineError as exc:
        raise EngineError(f"{exc}; nothing was recorded") from None
    if stop.is_set():
        raise EngineError("stopped before the recording started; nothing was recorded")
    print("gaitmon record: standing pose zeroed on both legs", file=sys.stderr)
    pair.start_recording()


def _lsl_opener(
    args: argparse.Namespace, meta: SessionMeta, outlets: dict[str, LslOutlets]
) -> Callable[[str, Engine], None]:
    """Each unit's outlets, opened before its first frame: the side in their names, source
    ids and descriptions, each with its own sample clock (``docs/lsl.md``)."""
    from gaitmon.engine import EngineError
    from gaitmon.lsl.outlets import LslOutlets

    def open_outlets(side: str, engine: Engine) -> None:
        side_meta = dataclasses.replace(meta, side=side)
        try:
            outlets[side] = LslOutlets.attach(
                engine, side_meta, allow_patient_id=args.lsl_patient_id, leg=side
            )
        except Exception as exc:  # liblsl could not open its sockets
            raise EngineError(f"could not open the {side} unit's LSL streams: {exc}") from None
        if not args.quiet:
            names = ", ".join(repr(n) for n in outlets[side].names)
            print(f"gaitmon record: streaming to LSL as {names}", file=sys.stderr)

    return open_outlets


def _close_outlets(outlets: dict[str, LslOutlets], linger_s: float = 0.0) -> None:
    for o in outlets.values():
        o.detach(linger_s=linger_s)
    outlets.clear()


def _wait_units(
    pair: EnginePair, args: argparse.Namespace, out: Path, stop: threading.Event, stall_s: float
) -> tuple[str, str]:
    """Until both legs have recorded ``--duration`` (or Ctrl-C, a write error, a silent unit):
    (stop reason, the message for a unit that fell silent or "")."""
    last_seen = {s: -1.0 for s in pair.engines}
    last_data = {s: time.monotonic() for s in pair.engines}
    last_print = 0.0
    while not stop.wait(0.02):
        now = time.monotonic()
        done = True
        for side, eng in pair.engines.items():
            rec_s = pair.recorded_s(side)
            if rec_s != last_seen[side]:
                last_seen[side], last_data[side] = rec_s, now
            if eng.recording.error:
                return "error", ""
            if now - last_data[side] > stall_s:
                return "error: no data from the unit", (
                    f"the {side} unit sent no data for {stall_s:g} s, so the recording stopped "
                    f"after {rec_s:.1f} of {args.duration:g} s; {out} holds what was received "
                    "(check the unit's power and link)"
                )
            done = done and rec_s >= args.duration
        if not args.quiet and now - last_print >= 1.0:
            last_print = now
            parts = []
            for side, eng in pair.engines.items():
                st = eng.device.stats
                parts.append(
                    f"{side} {min(pair.recorded_s(side), args.duration):6.1f} s, "
                    f"{st.decoder.frames_lost} lost, link {st.transport.state.value}"
                )
            print(f"recording {out.name}: " + "; ".join(parts) + f" / {args.duration:g} s",
                  file=sys.stderr, flush=True)  # fmt: skip
        if done:
            return "duration", ""
    return "user", ""
