"""Plumbing the live monitor and the review window share: guarded slots and window actions.

A slot wrapped in :func:`guarded` never lets an exception reach Qt (which would print a
traceback, or abort in a virtual): the window's ``report_exception(where, exc)`` turns it into
one line for the user and a logged traceback, each window in its own way (status bar, banner).
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import Any, Protocol

from PySide6.QtCore import Qt
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QWidget


class ReportsExceptions(Protocol):
    def report_exception(self, where: str, exc: BaseException) -> None: ...


def guarded(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Run a slot; hand any exception to ``self.report_exception(slot name, exc)``.

    Qt passes signal arguments the slot may not want (``triggered(bool)``): extra positional
    arguments are dropped.
    """
    params = list(inspect.signature(fn).parameters.values())[1:]
    if any(p.kind == p.VAR_POSITIONAL for p in params):
        n_args: int | None = None
    else:
        n_args = sum(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params)

    @functools.wraps(fn)
    def wrapper(self: ReportsExceptions, *args: Any) -> Any:
        try:
            return fn(self, *(args if n_args is None else args[:n_args]))
        except Exception as exc:
            self.report_exception(fn.__name__, exc)
            return None

    return wrapper


def make_action(
    owner: QWidget,
    text: str,
    slot: Callable[..., Any] | None = None,
    shortcut: str | None = None,
    tip: str = "",
    checkable: bool = False,
    checked: bool = False,
) -> QAction:
    """An action of ``owner``'s window: shortcut, tool/status tip, slot.

    The action is added to ``owner`` so its shortcut works even when no menu or toolbar shows it.
    A checkable action's slot gets the new state; any other slot is called without arguments.
    """
    a = QAction(text, owner)
    if shortcut:
        a.setShortcut(QKeySequence(shortcut))
        a.setShortcutContext(Qt.ShortcutContext.WindowShortcut)
    if tip:
        a.setToolTip(tip)
        a.setStatusTip(tip)
    a.setCheckable(checkable)
    if checkable:
        a.setChecked(checked)
    if slot is not None:
        # explicit lambdas: PySide decides how many signal arguments to pass from the
        # callable's own parameters, which `guarded` hides
        if checkable:
            a.triggered.connect(lambda on, s=slot: s(on))
        else:
            a.triggered.connect(lambda *_, s=slot: s())
    owner.addAction(a)
    return a
