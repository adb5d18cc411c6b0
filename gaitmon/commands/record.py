"""``gaitmon record``: record a session of one or two units (one leg, or both legs with
``--simulate-bilateral`` / ``--ports LEFT,RIGHT``; docs/bilateral.md) from the unit or the
simulator to an HDF5 file. One recording path for any number of units: the units
(``record_units``) run as one ``EngineGroup`` (a one-unit group records straight into FILE, a
pair's parts are combined into it at the end); LSL markers and remote control
(``record_lsl``) are one unit's."""

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

from gaitmon.commands import add_force, add_quiet, record_lsl, record_units
from gaitmon.commands.simulate import add_bilateral_options, add_simulator_options
from gaitmon.errors import UserError

if TYPE_CHECKING:
    from gaitmon.engine import Engine
    from gaitmon.engine.pair import EngineGroup
    from gaitmon.io.session import SessionMeta
    from gaitmon.lsl.control import RemoteControl
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
# How long the stop waits for the recorder to finish a one-unit file before it says so (as
# `Engine.stop_recording`); the parts of both legs get `EngineGroup.stop`'s longer default.
# Finishing computes over the whole recording (the smoother, /strides, /overview: ~15 CPU s an
# hour on a loaded 2-core machine), so each recorded hour adds FINISH_S_PER_H: a flat 30 s
# ended an 8-hour `--speed max` soak with "not finished after 30 s" while the close was
# working, and the process then hung at exit (its recorder thread inside h5py; issue 26).
STOP_ONE_S = 30.0
FINISH_S_PER_H = 120.0


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
    if args.lsl_scope and not (args.lsl or args.lsl_markers or args.lsl_control):
        raise UserError("--lsl-scope needs --lsl, --lsl-markers or --lsl-control")
    if args.lsl:
        from gaitmon.lsl.outlets import require_pylsl

        require_pylsl(args.lsl_scope)  # before anything starts: one line saying what to install
    defaults = argparse.ArgumentParser()
    add_bilateral_options(defaults, serve=False)
    pair_options = vars(defaults.parse_args([]))
    given = [n for n, v in pair_options.items() if getattr(args, n, v) != v]
    if given and not args.simulate_bilateral:
        names = ", ".join("--" + n.replace("_", "-") for n in given)
        raise UserError(f"{names}: only with --simulate-bilateral")
    lsl = None
    if record_units.both_legs(args):
        record_units.refuse_one_unit_options(args)
    else:  # the streams are found before the unit is touched
        lsl = record_lsl.open_inputs(args)
    try:
        return _record(args, out, meta, record_units.build(args), lsl)
    finally:
        if lsl is not None:
            lsl.close()


def _record(
    args: argparse.Namespace,
    out: Path,
    meta: SessionMeta,
    units: record_units.Units,
    lsl: record_lsl.LslInputs | None,
) -> int:
    """Record from every unit into ``out``: start, zero, wait for ``--duration`` on the
    units' clocks, stop, finish (a pair's parts combined), the closing lines."""
    from gaitmon.engine import EngineError
    from gaitmon.io.session import SessionError
    from gaitmon.io.transport import LinkError

    group = units.group
    control = lsl.control if lsl is not None else None
    for engine in group.engines.values():  # exactly --duration of rows, however loaded the host
        engine.record_limit_s = args.duration
    # The file (a leg's part) and its journal are created once the unit is identified and
    # before its first frame is requested, so nothing received is ever outside the file (a
    # crash during start-up lost everything received until the file existed: seconds on a
    # loaded machine). With --zero the units stream first (zeroing needs data), and the
    # recording starts after it, with each unit's calibration in its header; with
    # --lsl-control once the start word arrives. Two units stream first too, and both
    # recordings start once both stream: the units connect one after the other (a Bluetooth
    # unit takes seconds), and each part holds --duration from its own first row, so parts
    # started as each unit came up covered times that differed by the second unit's connect.
    later = args.zero or control is not None or group.in_parts
    outlets: dict[str, LslOutlets] = {}
    opener = record_lsl.outlet_opener(args, meta, outlets) if args.lsl else None

    def before_stream(side: str, engine: Engine) -> None:
        if args.zero:  # each engine thread looks for the standing window from its first sample
            group.request_zero_from_start(side)
        if opener is not None:
            opener(side, engine)

    try:
        group.start(out, meta, overwrite=args.force, record=not later,
                    before_stream=before_stream)  # fmt: skip
    except BaseException as exc:  # the group deleted the (empty) files it had created
        group.stop("error: start-up failed")
        record_lsl.close_outlets(outlets)
        if isinstance(exc, (EngineError, LinkError)):
            raise UserError(str(exc)) from None
        raise

    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    stall_s = STALL_S if units.simulated else STALL_PORT_S
    reason, stalled = "duration", ""
    try:
        if lsl is not None:
            record_lsl.start_markers(lsl, record_units.engine_of_one(group))
        if args.zero:
            _zero(group, stop)
        if stop.is_set():  # Ctrl-C while zeroing: the user wants no recording at all
            raise UserError("stopped before the recording started; nothing was recorded")
        if control is not None:
            engine = record_units.engine_of_one(group)
            record_lsl.wait_for_start(control, engine, stop, stall_s, args.quiet)
        if later:
            try:
                # with --zero each unit's first row is the sample its zero takes effect at
                group.start_recording(at_zero=args.zero and control is None)
            except EngineError as exc:
                raise UserError(str(exc)) from None
        for line in record_units.warn_wrong_legs(group):
            print(f"gaitmon record: {line}", file=sys.stderr)
        reason, stalled = _wait(group, args, out, stop, stall_s, control)
    finally:
        statuses = group.stop(reason, stop_timeout_s(group))
        record_lsl.close_outlets(outlets, linger_s=0.5)  # after the last event
        for s, h in old.items():
            signal.signal(s, h)
    from gaitmon.io.sim.truth import attach_ground_truth

    # one message per unit: the writer's, which states the rows a reader gets
    errors = [f"{s}: {st.error}" if s else st.error for s, st in statuses.items() if st.error]
    for side, unit in units.truth.items():
        if statuses[side].rows and not statuses[side].error:
            try:  # a full disk now: the recording is complete, only /truth is left out
                attach_ground_truth(group.recording_path(side), unit)
            except SessionError as exc:
                errors.append(f"{side}: {exc}" if side else str(exc))
    try:
        group.finish()  # a pair's parts combined into the file
    except SessionError as exc:
        errors.append(str(exc))
    if errors:
        raise UserError("; ".join(errors))
    if group.in_parts:
        from gaitmon.finish.bilateral import missing_legs

        for line in missing_legs(out):
            print(f"gaitmon record: warning: {line}", file=sys.stderr)
    if stalled:  # the request was not completed: say so, and exit non-zero
        raise UserError(stalled)
    lines = record_units.summary_lines(group, out)
    for side, eng in group.engines.items():  # a zero or a start the machine was too late for
        lines.extend(f"warning: {f'{side}: ' if side else ''}{note}" for note in eng.timing_notes)
    if lsl is not None:
        lines.append(record_lsl.summary(lsl, record_units.engine_of_one(group)))
    for line in lines:
        if line:
            print(f"gaitmon record: {line}", file=sys.stderr)
    return 0


def stop_timeout_s(group: EngineGroup) -> float:
    """How long the stop waits for the recorders to finish their files: the group's default
    (a one-unit file: :data:`STOP_ONE_S`), and :data:`FINISH_S_PER_H` more for each hour
    the longest recording holds."""
    from gaitmon.engine.pair import STOP_TIMEOUT_S

    hours = max((e.recording.rows / e.fs_hz for e in group.engines.values()), default=0.0) / 3600
    return (STOP_TIMEOUT_S if group.in_parts else STOP_ONE_S) + FINISH_S_PER_H * hours


def _zero(group: EngineGroup, stop: threading.Event) -> None:
    """Every unit zeroed from the same moment, or one line naming the unit (a leg) that
    could not be."""
    from gaitmon.engine import EngineError

    try:  # one unit in tilt/joint mode zeroes itself: its file logs no calibration again
        # the units stream from just before this: the earliest still window of their samples,
        # whatever the machine's load or the simulator's speed
        zeroed = group.zero(stop, from_start=True)
    except EngineError as exc:
        if not group.in_parts:
            raise UserError(str(exc)) from None
        raise UserError(f"{exc}; nothing was recorded") from None
    if zeroed:
        on = " on both legs" if group.in_parts else ""
        print(f"gaitmon record: standing pose zeroed{on}", file=sys.stderr)


def _wait(
    group: EngineGroup,
    args: argparse.Namespace,
    out: Path,
    stop: threading.Event,
    stall_s: float,
    control: RemoteControl | None,
) -> tuple[str, str]:
    """Until every unit has recorded ``--duration`` on its own clock (or Ctrl-C, the remote
    stop word, a write error, a unit fallen silent): (stop reason, the message for a unit that
    fell silent or "")."""
    # The watchdog measures silence, not the whole recording: a total wall-time budget
    # (duration / speed + 10 s) ended `--speed max` after ~10 s, since "max" is only as
    # fast as this machine can decode and record, not infinitely fast.
    last_seen = {s: -1.0 for s in group.sides}
    last_data = {s: time.monotonic() for s in group.sides}
    last_print = 0.0
    rows_from = {s: e.samples_total for s, e in group.engines.items()}
    last_rows = -1
    while not stop.wait(0.01):
        if control is not None and control.stopped.is_set():
            return f"remote: {control.words.stop!r} on LSL stream {control.name!r}", ""
        # only counters here: a display snapshot (ring-buffer copies) is not needed
        if args.status_lines and not group.in_parts:
            ((side, eng),) = group.engines.items()
            got = eng.samples_total - rows_from[side]
            if got != last_rows:
                last_rows = got
                print(f"ROWS {got} {time.monotonic():.6f}", flush=True)
        now = time.monotonic()
        recorded = {s: group.recorded_s(s) for s in group.sides}
        for side, rec_s in recorded.items():
            if rec_s != last_seen[side]:
                last_seen[side], last_data[side] = rec_s, now
        if any(e.recording.error for e in group.engines.values()):
            return "error", ""  # said once, as the command's error
        if not args.quiet and now - last_print >= 1.0:
            last_print = now
            print(record_units.progress_line(group, out, args.duration), file=sys.stderr,
                  flush=True)  # fmt: skip
        if all(rec_s >= args.duration for rec_s in recorded.values()):
            return "duration", ""
        for side, rec_s in recorded.items():
            if now - last_data[side] > stall_s:
                stalled = record_units.stalled_message(side, stall_s, rec_s, args.duration, out)
                return "error: no data from the unit", stalled
    return "user", ""
