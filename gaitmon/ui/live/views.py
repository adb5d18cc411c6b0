"""The live monitor's two views and its guided start, as window slots.

The **clinical** view (the default) shows the chosen filter's joint angles (hip, knee, ankle;
the green trace only) large, above a compact foot-contact strip (the gait phase and the heel
and toe sensors), with the Gait panel. The **engineering** view adds the accelerometer and
gyro-integration traces, the segment tilts and the raw-sensor dock. View ▸ Engineering view
(Ctrl+E, also on the toolbar) switches; the choice is remembered. The guided start
(:mod:`.guide`) is fed here from the window's and the engine's state.
"""

from __future__ import annotations

from PySide6.QtGui import QAction
from PySide6.QtWidgets import QCheckBox, QDockWidget

from gaitmon.ui.actions import guarded
from gaitmon.ui.live.base import LiveWindowBase
from gaitmon.ui.live.guide import GuideBar, GuideState

ENGINEERING_KEY = "view/engineering"


class ViewSlots(LiveWindowBase):
    """Slots of the View menu's engineering toggle and Help ▸ Guided start."""

    act_engineering: QAction
    method_boxes: dict[str, QCheckBox]
    method_actions: dict[str, QAction]
    raw_dock: QDockWidget
    guide: GuideBar

    @property
    def engineering(self) -> bool:
        return self.live.engineering

    @guarded
    def set_engineering_view(self, on: bool) -> None:
        """View ▸ Engineering view: also the raw-sensor dock comes and goes with it."""
        self._apply_view(bool(on))
        self.raw_dock.setVisible(bool(on))

    def _apply_view(self, on: bool) -> None:
        """The view without touching the raw dock (a restored layout decides it)."""
        self.live.set_engineering(on)
        if self.act_engineering.isChecked() != on:
            self.act_engineering.setChecked(on)
        # which traces to draw is an engineering choice: the clinical view draws the filter's
        for box in self.method_boxes.values():
            box.setVisible(on)
        for a in self.method_actions.values():
            a.setEnabled(on)
        if not on:
            self.raw_dock.setVisible(False)
        self.prefs.set(ENGINEERING_KEY, on)
        if self.paused and self.last_snapshot is not None:
            self.live.update_from(self.last_snapshot)

    def _restore_view(self) -> None:
        self._apply_view(self.prefs.get(ENGINEERING_KEY, False, bool))

    @guarded
    def show_guide(self) -> None:
        """Help ▸ Guided start: the step bar again (after it was closed or recording began)."""
        self.guide.reopen()

    def _show_guide_state(self, zeroed: bool | None = None) -> None:
        """Feed the step bar; ``zeroed`` from a snapshot (None: keep the last one seen while
        connected)."""
        conn = self.conn
        if zeroed is None:
            zeroed = conn is not None and self.guide.state.connected and self.guide.state.zeroed
        self.guide.show_state(
            GuideState(
                connected=conn is not None,
                connecting=self._connecting,
                zeroed=bool(zeroed) and conn is not None,
                recording=self._recording,
                simulated=conn is not None and conn.simulated,
            )
        )
