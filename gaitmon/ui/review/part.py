"""What every part of the review window shares: the window it belongs to (:class:`Host`).

The review window is composed of parts (has-a, not a stack of base classes): each
:class:`Part` owns its widgets, its slots and its workers, reads the document the window shows
(:attr:`Part.doc`), listens to that document's change events from :meth:`Part.document_set`
(:mod:`gaitmon.review.events`; the document drops its listeners when it is closed), and reports
an unexpected exception in one of its slots through the window (``guarded``).
"""

from __future__ import annotations

from typing import Protocol

from PySide6.QtCore import QObject, QSettings

from gaitmon.review.model import Document
from gaitmon.ui.review.status import StatusArea


class Host(Protocol):
    """The review window, as its parts see it."""

    settings: QSettings
    status: StatusArea

    @property
    def doc(self) -> Document | None: ...

    def report_exception(self, where: str, exc: BaseException) -> None: ...


class Part(QObject):
    """One part of the review window (see the module docstring)."""

    def __init__(self, host: Host, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.host = host
        self.status = host.status
        self.settings = host.settings

    @property
    def doc(self) -> Document | None:
        """The document the window shows (None when none is open)."""
        return self.host.doc

    def report_exception(self, where: str, exc: BaseException) -> None:
        self.host.report_exception(where, exc)

    def document_set(self, doc: Document | None) -> None:
        """``doc`` is shown now (None: none): subscribe to its events, show its state."""
