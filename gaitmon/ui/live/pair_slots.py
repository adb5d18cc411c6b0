"""The live window with both legs: Device ▸ Connect simulated pair / Connect two units, the
~30 Hz update of both engines, Record (one bilateral file), markers, zero, and the simulated
pair's link cuts, as window slots.

While a pair is connected the window shows :class:`~gaitmon.ui.live.pair_view.PairView` in
place of the one-leg plots and Gait dock; every one-leg slot it overrides (connect, record,
marker, zero, cut link) falls through to the one-leg code when no pair is connected, so the
one-unit window is unchanged. Connecting runs on the window's device worker (:mod:`.jobs`);
Record asks the pair's :class:`~gaitmon.engine.pair.EnginePair` to record each leg into its
crash-safe part, and Stop finishes both and combines them into the one file, the path
``gaitmon record --ports`` takes (``docs/bilateral.md``).
"""

from __future__ import annotations

import functools
import logging
import threading
from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import QTimer
from PySide6.QtGui import QAction
from PySide6.QtWidgets import (
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QDockWidget,
    QFormLayout,
    QVBoxLayout,
    QWidget,
)

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import EngineError, Mode, Snapshot
from gaitmon.io.sim.bilateral import BilateralConfig
from gaitmon.jobs import Response, Ticket
from gaitmon.live.connection import available_ports
from gaitmon.live.pair import (
    SIDE_NAMES,
    SIDES,
    LiveBilateral,
    PairConnection,
    PairSource,
    open_pair,
)
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.dialogs import SessionDialog
from gaitmon.ui.live.device import DeviceSlots
from gaitmon.ui.live.guide import GuideState
from gaitmon.ui.live.pair_view import PairView
from gaitmon.ui.live.prefs import default_session_folder
from gaitmon.ui.live.recording import RecordingSlots
from gaitmon.ui.live.status import banner_style, fmt_bytes, fmt_elapsed
from gaitmon.ui.live.views import ViewSlots

log = logging.getLogger("gaitmon.ui")

GAIT_EVERY = 3  # ticks between updates of each gait panel and of the measures (~10 Hz)
PAIR_ACTIONS = ("pair_sim", "pair_ports")
CUT_ACTIONS = ("cut_L", "cut_R")


@dataclass(frozen=True)
class PairConnectRequest:
    """What connecting both legs needs, captured on the GUI thread."""

    source: PairSource
    mode: Mode
    config: PipelineConfig

    def __call__(self, ticket: Ticket) -> PairConnection:
        return open_pair(self.source, self.mode, self.config)


class _Unwanted(threading.Event):
    """Set once nobody wants the request's answer (the window closing): ends a zero's
    retries early."""

    def __init__(self, ticket: Ticket) -> None:
        super().__init__()
        self.ticket = ticket

    def is_set(self) -> bool:
        return not self.ticket.wanted


class TwoPortsDialog(QDialog):
    """Pick the left and the right unit's ports."""

    def __init__(self, parent: QWidget | None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Connect two units (both legs)")
        form = QFormLayout()
        self.combos: dict[str, QComboBox] = {}
        ports = available_ports()
        for i, side in enumerate(SIDES):
            combo = QComboBox()
            for p in ports:
                combo.addItem(p.friendly(), p.device)
            combo.setCurrentIndex(min(i, combo.count() - 1))
            combo.setToolTip(f"The port of the unit worn on the {SIDE_NAMES[side]} leg")
            form.addRow(f"{SIDE_NAMES[side].capitalize()} leg", combo)
            self.combos[side] = combo
        buttons = QDialogButtonBox(
            QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel
        )
        buttons.button(QDialogButtonBox.StandardButton.Ok).setText("Connect")
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addWidget(buttons)

    def ports(self) -> tuple[str, str]:
        left, right = (str(self.combos[s].currentData() or "") for s in SIDES)
        return left, right


class PairSlots(DeviceSlots, RecordingSlots, ViewSlots):
    """Both legs in the live window (module doc)."""

    pair: PairConnection | None
    pair_sim: BilateralConfig | None  # the simulated pair's settings (command line)
    pair_view: PairView | None
    pair_model: LiveBilateral
    gait_dock: QDockWidget
    phase_combo: QComboBox
    _central_layout: QVBoxLayout
    _actions: dict[str, QAction]
    _pair_ticks: int
    _pair_cut_timers: dict[str, QTimer]
    _one_leg_docks: tuple[bool, bool]
    pair_snapshots: dict[str, Snapshot]  # the last drawn (what the tests look at)

    def _init_pair(self, pair_sim: BilateralConfig | None) -> None:
        self.pair_sim = pair_sim
        self.pair = None
        self.pair_view = None
        self.pair_model = LiveBilateral()
        self.pair_snapshots = {}
        self._pair_ticks = 0
        self._pair_cut_timers = {}
        self._one_leg_docks = (True, False)
        self._legend_shown: list[QWidget] = []

    # -- connecting ------------------------------------------------------------------------------

    @guarded
    def connect_simulated_pair(self) -> None:
        """Device ▸ Connect simulated pair: two simulated units on two pseudo-terminals."""
        self.connect_pair(PairSource(sim=self.pair_sim))

    @guarded
    def connect_two_ports(self) -> None:
        """Device ▸ Connect two units: pick the left and right ports, then connect."""
        if self._busy_or_connected():
            return
        dlg = TwoPortsDialog(self)
        if dlg.combos["L"].count() < 2:
            self.notify("Two units need two ports: pair both units first (gaitmon ports lists "
                        "them), or try Device ▸ Connect simulated pair.", 30_000)  # fmt: skip
            return
        if dlg.exec() != QDialog.DialogCode.Accepted:
            return
        left, right = dlg.ports()
        if left == right:
            self.notify("Choose two different ports: one for each leg.", 30_000)
            return
        self.connect_pair(PairSource(ports=(left, right)))

    def _busy_or_connected(self) -> bool:
        if self._connecting:
            return True
        if self.conn is not None or self.pair is not None:
            self.notify("Disconnect first (Ctrl+K), then connect both legs.")
            return True
        return False

    @guarded
    def connect_pair(self, source: PairSource) -> None:
        if self._busy_or_connected():
            return
        request = PairConnectRequest(source, Mode(self.mode_combo.currentData()), self.config)
        self._connecting = True
        self.status.set_state_pill("Connecting both legs…", "warn")
        self._update_controls()
        self.notify(f"Connecting to {source.label()}…", 0)
        self.jobs.worker.submit(request, self._pair_connected, on_stale=PairConnection.close)

    @guarded
    def _pair_connected(self, response: Response[PairConnection]) -> None:
        self._connecting = False
        pair, exc = response.value, response.error
        if exc is not None or pair is None:
            self.status.set_state_pill("Disconnected", "ok")
            self._update_controls()
            if exc is not None and not isinstance(exc, EngineError):
                log.error("connecting both legs failed", exc_info=exc)
            why = one_line(exc) if exc is not None else "unknown reason"
            self.notify(f"Could not connect both legs: {why}", 30_000)
            return
        if self._closing:
            pair.close()
            return
        self.pair = pair
        self.pair_model.reset()
        view = self._show_pair_view(True)
        view.clear()
        who = []
        for side, eng in pair.engines.items():
            ident = eng.identity
            if ident is not None:
                who.append(f"{side} #{ident.serial}")
                if ident.side in SIDES and ident.side != side:
                    self.notify(f"The unit connected as the {SIDE_NAMES[side]} leg (#"
                                f"{ident.serial}) says it is worn on {ident.side}: check the "
                                "order of the ports (left first).", 30_000)  # fmt: skip
        self.status.set_state_pill("Connected: both legs", "ok")
        self.notify(f"Connected to both legs: {', '.join(who)}.")
        self._update_controls()
        self.timer.start()
        self._tick()

    def _show_pair_view(self, on: bool) -> PairView:
        """The both-legs view in place of the one-leg plots and docks (and back)."""
        view = self.pair_view
        if view is None:
            view = PairView(self.colours)
            parent = self.live.parentWidget()
            layout = parent.layout() if parent is not None else None
            assert layout is not None
            layout.addWidget(view)
            self.pair_view = view
        if on:
            self._one_leg_docks = (self.gait_dock.isVisible(), self.raw_dock.isVisible())
            self.gait_dock.setVisible(False)
            self.raw_dock.setVisible(False)
        else:
            gait, raw = self._one_leg_docks
            self.gait_dock.setVisible(gait)
            self.raw_dock.setVisible(raw)
        self._show_one_leg_legend(not on)
        self.live.setVisible(not on)
        view.setVisible(on)
        return view

    def _show_one_leg_legend(self, on: bool) -> None:
        """The legend row of the one-leg plots (methods, FSR, phases, events) says nothing
        about the both-legs view: hidden with it, each widget back as it was after."""
        lay = self._central_layout
        widgets: list[QWidget] = []
        for i in range(lay.count()):
            item = lay.itemAt(i)
            row = item.layout() if item is not None else None
            if row is not None and row.indexOf(self.phase_combo) >= 0:
                items = (row.itemAt(k) for k in range(row.count()))
                widgets = [w for it in items if it is not None and (w := it.widget()) is not None]
        if not on:
            self._legend_shown = [w for w in widgets if w.isVisibleTo(self)]
            for w in widgets:
                w.setVisible(False)
        else:
            for w in self._legend_shown:
                w.setVisible(True)
            self._legend_shown = []

    def _restyle_pair_view(self) -> None:
        """A theme change: curves are created once per theme, so a new view in the new shades
        (its traces fill again from the next tick)."""
        old = self.pair_view
        if old is None:
            return
        parent = old.parentWidget()
        layout = parent.layout() if parent is not None else None
        if layout is None:
            return
        view = PairView(self.colours)
        layout.replaceWidget(old, view)
        view.setVisible(old.isVisible())
        old.deleteLater()
        self.pair_view = view

    @guarded
    def toggle_connect(self) -> None:
        if self.pair is not None:
            self.disconnect_device()
        else:
            super().toggle_connect()

    @guarded
    def disconnect_device(self) -> None:
        pair = self.pair
        if pair is None:
            super().disconnect_device()
            return
        self._wait_saved()  # a Stop's file is finished (and combined) before the units go
        self.timer.stop()
        for t in self._pair_cut_timers.values():
            t.stop()
        self._pair_cut_timers.clear()
        saved = ""
        try:
            if self._recording:
                saved = self._finish_pair_recording()
        finally:
            self.pair = None
            pair.close()
        self._show_pair_view(False)
        self.status.disconnected()
        self._update_controls()
        self.notify(f"{saved} Disconnected." if saved else "Disconnected.")

    # -- the ~30 Hz update ----------------------------------------------------------------------

    def _tick_pair(self) -> None:
        pair, view = self.pair, self.pair_view
        if pair is None or view is None:
            return
        paused = self.paused
        window_s = 0.05 if paused else self.window_s
        snaps = {side: eng.snapshot(window_s) for side, eng in pair.engines.items()}
        view.show_links(snaps, {s: pair.port_name(s) for s in SIDES})
        self._show_pair_banner(view)
        self._show_pair_recording(snaps)
        self._show_guide_state(all(s.calibrated for s in snaps.values()))
        if paused:
            return
        self.pair_model.update(snaps)
        if view.plots.window_s != self.window_s:
            view.plots.set_window(self.window_s)
        view.plots.update_from(snaps, {s: self.pair_model.x_now(s) for s in SIDES})
        if view.plots.layered:
            view.plots.viewport().repaint()
        self._pair_ticks += 1
        # the slowly changing part at ~10 Hz, one piece a tick: no tick pays for all three
        part = self._pair_ticks % GAIT_EVERY
        if part < len(SIDES):
            view.show_panel(SIDES[part], snaps[SIDES[part]])
        else:
            view.show_measures(self.pair_model.gait())
        self.pair_snapshots = snaps

    def _show_pair_banner(self, view: PairView) -> None:
        """The window's link banner (above the plots, as with one leg), a line per leg."""
        text, grade, tip = view.banner()
        banner = self.status.link_banner
        if not text:
            if banner.isVisible():
                banner.setVisible(False)
            return
        if banner.text() != text:
            banner.setText(text)
            banner.setToolTip(tip)
        if banner.property("grade") != grade:
            banner.setStyleSheet(banner_style(self.colours, grade))
            banner.setProperty("grade", grade)
        banner.setVisible(True)

    # -- recording --------------------------------------------------------------------------

    @guarded
    def toggle_recording(self) -> None:
        if self.pair is None:
            super().toggle_recording()
        elif self._recording:
            self.stop_pair_recording()
        else:
            self._open_pair_session_dialog()

    def _open_pair_session_dialog(self) -> None:
        if self.session_dialog is not None and self.session_dialog.isVisible():
            self.session_dialog.raise_()
            return
        p = self.prefs
        dlg = SessionDialog(
            self,
            folder=Path(p.get("session/folder", str(default_session_folder()))),
            patient_id=p.get("session/patient_id", ""),
            operator=p.get("session/operator", ""),
        )
        dlg.setWindowTitle("Record both legs")
        dlg.side.clear()
        dlg.side.addItem("Both legs (one unit each)", "")
        dlg.side.setEnabled(False)
        dlg.accepted.connect(self._pair_session_accepted)
        self.session_dialog = dlg
        dlg.open()

    @guarded
    def _pair_session_accepted(self) -> None:
        dlg, pair = self.session_dialog, self.pair
        if dlg is None or dlg.result_form is None:
            return
        if pair is None:
            self.notify("The units were disconnected; nothing is recorded.")
            return
        form = dlg.result_form
        self.start_pair_recording(form.path, form.patient_id, form.operator, form.notes)

    def start_pair_recording(
        self, path: Path, patient_id: str = "", operator: str = "", notes: str = ""
    ) -> bool:
        """Both legs into ``path`` (one bilateral session); False with a message if refused."""
        from gaitmon.io.session import SessionMeta

        pair = self.pair
        if pair is None:
            return False
        meta = SessionMeta(patient_id=patient_id, operator=operator, notes=notes)
        try:
            pair.pair.start_recording(path, meta)
        except EngineError as exc:
            self.notify(f"Could not start recording: {one_line(exc)}", 30_000)
            return False
        p = self.prefs
        p.set("session/folder", str(path.parent))
        p.set("session/operator", operator)
        p.set("session/patient_id", patient_id)
        self._recording = True
        self.status.record_banner.setVisible(False)
        self._update_controls()
        self.notify(f"Recording both legs to {path}")
        return True

    @guarded
    def stop_pair_recording(self) -> None:
        pair = self.pair
        if pair is None or not self._recording:
            return
        self._recording = False
        self._begin_saving(lambda: _save_pair(pair, "user"))  # (combining takes seconds)

    def _finish_pair_recording(self, reason: str = "user") -> str:
        """Stop both parts and combine them into the one file, here (a disconnect, a recorder
        that gave up); what happened, in one line."""
        pair = self.pair
        assert pair is not None
        self._recording = False
        self._update_controls()
        self.status.rec_label.setText("")
        return _save_pair(pair, reason)

    def _show_pair_recording(self, snaps: dict[str, Snapshot]) -> None:
        if not self._recording:
            return
        stopped = [s for s, snap in snaps.items() if not snap.recording.active]
        if stopped:  # a recorder gave up (a full disk): finish both, acquisition goes on
            why = "; ".join(f"{SIDE_NAMES[s]} leg: {snaps[s].recording.error or 'stopped'}"
                            for s in stopped)  # fmt: skip
            done = self._finish_pair_recording("error")
            msg = f"Recording stopped: {why}. Acquisition continues. {done}"
            self.status.show_recorder_stopped(msg)
            self.notify(msg, 0)
            return
        rec = snaps["L"].recording
        size = sum(snap.recording.file_bytes for snap in snaps.values())
        self.status.rec_label.setText(
            f"<span style='color:{self.colours.alert}'>●</span> REC both legs "
            f"{fmt_elapsed(rec.elapsed_s)} · {fmt_bytes(size)} · {Path(rec.path).name}"
        )

    # -- markers, zero, the simulated pair's links ---------------------------------------------

    @guarded
    def add_marker(self) -> None:
        if self.pair is None:
            super().add_marker()
            return
        label = self.marker_edit.text().strip()
        for eng in self.pair.engines.values():
            eng.add_marker(label)
        self.marker_edit.clear()
        where = " (saved in both legs' recording)" if self._recording else ""
        self.notify(f"Marker {label!r} dropped{where}." if label else f"Marker dropped{where}.")

    @guarded
    def zero(self) -> None:
        pair = self.pair
        if pair is None:
            super().zero()
            return
        self.act_zero.setEnabled(False)
        self.notify("Zeroing both legs: the subject stands upright and still…", 0)
        both = pair.pair

        def run(ticket: Ticket) -> list[str]:
            # both units from the same standing moment, retried while the subject settles
            # (up to 10 s), as `gaitmon record --simulate-bilateral --zero` does
            try:
                both.zero(stop=_Unwanted(ticket))
            except EngineError as exc:
                return [one_line(exc)]
            return []

        self.jobs.worker.submit(run, self._pair_zeroed)

    @guarded
    def _pair_zeroed(self, response: Response[list[str]]) -> None:
        self._update_controls()
        if response.error is not None:
            self.report_exception("zero", response.error)
        elif response.value:
            self.notify(f"Zero refused: {'; '.join(response.value)}", 30_000)
        else:
            self.notify("Standing pose zeroed on both legs: angles now read 0 in this pose.")

    @guarded
    def cut_pair_link(self, side: str, duration_s: float = 3.0) -> None:
        """Device ▸ Simulator ▸ Cut left / right leg's link: that unit's port vanishes."""
        pair = self.pair
        if pair is None or pair.simulator is None:
            self.notify("A leg's link can only be cut on the simulated pair.")
            return
        pair.simulator.pty(side).cut()
        self.notify(f"Simulated {SIDE_NAMES[side]} leg's link cut for {duration_s:g} s.")
        old = self._pair_cut_timers.pop(side, None)
        if old is not None:
            old.stop()
        t = QTimer(self)
        t.setSingleShot(True)
        t.timeout.connect(functools.partial(self._restore_pair_link, side))
        t.start(round(duration_s * 1000))
        self._pair_cut_timers[side] = t

    @guarded
    def _restore_pair_link(self, side: str) -> None:
        self._pair_cut_timers.pop(side, None)
        pair = self.pair
        if pair is None or pair.simulator is None:
            return
        pair.simulator.pty(side).restore()
        self.notify(f"Simulated {SIDE_NAMES[side]} leg's link restored; it reconnects by itself.")

    # -- controls ------------------------------------------------------------------------------

    def _update_controls(self) -> None:
        super()._update_controls()
        pair = self.pair
        idle = pair is None and self.conn is None and not self._connecting
        for name in PAIR_ACTIONS:
            self._actions[name].setEnabled(idle)
        simulated = pair is not None and pair.simulated
        self._actions["engineering"].setEnabled(pair is None)  # one leg's traces and sensors
        for name in CUT_ACTIONS:
            self._actions[name].setEnabled(simulated)
        if pair is None:
            return
        self.act_connect.setText("Disconnect")
        self.act_connect.setEnabled(True)
        for a in (self.act_zero, self.act_record, self.act_marker):
            a.setEnabled(True)
        self.act_record.setEnabled(not self._saving)  # a Stop's file is finished first
        self.act_record.setText("Stop" if self._recording else "Record")
        # the one-unit port and mode choices do not apply while both legs are connected
        for w in (self.port_combo, self.mode_combo, self.act_refresh):
            w.setEnabled(False)
        self.sim_menu.setEnabled(simulated)
        # the one-leg simulator's actions do not apply to a pair (it cannot stand on request)
        for name, act in self._actions.items():
            if name in ("cut", "restore", "sim_stand", "sim_walk") or name.startswith("sim_"):
                act.setEnabled(False)

    def _show_guide_state(self, zeroed: bool | None = None) -> None:
        pair = self.pair
        if pair is None:
            super()._show_guide_state(zeroed)
            return
        if zeroed is None:
            zeroed = self.guide.state.zeroed
        # simulated=False: the pair cannot stand still on request, so no menu hint for it
        state = GuideState(connected=True, connecting=False, zeroed=bool(zeroed),
                           recording=self._recording, simulated=False)  # fmt: skip
        self.guide.show_state(state)


def _save_pair(pair: PairConnection, reason: str) -> str:
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
