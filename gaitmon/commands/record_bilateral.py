"""``gaitmon record --simulate-bilateral`` / ``--ports LEFT,RIGHT``: both legs into one session.

One engine per unit (``gaitmon.engine.pair.EnginePair``), each recording a crash-safe part beside
FILE; at the stop the parts are combined into FILE with both units' clock fits
(``docs/bilateral.md``).
"""

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

from gaitmon.errors import UserError
from gaitmon.text import count

if TYPE_CHECKING:
    from gaitmon.engine.pair import EnginePair
    from gaitmon.io.session import SessionMeta

STALL_S = 10.0  # as gaitmon record: no frame from a unit this long ends the recording
STALL_PORT_S = 30.0


def _refuse_single_options(args: argparse.Namespace) -> None:
    both = "--simulate-bilateral" if args.simulate_bilateral else "--ports"
    if args.side:
        raise UserError(f"--side names the leg of one unit; with {both} both legs are recorded")
    if args.zero:
        raise UserError(f"--zero is not available with {both} yet; leave it out")
    if any(getattr(args, n, None) is not None for n in ("lsl_control", "lsl_markers")):
        raise UserError(f"the LSL options are not available with {both} yet; leave them out")
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
    try:
        pair.start(out, meta, overwrite=args.force)
    except (EngineError, LinkError) as exc:
        raise UserError(str(exc)) from None

    for side, eng in pair.engines.items():  # a unit says which leg it is configured for
        said = eng.identity.side if eng.identity is not None else ""
        if said in ("L", "R") and said != side:
            print(
                f"gaitmon record: warning: the unit recorded as the {side} leg (serial "
                f"{eng.identity.serial if eng.identity else '?'}) says it is worn on {said}; "
                "check the order of --ports (left first)",
                file=sys.stderr,
            )
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    stall_s = STALL_S if sim is not None else STALL_PORT_S
    reason, stalled = _wait(pair, args, out, stop, stall_s)
    try:
        statuses = pair.stop(reason)
    finally:
        for s, h in old.items():
            signal.signal(s, h)
    if sim is not None:
        from gaitmon.io.session.bilateral import part_path
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
