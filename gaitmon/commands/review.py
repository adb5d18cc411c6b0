"""``gaitmon review [FILE] [--side L|R]``: open the review window (Qt is imported only when a
display exists). A file that records both legs opens on its left leg, or on ``--side``'s; the
window's leg chooser switches."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

from gaitmon.commands import add_side
from gaitmon.errors import UserError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", nargs="?", default=None,
                   help="session file (.h5) to open; File ▸ Open otherwise")  # fmt: skip
    add_side(p)


def run(args: argparse.Namespace) -> int:
    from gaitmon.ui import launch

    if args.file is not None:
        from gaitmon.io.session.parts import session_files

        # a journal or the parts alone are a session too: recovered as it is opened
        if not (Path(args.file).exists() or session_files(args.file)):
            raise UserError(f"{args.file} does not exist; check the file name and folder")
    if args.side is not None:
        from gaitmon.io.session.parts import is_bilateral

        if args.file is None:
            raise UserError("--side goes with a FILE that records both legs; name the file")
        if not is_bilateral(args.file):
            raise UserError(f"{Path(args.file).name} records one unit; leave --side out")
    return launch(_review_window, args)


def _review_window() -> Callable[..., int]:
    from gaitmon.ui.review.window import run

    return run
