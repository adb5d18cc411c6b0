"""The live window's recording part: Record / Stop, the session dialog, markers, the file being
finished after a Stop, a recorder that gave up, for one unit or both legs.

One leg is the one-unit case: the same slots record what is connected, one engine
(:class:`~gaitmon.engine.Engine`) or both legs' :class:`~gaitmon.engine.pair.EnginePair` (each
leg into its crash-safe part, combined into one file on Stop, the path ``gaitmon record
--ports`` takes: ``docs/bilateral.md``); only the words and the dialog's side differ. The
session's details are asked for with :class:`SessionDialog` and remembered for next time.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from PySide6.QtGui import QAction
from PySide6.QtWidgets import QLineEdit, QMainWindow, QMessageBox

from gaitmon.engine import EngineError, Mode, Snapshot
from gaitmon.io.session.opening import stored_duration_s
from gaitmon.jobs import Response
from gaitmon.live.pair import SIDE_NAMES, SIDES, PairConnection
from gaitmon.review.settings import LiveKey
from gaitmon.text import duration_text
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.dialogs import SessionDialog
from gaitmon.ui.live.context import LiveContext
from gaitmon.ui.live.prefs import default_session_folder
from gaitmon.ui.live.status import fmt_bytes, fmt_elapsed

UNZEROED_QUESTION = (
    "Record without a standing Zero? The angles will be relative to the sensor axes "
    "(zero: estimated), not to the patient's standing pose: peak angles can differ by several "
    "degrees."
)
RECORD_ANYWAY, ZERO_FIRST = "Record anyway", "Zero first"


class RecordingPart:
    """Slots of the Session menu and toolbar; owns the marker field and the session dialog.
    ``confirm_unzeroed``: Record asks first when a leg has no standing Zero (raw mode; the
    unit's own modes zero themselves)."""

    def __init__(self, ctx: LiveContext, window: QMainWindow, actions: dict[str, QAction]) -> None:
        self.ctx = ctx
        self.window = window
        self.actions = actions
        self.session_dialog: SessionDialog | None = None
        self.confirm_unzeroed = True
        self.unzeroed_box: QMessageBox | None = None  # the question, while it is asked
        self._dialog_both = False  # the dialog open is for both legs
        self.marker_edit = QLineEdit()
        self.marker_edit.setPlaceholderText("marker label (optional)")
        self.marker_edit.setToolTip(
            "Optional label for the next marker; Enter or M (outside this field) drops it"
        )
        self.marker_edit.setMaximumWidth(190)
        self.marker_edit.returnPressed.connect(lambda: self.add_marker())

    def report_exception(self, where: str, exc: BaseException) -> None:
        self.ctx.report_exception(where, exc)

    def update_controls(self) -> None:
        ctx, record = self.ctx, self.actions["record"]
        self.actions["marker"].setEnabled(ctx.connected)
        record.setEnabled(ctx.connected and not ctx.saving)  # a Stop's file is finished first
        record.setText("Stop" if ctx.recording else "Record")
        record.setToolTip(
            "Stop recording (Ctrl+R)" if ctx.recording else "Record a session (Ctrl+R)"
        )

    @guarded
    def toggle_recording(self) -> None:
        if self.ctx.recording:
            self.stop_recording()
        else:
            self.open_session_dialog()

    @guarded
    def open_session_dialog(self) -> None:
        ctx = self.ctx
        if not ctx.connected:
            ctx.notify("Connect to a unit before recording.")
            return
        if self.session_dialog is not None and self.session_dialog.isVisible():
            self.session_dialog.raise_()
            return
        if self.confirm_unzeroed and not self._unzeroed_answered():
            return
        p = ctx.prefs
        folder = Path(p.get(LiveKey.SESSION_FOLDER, str(default_session_folder())))
        side = ""
        if ctx.conn is not None:
            ident = ctx.conn.engine.identity
            side = p.get(LiveKey.SIDE) or (ident.side if ident else "")
        dlg = SessionDialog(
            self.window,
            folder=folder,
            patient_id=p.get(LiveKey.PATIENT_ID),
            side=side,
            operator=p.get(LiveKey.OPERATOR),
        )
        self._dialog_both = ctx.pair is not None
        if self._dialog_both:
            dlg.setWindowTitle("Record both legs")
            dlg.side.clear()
            dlg.side.addItem("Both legs (one unit each)", "")
            dlg.side.setEnabled(False)
        dlg.accepted.connect(self._session_accepted)
        self.session_dialog = dlg
        dlg.open()

    def unzeroed_legs(self) -> list[str]:
        """The connected legs ("" one unit, else "L" / "R") whose angles have no standing
        Zero (raw mode only: the unit's own modes zero themselves)."""
        return [side for side, eng in self.ctx.engines.items()
                if eng.mode is Mode.RAW and not eng.snapshot(0.05).calibrated]  # fmt: skip

    def _unzeroed_answered(self) -> bool:
        """True to go on to the session dialog: every leg is zeroed, or the user chose Record
        anyway. Zero first starts the Zero; Cancel does nothing."""
        legs = self.unzeroed_legs()
        if not legs:
            return True
        question = UNZEROED_QUESTION
        if self.ctx.pair is not None:
            which = "both legs" if len(legs) > 1 else f"the {SIDE_NAMES[legs[0]]} leg"
            question = question.replace("standing Zero?", f"standing Zero on {which}?", 1)
        box = QMessageBox(self.window)
        box.setIcon(QMessageBox.Icon.Warning)
        box.setWindowTitle("No standing Zero")
        box.setText(question)
        box.setInformativeText(
            "Zero first: ask the patient to stand upright and still, leg straight; the Zero "
            "takes a few seconds. Review and the report say \"zero: estimated\" for such a "
            "recording."
        )
        anyway = box.addButton(RECORD_ANYWAY, QMessageBox.ButtonRole.AcceptRole)
        zero = box.addButton(ZERO_FIRST, QMessageBox.ButtonRole.ActionRole)
        box.setEscapeButton(box.addButton(QMessageBox.StandardButton.Cancel))
        box.setDefaultButton(zero)
        self.unzeroed_box = box
        try:
            box.exec()
        finally:
            self.unzeroed_box = None
        clicked = box.clickedButton()
        if clicked is zero:
            self.actions["zero"].trigger()
        return clicked is anyway

    @guarded
    def _session_accepted(self) -> None:
        dlg = self.session_dialog
        if dlg is None or dlg.result_form is None:
            return
        form = dlg.result_form
        if not self.ctx.connected:
            what = "units were" if self._dialog_both else "unit was"
            self.ctx.notify(f"The {what} disconnected; nothing is recorded.")
            return
        self.start_recording(form.path, form.patient_id, form.operator, form.notes, form.side)

    def start_recording(
        self, path: Path, patient_id: str = "", operator: str = "", notes: str = "",
        side: str = "",
    ) -> bool:  # fmt: skip
        """What is connected into ``path`` (both legs: one session of two units); False with a
        message if refused."""
        ctx = self.ctx
        try:
            from gaitmon.io.session import SessionMeta
        except ImportError:
            ctx.notify("Recording is not available in this installation (no session writer).")
            return False
        pair, conn = ctx.pair, ctx.conn
        if pair is None and conn is None:
            return False
        both = pair is not None
        meta = SessionMeta(patient_id=patient_id, side="" if both else side, operator=operator,
                           notes=notes)  # fmt: skip
        try:
            if pair is not None:
                pair.pair.start_recording(path, meta)
            elif conn is not None:
                conn.engine.start_recording(path, meta)
        except EngineError as exc:  # said where it stays until the next recording starts
            msg = f"Not recording: {one_line(exc)}"
            ctx.status.show_recorder_stopped(msg)
            ctx.notify(msg, 30_000)
            return False
        p = ctx.prefs
        p.set(LiveKey.SESSION_FOLDER, str(path.parent))
        p.set(LiveKey.OPERATOR, operator)
        if not both:
            p.set(LiveKey.SIDE, side)
        p.set(LiveKey.PATIENT_ID, patient_id)
        ctx.recording = True
        ctx.status.record_banner.setVisible(False)
        ctx.controls_changed()
        ctx.notify(f"Recording both legs to {path}" if both else f"Recording to {path}")
        return True

    @guarded
    def stop_recording(self) -> None:
        ctx = self.ctx
        pair, conn = ctx.pair, ctx.conn
        if not ctx.recording or (pair is None and conn is None):
            return
        ctx.recording = False
        if pair is not None:
            self._begin_saving(lambda: save_pair(pair, "user"))  # (combining takes seconds)
            return
        assert conn is not None
        engine = conn.engine

        def save() -> str:  # on the device worker
            status = engine.stop_recording()
            if status.error:
                return f"Recording stopped with an error: {status.error}"
            size, took = fmt_bytes(status.file_bytes), fmt_elapsed(status.elapsed_s)
            stored = stored_duration_s(status.path)  # as info, review and the report say it
            if stored is not None:
                took = duration_text(stored)
            return f"Recording saved: {status.path} ({status.rows:,} frames, {size}, {took})"

        self._begin_saving(save)

    def _begin_saving(self, save: Callable[[], str]) -> None:
        """Finish a stopped recording's file on the device worker (``save`` returns the line to
        show): on a long session that takes seconds (the smoother, the stride store), and the
        window keeps drawing meanwhile; Record waits until the file is done."""
        ctx = self.ctx
        ctx.saving = True
        ctx.controls_changed()
        ctx.status.rec_label.set_texts("Saving the recording…", "Saving…")
        ctx.notify("Recording stopped; saving the file…", 0)  # (not "Recording to …")
        ctx.jobs.worker.submit(lambda ticket: save(), self._saved)

    def _saved(self, response: Response[str]) -> None:
        ctx = self.ctx
        ctx.saving = False
        ctx.status.rec_label.set_texts("")
        ctx.controls_changed()
        if response.error is not None:
            ctx.report_exception("saving the recording", response.error)
        elif response.value:
            ctx.notify(response.value, 30_000)

    def finish_pair_recording(self, reason: str = "user") -> str:
        """Stop both parts and combine them into the one file, here (a disconnect, a recorder
        that gave up); what happened, in one line."""
        ctx = self.ctx
        pair = ctx.pair
        assert pair is not None
        ctx.recording = False
        ctx.controls_changed()
        ctx.status.rec_label.set_texts("")
        return save_pair(pair, reason)

    def show_recording(self, snaps: dict[str, Snapshot]) -> None:
        """The recording line of the status bar (each tick); finish the file if a recorder gave
        up (a full disk), acquisition going on."""
        ctx = self.ctx
        if not ctx.recording:
            return
        fs_hz = next((e.fs_hz for e in ctx.engines.values()), 100.0)
        stopped = [s for s, snap in snaps.items() if not snap.recording.active]
        if stopped and ctx.pair is not None:
            why = "; ".join(f"{SIDE_NAMES[s]} leg: {snaps[s].recording.error or 'stopped'}"
                            for s in stopped)  # fmt: skip
            done = self.finish_pair_recording("error")
            msg = f"Recording stopped: {why}. Acquisition continues. {done}"
        elif stopped and ctx.conn is not None:
            rec = snaps[stopped[0]].recording
            status = ctx.conn.engine.stop_recording()
            ctx.recording = False
            ctx.controls_changed()
            why = rec.error or status.error or "the recorder stopped"
            msg = (
                f"Recording stopped: {why}. Acquisition continues; "
                f"{status.rows} frames were saved in {Path(status.path).name}."
            )
        elif ctx.pair is not None:
            rec = snaps["L"].recording  # its part file; the line names the session's file
            path = ctx.pair.pair.path
            if path is not None:
                rec = dataclasses.replace(rec, path=str(path))
            ctx.status.show_recording(rec, fs_hz, "both legs")
            return
        else:
            for snap in snaps.values():
                ctx.status.show_recording(snap.recording, fs_hz)
            return
        ctx.status.show_recorder_stopped(msg)
        ctx.notify(msg, 0)

    @guarded
    def add_marker(self) -> None:
        ctx = self.ctx
        engines = ctx.engines
        if not engines:
            ctx.notify("Connect to a unit before dropping markers.")
            return
        label = self.marker_edit.text().strip()
        for eng in engines.values():
            eng.add_marker(label)
        self.marker_edit.clear()
        where = ""
        if ctx.recording:
            where = " (saved in both legs' recording)" if ctx.pair else " (saved in the recording)"
        ctx.notify(f"Marker {label!r} dropped{where}." if label else f"Marker dropped{where}.")


def save_pair(pair: PairConnection, reason: str) -> str:
    """Stop both parts and combine them into the one file (any thread); the line to show."""
    statuses = pair.pair.stop_recording(reason)
    errors = [f"{SIDE_NAMES[s]} leg: {st.error}" for s, st in statuses.items() if st.error]
    try:
        path = pair.pair.finish()
    except Exception as exc:  # the parts stay; the next open of the file combines them
        errors.append(one_line(exc))
        path = None
    if errors:
        return f"Recording stopped with an error: {'; '.join(errors)}"
    assert path is not None
    rows = " · ".join(f"{s} {statuses[s].rows:,}" for s in SIDES)
    return (f"Recording saved: both legs in {path} ({rows} frames, "
            f"{fmt_bytes(path.stat().st_size)}).")  # fmt: skip
