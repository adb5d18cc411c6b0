"""The guided start: a step bar above the plots, Connect → stand still and Zero → Record.

Each step shows its state (done ✓, current, waiting) from the real state the window passes to
:meth:`GuideBar.show_state` (connected? zeroed, from the engine's snapshot? recording?); the
current step's button performs it by triggering the window's own action (so it does exactly
what the menu and the shortcut do), and a one-line hint says what to do. The bar collapses
when a zeroed recording starts; Help ▸ Guided start opens it again. A recording started without
a standing Zero keeps it open (opens it if it was closed) with a warning in the alert colour:
the angles are then relative to the sensor axes, and that is said where they are read.
"""

from __future__ import annotations

from dataclasses import dataclass

from PySide6.QtGui import QAction
from PySide6.QtWidgets import QHBoxLayout, QLabel, QPushButton, QSizePolicy, QToolButton, QWidget

from gaitmon.ui.theme import Colours

CONNECT, ZERO, RECORD, RECORDING = 0, 1, 2, 3  # the current step (RECORDING: all done)
DONE, CURRENT, WAITING = "done", "current", "waiting"
UNZEROED_WARNING = "Recording without a standing Zero"


@dataclass(frozen=True)
class GuideState:
    """What the guide looks at: all of it real state, none of it the guide's own."""

    connected: bool
    connecting: bool = False
    zeroed: bool = False
    recording: bool = False
    simulated: bool = False
    zero_source: str = ""  # where the angles' zero comes from (the engine's snapshot)


def current_step(state: GuideState) -> int:
    if not state.connected:
        return CONNECT
    if state.recording:
        return RECORDING
    return RECORD if state.zeroed else ZERO


def hint(state: GuideState) -> str:
    text = _step_hint(state)
    if state.connected and state.zero_source and not (state.recording and not state.zeroed):
        text += f" Angles' zero: {state.zero_source}."
    return text


def _step_hint(state: GuideState) -> str:
    step = current_step(state)
    if step == CONNECT:
        if state.connecting:
            return "Connecting to the unit…"
        return ("Choose the unit (or the simulated device) under Unit, or type its port "
                "(a path or bt://address), then press Connect.")
    if step == ZERO:
        sim = " (simulator: Device ▸ Simulator ▸ Stand still)" if state.simulated else ""
        return f"Ask the patient to stand upright and still, leg straight, then press Zero{sim}."
    if step == RECORD:
        walk = " (simulator: Device ▸ Simulator ▸ Walk again)" if state.simulated else ""
        return f"Zeroed: the angles read 0 in that pose. The patient may walk{walk}; press Record."
    if not state.zeroed:
        return (f"{UNZEROED_WARNING}: the angles are relative to the sensor axes (zero: "
                "estimated), not the standing pose. Zero (Ctrl+0) while the patient stands still "
                "sets it from then on.")  # fmt: skip
    return "Recording. M drops a marker; Stop (Ctrl+R) ends the session."


class GuideBar(QWidget):
    """The step bar. ``actions``: the window's Connect, Zero and Record actions, in step order."""

    TITLES = ("Connect", "Stand still, then Zero", "Record")

    def __init__(self, colours: Colours, actions: tuple[QAction, QAction, QAction]) -> None:
        super().__init__()
        self.setObjectName("guide-bar")
        self.colours = colours
        self.actions_ = actions
        self.state = GuideState(connected=False)
        self.dismissed = False  # the user closed it, or a recording started
        self.warning = False  # showing "recording without a standing Zero"
        self.states: list[str] = ["", "", ""]  # as shown
        lay = QHBoxLayout(self)
        lay.setContentsMargins(4, 2, 4, 2)
        lay.setSpacing(6)
        lay.addWidget(QLabel("<b>Start:</b>"))
        self.buttons: list[QPushButton] = []
        for i, action in enumerate(actions):
            if i:
                lay.addWidget(QLabel("→"))
            b = QPushButton()
            b.clicked.connect(action.trigger)
            b.setSizePolicy(QSizePolicy.Policy.Fixed, QSizePolicy.Policy.Fixed)
            self.buttons.append(b)
            lay.addWidget(b)
        self.hint_label = QLabel()
        self.hint_label.setWordWrap(True)  # two lines rather than a clipped hint
        self.hint_label.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Preferred)
        self.hint_label.setMinimumWidth(120)  # (the window fits an 854 px screen)
        lay.addSpacing(8)
        lay.addWidget(self.hint_label, 1)
        close = QToolButton()
        close.setText("✕")
        close.setAutoRaise(True)
        close.setToolTip("Hide the guided start (Help ▸ Guided start shows it again)")
        close.clicked.connect(self.dismiss)
        self.close_button = close
        lay.addWidget(close)
        self.show_state(self.state)

    def set_colours(self, colours: Colours) -> None:
        """A theme change: restyle the steps in the new shades."""
        self.colours = colours
        self.states = ["", "", ""]
        self.show_state(self.state)

    @property
    def hint_text(self) -> str:
        return self.hint_label.text()

    def dismiss(self) -> None:
        self.dismissed = True
        self.setVisible(False)

    def reopen(self) -> None:
        self.dismissed = False
        self.setVisible(True)
        self.show_state(self.state)

    def show_state(self, state: GuideState) -> None:
        started = state.recording and not self.state.recording
        unzeroed = state.recording and not state.zeroed
        warned, self.warning = self.warning, unzeroed
        self.state = state
        if unzeroed and not warned:  # said where the angles are read, until a Zero
            self.dismissed = False
            self.setVisible(True)
        elif started and not self.dismissed:
            self.dismiss()  # the guide has done its job: the plots get the room
        elif warned and not unzeroed and state.recording and not self.dismissed:
            self.dismiss()  # zeroed while recording: the warning has done its job
        style = f"QLabel {{ color: {self.colours.alert}; font-weight: 700; }}" if unzeroed else ""
        if self.hint_label.styleSheet() != style:
            self.hint_label.setStyleSheet(style)
        step = current_step(state)
        c = self.colours
        for i, (b, action) in enumerate(zip(self.buttons, self.actions_, strict=True)):
            kind = DONE if i < step else CURRENT if i == step else WAITING
            if i == ZERO and unzeroed:  # recording unzeroed: Zero is still to do
                kind = CURRENT
            restyle = kind != self.states[i]
            self.states[i] = kind
            mark = "✓ " if kind == DONE else f"{i + 1}  "
            title = self.TITLES[i]
            if kind == CURRENT and i == CONNECT and state.connecting:
                title = "Connecting…"
            text = f"{mark}{title}"
            if b.text() != text:
                b.setText(text)
            b.setEnabled(kind == CURRENT and action.isEnabled())
            if not restyle:
                continue
            if kind == DONE:
                style = f"QPushButton {{ color: {c.ok}; border: none; font-weight: 600; }}"
            elif kind == CURRENT:
                style = (
                    f"QPushButton {{ font-weight: 700; padding: 3px 12px; border-radius: 4px; "
                    f"border: 2px solid {c.ok}; }}"
                )
            else:
                style = "QPushButton { border: none; }"
            b.setStyleSheet(style)
            b.setToolTip(action.toolTip() if kind == CURRENT else "")
        text = hint(state)
        if self.hint_label.text() != text:
            self.hint_label.setText(text)
