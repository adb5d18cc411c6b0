"""The ``gaitmon`` command line. Each subcommand lives in its own module and registers here.

Only the module of the subcommand being run is imported (``gaitmon --help`` lists them from
:data:`SUBCOMMANDS` alone), so a command pays for what it uses and nothing else.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
from collections.abc import Callable, Sequence

from gaitmon import __version__, logs
from gaitmon.commands import DEBUG_ENV  # set: an internal error keeps its traceback (tests)
from gaitmon.errors import UserError

log = logging.getLogger("gaitmon.cli")


# name -> help. Each module (loaded by _load) defines add_arguments(parser) and run(args) -> int.
SUBCOMMANDS: dict[str, str] = {
    "record": "record a session from the unit or the simulator",
    "info": "summarise a session (recovers an interrupted one)",
    "process": "re-run the pipeline offline with new settings",
    "import": "import a LabRecorder recording (.xdf) of gaitmon's LSL streams as a session file",
    "batch": "reprocess every session of a study (local or Dask)",
    "bench": "measure pipeline speed and print the figures",
    "export": "export a recorded session to CSV, MATLAB .mat or C3D",
    "report": "write the one-page clinical report (PDF) of a session",
    "compare": "compare sessions of one patient (PDF): cycles, measures and changes",
    "lab": "reproduce the papers' filter experiments as reports",
    "ports": "list serial ports a unit could be on",
    "simulate": "run a simulated gait unit on a pseudo-terminal",
    "review": "open the review window: timeline, strides, gait cycles",
    "desktop": "put gaitmon in the applications menu (install) or take it out (uninstall)",
}


Run = Callable[[argparse.Namespace], int]


def _load(name: str) -> tuple[Callable[[argparse.ArgumentParser], None], Run]:
    """The subcommand's ``add_arguments`` and ``run``: its module, imported here plainly
    (only the one being run is loaded; the layer test sees each arrow)."""
    if name == "record":
        from gaitmon.commands import record

        return record.add_arguments, record.run
    if name == "info":
        from gaitmon.commands import info

        return info.add_arguments, info.run
    if name == "process":
        from gaitmon.commands import process

        return process.add_arguments, process.run
    if name == "import":
        from gaitmon.commands import import_xdf

        return import_xdf.add_arguments, import_xdf.run
    if name == "batch":
        from gaitmon.commands import batch

        return batch.add_arguments, batch.run
    if name == "bench":
        from gaitmon.commands import bench

        return bench.add_arguments, bench.run
    if name == "export":
        from gaitmon.commands import export

        return export.add_arguments, export.run
    if name == "report":
        from gaitmon.commands import report

        return report.add_arguments, report.run
    if name == "compare":
        from gaitmon.commands import compare

        return compare.add_arguments, compare.run
    if name == "lab":
        from gaitmon.commands import lab

        return lab.add_arguments, lab.run
    if name == "ports":
        from gaitmon.commands import ports

        return ports.add_arguments, ports.run
    if name == "simulate":
        from gaitmon.commands import simulate

        return simulate.add_arguments, simulate.run
    if name == "review":
        from gaitmon.commands import review

        return review.add_arguments, review.run
    if name == "desktop":
        from gaitmon.commands import desktop

        return desktop.add_arguments, desktop.run
    raise KeyError(name)


def open_live_monitor(args: argparse.Namespace) -> int:
    """No subcommand: the live monitor window (``--simulate``: connected to the simulator).

    The simulator options given here also apply when the simulated device is picked in the
    window; they become a SimConfig at this edge, never an argparse namespace inside the UI.
    """
    from gaitmon.commands.live_pair import pair_from_args
    from gaitmon.commands.simulate import sim_config_from_args
    from gaitmon.ui import launch  # imports no Qt until a display is known to be there

    pair_sim, pair = pair_from_args(args)
    # the window's run: sim, the simulated device's settings; connect_simulated: connect to
    # it at once; pair: connect both legs at once (pair_sim: the simulated pair's settings)
    return launch(
        _live_window,
        sim_config_from_args(args),
        connect_simulated=bool(args.simulate),
        pair_sim=pair_sim,
        pair=pair,
    )


def _live_window() -> Callable[..., int]:
    from gaitmon.ui.live import run

    return run


def terminal_columns() -> int:
    """``shutil.get_terminal_size().columns``, the width argparse's help is wrapped to, without
    importing shutil (with bz2 and lzma ~2 ms of every command: argparse makes a formatter for
    each option it adds): ``$COLUMNS``, else the terminal of standard output, else 80."""
    try:
        columns = int(os.environ["COLUMNS"])
    except (KeyError, ValueError):
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(sys.__stdout__.fileno()).columns  # type: ignore[union-attr]
        except (AttributeError, ValueError, OSError):
            columns = 0
        columns = columns or 80
    return columns


class HelpFormatter(argparse.HelpFormatter):
    """argparse's formatter, its default width from :func:`terminal_columns` (the same)."""

    def __init__(self, prog: str, indent_increment: int = 2, max_help_position: int = 24,
                 width: int | None = None) -> None:  # fmt: skip
        width = terminal_columns() - 2 if width is None else width
        super().__init__(prog, indent_increment, max_help_position, width)


# options that print and exit: given with nothing but these (and --verbose), the window's
# simulator options are not needed (``gaitmon --verbose`` alone opens the window: it needs them)
_PRINTING = frozenset({"--version", "--log-path"})


def build_parser(
    command: str | None = None, argv: Sequence[str] | None = None
) -> argparse.ArgumentParser:
    """The parser. Only ``command``'s module is loaded and its options known; every other
    subcommand is listed by name and help alone (so ``gaitmon --help`` loads none). ``argv``
    (the words to parse, when known) of only ``--version``/``--log-path``: without the live
    window's simulator options."""
    parser = argparse.ArgumentParser(
        prog="gaitmon",
        description="Live monitor, recorder and reviewer for a wearable gait-measurement unit.",
        formatter_class=HelpFormatter,
    )
    parser.add_argument(
        "--version", action=_Print, nargs=0, const=_version_text, help="print the version and "
        "where the log file is, and exit"
    )  # fmt: skip
    parser.add_argument(
        "--log-path", action=_Print, nargs=0, const=_log_path_text,
        help="print the log file's path and exit",
    )  # fmt: skip
    _add_verbose(parser)
    # no subcommand: open the live monitor (gaitmon.ui, imported lazily: headless stays Qt-free)
    parser.epilog = "Without a COMMAND, gaitmon opens the live monitor window."
    parser.add_argument(
        "--simulate",
        action="store_true",
        help="open the live monitor connected to the simulated unit",
    )
    words = set(argv or ())
    window = command is None and not (words & _PRINTING and words <= _PRINTING | {"--verbose"})
    if window:  # the window's simulator options; a subcommand has its own
        from gaitmon.commands.simulate import add_simulator_options

        add_simulator_options(parser.add_argument_group("simulated unit (with --simulate)"))
        from gaitmon.commands.live_pair import add_pair_options

        add_pair_options(parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    # a command given: its parser alone (each costs argparse ~1 ms); none: all, for the help
    for name, help_text in SUBCOMMANDS.items():
        if command is not None and name != command:
            continue
        p = sub.add_parser(name, help=help_text, description=help_text,
                           formatter_class=HelpFormatter)  # fmt: skip
        _add_verbose(p, argparse.SUPPRESS)  # also after the command: gaitmon record --verbose
        if name == command:
            add_arguments, run = _load(name)
            add_arguments(p)
            p.set_defaults(_run=run)
    return parser


def _add_verbose(p: argparse.ArgumentParser, default: object = False) -> None:
    p.add_argument(
        "--verbose", action="store_true", default=default,
        help="also show the log's information lines on the terminal (they always go to the "
        "log file: gaitmon --log-path)",
    )  # fmt: skip


def _log_path_text() -> str:
    from gaitmon import paths

    try:
        return str(paths.log_file())
    except ModuleNotFoundError:  # platformdirs missing: no log file
        return "none (platformdirs is not installed)"


def _version_text() -> str:
    return f"gaitmon {__version__} (log: {_log_path_text()})"


class _Print(argparse.Action):
    """Print ``const()`` as it is (argparse's version action would wrap a long path) and exit."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: object, option_string: str | None = None) -> None:  # fmt: skip
        print(self.const())
        parser.exit()


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
    # the log first (gaitmon.logs): what runs below may log; --verbose is read before parsing
    # so that an error while parsing is logged too
    log_path = logs.setup(verbose="--verbose" in argv)
    try:
        args = build_parser(command, argv).parse_args(argv)
        log.info("gaitmon %s (gaitmon %s)", " ".join(argv), __version__)
        run: Run = getattr(args, "_run", None) or open_live_monitor
        rc = int(run(args) or 0)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
        return rc
    except BrokenPipeError:
        return _quiet_broken_pipe()
    except UserError as exc:
        log.info("%s: error: %s", prog, exc, extra={"shown": True})
        _stderr_line(f"{prog}: error: {exc}")
        return 2
    except KeyboardInterrupt:
        log.info("%s: interrupted", prog, extra={"shown": True})
        _stderr_line(f"{prog}: interrupted")
        return 130
    except Exception as exc:  # a bug: its traceback to the log file, one line to the user
        if os.environ.get(DEBUG_ENV):
            raise
        log.exception("%s: internal error", prog)
        where = f"; details in {log_path}" if log_path else ""
        what = " ".join(str(exc).split())[:200] or type(exc).__name__
        _stderr_line(f"{prog}: internal error: {what}{where}")
        return 1


def _stderr_line(text: str) -> None:
    """One line on stderr (a message with line breaks is joined: one problem, one line); a
    line that cannot be written (stderr closed too) is dropped."""
    with contextlib.suppress(OSError, ValueError):
        print(" ".join(text.split()), file=sys.stderr)


if __name__ == "__main__":
    raise SystemExit(main())
