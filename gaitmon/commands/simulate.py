"""``gaitmon simulate``: run the simulated gait unit on a pseudo-terminal until interrupted.

Also the simulator's command-line options, shared with ``gaitmon record --simulate`` and
``gaitmon --simulate``, and :func:`sim_config_from_args`, which turns them into a
:class:`gaitmon.io.sim.config.SimConfig` (the only place an argparse namespace becomes one).
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
import threading
from collections.abc import Callable
from types import FrameType
from typing import TYPE_CHECKING

from gaitmon.errors import UserError
from gaitmon.io.sim.config import SimConfig, serve_on_pty
from gaitmon.io.sim.patterns import PATTERNS, REALISM_LEVELS

if TYPE_CHECKING:
    from gaitmon.io.sim.bilateral import BilateralConfig

DESCRIPTION = """\
Run a simulated gait unit (one leg: 4 IMUs + heel/toe FSRs sampled at 100 Hz) that speaks the
real gaitmon wire protocol on a pseudo-terminal, with optional frame loss and corruption.
"""

EPILOG = """\
The first line on standard output is the port path (flushed), so a script can read it:

  gaitmon simulate --pty > sim.out &
  until [ -s sim.out ]; do sleep 0.2; done;  port=$(head -n1 sim.out)

Open that path like a Bluetooth serial port (e.g. serial.Serial(port)); the unit speaks the
gaitmon protocol (docs/protocol.md): it is idle until it receives SELECT_KIND / START_STREAM /
REQUEST_FRAME / IDENTIFY / ZERO commands. The subject stands still for --standing-s seconds
(time for ZERO), then walks; with --stand they stand until told to walk. While it runs:

  kill -USR1 <pid>   the subject stops at the next step and stands still (zero now)
  kill -USR2 <pid>   the subject walks again

With --bilateral, two units (left and right leg) walk one walk on two pseudo-terminals: the
first line is the left unit's port, the second the right's. Each has its own sample clock
(--clock-offset-s, --drift-ppm), its own faults (--loss-pct and --corrupt-pct apply to each
link, drawn independently) and says its side and serial number in its IDENTITY frame. A value
list that starts with a minus sign needs '=': --drift-ppm=-22,37. SIGUSR1/2 are not available.

Stop with Ctrl-C or SIGTERM; the fault ledger is printed to standard error on exit.
"""


def _pct(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not 0.0 <= v <= 100.0:
        raise argparse.ArgumentTypeError(f"must be within 0..100, got {v}")
    return v


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not v > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {v}")
    return v


def _seconds(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not 0.0 <= v < math.inf:
        raise argparse.ArgumentTypeError(f"must be >= 0 s, got {v}")
    return v


def _speed(text: str) -> float:
    if text.lower() in ("max", "inf", "fast"):
        return math.inf
    return _positive(text)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.description = DESCRIPTION
    parser.epilog = EPILOG
    parser.add_argument(
        "--pty",
        action="store_true",
        help="serve the unit on a pseudo-terminal (the only mode at present; required)",
    )
    parser.add_argument(
        "--link",
        metavar="PATH",
        help="stable symlink to the port (default: a new /tmp/gaitmon-sim-XXXX/ttyGAIT0)",
    )
    add_simulator_options(parser)
    add_bilateral_options(parser.add_argument_group("two units, one per leg (--bilateral)"))


def add_simulator_options(
    parser: argparse.ArgumentParser | argparse._ArgumentGroup, *, side: bool = True
) -> None:
    """The simulated unit's options, shared by ``simulate``, ``record`` and the application.

    ``side=False`` leaves out ``--side`` for commands that have their own (the session's leg).
    """
    parser.add_argument(
        "--cadence",
        type=_positive,
        default=110.0,
        metavar="STEPS_PER_MIN",
        help="walking cadence in steps/min (default: 110)",
    )
    parser.add_argument(
        "--stride-cv",
        type=float,
        default=0.02,
        metavar="CV",
        help="stride-to-stride variability of stride time (default: 0.02)",
    )
    parser.add_argument(
        "--pattern",
        choices=sorted(PATTERNS),
        default="normal",
        help="gait pattern (default: normal)",
    )
    parser.add_argument(
        "--standing-s",
        type=float,
        default=5.0,
        metavar="S",
        help="seconds of quiet standing before walking starts (default: 5)",
    )
    parser.add_argument(
        "--stand",
        action="store_true",
        help="the subject stands still from the start until told to walk (the window's Device "
        "▸ Simulator ▸ Walk again, or SIGUSR2 to `gaitmon simulate`)",
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    if side:
        parser.add_argument(
            "--side", choices=("L", "R"), default="R", help="leg the unit is worn on (default: R)"
        )
    parser.add_argument(
        "--speed",
        type=_speed,
        default=1.0,
        metavar="FACTOR",
        help="time factor: 1 = real time, 10 = ten times faster, 'max' = as fast as the "
        "client reads (default: 1)",
    )
    parser.add_argument(
        "--loss-pct",
        type=_pct,
        default=0.0,
        metavar="PCT",
        help="percentage of data frames dropped at random (default: 0)",
    )
    parser.add_argument(
        "--corrupt-pct",
        type=_pct,
        default=0.0,
        metavar="PCT",
        help="percentage of data frames with 1-3 flipped bits (default: 0)",
    )
    parser.add_argument(
        "--heel-dead-at",
        type=_seconds,
        default=math.inf,
        metavar="S",
        help="the heel force sensor dies (reads ~0 counts, never loads) S seconds after the "
        "unit starts; the window's Device ▸ Simulator menu does it at any time (default: never)",
    )
    parser.add_argument(
        "--toe-stuck-at",
        type=_seconds,
        default=math.inf,
        metavar="S",
        help="the toe force sensor sticks loaded S seconds after the unit starts (default: never)",
    )
    parser.add_argument(
        "--realism",
        choices=REALISM_LEVELS,
        default="default",
        help="how hard the simulator is: 'real' adds what real feet and sensors do (gain and "
        "cross-axis errors, roll and 180-degree turns, a stance foot that is not still, stride "
        "length variability; docs/simulator.md) (default: default)",
    )


def sim_config_from_args(args: argparse.Namespace) -> SimConfig:
    """The options of :func:`add_simulator_options` as a SimConfig (UserError if one is bad).

    Without ``--side`` (``record`` has its own, the session's leg, which may be empty) the unit
    is worn on that side, or on the right.
    """
    try:
        return SimConfig(
            cadence_steps_min=args.cadence,
            stride_cv=args.stride_cv,
            pattern=args.pattern,
            standing_s=math.inf if getattr(args, "stand", False) else args.standing_s,
            seed=args.seed,
            side=getattr(args, "side", "") or "R",
            speed=args.speed,
            loss_pct=args.loss_pct,
            corrupt_pct=args.corrupt_pct,
            heel_dead_at_s=getattr(args, "heel_dead_at", math.inf),
            toe_stuck_at_s=getattr(args, "toe_stuck_at", math.inf),
            realism=getattr(args, "realism", "default"),
        )
    except ValueError as exc:
        raise UserError(str(exc)) from None


def _pair(kind: type[float] | type[int], what: str) -> Callable[[str], tuple[float, float]]:
    def parse(text: str) -> tuple[float, float]:
        parts = text.split(",")
        try:
            if len(parts) != 2:
                raise ValueError
            left, right = (float(kind(p.strip())) for p in parts)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"give {what} as LEFT,RIGHT (two numbers), got {text!r}"
            ) from None
        return left, right

    return parse


def add_bilateral_options(
    parser: argparse.ArgumentParser | argparse._ArgumentGroup, *, serve: bool = True
) -> None:
    """The options of a simulated pair of units (``gaitmon.io.sim.bilateral``); ``serve=False``
    leaves out ``--bilateral`` and ``--links`` (``gaitmon record`` has ``--simulate-bilateral``
    and no ports to name)."""
    if serve:
        parser.add_argument(
            "--bilateral",
            action="store_true",
            help="simulate two units, left and right leg, walking one walk (--side is ignored)",
        )
    parser.add_argument(
        "--asymmetry",
        choices=("none", "hemiparetic"),
        default="none",
        help="none: symmetric legs half a cycle apart; hemiparetic: the affected leg takes a "
        "shorter step (--step-ratio), a shorter stance (0.60 vs 0.66 of the stride) and swings "
        "with a stiff knee (default: none)",
    )
    parser.add_argument(
        "--affected", choices=("L", "R"), default="L", help="the affected leg (default: L)"
    )
    parser.add_argument(
        "--step-ratio",
        type=_positive,
        default=None,
        metavar="RATIO",
        help="affected / unaffected step time (default: 0.85 hemiparetic, 1 none)",
    )
    parser.add_argument(
        "--drift-ppm",
        type=_pair(float, "the drift in ppm"),
        default=(37.0, -22.0),
        metavar="L,R",
        help="each unit's crystal error in ppm, + = fast (default: 37,-22)",
    )
    parser.add_argument(
        "--clock-offset-s",
        type=_pair(float, "the clock offsets in seconds"),
        default=(0.2537, 0.0412),
        metavar="L,R",
        help="when each unit starts counting, s after the pair starts; within the standing "
        "time (default: 0.2537,0.0412)",
    )
    parser.add_argument(
        "--serials",
        type=_pair(int, "the serial numbers"),
        default=(1001, 1002),
        metavar="L,R",
        help="the units' serial numbers (default: 1001,1002)",
    )
    if not serve:
        return
    parser.add_argument(
        "--links",
        type=lambda t: tuple(t.split(",")),
        default=None,
        metavar="LEFT,RIGHT",
        help="stable symlinks to the two ports (default: ttyGAIT-L and ttyGAIT-R in a new "
        "/tmp/gaitmon-bisim-XXXX)",
    )


def bilateral_config_from_args(args: argparse.Namespace) -> BilateralConfig:
    """The simulator's and the pair's options as a BilateralConfig (UserError if one is bad)."""
    if getattr(args, "stand", False):
        raise UserError("--stand is not available with --bilateral; use --standing-s")
    for name in ("heel_dead_at", "toe_stuck_at"):
        if getattr(args, name, math.inf) != math.inf:
            raise UserError(
                f"--{name.replace('_', '-')} is not available with --bilateral yet; leave it out"
            )
    from gaitmon.io.sim.bilateral import BilateralConfig, UnitSpec, side_seed
    from gaitmon.io.sim.clock import CrystalClock
    from gaitmon.io.sim.faults import FaultConfig

    try:
        specs = [
            UnitSpec(
                serial=int(args.serials[i]),
                clock=CrystalClock(offset_s=args.clock_offset_s[i], ppm=args.drift_ppm[i]),
                faults=FaultConfig(
                    seed=side_seed(args.seed, side, 4),
                    loss_pct=args.loss_pct,
                    corrupt_pct=args.corrupt_pct,
                ),
            )
            for i, side in enumerate(("L", "R"))
        ]
        return BilateralConfig(
            cadence_steps_min=args.cadence,
            stride_cv=args.stride_cv,
            pattern=args.pattern,
            standing_s=args.standing_s,
            seed=args.seed,
            speed=args.speed,
            asymmetry=args.asymmetry,
            affected=args.affected,
            step_ratio=args.step_ratio,
            left=specs[0],
            right=specs[1],
        )
    except ValueError as exc:
        raise UserError(str(exc)) from None


def run(args: argparse.Namespace) -> int:
    if not args.pty:
        raise UserError(
            "nothing to do: pass --pty to serve the simulated unit on a pseudo-terminal"
        )
    if args.bilateral:
        return _run_bilateral(args)
    if args.links is not None:
        raise UserError("--links names the two ports of --bilateral; use --link for one unit")
    config = sim_config_from_args(args)
    try:
        sim = serve_on_pty(config, args.link)
    except OSError as exc:
        raise UserError(f"cannot create the pseudo-terminal or link: {exc}") from None
    unit = sim.unit

    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    def on_stand(signum: int, frame: FrameType | None) -> None:
        unit.stand_still()

    def on_walk(signum: int, frame: FrameType | None) -> None:
        unit.walk()

    handlers = {signal.SIGINT: on_signal, signal.SIGTERM: on_signal}
    if hasattr(signal, "SIGUSR1"):  # POSIX, as the pty itself
        handlers[signal.SIGUSR1] = on_stand
        handlers[signal.SIGUSR2] = on_walk
    old = {s: signal.signal(s, h) for s, h in handlers.items()}
    try:
        print(sim.link_path, flush=True)
        print(
            f"gaitmon simulate: serving {unit.identity.name} on {sim.slave_path} "
            f"(link {sim.link_path}); Ctrl-C to stop",
            file=sys.stderr,
            flush=True,
        )
        while not stop.wait(0.2):
            pass
    finally:
        sim.stop()
        unit.close()
        for s, h in old.items():
            signal.signal(s, h)
    summary = ", ".join(f"{k}={v}" for k, v in unit.ledger.summary().items())
    print(f"gaitmon simulate: stopped; {summary}", file=sys.stderr, flush=True)
    return 0


def _run_bilateral(args: argparse.Namespace) -> int:
    if args.link is not None:
        raise UserError("--bilateral serves two ports: name them with --links LEFT,RIGHT")
    links = args.links
    if links is not None and len(links) != 2:
        raise UserError(f"give --links as LEFT,RIGHT (two paths), got {','.join(links)!r}")
    config = bilateral_config_from_args(args)
    from gaitmon.io.sim.bilateral import serve_pair_on_ptys

    try:
        pair = serve_pair_on_ptys(config, links)
    except (OSError, ValueError) as exc:
        raise UserError(f"cannot create the pseudo-terminals or links: {exc}") from None

    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    handlers = {signal.SIGINT: on_signal, signal.SIGTERM: on_signal}
    old = {s: signal.signal(s, h) for s, h in handlers.items()}
    try:
        left, right = pair.link_paths
        print(left, flush=True)
        print(right, flush=True)
        for side, pty in (("L", pair.left), ("R", pair.right)):
            c = config.unit_spec(side).clock
            print(
                f"gaitmon simulate: {side} unit {pty.unit.identity.serial} on {pty.slave_path} "
                f"(link {pty.link_path}); clock offset {c.offset_s:g} s, drift {c.ppm:+g} ppm",
                file=sys.stderr,
                flush=True,
            )
        print("gaitmon simulate: Ctrl-C to stop", file=sys.stderr, flush=True)
        while not stop.wait(0.2):
            pass
    finally:
        pair.stop()
        pair.sim.close()
        for s, h in old.items():
            signal.signal(s, h)
    for side, unit in (("L", pair.sim.left), ("R", pair.sim.right)):
        summary = ", ".join(f"{k}={v}" for k, v in unit.ledger.summary().items())
        print(f"gaitmon simulate: {side} stopped; {summary}", file=sys.stderr, flush=True)
    return 0
