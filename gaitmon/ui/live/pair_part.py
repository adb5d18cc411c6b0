"""The live window's both-legs part: Device ▸ Connect simulated pair / Connect two units,
disconnecting them, the ~30 Hz update of both engines, zero, and the simulated pair's link cuts.

While a pair is connected the window shows :class:`~gaitmon.ui.live.pair_view.PairView` in
place of the one-leg plots and docks (:meth:`~gaitmon.ui.live.views.ViewPart.set_shown`); the
window routes Connect / Disconnect and Zero here when a pair is connected, to
:mod:`.device` otherwise. Recording and markers are the one-unit part's own
(:mod:`.recording`: both legs are what is connected). Connecting runs on the window's device
worker (:mod:`.jobs`).
"""

from __future__ import annotations

import functools
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass, field

from PySide6.QtCore import QTimer
from PySide6.QtGui import QAction
from PySide6.QtWidgets import (
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QFormLayout,
    QMainWindow,
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
from gaitmon.ui.live.context import LiveContext
from gaitmon.ui.live.jobs import ConnectSteps
from gaitmon.ui.live.pair_view import PairView
from gaitmon.ui.live.recording import RecordingPart
from gaitmon.ui.live.views import ViewPart

log = logging.getLogger("gaitmon.ui")

GAIT_EVERY = 3  # ticks between updates of each gait panel and of the measures (~10 Hz)
PAIR_ACTIONS = ("pair_sim", "pair_ports")
CUT_ACTIONS = ("cut_L", "cut_R", "stall_L", "stall_R")


@dataclass(frozen=True)
class PairConnectRequest:
    """What connecting both legs needs, captured on the GUI thread."""

    source: PairSource
    mode: Mode
    config: PipelineConfig
    steps: ConnectSteps = field(default_factory=ConnectSteps)  # what it is doing, for the bar

    def __call__(self, ticket: Ticket) -> PairConnection:
        self.steps.prepare(self.config)
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


class PairPart:
    """Both legs in the live window (module doc); owns the both-legs view, the live bilateral
    model and the simulated pair's link-cut timers. ``started`` / ``stopping``: the window's
    steps once both legs are connected and before they go (the display timer); ``show_guide``
    feeds the guided start (both legs zeroed?)."""

    def __init__(
        self,
        ctx: LiveContext,
        window: QMainWindow,
        actions: dict[str, QAction],
        *,
        pair_sim: BilateralConfig | None,
        mode: Callable[[], Mode],
        view: ViewPart,
        recording: RecordingPart,
        started: Callable[[], None],
        stopping: Callable[[], None],
        show_guide: Callable[[bool | None], None],
    ) -> None:
        self.ctx = ctx
        self.window = window
        self.actions = actions
        self.pair_sim = pair_sim  # the simulated pair's settings (command line)
        self._mode = mode
        self.one_leg = view
        self.recording = recording
        self._started, self._stopping, self._show_guide = started, stopping, show_guide
        self.view: PairView | None = None
        self.model = LiveBilateral()
        self.snapshots: dict[str, Snapshot] = {}  # the last drawn (what the tests look at)
        self._ticks = 0
        self._cut_timers: dict[str, QTimer] = {}

    def report_exception(self, where: str, exc: BaseException) -> None:
        self.ctx.report_exception(where, exc)

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
        dlg = TwoPortsDialog(self.window)
        if dlg.combos["L"].count() < 2:
            self.ctx.notify("Two units need two ports: pair both units first (gaitmon ports "
                            "lists them), or try Device ▸ Connect simulated pair.",
                            30_000)  # fmt: skip
            return
        if dlg.exec() != QDialog.DialogCode.Accepted:
            return
        left, right = dlg.ports()
        if left == right:
            self.ctx.notify("Choose two different ports: one for each leg.", 30_000)
            return
        self.connect_pair(PairSource(ports=(left, right)))

    def _busy_or_connected(self) -> bool:
        if self.ctx.connecting:
            return True
        if self.ctx.connected:
            self.ctx.notify("Disconnect first (Ctrl+K), then connect both legs.")
            return True
        return False

    @guarded
    def connect_pair(self, source: PairSource) -> None:
        if self._busy_or_connected():
            return
        ctx = self.ctx
        steps = ctx.begin_connect(source.label(), "Connecting both legs…")
        request = PairConnectRequest(source, self._mode(), ctx.config, steps)
        ctx.jobs.worker.submit(request, self._connected, on_stale=PairConnection.close)

    @guarded
    def _connected(self, response: Response[PairConnection]) -> None:
        ctx = self.ctx
        pair = ctx.opened(response, "connect both legs")
        if pair is None:
            return
        ctx.pair = pair
        self.model.reset()
        view = self._show_view(True)
        view.clear()
        who = []
        for side, eng in pair.engines.items():
            ident = eng.identity
            if ident is not None:
                who.append(f"{side} #{ident.serial}")
                if ident.side in SIDES and ident.side != side:
                    ctx.notify(f"The unit connected as the {SIDE_NAMES[side]} leg (#"
                               f"{ident.serial}) says it is worn on {ident.side}: check the "
                               "order of the ports (left first).", 30_000)  # fmt: skip
        ctx.status.set_state_pill("Connected: both legs", "ok")
        ctx.notify(f"Connected to both legs: {', '.join(who)}.")
        self._started()

    def _show_view(self, on: bool) -> PairView:
        """The both-legs view in place of the one-leg plots and docks (and back)."""
        view = self.view
        if view is None:
            view = PairView(self.ctx.colours)
            parent = self.one_leg.live.parentWidget()
            layout = parent.layout() if parent is not None else None
            assert layout is not None
            layout.addWidget(view)
            self.view = view
        self.one_leg.set_shown(not on)
        view.setVisible(on)
        return view

    def restyle(self) -> None:
        """A theme change: curves are created once per theme, so a new view in the new shades
        (its traces fill again from the next tick)."""
        old = self.view
        if old is None:
            return
        parent = old.parentWidget()
        layout = parent.layout() if parent is not None else None
        if layout is None:
            return
        view = PairView(self.ctx.colours)
        for side, panel in view.panels.items():  # where each engine's recording began
            panel.recording_start = old.panels[side].recording_start
        layout.replaceWidget(old, view)
        view.setVisible(old.isVisible())
        old.deleteLater()
        self.view = view

    @guarded
    def disconnect_pair(self) -> None:
        ctx = self.ctx
        pair = ctx.pair
        if pair is None:
            return
        ctx.wait_saved()  # a Stop's file is finished (and combined) before the units go
        self._stopping()
        for t in self._cut_timers.values():
            t.stop()
        self._cut_timers.clear()
        saved = ""
        try:
            if ctx.recording:
                saved = self.recording.finish_pair_recording()
        finally:
            ctx.pair = None
            pair.close()
        self._show_view(False)
        ctx.status.disconnected()
        ctx.controls_changed()
        ctx.notify(f"{saved} Disconnected." if saved else "Disconnected.")

    # -- the ~30 Hz update ----------------------------------------------------------------------

    def tick(self) -> None:
        ctx, pair, view = self.ctx, self.ctx.pair, self.view
        if pair is None or view is None:
            return
        paused = self.one_leg.paused
        window_s = self.one_leg.window_s
        snaps = {side: eng.snapshot(0.05 if paused else window_s)
                 for side, eng in pair.engines.items()}  # fmt: skip
        view.show_links(snaps, {s: pair.port_name(s) for s in SIDES})
        ctx.status.show_banner(*view.banner())
        pill = view.pill()
        if ctx.status.state_text != pill[0]:  # a leg without data is never "Connected"
            ctx.status.set_state_pill(*pill)
        self.recording.show_recording(snaps)
        self._show_guide(all(s.calibrated for s in snaps.values()))
        if paused:
            return
        self.model.update(snaps)
        if view.plots.window_s != window_s:
            view.plots.set_window(window_s)
        view.plots.update_from(snaps, {s: self.model.x_now(s) for s in SIDES})
        if view.plots.layered:
            view.plots.viewport().repaint()
        self._ticks += 1
        # the slowly changing part at ~10 Hz, one piece a tick: no tick pays for all three
        part = self._ticks % GAIT_EVERY
        if part < len(SIDES):
            view.show_panel(SIDES[part], snaps[SIDES[part]])
        else:
            view.show_measures(self.model.gait(), {s: snaps[s].stalled_s for s in SIDES})
        self.snapshots = snaps

    # -- zero, the simulated pair's links ---------------------------------------------------

    @guarded
    def zero(self) -> None:
        pair = self.ctx.pair
        if pair is None:
            return
        self.actions["zero"].setEnabled(False)
        self.ctx.notify("Zeroing both legs: the subject stands upright and still…", 0)
        both = pair.pair

        def run(ticket: Ticket) -> list[str]:
            # both units from the same standing moment, retried while the subject settles
            # (up to 10 s), as `gaitmon record --simulate-bilateral --zero` does
            try:
                both.zero(stop=_Unwanted(ticket))
            except EngineError as exc:
                return [one_line(exc)]
            return []

        self.ctx.jobs.worker.submit(run, self._zeroed)

    @guarded
    def _zeroed(self, response: Response[list[str]]) -> None:
        ctx = self.ctx
        ctx.controls_changed()
        if response.error is not None:
            ctx.report_exception("zero", response.error)
        elif response.value:
            ctx.notify(f"Zero refused: {'; '.join(response.value)}", 30_000)
        else:
            ctx.notify("Standing pose zeroed on both legs: angles now read 0 in this pose.")

    @guarded
    def cut_pair_link(self, side: str, duration_s: float = 3.0) -> None:
        """Device ▸ Simulator ▸ Cut left / right leg's link: that unit's port vanishes."""
        pair = self.ctx.pair
        if pair is None or pair.simulator is None:
            self.ctx.notify("A leg's link can only be cut on the simulated pair.")
            return
        pair.simulator.pty(side).cut()
        self.ctx.notify(f"Simulated {SIDE_NAMES[side]} leg's link cut for {duration_s:g} s.")
        old = self._cut_timers.pop(side, None)
        if old is not None:
            old.stop()
        t = QTimer(self.window)
        t.setSingleShot(True)
        t.timeout.connect(functools.partial(self._restore_link, side))
        t.start(round(duration_s * 1000))
        self._cut_timers[side] = t

    @guarded
    def stall_pair_link(self, side: str, duration_s: float = 5.0) -> None:
        """Device ▸ Simulator ▸ Stall left / right leg's link: that unit holds its frames, then
        sends the backlog."""
        pair = self.ctx.pair
        if pair is None or pair.simulator is None:
            self.ctx.notify("A leg's link can only be stalled on the simulated pair.")
            return
        pair.simulator.pty(side).unit.stall(duration_s)
        self.ctx.notify(f"Simulated {SIDE_NAMES[side]} unit holds its data for {duration_s:g} s, "
                        "then sends it all.")  # fmt: skip

    @guarded
    def _restore_link(self, side: str) -> None:
        self._cut_timers.pop(side, None)
        pair = self.ctx.pair
        if pair is None or pair.simulator is None:
            return
        pair.simulator.pty(side).restore()
        self.ctx.notify(f"Simulated {SIDE_NAMES[side]} leg's link restored; it reconnects by "
                        "itself.")  # fmt: skip

    def update_controls(self) -> None:
        ctx, acts = self.ctx, self.actions
        idle = not ctx.connected and not ctx.connecting
        for name in PAIR_ACTIONS:
            acts[name].setEnabled(idle)
        simulated = ctx.pair is not None and ctx.pair.simulated
        acts["engineering"].setEnabled(ctx.pair is None)  # one leg's traces and sensors
        for name in CUT_ACTIONS:
            acts[name].setEnabled(simulated)
