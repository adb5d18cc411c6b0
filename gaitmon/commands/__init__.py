"""CLI subcommands: each module defines add_arguments(parser) and run(args) -> int.

Options every command that writes spells the same way live here (:func:`add_force`,
:func:`add_quiet`), so ``--force`` and ``-q/--quiet`` mean the same in ``record``, ``export``,
``report`` and ``process``. Old spellings stay accepted as hidden aliases.
"""

from __future__ import annotations

import argparse
import contextlib
import os
from collections.abc import Iterator
from pathlib import Path


def add_force(p: argparse.ArgumentParser, what: str = "the output file") -> None:
    """``--force``: replace existing output (``--overwrite``, the old ``record`` spelling, is
    a hidden alias)."""
    p.add_argument("--force", action="store_true", help=f"replace {what} if it exists")
    p.add_argument("--overwrite", dest="force", action="store_true", help=argparse.SUPPRESS)


def add_quiet(p: argparse.ArgumentParser, what: str = "no progress or summary lines") -> None:
    """``-q/--quiet``: only warnings and errors on the terminal."""
    p.add_argument("-q", "--quiet", action="store_true", help=what)


# What analysing a damaged file's contents can raise past the reader's checks (numpy on odd
# shapes, h5py on a bad chunk). TypeError, AttributeError, NameError are left out: they are
# programming errors, and stay tracebacks.
DAMAGE_ERRORS: tuple[type[BaseException], ...] = (
    ValueError, IndexError, KeyError, OSError, RuntimeError, ZeroDivisionError,
    FloatingPointError, OverflowError,
)  # fmt: skip

DEBUG_ENV = "GAITMON_DEBUG"  # set to 1: the last resort re-raises, so tests see the real error


@contextlib.contextmanager
def damaged_file_guard(path: str | os.PathLike[str]) -> Iterator[None]:
    """The last resort around a command's analysis of a file: an exception its contents cause
    becomes one "damaged file" line (exit 2). The reader validates what it can at the file's
    edge (:mod:`gaitmon.io.session.reader`); this catches what only shows deeper. With
    ``GAITMON_DEBUG=1`` the exception propagates, so a test can tell the two apart."""
    from gaitmon.errors import UserError

    try:
        yield
    except BrokenPipeError:  # the reader of our output went away: not the file's fault
        raise
    except DAMAGE_ERRORS as exc:
        if os.environ.get(DEBUG_ENV):
            raise
        what = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise UserError(
            f"{Path(path).name} is damaged and cannot be analysed ({what}); "
            "the recording's own journal or a backup may hold a good copy"
        ) from None
