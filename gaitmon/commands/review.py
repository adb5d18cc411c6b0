"""``gaitmon review [FILE]``: open the review window (Qt is imported only when a display exists)."""

from __future__ import annotations

import argparse
from pathlib import Path

from gaitmon.cli import UserError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", nargs="?", default=None,
                   help="session file (.h5) to open; File ▸ Open otherwise")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    from gaitmon.ui import display_problem

    if args.file is not None and not Path(args.file).exists():
        raise UserError(f"{args.file} does not exist; check the file name and folder")
    problem = display_problem()
    if problem is not None:
        raise UserError(problem)
    try:
        from gaitmon.ui.review.window import run as run_window
    except ImportError as exc:  # PySide6 missing, or a system library Qt needs
        raise UserError(f"the desktop interface cannot start: {exc}") from None
    return run_window(args)
