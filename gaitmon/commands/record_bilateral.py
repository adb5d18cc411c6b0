"""``gaitmon record --simulate-bilateral`` / ``--ports LEFT,RIGHT``: both legs into one session.

One engine per unit (``gaitmon.engine.pair.EnginePair``), each recording a crash-safe part beside
FILE; at the stop the parts are combined into FILE with both units' clock fits
(``docs/bilateral.md``).
"""

from __future__ import annotations

import argparse
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

from gaitmon.errors import UserError
from gaitmon.text import count

if TYPE_CHECKING:
    from gaitmon.engine import Engine
    from gaitmon.engine.pair import EnginePair
    from gaitmon.io.session import SessionMeta
    from gaitmon.lsl.outlets import LslOutlets

STALL_S = 10.0  # as gaitmon record: no frame from a unit this long ends the recording
STALL_PORT_S = 30.0


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


def run(args: argparse.Namespace, out: Path, meta: SessionMeta) -> int:
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
            _zero(pair, stop)
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
    reason, stalled = _wait(pair, args, out, stop, stall_s)
    try:
        statuses = pair.stop(reason)
    finally:
        _close_outlets(outlets, linger_s=0.5)  # after the last event; a recorder takes the rest
        for s, h in old.items():
            signal.signal(s, h)
    if sim is not None:
        from gaitmon.finish.bilateral import part_path
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


def _zero(pair: EnginePair, stop: threading.Event) -> None:
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


def _wait(
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
