"""``gaitmon record``'s units: built from the options (one unit: ``--simulate`` / ``--port``;
both legs: ``--simulate-bilateral`` / ``--ports LEFT,RIGHT``) into one
:class:`~gaitmon.engine.pair.EngineGroup`, and the lines that speak of them (progress, warnings,
the closing summary). A one-unit group is keyed by ``""`` (no leg: the session's ``--side``
says which, if any), a pair by ``"L"`` and ``"R"``."""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from gaitmon.commands.simulate import sim_config_from_args
from gaitmon.errors import UserError
from gaitmon.text import count

if TYPE_CHECKING:
    from gaitmon.engine import Engine
    from gaitmon.engine.pair import EngineGroup
    from gaitmon.io.sim.unit import SimulatedUnit
    from gaitmon.io.transport import Transport


@dataclass(frozen=True)
class Units:
    """The engines of one recording, and what the command needs to know of their source."""

    group: EngineGroup
    simulated: bool
    # each simulated unit by side: its ground truth goes into its recording at the end
    truth: Mapping[str, SimulatedUnit] = field(default_factory=dict)


def both_legs(args: argparse.Namespace) -> bool:
    """The options ask for both legs (a pair of units) rather than one unit."""
    return bool(args.simulate_bilateral) or args.ports is not None


def refuse_one_unit_options(args: argparse.Namespace) -> None:
    """The options that only make sense for one unit, refused with both legs."""
    both = "--simulate-bilateral" if args.simulate_bilateral else "--ports"
    if args.side:
        raise UserError(f"--side names the leg of one unit; with {both} both legs are recorded")
    inputs = ("lsl_control", "lsl_markers", "lsl_control_source_id", "lsl_markers_source_id")
    if any(getattr(args, n, None) is not None for n in inputs):
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


def build(args: argparse.Namespace) -> Units:
    """The units the options name, each with its engine (not started)."""
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.engine import Engine
    from gaitmon.engine.pair import EngineGroup
    from gaitmon.io.device import Device
    from gaitmon.io.session.parts import SIDES
    from gaitmon.io.transport import InProcessTransport

    links: dict[str, tuple[Transport, str]] = {}  # side: (link, how the file names it)
    truth: dict[str, SimulatedUnit] = {}
    if args.simulate_bilateral:
        from gaitmon.commands.simulate import bilateral_config_from_args
        from gaitmon.io.sim.bilateral import BilateralSim

        sim = BilateralSim(bilateral_config_from_args(args))
        truth = dict(zip(SIDES, sim.units, strict=True))
        links = {s: (InProcessTransport(u, name=f"simulated {s}"), "simulated")
                 for s, u in truth.items()}  # fmt: skip
    elif args.simulate:
        from gaitmon.io.sim.config import build_unit

        one = sim_config_from_args(args)
        if math.isfinite(one.standing_s):
            # the subject's standing counts from the first streamed sample, not from when the
            # unit was made: the zero and the recording see the same samples at any speed or
            # load (it stands, from the unit's making, until then)
            truth = {"": build_unit(dataclasses.replace(one, standing_s=math.inf))}
            truth[""].stand_until_streamed(one.standing_s)
        else:
            truth = {"": build_unit(one)}
        links = {"": (InProcessTransport(truth[""]), "simulated")}
    else:
        from gaitmon.io.ports import make_transport

        if args.ports is not None:
            ports = [p.strip() for p in str(args.ports).split(",")]
            if len(ports) != 2 or not all(ports) or ports[0] == ports[1]:
                raise UserError(
                    "--ports needs two different ports, left first: LEFT,RIGHT "
                    f"(got {args.ports!r})"
                )
            named = dict(zip(SIDES, ports, strict=True))
        else:
            named = {"": args.port}
        # serial, or bt://ADDRESS
        links = {s: (make_transport(p, args.baud), p) for s, p in named.items()}
    engines: dict[str, Engine] = {
        s: Engine(Device(t), args.mode, PipelineConfig(), transport_label=label)
        for s, (t, label) in links.items()
    }
    return Units(EngineGroup(engines), simulated=bool(truth), truth=truth)


def warn_wrong_legs(group: EngineGroup) -> list[str]:
    """A leg's unit that says it is configured for the other leg (--ports the wrong way
    round): one warning each."""
    out = []
    for side, eng in group.engines.items():
        said = eng.identity.side if eng.identity is not None else ""
        if side and said in ("L", "R") and said != side:
            out.append(
                f"warning: the unit recorded as the {side} leg (serial "
                f"{eng.identity.serial if eng.identity else '?'}) says it is worn on {said}; "
                "check the order of --ports (left first)"
            )
    return out


def progress_line(group: EngineGroup, out: Path, duration_s: float) -> str:
    """Where the recording is: one unit's seconds and rows, or each leg's seconds."""
    seen = {s: min(group.recorded_s(s), duration_s) for s in group.sides}
    if not group.in_parts:
        ((side, eng),) = group.engines.items()
        link = eng.device.stats
        return (
            f"recording {out.name}: {seen[side]:6.1f} / {duration_s:g} s, "
            f"{eng.recording.rows} frames, {link.decoder.frames_lost} lost, "
            f"{link.decoder.crc_failures} CRC errors, link {link.transport.state.value}"
        )
    legs = "; ".join(
        f"{side} {seen[side]:6.1f} s, {eng.device.stats.decoder.frames_lost} lost, "
        f"link {eng.device.stats.transport.state.value}"
        for side, eng in group.engines.items()
    )
    return f"recording {out.name}: {legs} / {duration_s:g} s"


def stalled_message(side: str, stall_s: float, recorded_s: float, duration_s: float,
                    out: Path) -> str:  # fmt: skip
    unit = f"the {side} unit" if side else "the unit"
    return (
        f"{unit} sent no data for {stall_s:g} s, so the recording stopped after "
        f"{recorded_s:.1f} of {duration_s:g} s; {out} holds what was received "
        "(check the unit's power and link)"
    )


def summary_lines(group: EngineGroup, out: Path) -> list[str]:
    """The closing lines: what each unit recorded and lost, and the file written, as the
    finished file states them (``gaitmon info``'s counts: the link's own totals also hold
    what it lost before the recording started and after it stopped)."""
    from gaitmon.commands.info import LinkCounts
    from gaitmon.finish import open_session

    rows, lost = {}, {}
    for side in group.sides:
        with open_session(out, side=side or None) as s:
            link = LinkCounts.of(s)
            rows[side] = count(s.n_samples, "frame")
            lost[side] = f"{link.lost_text()}, {link.units_text()}"
    size = f"{out.stat().st_size / 1e6:.1f} MB"
    if not group.in_parts:
        return [f"wrote {rows['']} to {out} ({size}); {lost['']}"]
    return [
        *(f"{side} {rows[side]}, {lost[side]}" for side in group.sides),
        f"wrote both legs to {out} ({size})",
    ]


def engine_of_one(group: EngineGroup) -> Engine:
    """The engine of a one-unit group (the LSL inputs feed and wait on it)."""
    (engine,) = group.engines.values()
    return engine
