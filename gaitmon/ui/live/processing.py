"""The live window's processing part: the Settings dialog and the tilt filter
(Device ▸ Tilt filter), both applied live through the engine's ``apply_config`` (a running
recording logs the change) and remembered in the preferences. The settings in force are the
context's ``config``; the plots are told the FSR threshold and the filter's name.
"""

from __future__ import annotations

from PySide6.QtGui import QAction, QActionGroup
from PySide6.QtWidgets import QMainWindow

from gaitmon.dsp.methods import live_names
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import EngineError, Mode
from gaitmon.review.settings import PIPELINE_SETTINGS
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.dialogs import SettingsDialog
from gaitmon.ui.live.actions import tilt_action
from gaitmon.ui.live.context import LiveContext
from gaitmon.ui.live.views import ViewPart


class ProcessingPart:
    """Slots of Device ▸ Settings… and Device ▸ Tilt filter; owns the settings dialog and the
    tilt filter's exclusive action group."""

    def __init__(
        self, ctx: LiveContext, window: QMainWindow, actions: dict[str, QAction], view: ViewPart
    ) -> None:
        self.ctx = ctx
        self.window = window
        self.view = view
        self.settings_dialog: SettingsDialog | None = None
        # the methods the registry offers, as when the window built its actions
        self.tilt_actions = {key: actions[tilt_action(key)] for key in live_names()}
        self.tilt_group = QActionGroup(window)  # exclusive: one filter in force
        for a in self.tilt_actions.values():
            self.tilt_group.addAction(a)

    def report_exception(self, where: str, exc: BaseException) -> None:
        self.ctx.report_exception(where, exc)

    def _unit_computes(self) -> bool:
        conn = self.ctx.conn
        return conn is not None and conn.engine.mode is not Mode.RAW

    def _apply_config(self, cfg: PipelineConfig, what: str) -> bool:
        """``cfg`` in force from the engine's next block, and remembered; False (and the
        reason in the status bar) if the engine refused it."""
        ctx = self.ctx
        if ctx.conn is not None:
            try:
                ctx.conn.engine.apply_config(cfg)
            except EngineError as exc:
                ctx.notify(f"{what} not applied: {one_line(exc)}", 30_000)
                return False
        ctx.config = cfg
        ctx.prefs.save_pipeline_config(cfg)
        self.view.live.set_fsr_threshold(cfg.fsr_threshold)
        self.show_tilt_method()
        return True

    @guarded
    def open_settings(self) -> None:
        note = ""
        if self._unit_computes():
            note = (
                "The unit computes the angles in this mode: these settings take effect when "
                "gaitmon computes (mode “PC computes”). They are saved now."
            )
        dlg = SettingsDialog(self.window, self.ctx.config, note=note)
        dlg.accepted.connect(self._settings_accepted)
        self.settings_dialog = dlg
        dlg.open()

    @guarded
    def _settings_accepted(self) -> None:
        dlg = self.settings_dialog
        if dlg is None or dlg.config is None:
            return
        # the tilt filter is chosen in its own menu, perhaps while the dialog was open
        cfg = dlg.config.replace(tilt_method=self.ctx.config.tilt_method)
        if not self._apply_config(cfg, "Settings"):
            return
        logged = " and logged in the recording" if self.ctx.recording else ""
        self.ctx.notify(f"Settings applied{logged}: {settings_text(cfg)}.")

    @guarded
    def set_tilt_method(self, method: str, on: bool = True) -> None:
        """Device ▸ Tilt filter: the filter that makes the Kalman (green) angles."""
        if not on:
            return  # the group is exclusive: the other action's trigger does the work
        if method == self.ctx.config.tilt_method:
            self.show_tilt_method()
            return
        cfg = self.ctx.config.replace(tilt_method=method)
        if not self._apply_config(cfg, "Tilt filter"):
            self.show_tilt_method()  # the menu goes back to the filter in force
            return
        if self._unit_computes():
            self.ctx.notify(
                f"Tilt filter: {cfg.tilt_method_label}, saved; it takes effect when gaitmon "
                "computes (mode “PC computes”): the unit computes the angles in this mode."
            )
        else:
            logged = " (logged in the recording)" if self.ctx.recording else ""
            self.ctx.notify(f"Tilt filter: {cfg.tilt_method_label}, from now on{logged}.")

    def show_tilt_method(self) -> None:
        """The menu's check mark and, until a snapshot says otherwise, the plots' titles."""
        config = self.ctx.config
        for key, act in self.tilt_actions.items():
            if act.isChecked() != (key == config.tilt_method):
                act.setChecked(key == config.tilt_method)
        if self.ctx.conn is None:
            self.view.live.set_angle_method(config.tilt_method_label)


def settings_text(cfg: PipelineConfig) -> str:
    """The Settings dialog's values in force: "cut-off 4 Hz, Q_angle 0.001, …, FSR threshold
    1000" (the settings table's short names and units)."""
    return ", ".join(f"{s.short} {getattr(cfg, s.name):g}{s.unit}" for s in PIPELINE_SETTINGS)
