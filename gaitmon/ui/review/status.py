"""What the review window tells the user: the problem banner, the notes, the job's progress bar
with its Cancel button, the angles shown (their method, always in the status bar) and
status-bar messages.

:class:`StatusArea` builds these widgets into the window (the banner and notes above the
timeline, the progress bar in the status bar) and is the one place that shows or hides them.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (
    QHBoxLayout,
    QLabel,
    QMainWindow,
    QProgressBar,
    QPushButton,
    QToolButton,
    QWidget,
)

from gaitmon.ui.dialogs import ERROR_STYLE

PROBLEM_MS = 15_000  # a problem also stays in the status bar this long
PROGRESS_STEPS = 1000  # the bar's range: tenths of a percent


class StatusArea:
    """The banner, notes and progress widgets of one window; see the module docstring."""

    def __init__(self, window: QMainWindow, on_cancel: Callable[[], None]) -> None:
        self._window = window
        self.last_problem = ""
        self.banner = QLabel()
        self.banner.setWordWrap(True)
        self.banner.setStyleSheet(ERROR_STYLE)
        self.banner.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.banner_close = QToolButton()
        self.banner_close.setText("✕")
        self.banner_close.setToolTip("Hide this message")
        self.banner_close.clicked.connect(self.hide_problem)
        banner_row = QHBoxLayout()
        banner_row.setContentsMargins(0, 0, 0, 0)
        banner_row.addWidget(self.banner, 1)
        banner_row.addWidget(self.banner_close)
        self.banner_box = QWidget()
        self.banner_box.setLayout(banner_row)
        self.banner_box.setVisible(False)
        self.notes = QLabel()
        self.notes.setWordWrap(True)
        self.notes.setVisible(False)

        sb = window.statusBar()
        # which angles every lane, the strides and the cycles show (View ▸ Angles switches)
        self.angles = QLabel()
        self.angles.setVisible(False)
        # the status bar two lines tall from the start (the angles' method, their zero): grown
        # under a message shown, it had Qt show the hint (a normal widget the message hides)
        # over the message
        two_lines = 2 * self.angles.fontMetrics().lineSpacing() + 2
        self.angles.setMinimumHeight(two_lines)
        sb.setMinimumHeight(two_lines + 4)
        sb.addPermanentWidget(self.angles)
        self.progress = QProgressBar()
        self.progress.setRange(0, PROGRESS_STEPS)
        self.progress.setMaximumWidth(220)
        self.progress.setTextVisible(False)
        self.progress_label = QLabel()
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setToolTip("Stop the running job")
        self.cancel_button.clicked.connect(on_cancel)
        for w in self._progress_widgets:
            sb.addPermanentWidget(w)
            w.setVisible(False)
        self.hint = QLabel("Shift+drag on the timeline selects a range; E excludes it.")
        sb.addWidget(self.hint)

    @property
    def _progress_widgets(self) -> tuple[QWidget, ...]:
        return (self.progress_label, self.progress, self.cancel_button)

    # -- messages --------------------------------------------------------------------------------

    def message(self, text: str, timeout_ms: int = 0) -> None:
        """A line in the status bar (0: until the next one)."""
        self._window.statusBar().showMessage(text, timeout_ms)

    def show_problem(self, text: str) -> None:
        self.last_problem = text
        self.banner.setText(text)
        self.banner_box.setVisible(True)
        self.message(text, PROBLEM_MS)

    def hide_problem(self) -> None:
        self.banner_box.setVisible(False)

    def show_notes(self, notes: list[str]) -> None:
        """Problems worth a line that do not stop the work (recovery, side file, ...)."""
        self.notes.setText(" · ".join(f"Note: {n}" for n in notes))
        self.notes.setVisible(bool(notes))

    def show_angles(self, method: str, tip: str) -> None:
        """The method behind the angles shown ("" when no session is open), and where their
        zero comes from on a second line: on one line the two were ~800 px wide and cut the
        status bar's message (the file shown) at the window's default width."""
        name, _sep, zero = method.partition(" · zero: ")
        text = f"Angles: <b>{name}</b>" + (f"<br>zero: {zero}" if zero else "")
        self.angles.setText(text if method else "")
        self.angles.setToolTip(tip)
        self.angles.setVisible(bool(method))

    # -- progress --------------------------------------------------------------------------------

    def show_progress(self, label: str, fraction: float) -> None:
        self.progress_label.setText(label)
        self.progress.setValue(int(PROGRESS_STEPS * max(0.0, min(1.0, fraction))))
        for w in self._progress_widgets:
            w.setVisible(True)

    def hide_progress(self) -> None:
        for w in self._progress_widgets:
            w.setVisible(False)
