"""What the walk-through test (tests/test_walkthrough.py) checks on any window it visits: text
cut short (a label, the status bar's message, a table cell or header narrower than its text),
and a window's picture for a person to look at; and its waits (on a condition, for a
module-scoped fixture that has no qtbot) and the PDFs' text.

Widths are measured as Qt draws them: the widget's own font (a cell's FontRole), rich text laid
out by QTextDocument as a QLabel does, minus the margins the style leaves. A text wider than its
room counts as cut whether Qt clips it or elides it (a table cell's "…"); a "…" the text
itself holds ("waiting for complete strides…") does not."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QFont, QFontMetrics, QTextDocument
from PySide6.QtGui import Qt as QtGuiQt
from PySide6.QtTest import QTest
from PySide6.QtWidgets import (
    QAbstractItemView,
    QApplication,
    QHeaderView,
    QLabel,
    QSizeGrip,
    QStatusBar,
    QStyle,
    QTableView,
    QWidget,
)

SLACK_PX = 1  # rounding between QFontMetrics and the painter
WAIT_S = 120.0  # a condition, never a duration: generous for a busy 2-core machine


def _label_text_width(label: QLabel) -> tuple[str, int]:
    """(plain text, width it needs on one line per line) of ``label``, as it draws it."""
    text = label.text()
    rich = label.textFormat() == Qt.TextFormat.RichText or (
        label.textFormat() == Qt.TextFormat.AutoText and QtGuiQt.mightBeRichText(text)
    )
    if rich:
        doc = QTextDocument()
        doc.setDefaultFont(label.font())
        doc.setDocumentMargin(0)
        doc.setHtml(text)
        return doc.toPlainText(), int(doc.idealWidth() + 0.999)
    fm = label.fontMetrics()
    plain = text.replace("&&", "\0").replace("&", "").replace("\0", "&") if label.buddy() else text
    return plain, max(fm.horizontalAdvance(line) for line in plain.split("\n"))


def label_problems(label: QLabel) -> list[str]:
    if not label.isVisible() or label.text().strip() == "":
        return []
    plain, need = _label_text_width(label)
    name = f"label {plain[:60]!r}"
    cr = label.contentsRect()
    room = cr.width() - 2 * label.margin() - max(label.indent(), 0)
    seen = label.visibleRegion().boundingRect()
    if label.wordWrap():
        # wrapped: every line is whole if the label is as tall as its text at its width
        want = label.heightForWidth(label.width())
        if want > label.height() + SLACK_PX:
            return [f"{name}: wraps to {want} px, {label.height()} px tall"]
        if seen.height() + SLACK_PX < min(want, label.height()):
            return [f"{name}: {seen.height()} of {want} px visible"]
        return []
    if need > room + SLACK_PX:
        return [f"{name}: needs {need} px, has {room}"]
    if seen.width() + SLACK_PX < min(need, room):
        return [f"{name}: {seen.width()} of {need} px visible"]
    return []


def message_room(bar: QStatusBar) -> int:
    """The width (px) Qt gives the status bar's message: from 6 px to 2 px left of its first
    visible permanent widget (QStatusBarPrivate::messageRect), or width - 12."""
    right = bar.width() - 12
    for w in bar.findChildren(QWidget, options=Qt.FindChildOption.FindDirectChildrenOnly):
        if w.isVisible() and not isinstance(w, QSizeGrip) and w.width() > 0:
            right = min(right, w.x() - 2)
    return right - 6


def status_message_problems(bar: QStatusBar) -> list[str]:
    """The status bar's message is drawn left of its first visible permanent widget (Qt's
    QStatusBarPrivate::messageRect: from 6 px to that widget's x - 2, or width - 12)."""
    msg = bar.currentMessage()
    if not bar.isVisible() or not msg:
        return []
    drawn = getattr(bar, "drawn_message", None)
    if drawn is not None and drawn() != msg:
        # a bar that fits its message (gaitmon.ui.live.bar.MessageBar): only a path may be
        # elided (in the middle, the words around it whole), the whole message in its tooltip
        shown = drawn()
        head, _, tail = shown.partition("…")
        path_cut = bool(re.search(r"[/\\]", head.split(" ")[-1] + tail.split(" ")[0]))
        if not (path_cut and msg.startswith(head) and msg.endswith(tail)):
            return [f"status message {msg[:70]!r}: drawn as {shown!r}"]
        if bar.toolTip() != msg:
            return [f"status message {msg[:70]!r}: elided, not in the tooltip"]
        msg = shown
    room = message_room(bar)
    need = bar.fontMetrics().horizontalAdvance(msg)
    return [f"status message {msg[:70]!r}: needs {need} px, has {room}"] if need > room else []


def _cell_margin(view: QAbstractItemView) -> int:
    return view.style().pixelMetric(QStyle.PixelMetric.PM_FocusFrameHMargin, None, view) + 1


def table_problems(view: QTableView) -> list[str]:
    if not view.isVisible() or view.model() is None:
        return []
    m = view.model()
    out: list[str] = []
    margin = _cell_margin(view)
    vp = view.viewport().rect()
    hh: QHeaderView = view.horizontalHeader()
    if hh.isVisible():
        hm = view.style().pixelMetric(QStyle.PixelMetric.PM_HeaderMargin, None, hh)
        fm = QFontMetrics(hh.font())
        for c in range(m.columnCount()):
            if view.isColumnHidden(c):
                continue
            title = str(m.headerData(c, Qt.Orientation.Horizontal) or "")
            need = max((fm.horizontalAdvance(t) for t in title.split("\n")), default=0)
            if title and need + 2 * hm > hh.sectionSize(c) + SLACK_PX:
                out.append(f"header {title!r}: needs {need + 2 * hm} px, has {hh.sectionSize(c)}")
    for r in range(m.rowCount()):
        top = view.rowViewportPosition(r)
        if view.isRowHidden(r) or top + view.rowHeight(r) < 0 or top > vp.bottom():
            continue
        for c in range(m.columnCount()):
            if view.isColumnHidden(c):
                continue
            idx = m.index(r, c)
            text = idx.data(Qt.ItemDataRole.DisplayRole)
            if text is None or str(text) == "":
                continue
            text = str(text)
            font = idx.data(Qt.ItemDataRole.FontRole)
            fm = QFontMetrics(font if isinstance(font, QFont) else view.font())
            need = max(fm.horizontalAdvance(t) for t in text.split("\n"))
            room = view.columnWidth(c) - 2 * margin
            if need > room + SLACK_PX:
                out.append(f"cell ({r}, {c}) {text!r}: needs {need} px, has {room}")
                continue
            # where the text is drawn must be inside the viewport (a table wider than its
            # viewport clips its last columns: "excluded: crosses a g")
            x = view.columnViewportPosition(c)
            align = idx.data(Qt.ItemDataRole.TextAlignmentRole)
            flags = Qt.AlignmentFlag(int(align)) if align is not None else (
                Qt.AlignmentFlag.AlignLeft)  # fmt: skip
            if flags & Qt.AlignmentFlag.AlignRight:
                left = x + view.columnWidth(c) - margin - need
            elif flags & Qt.AlignmentFlag.AlignHCenter:
                left = x + (view.columnWidth(c) - need) // 2
            else:
                left = x + margin
            if left < -SLACK_PX or left + need > vp.width() + SLACK_PX:
                out.append(f"cell ({r}, {c}) {text!r}: drawn at {left}..{left + need} px, "
                           f"the viewport shows 0..{vp.width()}")  # fmt: skip
    return out


def cut_text(window: QWidget) -> list[str]:
    """Every text cut short in ``window`` (and its visible dialogs): labels, the status bar's
    message, table cells and headers."""
    out: list[str] = []
    for label in window.findChildren(QLabel):
        out += label_problems(label)
    for bar in window.findChildren(QStatusBar):
        out += status_message_problems(bar)
    for view in window.findChildren(QTableView):
        out += table_problems(view)
    return out


def settled_cut_text(window: QWidget, timeout_s: float = 3.0) -> list[str]:
    """:func:`cut_text` once the layout has caught up with the texts: a label given a longer
    text gets its height at the next layout pass, and a live window sets texts at every
    snapshot, so one look can fall between the two (CI, loaded: a gait-cycle title that had
    just wrapped to a second line, 42 px against 28). What stays cut for ``timeout_s`` is
    returned."""
    deadline = time.monotonic() + timeout_s
    while True:
        QApplication.processEvents()
        out = cut_text(window)
        if not out or time.monotonic() > deadline:
            return out
        QTest.qWait(30)


def number(text: str, pattern: str) -> str:
    """The first group of ``pattern`` in ``text`` (the test fails naming the text if none)."""
    found = re.search(pattern, text)
    assert found is not None, f"{pattern!r} not in {text[:2000]!r}"
    return found.group(1)


SHOTS = os.environ.get("GAITMON_WALK_SHOTS", "")


def shot(widget: QWidget, name: str) -> None:
    """With GAITMON_WALK_SHOTS=DIR, the window's picture in DIR/NAME.png (for a person)."""
    if SHOTS:
        Path(SHOTS).mkdir(parents=True, exist_ok=True)
        widget.grab().save(str(Path(SHOTS) / f"{name}.png"))


def keep(path: Path) -> None:
    """With GAITMON_WALK_SHOTS=DIR, a copy of ``path`` (a PDF) in DIR (for a person)."""
    if SHOTS:
        Path(SHOTS).mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, Path(SHOTS) / path.name)


def wait_until(pred: Callable[[], object], what: str, timeout_s: float = WAIT_S,
               window: QWidget | None = None) -> None:  # fmt: skip
    """Process Qt events until ``pred()`` is true (qtbot.waitUntil for a module fixture);
    on a timeout, what ``window``'s status bar said."""
    deadline = time.monotonic() + timeout_s
    while not pred():
        if time.monotonic() > deadline:
            said = window.statusBar().currentMessage() if window is not None else ""
            raise AssertionError(f"timed out waiting for {what} ({said!r})")
        QTest.qWait(20)


def truncated_words(text: str) -> list[str]:
    """Words a PDF cut short ("gaitmon-sim f…"); a "…" between spaces is a range."""
    return re.findall(r"\S*\w…", text)


def gaitmon_threads() -> set[threading.Thread]:
    return {t for t in threading.enumerate() if t.name.startswith("gaitmon")}


def wait_threads_gone(before: set[threading.Thread]) -> None:
    wait_until(lambda: not [t for t in gaitmon_threads() - before if t.is_alive()],
               "the windows' threads to end", 60)  # fmt: skip


def pdf_text(pdf: Path) -> str:
    out = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True,
                         text=True, check=True)  # fmt: skip
    return " ".join(out.stdout.split())


def current_points(win) -> int:
    """The most points of the current stride's line in the hip, knee and ankle cycle plots."""
    return max(0 if (x := c.getData()[0]) is None else len(x)
               for c in win.gait_panel.cycles.current)  # fmt: skip


def drawn_after_gap(snap) -> bool:
    """The current stride the engine hands the panel starts after the newest lost sample."""
    lost = np.flatnonzero(snap.series["lost"] > 0)
    n = len(snap.gait.current_pct)
    return not (len(lost) and n) or len(snap.series["t_s"]) - n > lost[-1]


@dataclass(frozen=True)
class Truth:
    """The recording's figures from the one analysis (gaitmon.analysis), as each surface
    formats them; the surfaces must show exactly these."""

    n_total: int
    n_included: int
    stride_s: float
    stride_sd_s: float
    stance_pct: float
    cadence: float
    length_m: float
    speed_m_s: float
    duration: str
    side: str
    zero: str
    gaps: int
    n_across_gap: int  # strides excluded as crossing a gap


def truth_of(path: Path) -> Truth:
    from gaitmon.analysis import GAP, analyse_session
    from gaitmon.finish import open_session
    from gaitmon.text import duration_text, side_text

    with open_session(path) as s:
        an = analyse_session(s)
        summ, sp = an.summary(), an.spatial()
        return Truth(len(an.rows), an.n_included, summ.stride_time_mean_s,
                     summ.stride_time_sd_s, summ.stance_pct_mean,
                     summ.cadence_derived_steps_per_min, sp.stride_length_mean_m,
                     sp.speed_mean_m_s, duration_text(s.duration_s), side_text(s.meta.side),
                     s.zero_source, len(s.gaps),
                     sum(r.excluded == GAP for r in an.rows))  # fmt: skip


def sim_action(win, text: str):
    """Device ▸ Simulator ▸ ``text`` (the menu's own action)."""
    return next(a for a in win.sim_menu.actions() if a.text().replace("&", "") == text)


def show_at_default_size(win: QWidget) -> None:
    """Shown at the size a first start opens it (1400 x 860), not as restored on the offscreen
    platform's 800 x 800 screen (the small screen is looked at on purpose, at 854 x 774)."""
    win.show()
    win.resize(1400, 860)
    QApplication.processEvents()


def record_dialog(win, path: Path, *, patient: str = "", side: str | None = None) -> None:
    """Record ▸ the session dialog filled and accepted (no unzeroed question may come)."""
    asked: list[str] = []

    def no_question() -> None:  # a question would block in its own loop: answer and note it
        box = win.recording_part.unzeroed_box
        if box is not None:
            asked.append(box.text())
            box.reject()

    QTimer.singleShot(0, no_question)
    win.act_record.trigger()
    assert asked == [], asked
    dlg = win.recording_part.session_dialog
    assert dlg is not None and dlg.isVisible()
    if patient:
        dlg.patient.setText(patient)
    if side is not None:
        dlg.side.setCurrentIndex(dlg.side.findData(side))
    dlg.path.setText(str(path))
    dlg.path.textEdited.emit(str(path))
    dlg.buttons.buttons()[0].click()
    assert win.recording, win.statusBar().currentMessage()
