"""A status bar whose texts shrink instead of being cut (issue 25: a window on an 854 px screen).

:class:`FittingLabel` shows the longest of its texts (most to least said) that fits its width,
the longest always in its tooltip: the status bar's labels give way in a narrow window, word by
word, never mid-word. :class:`MessageBar` draws a message too long for its room with the
file path in it elided in the middle (the rest of the message whole), the whole message in its
tooltip; ``currentMessage()`` stays the whole text.
"""

from __future__ import annotations

import re

from PySide6.QtCore import QRect, QSize, Qt
from PySide6.QtGui import QFontMetrics, QPainter, QPaintEvent, QResizeEvent, QTextDocument
from PySide6.QtGui import Qt as QtGuiQt
from PySide6.QtWidgets import (
    QLabel,
    QSizeGrip,
    QSizePolicy,
    QStatusBar,
    QStyle,
    QStyleOption,
    QWidget,
)

_PATH = re.compile(r"\S*[/\\]\S*")  # a token with a path separator in it
MESSAGE_MIN_PX = 420  # the status bar leaves its message at least this


def text_width(label: QLabel, text: str) -> int:
    """Width ``label`` needs for ``text`` on one line (rich text laid out as QLabel does)."""
    if QtGuiQt.mightBeRichText(text):
        doc = QTextDocument()
        doc.setDefaultFont(label.font())
        doc.setDocumentMargin(0)
        doc.setHtml(text)
        return int(doc.idealWidth() + 0.999)
    return label.fontMetrics().horizontalAdvance(text)


class FittingLabel(QLabel):
    """A one-line label with texts from the most to the least said: it shows the first that
    fits, and its size hints are the first's width (preferred) and the last's (minimum)."""

    def __init__(self, tooltip: str = "", parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._texts: tuple[str, ...] = ("",)
        self._widths: tuple[int, ...] = (0,)
        self._tooltip = tooltip
        self.setToolTip(tooltip)
        self.setSizePolicy(QSizePolicy.Policy.Preferred, QSizePolicy.Policy.Preferred)

    @property
    def full_text(self) -> str:
        return self._texts[0]

    def set_texts(self, *texts: str, tooltip: str | None = None) -> None:
        """Show the first of ``texts`` that fits (the first in the tooltip when another is
        shown); ``tooltip``: a new tooltip under it."""
        if tooltip is not None:
            self._tooltip = tooltip
        texts = tuple(t for t in texts if t) or ("",)
        if texts != self._texts:
            self._texts = texts
            widths = tuple(text_width(self, t) for t in texts)
            if widths != self._widths:
                self._widths = widths
                self.updateGeometry()
                bar = self.parentWidget()
                if isinstance(bar, MessageBar):  # now, not at the next layout pass: a
                    bar.relayout()  # count grown by a digit is never drawn cut meanwhile
        self._fit()

    def _room(self) -> int:
        return self.contentsRect().width() - 2 * self.margin()

    def _fit(self) -> None:
        room = self._room()
        k = next((i for i, w in enumerate(self._widths) if w <= room), len(self._texts) - 1)
        text = self._texts[k]
        if self.text() != text:
            super().setText(text)
        tip = self._tooltip
        if k:  # the whole text, where a shorter one is shown
            plain = QTextDocument()
            plain.setHtml(self._texts[0])
            whole = plain.toPlainText() if QtGuiQt.mightBeRichText(self._texts[0]) else (
                self._texts[0])  # fmt: skip
            tip = f"{whole}\n{tip}" if tip else whole
        if self.toolTip() != tip:
            self.setToolTip(tip)

    def _hint(self, width: int) -> QSize:
        m = self.contentsMargins()
        h = super().sizeHint().height()
        return QSize(width + m.left() + m.right() + 2 * self.margin(), h)

    def sizeHint(self) -> QSize:
        return self._hint(self._widths[0])

    def widths_with_margins(self) -> list[int]:
        """The width each of its texts needs, margins included, from the widest down."""
        extra = self._hint(0).width()
        return sorted({w + extra for w in self._widths}, reverse=True)

    def minimumSizeHint(self) -> QSize:
        return self._hint(self._widths[-1])

    def resizeEvent(self, event: QResizeEvent) -> None:
        super().resizeEvent(event)
        self._fit()


def fit_message(text: str, metrics: QFontMetrics, room: int) -> str:
    """``text`` as it fits ``room`` px: whole, or its longest path elided in the middle (the
    words around it whole), or, with no path or still too long, elided at the end."""
    if metrics.horizontalAdvance(text) <= room:
        return text
    paths = sorted(_PATH.finditer(text), key=lambda m: len(m.group()), reverse=True)
    if paths:
        m = paths[0]
        head, tail = text[: m.start()], text[m.end() :]
        left = room - metrics.horizontalAdvance(head + tail)
        if left >= metrics.horizontalAdvance("…/x…"):
            path = metrics.elidedText(m.group(), Qt.TextElideMode.ElideMiddle, left)
            return head + path + tail
    return metrics.elidedText(text, Qt.TextElideMode.ElideRight, room)


class MessageBar(QStatusBar):
    """A status bar that fits its message to the room its permanent widgets leave
    (:func:`fit_message`), the whole message in its tooltip when cut."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._own_tip: str | None = None  # the tooltip this bar set (a cut message), if any
        self._other_tip = ""
        self.messageChanged.connect(lambda _text: self._tip())

    def _permanent(self) -> list[QWidget]:
        direct = Qt.FindChildOption.FindDirectChildrenOnly
        return [w for w in self.findChildren(QWidget, options=direct)
                if not w.isHidden() and not isinstance(w, QSizeGrip)]  # fmt: skip

    def relayout(self) -> None:
        """Share the width again and lay the permanent widgets out at once."""
        self.share_width()
        lay = self.layout()
        if lay is not None:
            lay.invalidate()
            lay.activate()

    def share_width(self) -> None:
        """Leave the message at least :data:`MESSAGE_MIN_PX`: the fitting labels' widths are
        capped, the widest giving way first, a text at a time (Qt gives a message only what
        the permanent widgets leave)."""
        widgets = self._permanent()
        fitting = [w for w in widgets if isinstance(w, FittingLabel)]
        if not fitting:
            return
        spacing = 10 * len(widgets) + 20  # the layout's spacing and margins, generously
        fixed = sum(w.sizeHint().width() for w in widgets if not isinstance(w, FittingLabel))
        budget = self.width() - MESSAGE_MIN_PX - fixed - spacing
        # the widest label gives way first, a text at a time, until the message has its room
        steps = [w.widths_with_margins() for w in fitting]
        at = [0] * len(fitting)
        while sum(st[k] for st, k in zip(steps, at, strict=True)) > budget:
            can = [i for i, st in enumerate(steps) if at[i] + 1 < len(st)]
            if not can:
                break
            widest = max(can, key=lambda i: steps[i][at[i]])
            at[widest] += 1
        for w, st, k in zip(fitting, steps, at, strict=True):
            if w.maximumWidth() != st[k]:
                w.setMaximumWidth(st[k])

    def message_rect(self) -> QRect:
        """Where Qt draws the message: from 6 px to 2 px left of the first visible permanent
        widget (QStatusBarPrivate::messageRect, left to right)."""
        right = self.width() - 12
        for w in self.findChildren(QWidget, options=Qt.FindChildOption.FindDirectChildrenOnly):
            if w.isVisible() and not isinstance(w, QSizeGrip) and w.width() > 0:
                right = min(right, w.x() - 2)
        return QRect(6, 0, max(0, right - 6), self.height())

    def drawn_message(self) -> str:
        """The message as drawn (what a user reads)."""
        return fit_message(self.currentMessage(), self.fontMetrics(), self.message_rect().width())

    def _tip(self) -> None:
        """The whole message in the tooltip while it is cut; the tooltip given by others
        (a refused Zero's figures) back when it is not."""
        msg = self.currentMessage()
        if msg and self.drawn_message() != msg:
            if self._own_tip is None:
                self._other_tip = self.toolTip()
            if self.toolTip() != msg:
                self.setToolTip(msg)
            self._own_tip = msg
        elif self._own_tip is not None:
            if self.toolTip() == self._own_tip:
                self.setToolTip(self._other_tip)
            self._own_tip = None

    def resizeEvent(self, event: QResizeEvent) -> None:
        super().resizeEvent(event)
        self.share_width()
        self._tip()

    def paintEvent(self, event: QPaintEvent) -> None:
        msg = self.currentMessage()
        self._tip()  # (the permanent widgets may have moved since the message came)
        if not msg:
            super().paintEvent(event)
            return
        # as QStatusBar::paintEvent draws it, with the message fitted to its room
        p = QPainter(self)
        opt = QStyleOption()
        opt.initFrom(self)
        self.style().drawPrimitive(QStyle.PrimitiveElement.PE_PanelStatusBar, opt, p, self)
        p.setPen(self.palette().windowText().color())
        p.drawText(self.message_rect(), int(Qt.AlignmentFlag.AlignLeading
                   | Qt.AlignmentFlag.AlignVCenter | Qt.TextFlag.TextSingleLine),
                   self.drawn_message())  # fmt: skip
        p.end()
