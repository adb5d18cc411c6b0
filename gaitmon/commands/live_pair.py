"""The live monitor's both-legs options: ``gaitmon --simulate-bilateral`` (with the simulated
pair's options, as ``gaitmon record --simulate-bilateral``) and ``gaitmon --ports LEFT,RIGHT``,
turned into a ``PairSource`` at this edge (``docs/bilateral.md``, "Live window")."""

from __future__ import annotations

import argparse
import math
from typing import TYPE_CHECKING

from gaitmon.errors import UserError

if TYPE_CHECKING:
    from gaitmon.io.sim.bilateral import BilateralConfig
    from gaitmon.live.pair import PairSource


def add_pair_options(parser: argparse.ArgumentParser) -> None:
    from gaitmon.commands.simulate import add_bilateral_options

    group = parser.add_argument_group("both legs, one unit each (docs/bilateral.md)")
    group.add_argument(
        "--simulate-bilateral",
        action="store_true",
        help="open the live monitor connected to a simulated pair of units, left and right leg",
    )
    group.add_argument(
        "--ports",
        metavar="LEFT,RIGHT",
        help="open the live monitor connected to two units: the left and the right leg's ports",
    )
    add_bilateral_options(
        parser.add_argument_group("simulated pair of units (with --simulate-bilateral)"),
        serve=False,
    )


def pair_from_args(args: argparse.Namespace) -> tuple[BilateralConfig | None, PairSource | None]:
    """(the simulated pair's settings, what to connect both legs to at once); UserError for a
    bad combination."""
    from gaitmon.commands.simulate import add_bilateral_options, bilateral_config_from_args
    from gaitmon.live.pair import PairSource

    defaults = argparse.ArgumentParser()
    add_bilateral_options(defaults, serve=False)
    given = [n for n, v in vars(defaults.parse_args([])).items() if getattr(args, n, v) != v]
    chosen = [name for name, on in (("--simulate", args.simulate),
                                    ("--simulate-bilateral", args.simulate_bilateral),
                                    ("--ports", args.ports is not None)) if on]  # fmt: skip
    if len(chosen) > 1:
        raise UserError(f"{' and '.join(chosen)}: choose one")
    if given and not args.simulate_bilateral:
        names = ", ".join("--" + n.replace("_", "-") for n in given)
        raise UserError(f"{names}: only with --simulate-bilateral")
    if args.simulate_bilateral:
        if math.isinf(args.speed):
            raise UserError(
                "--speed max is not available with --simulate-bilateral: the live window "
                "shows both legs in real time (give a factor, e.g. --speed 2)"
            )
        config = bilateral_config_from_args(args)
        return config, PairSource(sim=config)
    if args.ports is not None:
        ports = [p.strip() for p in str(args.ports).split(",")]
        if len(ports) != 2 or not all(ports) or ports[0] == ports[1]:
            raise UserError(
                f"--ports needs two different ports, left first: LEFT,RIGHT (got {args.ports!r})"
            )
        return None, PairSource(ports=(ports[0], ports[1]))
    return None, None
