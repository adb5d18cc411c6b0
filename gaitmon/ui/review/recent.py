"""What the review window remembers in its QSettings, by the keys named once in
:class:`gaitmon.review.settings.ReviewKey`: the Open recent list and the last folders."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QMenu

from gaitmon.review.settings import ReviewKey

MAX_RECENT = 8
KEY = ReviewKey.RECENT.key


def folder(settings: QSettings, key: ReviewKey) -> str:
    """A remembered folder (the home folder until one is)."""
    return str(settings.value(key.key, key.default))


def remember(settings: QSettings, key: ReviewKey, value: object) -> None:
    settings.setValue(key.key, str(value) if key.kind is str else value)


def recent_files(settings: QSettings) -> list[str]:
    value = settings.value(KEY, ReviewKey.RECENT.default)
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
