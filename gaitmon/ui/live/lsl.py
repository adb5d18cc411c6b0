"""The live window's Lab Streaming Layer part: Device ▸ Stream to LSL and its patient-id
permission, both checkable and remembered.

While the action is on and a unit is connected, :class:`gaitmon.lsl.outlets.LslOutlets`
listens to the engine (on the engine thread) and publishes the streams of ``docs/lsl.md``;
nothing LSL exists otherwise (pylsl is imported only when it is turned on). Without pylsl the
action turns itself off with one line saying what to install.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from PySide6.QtGui import QAction

from gaitmon.review.settings import LiveKey
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.live.context import LiveContext

if TYPE_CHECKING:
    from gaitmon.lsl.outlets import LslOutlets



class LslPart:
    """Slots of Device ▸ Stream to LSL / Patient id in LSL streams; owns the outlets while
    streaming. ``connected`` / ``stop`` are the window's calls when a unit comes and goes."""

    def __init__(self, ctx: LiveContext, actions: dict[str, QAction]) -> None:
        self.ctx = ctx
        self.act_lsl = actions["lsl"]
        self.act_lsl_patient = actions["lsl_patient_id"]
        self.lsl_outlets: LslOutlets | None = None

    def report_exception(self, where: str, exc: BaseException) -> None:
        self.ctx.report_exception(where, exc)

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
                self.ctx.prefs.set(LiveKey.LSL, False)
                self.ctx.notify(one_line(exc), 30_000)
                return
        self.ctx.prefs.set(LiveKey.LSL, on)
        if self.act_lsl.isChecked() != on:
            self.act_lsl.setChecked(on)
        if not on:
            if self.lsl_outlets is not None:
                self.stop()
                self.ctx.notify("Streaming to LSL stopped.")
            return
        if self.ctx.conn is None:
            self.ctx.notify("Streaming to LSL starts when a unit is connected.")
            return
        self._start()

    @guarded
    def set_lsl_patient_id(self, on: bool) -> None:
        """Device ▸ Patient id in LSL streams (checkable, remembered): applies from the next
        start of streaming (a stream's description is fixed when it opens)."""
        self.ctx.prefs.set(LiveKey.LSL_PATIENT_ID, bool(on))
        if self.act_lsl_patient.isChecked() != bool(on):
            self.act_lsl_patient.setChecked(bool(on))
        if self.lsl_outlets is not None and self.lsl_outlets.allow_patient_id != bool(on):
            self.stop()
            self._start()  # the streams open again with the new description

    def restore(self) -> None:
        self.lsl_outlets = None
        self.act_lsl_patient.setChecked(self.ctx.prefs.get(LiveKey.LSL_PATIENT_ID))
        self.act_lsl.setChecked(self.ctx.prefs.get(LiveKey.LSL))

    def _start(self) -> None:
        """Open the outlets on the connected engine (the action is on)."""
        conn = self.ctx.conn
        if conn is None or self.lsl_outlets is not None:
            return
        from gaitmon.io.session import SessionMeta
        from gaitmon.lsl.outlets import LslOutlets, LslUnavailable

        ident = conn.engine.identity
        meta = SessionMeta(
            patient_id=self.ctx.prefs.get(LiveKey.PATIENT_ID),
            side=self.ctx.prefs.get(LiveKey.SIDE) or (ident.side if ident else ""),
        )
        allow = self.act_lsl_patient.isChecked()
        try:
            self.lsl_outlets = LslOutlets.attach(conn.engine, meta, allow_patient_id=allow)
        except LslUnavailable as exc:
            self.act_lsl.setChecked(False)
            self.ctx.notify(one_line(exc), 30_000)
            return
        except Exception as exc:  # liblsl could not open its sockets: say so, keep going
            self.act_lsl.setChecked(False)
            self.ctx.notify(f"Could not stream to LSL: {one_line(exc)}", 30_000)
            return
        names = ", ".join(self.lsl_outlets.names)
        self.ctx.notify(f"Streaming to LSL: {names}.")

    def stop(self) -> None:
        outlets, self.lsl_outlets = self.lsl_outlets, None
        if outlets is not None:
            outlets.detach()

    def connected(self) -> None:
        """A unit is connected: stream if the action is on."""
        if self.act_lsl.isChecked():
            self._start()
