"""Desktop user interface. The only package in gaitmon that imports Qt (PySide6, pyqtgraph).

Importing this package does not import Qt: `launch` (behind the live monitor and `gaitmon review`)
checks for a display first and loads the window lazily, so the command line keeps working on a
headless machine.
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import sys
from collections.abc import Callable
from pathlib import Path

XCB_HINT = (
    "install the X11 client libraries Qt needs, e.g. on Debian/Ubuntu: sudo apt install "
    "libxcb-cursor0 libxcb-icccm4 libxcb-keysyms1 libxcb-shape0 libxkbcommon-x11-0"
)


def one_line(exc: BaseException) -> str:
    """The first line of an exception's message (its type's name when the message is empty)."""
    text = str(exc).strip()
    return (text.splitlines()[0] if text else "") or type(exc).__name__


def xcb_plugin_problem(plugin: Path | None = None) -> str | None:
    """Why Qt's X11 plugin would fail to load (one line), or None.

    Qt aborts the process when no platform plugin loads (a missing libxcb-cursor0 is the usual
    cause on a fresh Linux desktop); loading the plugin ourselves first turns that into a
    message naming the missing library.
    """
    if plugin is None:
        spec = importlib.util.find_spec("PySide6")  # locate without importing Qt
        if spec is None or not spec.submodule_search_locations:
            return None
        root = Path(next(iter(spec.submodule_search_locations)))
        plugin = root / "Qt" / "plugins" / "platforms" / "libqxcb.so"
    if not plugin.exists():
        return None
    try:
        ctypes.CDLL(str(plugin))
    except OSError as exc:
        return f"the Qt X11 platform plugin cannot load ({one_line(exc)}); {XCB_HINT}"
    return None


def display_problem() -> str | None:
    """Why no window can be shown here (one line), or None when a display looks available."""
    platform = os.environ.get("QT_QPA_PLATFORM", "")
    if platform and not platform.startswith("xcb"):
        return None  # the user chose a platform (offscreen, wayland, ...)
    if not sys.platform.startswith("linux"):
        return None
    if not platform and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return (
            "no display available (DISPLAY and WAYLAND_DISPLAY are not set): run gaitmon on a "
            "desktop session, or use the command-line subcommands (gaitmon --help)"
        )
    if platform.startswith("xcb") or not os.environ.get("WAYLAND_DISPLAY"):
        return xcb_plugin_problem() or x_display_problem()
    return None


def x_display_problem() -> str | None:
    """Why the X server in $DISPLAY cannot be reached (Qt would abort), or None."""
    try:
        xcb = ctypes.CDLL("libxcb.so.1")
    except OSError:
        return None  # the plugin check reports missing libraries
    xcb.xcb_connect.restype = ctypes.c_void_p
    xcb.xcb_connect.argtypes = [ctypes.c_char_p, ctypes.c_void_p]
    xcb.xcb_connection_has_error.argtypes = [ctypes.c_void_p]
    xcb.xcb_disconnect.argtypes = [ctypes.c_void_p]
    conn = xcb.xcb_connect(None, None)  # None: use $DISPLAY, as Qt will
    try:
        failed = xcb.xcb_connection_has_error(conn)
    finally:
        xcb.xcb_disconnect(conn)
    if failed:
        display = os.environ.get("DISPLAY", "")
        return (
            f"cannot connect to the X display {display!r}: is the desktop session running and "
            "may this user use it?"
        )
    return None


def launch(load: Callable[[], Callable[..., int]], *args: object, **kwargs: object) -> int:
    """Run ``load()(*args, **kwargs)`` when a window can open: ``load`` imports a gaitmon.ui
    module that opens a window (plainly, inside it) and returns its ``run``.

    No display, or Qt not importable (PySide6 missing, or a system library it needs), is a
    one-line ``gaitmon.errors.UserError``; the module, and with it Qt, is imported only after the
    display check, because Qt aborts the process when its platform plugin cannot start.
    """
    from gaitmon.errors import UserError

    problem = display_problem()
    if problem is not None:
        raise UserError(problem)
    try:
        run = load()
    except ImportError as exc:  # PySide6 missing, or a system library Qt needs
        raise UserError(f"the desktop interface cannot start: {exc}") from None
    return int(run(*args, **kwargs))
