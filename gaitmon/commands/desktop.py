"""``gaitmon desktop install|uninstall``: gaitmon in the applications menu (Linux desktops)."""

from __future__ import annotations

import argparse
import shutil
import subprocess

from gaitmon.ui import desktop  # Qt-free: file locations and copying only


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "action",
        choices=("install", "uninstall"),
        help="install: write gaitmon's menu entry and icon into your user's data folder "
        "($XDG_DATA_HOME, ~/.local/share), starting this installation's gaitmon; uninstall: "
        "remove them",
    )


def run(args: argparse.Namespace) -> int:
    if args.action == "install":
        written = desktop.install()
        for path in written:
            print(f"wrote {path}")
        _refresh(written[0].parent)
        print(f"gaitmon is in the applications menu; it starts {desktop.exec_command()[0]}")
        return 0
    removed = desktop.uninstall()
    for path in removed:
        print(f"removed {path}")
    if not removed:
        print("gaitmon's menu entry was not installed; nothing to remove")
    else:
        _refresh(removed[0].parent)
    return 0


def _refresh(applications: object) -> None:
    """Tell the desktop's menu cache, where the tool is there (most desktops watch the folder
    and need nothing)."""
    tool = shutil.which("update-desktop-database")
    if tool:
        subprocess.run([tool, "-q", str(applications)], check=False, capture_output=True)
