"""The live monitor's Lab Streaming Layer slots: Device ▸ Stream to LSL and its patient-id
permission, both checkable and remembered.

While the action is on and a unit is connected, :class:`gaitmon.lsl.outlets.LslOutlets`
listens to the engine (on the engine thread) and publishes the streams of ``docs/lsl.md``;
nothing LSL exists otherwise (pylsl is imported only when it is turned on). Without pylsl the
action turns itself off with one line saying what to install.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from PySide6.QtGui import QAction

from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.live.base import LiveWindowBase

if TYPE_CHECKING:
    from gaitmon.lsl.outlets import LslOutlets

LSL_KEY = "lsl/enabled"
LSL_PATIENT_KEY = "lsl/patient_id"


class LslSlots(LiveWindowBase):
    """Slots of Device ▸ Stream to LSL / Patient id in LSL streams."""

    act_lsl: QAction
    act_lsl_patient: QAction
    lsl_outlets: LslOutlets | None

    @property
    def lsl_streaming(self) -> bool:
        return self.lsl_outlets is not None

    @guarded
    def set_lsl_streaming(self, on: bool) -> None:
        """Device ▸ Stream to LSL (checkable, remembered)."""
        on = bool(on)
        if on:
            from gaitmon.lsl.outlets import LslUnavailable, require_pylsl

            try:
                require_pylsl()
            except LslUnavailable as exc:
                self.act_lsl.setChecked(False)
                self.prefs.set(LSL_KEY, False)
                self.notify(one_line(exc), 30_000)
                return
        self.prefs.set(LSL_KEY, on)
        if self.act_lsl.isChecked() != on:
            self.act_lsl.setChecked(on)
        if not on:
            if self.lsl_outlets is not None:
                self._lsl_stop()
                self.notify("Streaming to LSL stopped.")
            return
        if self.conn is None:
            self.notify("Streaming to LSL starts when a unit is connected.")
            return
        self._lsl_start()

    @guarded
    def set_lsl_patient_id(self, on: bool) -> None:
        """Device ▸ Patient id in LSL streams (checkable, remembered): applies from the next
        start of streaming (a stream's description is fixed when it opens)."""
        self.prefs.set(LSL_PATIENT_KEY, bool(on))
        if self.act_lsl_patient.isChecked() != bool(on):
            self.act_lsl_patient.setChecked(bool(on))
        if self.lsl_outlets is not None and self.lsl_outlets.allow_patient_id != bool(on):
            self._lsl_stop()
            self._lsl_start()  # the streams open again with the new description

    def _restore_lsl(self) -> None:
        self.lsl_outlets = None
        self.act_lsl_patient.setChecked(self.prefs.get(LSL_PATIENT_KEY, False, bool))
        self.act_lsl.setChecked(self.prefs.get(LSL_KEY, False, bool))

    def _lsl_start(self) -> None:
        """Open the outlets on the connected engine (the action is on)."""
        conn = self.conn
        if conn is None or self.lsl_outlets is not None:
            return
        from gaitmon.io.session import SessionMeta
        from gaitmon.lsl.outlets import LslOutlets, LslUnavailable

        ident = conn.engine.identity
        meta = SessionMeta(
            patient_id=self.prefs.get("session/patient_id", ""),
            side=self.prefs.get("session/side", "") or (ident.side if ident else ""),
        )
        allow = self.act_lsl_patient.isChecked()
        try:
            self.lsl_outlets = LslOutlets.attach(conn.engine, meta, allow_patient_id=allow)
        except LslUnavailable as exc:
            self.act_lsl.setChecked(False)
            self.notify(one_line(exc), 30_000)
            return
        except Exception as exc:  # liblsl could not open its sockets: say so, keep going
            self.act_lsl.setChecked(False)
            self.notify(f"Could not stream to LSL: {one_line(exc)}", 30_000)
            return
        names = ", ".join(self.lsl_outlets.names)
        self.notify(f"Streaming to LSL: {names}.")

    def _lsl_stop(self) -> None:
        outlets, self.lsl_outlets = self.lsl_outlets, None
        if outlets is not None:
            outlets.detach()

    def _lsl_connected(self) -> None:
        """A unit is connected: stream if the action is on."""
        if self.act_lsl.isChecked():
            self._lsl_start()
