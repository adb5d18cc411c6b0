"""CLI subcommands: each module defines add_arguments(parser) and run(args) -> int.

Options every command that writes spells the same way live here (:func:`add_force`,
:func:`add_quiet`), so ``--force`` and ``-q/--quiet`` mean the same in ``record``, ``export``,
``report`` and ``process``. Old spellings stay accepted as hidden aliases.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

# what analysing a damaged file's contents can raise (gaitmon.errors: batch jobs use it too)
from gaitmon.errors import DAMAGE_ERRORS

__all__ = ["DAMAGE_ERRORS", "DEBUG_ENV", "Progress", "add_force", "add_quiet",
           "damaged_file_guard"]  # fmt: skip


def add_force(p: argparse.ArgumentParser, what: str = "the output file") -> None:
    """``--force``: replace existing output (``--overwrite``, the old ``record`` spelling, is
    a hidden alias)."""
    p.add_argument("--force", action="store_true", help=f"replace {what} if it exists")
    p.add_argument("--overwrite", dest="force", action="store_true", help=argparse.SUPPRESS)


def add_quiet(p: argparse.ArgumentParser, what: str = "no progress or summary lines") -> None:
    """``-q/--quiet``: only warnings and errors on the terminal."""
    p.add_argument("-q", "--quiet", action="store_true", help=what)


# One BLAS thread, unless the user set their own: gaitmon's arithmetic is its own loops and small
# matrices, never a BLAS call large enough to share out, and OpenBLAS starts a thread per core
# at numpy's import (~35 ms of CPU on 2 cores) that then spins beside the live view and the
# recorder. Set before numpy is imported (the command line imports this package first:
# tests/test_command_imports).
USER_SET_BLAS_THREADS = "OPENBLAS_NUM_THREADS" in os.environ
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def user_environ() -> dict[str, str]:
    """The environment as the user started gaitmon (a benchmark's references run in it)."""
    env = dict(os.environ)
    if not USER_SET_BLAS_THREADS:
        env.pop("OPENBLAS_NUM_THREADS", None)
    return env


DEBUG_ENV = "GAITMON_DEBUG"  # set to 1: the last resort re-raises, so tests see the real error


@contextlib.contextmanager
def damaged_file_guard(path: str | os.PathLike[str]) -> Iterator[None]:
    """The last resort around a command's analysis of a file: an exception its contents cause
    becomes one "damaged file" line (exit 2). The reader validates what it can at the file's
    edge (:mod:`gaitmon.io.session.reader`); this catches what only shows deeper. An error of
    writing (a read-only drive, a full disk) is the output's, never called damage. With
    ``GAITMON_DEBUG=1`` the exception propagates, so a test can tell the two apart."""
    from gaitmon.errors import UserError, is_output_error, output_error_text

    try:
        yield
    except BrokenPipeError:  # the reader of our output went away: not the file's fault
        raise
    except DAMAGE_ERRORS as exc:
        if os.environ.get(DEBUG_ENV):
            raise
        if isinstance(exc, OSError) and is_output_error(exc, path):  # a write, not the file
            raise UserError(output_error_text(exc, exc.filename or "the output")) from None
        what = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise UserError(
            f"{Path(path).name} is damaged and cannot be analysed ({what}); "
            "the recording's own journal or a backup may hold a good copy"
        ) from None


class Progress:
    """Percent on stderr: rewritten in place on a terminal, every 10 % otherwise (``export``,
    ``batch``)."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.tty = sys.stderr.isatty()
        self.last = -1
        self.shown = False

    def __call__(self, fraction: float, detail: str = "") -> None:
        pct = int(100 * min(max(fraction, 0.0), 1.0))
        step = 1 if self.tty else 10
        if pct // step == self.last // step and pct != 100:
            return
        if pct == self.last:
            return
        self.last = pct
        self.shown = True
        tail = f" {detail}" if detail else ""
        if self.tty:
            sys.stderr.write(f"\r{self.label}: {pct:3d}%{tail}")
            if pct == 100:
                sys.stderr.write("\n")
        else:
            sys.stderr.write(f"{self.label}: {pct}%{tail}\n")
        sys.stderr.flush()


def add_side(p: argparse.ArgumentParser) -> None:
    """``--side L|R``: the leg to take from a file that records both legs."""
    p.add_argument(
        "--side", choices=("L", "R"), default=None,
        help="of a session that records both legs (bilateral): the leg to use",
    )  # fmt: skip


def check_side(path: str | os.PathLike[str], side: str | None) -> None:
    """One line (UserError) when a bilateral file comes without ``--side``, or ``--side``
    with a one-unit file."""
    from gaitmon.errors import UserError
    from gaitmon.io.session.parts import BOTH_LEGS, is_bilateral

    both = is_bilateral(path)
    name = Path(path).name
    if both and side is None:
        raise UserError(BOTH_LEGS.format(name=name))
    if side is not None and not both and Path(path).exists():
        raise UserError(f"{name} records one unit; leave --side out")


def run_command(add_arguments: Callable[[argparse.ArgumentParser], None],
                run: Callable[[argparse.Namespace], int], argv: list[str]) -> int:
    """Run a subcommand's module in this process as ``gaitmon`` would, without reaching up to
    the command line (``gaitmon bench`` measures commands this way); a UserError is exit 2."""
    from gaitmon.errors import UserError

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    try:
        return int(run(parser.parse_args(argv)) or 0)
    except UserError:
        return 2
