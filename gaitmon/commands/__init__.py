"""CLI subcommands: each module defines add_arguments(parser) and run(args) -> int.

Options every command that writes spells the same way live here (:func:`add_force`,
:func:`add_quiet`), so ``--force`` and ``-q/--quiet`` mean the same in ``record``, ``export``,
``report`` and ``process``. Old spellings stay accepted as hidden aliases.
"""

from __future__ import annotations

import argparse


def add_force(p: argparse.ArgumentParser, what: str = "the output file") -> None:
    """``--force``: replace existing output (``--overwrite``, the old ``record`` spelling, is
    a hidden alias)."""
    p.add_argument("--force", action="store_true", help=f"replace {what} if it exists")
    p.add_argument("--overwrite", dest="force", action="store_true", help=argparse.SUPPRESS)


def add_quiet(p: argparse.ArgumentParser, what: str = "no progress or summary lines") -> None:
    """``-q/--quiet``: only warnings and errors on the terminal."""
    p.add_argument("-q", "--quiet", action="store_true", help=what)
