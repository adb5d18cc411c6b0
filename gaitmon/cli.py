"""The ``gaitmon`` command line. Each subcommand lives in its own module and registers here.

Only the module of the subcommand being run is imported (``gaitmon --help`` lists them from
:data:`SUBCOMMANDS` alone), so a command pays for what it uses and nothing else.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Callable, Sequence

from gaitmon import __version__
from gaitmon.errors import UserError

# name -> (module path, help). Modules define add_arguments(parser) and run(args) -> int.
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "record": ("gaitmon.commands.record", "record a session from the unit or the simulator"),
    "info": ("gaitmon.commands.info", "summarise a session (recovers an interrupted one)"),
    "process": ("gaitmon.commands.process", "re-run the pipeline offline with new settings"),
    "import": ("gaitmon.commands.import_xdf", "import a LabRecorder recording (.xdf) of gaitmon's "
               "LSL streams as a session file"),
    "batch": ("gaitmon.commands.batch", "reprocess every session of a study (local or Dask)"),
    "bench": ("gaitmon.commands.bench", "measure pipeline speed and print the figures"),
    "export": ("gaitmon.commands.export", "export a recorded session to CSV, MATLAB .mat or C3D"),
    "report": ("gaitmon.commands.report", "write the one-page clinical report (PDF) of a session"),
    "compare": ("gaitmon.commands.compare", "compare sessions of one patient (PDF): cycles, "
                "measures and changes"),
    "lab": ("gaitmon.commands.lab", "reproduce the papers' filter experiments as reports"),
    "ports": ("gaitmon.commands.ports", "list serial ports a unit could be on"),
    "simulate": ("gaitmon.commands.simulate", "run a simulated gait unit on a pseudo-terminal"),
    "review": ("gaitmon.commands.review", "open the review window: timeline, strides, gait cycles"),
}


Run = Callable[[argparse.Namespace], int]


def _load(module_path: str) -> tuple[Callable[[argparse.ArgumentParser], None], Run]:
    import importlib

    mod = importlib.import_module(module_path)
    return mod.add_arguments, mod.run


def open_live_monitor(args: argparse.Namespace) -> int:
    """No subcommand: the live monitor window (``--simulate``: connected to the simulator).

    The simulator options given here also apply when the simulated device is picked in the
    window; they become a SimConfig at this edge, never an argparse namespace inside the UI.
    """
    from gaitmon.commands.live_pair import pair_from_args
    from gaitmon.commands.simulate import sim_config_from_args
    from gaitmon.ui import run_app  # imports no Qt until a display is known to be there

    pair_sim, pair = pair_from_args(args)
    return run_app(
        sim_config_from_args(args),
        connect_simulated=bool(args.simulate),
        pair_sim=pair_sim,
        pair=pair,
    )


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser. Only ``command``'s module is loaded and its options known; every other
    subcommand is listed by name and help alone (so ``gaitmon --help`` loads none)."""
    parser = argparse.ArgumentParser(
        prog="gaitmon",
        description="Live monitor, recorder and reviewer for a wearable gait-measurement unit.",
    )
    parser.add_argument("--version", action="version", version=f"gaitmon {__version__}")
    # no subcommand: open the live monitor (gaitmon.ui, imported lazily: headless stays Qt-free)
    parser.epilog = "Without a COMMAND, gaitmon opens the live monitor window."
    parser.add_argument(
        "--simulate",
        action="store_true",
        help="open the live monitor connected to the simulated unit",
    )
    if command is None:  # the window's simulator options; a subcommand has its own
        from gaitmon.commands.simulate import add_simulator_options

        add_simulator_options(parser.add_argument_group("simulated unit (with --simulate)"))
        from gaitmon.commands.live_pair import add_pair_options

        add_pair_options(parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module_path, help_text) in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        if name == command:
            add_arguments, run = _load(module_path)
            add_arguments(p)
            p.set_defaults(_run=run)
    return parser


# Exit status when the reader of our standard output went away (``gaitmon info F | head -1``):
# what a shell reports for a program ended by SIGPIPE (128 + 13), as ``cat`` or ``grep`` give.
EXIT_BROKEN_PIPE = 141


def _quiet_broken_pipe() -> int:
    """The reader of standard output has gone: say nothing more there (Python's documented
    recipe: point stdout at devnull so the interpreter's final flush cannot fail again)."""
    # stdout without a file descriptor (a test's capture) has nothing to redirect
    with contextlib.suppress(OSError, ValueError, AttributeError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    return EXIT_BROKEN_PIPE


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    # the first word that names a subcommand is the subcommand (no option takes one as value)
    command = next((a for a in argv if a in SUBCOMMANDS), None)
    prog = f"gaitmon {command}" if command else "gaitmon"
    try:
        args = build_parser(command).parse_args(argv)
        run: Run = getattr(args, "_run", None) or open_live_monitor
        rc = int(run(args) or 0)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
        return rc
    except BrokenPipeError:
        return _quiet_broken_pipe()
    except UserError as exc:
        _stderr_line(f"{prog}: error: {exc}")
        return 2
    except KeyboardInterrupt:
        _stderr_line(f"{prog}: interrupted")
        return 130


def _stderr_line(text: str) -> None:
    """One line on stderr (a message with line breaks is joined: one problem, one line); a
    line that cannot be written (stderr closed too) is dropped."""
    with contextlib.suppress(OSError, ValueError):
        print(" ".join(text.split()), file=sys.stderr)


if __name__ == "__main__":
    raise SystemExit(main())
