"""Desktop integration files shipped inside the package, and their install into the user's menu.

``gaitmon.desktop`` (a freedesktop.org desktop entry), ``gaitmon.png`` (256 px, drawn by
:func:`gaitmon.ui.app.draw_icon`) and ``gaitmon.svg`` (the same drawing) install with
``pip install``; the windows take their icon from the PNG. ``gaitmon desktop install`` copies
the entry into ``$XDG_DATA_HOME/applications`` (``~/.local/share/applications``) with ``Exec``
set to this installation's ``gaitmon``, and the icons into the hicolor theme
(``icons/hicolor/256x256/apps``, ``icons/hicolor/scalable/apps``), so the applications menu
starts gaitmon; ``gaitmon desktop uninstall`` removes exactly those files. Linux (and other
freedesktop desktops) only. Qt-free: the command line uses it.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

from gaitmon.errors import UserError

HERE = Path(__file__).resolve().parent
DESKTOP_ID = "gaitmon"  # the entry's file name, QGuiApplication.setDesktopFileName's argument
ENTRY = HERE / f"{DESKTOP_ID}.desktop"
ICON_PNG = HERE / "gaitmon.png"
ICON_SVG = HERE / "gaitmon.svg"


def data_home() -> Path:
    """``$XDG_DATA_HOME``, by default ``~/.local/share`` (the freedesktop base directory spec:
    a relative value is ignored)."""
    value = os.environ.get("XDG_DATA_HOME", "")
    return Path(value) if os.path.isabs(value) else Path.home() / ".local" / "share"


def targets(home: Path | None = None) -> dict[Path, Path]:
    """Installed file -> the shipped file it is made from."""
    home = data_home() if home is None else home
    icons = home / "icons" / "hicolor"
    return {
        home / "applications" / f"{DESKTOP_ID}.desktop": ENTRY,
        icons / "256x256" / "apps" / f"{DESKTOP_ID}.png": ICON_PNG,
        icons / "scalable" / "apps" / f"{DESKTOP_ID}.svg": ICON_SVG,
    }


def exec_command() -> list[str]:
    """This installation's gaitmon: the ``gaitmon`` script beside the running interpreter
    (a virtual environment's ``bin``), else the one on PATH, else ``python -m gaitmon``."""
    beside = Path(sys.executable).parent / "gaitmon"
    if beside.is_file() and os.access(beside, os.X_OK):
        return [str(beside)]
    found = shutil.which("gaitmon")
    if found:
        return [str(Path(found).resolve())]
    return [sys.executable, "-m", "gaitmon"]


def quote_exec_arg(arg: str) -> str:
    """One argument of an ``Exec`` key: quoted when it holds a reserved character, with the
    spec's escapes inside quotes (the desktop entry spec, "The Exec key")."""
    if arg and not any(c in arg for c in ' \t\n"\'\\><~|&;$*?#()`'):
        return arg.replace("%", "%%")
    inner = "".join("\\" + c if c in '"`$\\' else c for c in arg).replace("%", "%%")
    # a backslash in a desktop file's string value is itself escaped
    return '"' + inner.replace("\\", "\\\\") + '"'


def entry_text(command: list[str] | None = None) -> str:
    """The shipped entry with ``Exec`` (and ``TryExec``) pointing at ``command``."""
    command = exec_command() if command is None else command
    lines = []
    for line in ENTRY.read_text(encoding="utf-8").splitlines():
        if line.startswith("Exec="):
            line = "Exec=" + " ".join(quote_exec_arg(a) for a in command)
        elif line.startswith("TryExec="):
            line = "TryExec=" + command[0]  # the program itself, unquoted (a path)
        lines.append(line)
    return "\n".join(lines) + "\n"


def _check_platform() -> None:
    if sys.platform == "win32" or sys.platform == "darwin":
        raise UserError(
            "gaitmon desktop installs a freedesktop.org menu entry (Linux desktops); on this "
            "system start gaitmon from a terminal or make a shortcut to it"
        )


def install(home: Path | None = None) -> list[Path]:
    """Write the entry and icons (replacing gaitmon's earlier ones); the files written."""
    _check_platform()
    written = []
    for dst, src in targets(home).items():
        try:
            dst.parent.mkdir(parents=True, exist_ok=True)
            tmp = dst.with_name(dst.name + ".tmp")
            if src == ENTRY:
                tmp.write_text(entry_text(), encoding="utf-8")
            else:
                shutil.copyfile(src, tmp)
            os.replace(tmp, dst)
        except OSError as exc:
            raise UserError(f"cannot write {dst}: {exc.strerror or exc}") from None
        written.append(dst)
    return written


def uninstall(home: Path | None = None) -> list[Path]:
    """Remove the files :func:`install` writes; the ones that were there."""
    _check_platform()
    removed = []
    for dst in targets(home):
        try:
            dst.unlink()
        except FileNotFoundError:
            continue
        except OSError as exc:
            raise UserError(f"cannot remove {dst}: {exc.strerror or exc}") from None
        removed.append(dst)
    return removed
