"""``gaitmon record``'s Lab Streaming Layer: the inputs of one unit's recording
(``--lsl-markers NAME`` records an external marker stream into the session, ``--lsl-control
NAME`` starts and stops the recording from a marker stream) and the outlets of every unit
(``--lsl``). Without these options pylsl is not even imported."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from gaitmon.errors import UserError
from gaitmon.lsl.network import SCOPES

if TYPE_CHECKING:
    from gaitmon.engine import Engine
    from gaitmon.io.session import SessionMeta
    from gaitmon.lsl.control import RemoteControl
    from gaitmon.lsl.inlet import MarkerInlet
    from gaitmon.lsl.outlets import LslOutlets

DEFAULT_TIMEOUT_S = 5.0


def add_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("Lab Streaming Layer input (needs gaitmon[lsl]; docs/lsl.md)")
    g.add_argument(
        "--lsl-markers",
        metavar="NAME",
        help="record the LSL marker stream NAME (e.g. a stimulator's triggers) as markers, "
        "each on the row sampled at its timestamp",
    )
    g.add_argument(
        "--lsl-markers-source-id",
        metavar="ID",
        help="take the --lsl-markers stream only from the sender with this LSL source id "
        "(needed when two streams share the name)",
    )
    g.add_argument(
        "--lsl-control",
        metavar="NAME",
        help="wait for a start word on the LSL marker stream NAME before recording, stop on "
        "its stop word (--duration still bounds the recording)",
    )
    g.add_argument(
        "--lsl-start-word", metavar="WORD", help="the word that starts (default: start)"
    )
    g.add_argument("--lsl-stop-word", metavar="WORD", help="the word that stops (default: stop)")
    g.add_argument(
        "--lsl-control-source-id",
        metavar="ID",
        help="take start/stop only from the --lsl-control stream with this LSL source id "
        "(recommended: a stream's name alone does not say who sends it)",
    )
    g.add_argument(
        "--lsl-scope",
        choices=SCOPES,
        default=None,
        help="where LSL looks for streams and answers discovery: machine (this computer "
        "only, the default), link (the local network) or site (liblsl's own default); "
        "applies to --lsl too (docs/lsl.md)",
    )
    g.add_argument(
        "--lsl-timeout",
        type=float,
        default=DEFAULT_TIMEOUT_S,
        metavar="S",
        help=f"seconds to look for the LSL streams (default {DEFAULT_TIMEOUT_S:g})",
    )


@dataclass
class LslInputs:
    markers: MarkerInlet | None = None
    control: RemoteControl | None = None

    def close(self) -> None:
        for part in (self.markers, self.control):
            if part is not None:
                with contextlib.suppress(Exception):
                    part.close()


def open_inputs(args: argparse.Namespace) -> LslInputs | None:
    """Find the streams the options name (before the unit is touched: a wrong name costs
    nothing); None without LSL options. The inlets start pulling with ``start``."""
    words_given = args.lsl_start_word is not None or args.lsl_stop_word is not None
    if args.lsl_control is None and words_given:
        raise UserError("--lsl-start-word and --lsl-stop-word need --lsl-control NAME")
    if args.lsl_control is None and args.lsl_control_source_id is not None:
        raise UserError("--lsl-control-source-id needs --lsl-control NAME")
    if args.lsl_markers is None and args.lsl_markers_source_id is not None:
        raise UserError("--lsl-markers-source-id needs --lsl-markers NAME")
    if args.lsl_markers is None and args.lsl_control is None:
        return None
    if not (args.lsl_timeout > 0 and args.lsl_timeout <= 3600):
        raise UserError(
            f"--lsl-timeout must be a positive number of seconds, at most 3600; "
            f"got {args.lsl_timeout}"
        )
    from gaitmon.lsl.control import ControlWords, RemoteControl
    from gaitmon.lsl.inlet import MarkerBudget, MarkerInlet, import_pylsl, resolve_marker_stream

    pylsl = import_pylsl(args.lsl_scope)
    out = LslInputs()
    try:
        if args.lsl_control is not None:
            words = ControlWords(args.lsl_start_word or "start", args.lsl_stop_word or "stop")
            info = resolve_marker_stream(pylsl, args.lsl_control, args.lsl_timeout,
                                         "--lsl-control", args.lsl_control_source_id)  # fmt: skip
            out.control = RemoteControl(pylsl, info, words, open_timeout_s=args.lsl_timeout)
            out.control.start()  # a start word sent while the unit connects still counts
        if args.lsl_markers is not None:
            info = resolve_marker_stream(pylsl, args.lsl_markers, args.lsl_timeout,
                                         "--lsl-markers", args.lsl_markers_source_id)  # fmt: skip
            out.markers = MarkerInlet(
                pylsl, info, open_timeout_s=args.lsl_timeout, budget=MarkerBudget()
            )
    except BaseException:
        out.close()
        raise
    return out


def start_markers(inputs: LslInputs, engine: Engine) -> None:
    """Every sample of the marker stream from now on goes to the engine, at its instant."""
    if inputs.markers is None:
        return

    def to_engine(label: str, host_time_s: float) -> None:
        engine.add_marker(label, host_time_s=host_time_s)

    inputs.markers.start(to_engine)


def wait_for_start(
    control: RemoteControl, engine: Engine, stop: threading.Event, stall_s: float, quiet: bool
) -> None:
    """Block until the start word arrives (the unit streams meanwhile), Ctrl-C, or the unit
    falls silent for ``stall_s``; the last two raise UserError (nothing was recorded)."""
    if not quiet:
        print(
            f"gaitmon record: the unit is streaming; waiting for {control.words.start!r} on the "
            f"LSL stream {control.name!r} (Ctrl-C to quit)",
            file=sys.stderr,
            flush=True,
        )
    seen, last_data = engine.samples_total, time.monotonic()
    while not control.started.is_set():
        if stop.wait(0.01):
            raise UserError(
                f"stopped before {control.words.start!r} arrived on {control.name!r}; "
                "nothing was recorded"
            )
        now = time.monotonic()
        if engine.samples_total != seen:
            seen, last_data = engine.samples_total, now
        elif now - last_data > stall_s:
            raise UserError(
                f"the unit sent no data for {stall_s:g} s while waiting for "
                f"{control.words.start!r}; nothing was recorded (check the unit's power and link)"
            )


def summary(inputs: LslInputs | None, engine: Engine) -> str:
    """What became of the external markers, for the command's last lines ("" without): how
    many were recorded, and why each of the others was not. The inlet is closed first, so
    that every marker received is in the counts (one arriving now is after the recording)."""
    if inputs is None or inputs.markers is None:
        return ""
    inlet = inputs.markers
    inlet.close()
    c = engine.timed_markers
    text = f"{c.recorded:,} of {inlet.received:,} markers from LSL stream {inlet.name!r} recorded"
    dropped = inlet.dropped + engine.timed_marker_overflow
    why = [
        (c.before, "stamped before the recording started"),
        (c.after, "stamped or sent after the recording stopped"),
        (c.waiting, "still waiting for their sample when the unit stopped"),
        (dropped, f"dropped (the stream sent {inlet.budget_text})" if inlet.budget_text
         else "dropped (too many waiting at once)"),
    ]
    not_recorded = [f"{n:,} {reason}" for n, reason in why if n]
    if not_recorded:
        text += "; not recorded: " + ", ".join(not_recorded)
    if inlet.error:
        text += f"; last inlet error: {inlet.error}"
    return text


def outlet_opener(
    args: argparse.Namespace, meta: SessionMeta, outlets: dict[str, LslOutlets]
) -> Callable[[str, Engine], None]:
    """``before_stream(side, engine)`` opening each unit's outlets into ``outlets`` before its
    first frame (a recorder misses none): a leg's side in their names, source ids and
    descriptions, each with its own sample clock (``docs/lsl.md``)."""
    from gaitmon.engine import EngineError
    from gaitmon.lsl.outlets import LslOutlets

    def open_outlets(side: str, engine: Engine) -> None:
        unit_meta = dataclasses.replace(meta, side=side) if side else meta
        try:
            outlets[side] = LslOutlets.attach(
                engine, unit_meta, allow_patient_id=args.lsl_patient_id, leg=side
            )
        except Exception as exc:  # liblsl could not open its sockets
            whose = f"the {side} unit's" if side else "the"
            raise EngineError(f"could not open {whose} LSL streams: {exc}") from None
        if not args.quiet:
            names = ", ".join(repr(n) for n in outlets[side].names)
            print(f"gaitmon record: streaming to LSL as {names}", file=sys.stderr)

    return open_outlets


def close_outlets(outlets: dict[str, LslOutlets], linger_s: float = 0.0) -> None:
    """Every unit's outlets closed (``linger_s``: after the engines' last event, a recorder
    connected that long takes the rest first)."""
    for o in outlets.values():
        o.detach(linger_s=linger_s)
    outlets.clear()
