"""``gaitmon review [FILE]``: open the review window (Qt is imported only when a display exists)."""

from __future__ import annotations

import argparse
from pathlib import Path

from gaitmon.commands import refuse_both_legs
from gaitmon.errors import UserError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", nargs="?", default=None,
                   help="session file (.h5) to open; File ▸ Open otherwise")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    from gaitmon.ui import launch

    if args.file is not None and not Path(args.file).exists():
        from gaitmon.io.session.parts import parts_of

        if not parts_of(args.file):
            raise UserError(f"{args.file} does not exist; check the file name and folder")
    refuse_both_legs(args.file, "review")
    return launch("gaitmon.ui.review.window", args)
