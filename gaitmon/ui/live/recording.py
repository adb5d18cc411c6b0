"""The live monitor's session slots: start / stop a recording, markers, a recorder that gave up.

The engine records; these slots ask for the session's details (:class:`SessionDialog`), start
and stop it, remember the details for next time, and finish the file when the recorder stopped
by itself (a full disk) while acquisition goes on.
"""

from __future__ import annotations

from pathlib import Path

from gaitmon.engine import EngineError, Snapshot
from gaitmon.live.connection import Connection
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.dialogs import SessionDialog
from gaitmon.ui.live.base import LiveWindowBase
from gaitmon.ui.live.prefs import default_session_folder
from gaitmon.ui.live.status import fmt_bytes, fmt_elapsed


class RecordingSlots(LiveWindowBase):
    """Slots of the Session menu and toolbar."""

    @guarded
    def toggle_recording(self) -> None:
        if self._recording:
            self.stop_recording()
        else:
            self.open_session_dialog()

    @guarded
    def open_session_dialog(self) -> None:
        if self.conn is None:
            self.notify("Connect to a unit before recording.")
            return
        if self.session_dialog is not None and self.session_dialog.isVisible():
            self.session_dialog.raise_()
            return
        p = self.prefs
        folder = Path(p.get("session/folder", str(default_session_folder())))
        ident = self.conn.engine.identity
        side = p.get("session/side", "") or (ident.side if ident else "")
        dlg = SessionDialog(
            self,
            folder=folder,
            patient_id=p.get("session/patient_id", ""),
            side=side,
            operator=p.get("session/operator", ""),
        )
        dlg.accepted.connect(self._session_accepted)
        self.session_dialog = dlg
        dlg.open()

    @guarded
    def _session_accepted(self) -> None:
        dlg = self.session_dialog
        conn = self.conn
        if dlg is None or dlg.result_form is None:
            return
        form = dlg.result_form
        if conn is None:
            self.notify("The unit was disconnected; nothing is recorded.")
            return
        try:
            from gaitmon.io.session import SessionMeta
        except ImportError:
            self.notify("Recording is not available in this installation (no session writer).")
            return
        meta = SessionMeta(
            patient_id=form.patient_id, side=form.side, operator=form.operator, notes=form.notes
        )
        try:
            conn.engine.start_recording(form.path, meta)
        except EngineError as exc:
            self.notify(f"Could not start recording: {one_line(exc)}", 30_000)
            return
        p = self.prefs
        p.set("session/folder", str(form.path.parent))
        p.set("session/operator", form.operator)
        p.set("session/side", form.side)
        p.set("session/patient_id", form.patient_id)
        self._recording = True
        self.status.record_banner.setVisible(False)
        self._update_controls()
        self.notify(f"Recording to {form.path}")

    @guarded
    def stop_recording(self) -> None:
        conn = self.conn
        if conn is None or not self._recording:
            return
        self._recording = False
        engine = conn.engine

        def save() -> str:  # on the device worker
            status = engine.stop_recording()
            if status.error:
                return f"Recording stopped with an error: {status.error}"
            size, took = fmt_bytes(status.file_bytes), fmt_elapsed(status.elapsed_s)
            return f"Recording saved: {status.path} ({status.rows:,} frames, {size}, {took})"

        self._begin_saving(save)

    def _show_recording(self, snap: Snapshot, conn: Connection) -> None:
        """The recording line of the status bar; finish the file if the recorder gave up."""
        rec = snap.recording
        if self._recording and not rec.active:
            # the recorder stopped by itself (full disk, ...): finish the file, keep acquiring
            status = conn.engine.stop_recording()
            self._recording = False
            self._update_controls()
            why = rec.error or status.error or "the recorder stopped"
            msg = (
                f"Recording stopped: {why}. Acquisition continues; "
                f"{status.rows} frames were saved in {Path(status.path).name}."
            )
            self.status.show_recorder_stopped(msg)
            self.notify(msg, 0)
            return
        if self._recording:
            self.status.show_recording(rec)

    @guarded
    def add_marker(self) -> None:
        conn = self.conn
        if conn is None:
            self.notify("Connect to a unit before dropping markers.")
            return
        label = self.marker_edit.text().strip()
        conn.engine.add_marker(label)
        self.marker_edit.clear()
        where = " (saved in the recording)" if self._recording else ""
        self.notify(f"Marker {label!r} dropped{where}." if label else f"Marker dropped{where}.")
