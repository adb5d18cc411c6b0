"""The review window's Open recent list, kept in its QSettings (``review/recent``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QMenu

MAX_RECENT = 8
KEY = "review/recent"


def recent_files(settings: QSettings) -> list[str]:
    value = settings.value(KEY, [])
    if isinstance(value, str):
        return [value]
    return [str(v) for v in value] if isinstance(value, list) else []


def add_recent(settings: QSettings, path: Path) -> None:
    p = str(path.resolve())
    items = [p, *(r for r in recent_files(settings) if r != p)][:MAX_RECENT]
    settings.setValue(KEY, items)


def fill_recent(menu: QMenu, settings: QSettings, open_file: Callable[[str], None]) -> None:
    """The submenu as it is about to show: one entry a file (its full path as the tip), and
    Clear the list."""
    menu.clear()
    items = recent_files(settings)
    if not items:
        a = menu.addAction("(none yet)")
        a.setEnabled(False)
        return
    for p in items:
        a = menu.addAction(Path(p).name)
        a.setToolTip(p)
        a.setStatusTip(p)
        a.triggered.connect(lambda _checked=False, p=p: open_file(p))
    menu.addSeparator()
    clear = menu.addAction("Clear the list")
    clear.triggered.connect(lambda: settings.setValue(KEY, []))
