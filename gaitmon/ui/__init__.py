"""Desktop user interface. The only package in gaitmon that imports Qt (PySide6, pyqtgraph).

Importing this package does not import Qt: `run_app` checks for a display first and loads the
window lazily, so the command line keeps working on a headless machine.
"""

from __future__ import annotations

import os
import sys
from typing import Any


def display_problem() -> str | None:
    """Why no window can be shown here (one line), or None when a display looks available."""
    if os.environ.get("QT_QPA_PLATFORM"):
        return None  # the user chose a platform (offscreen, xcb, wayland, ...)
    if sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        return (
            "no display available (DISPLAY and WAYLAND_DISPLAY are not set): run gaitmon on a "
            "desktop session, or use the command-line subcommands (gaitmon --help)"
        )
    return None


def run_app(args: Any) -> int:
    """Open the live monitor (``args.simulate``: connect straight to the simulated unit)."""
    from gaitmon.cli import UserError

    problem = display_problem()
    if problem is not None:
        raise UserError(problem)
    try:
        from gaitmon.ui.app import run
    except ImportError as exc:  # PySide6 missing, or a system library Qt needs
        raise UserError(f"the desktop interface cannot start: {exc}") from None
    return run(args)
