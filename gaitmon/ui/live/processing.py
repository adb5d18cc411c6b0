"""The live monitor's processing slots: the Settings dialog and the tilt filter
(Device ▸ Tilt filter), both applied live through the engine's ``apply_config`` (a running
recording logs the change) and remembered in the preferences.
"""

from __future__ import annotations

from PySide6.QtGui import QAction

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import EngineError, Mode
from gaitmon.ui import one_line
from gaitmon.ui.actions import guarded
from gaitmon.ui.dialogs import SettingsDialog
from gaitmon.ui.live.base import LiveWindowBase


class ProcessingSlots(LiveWindowBase):
    """Slots of Device ▸ Settings… and Device ▸ Tilt filter."""

    settings_dialog: SettingsDialog | None
    tilt_actions: dict[str, QAction]

    def _unit_computes(self) -> bool:
        return self.conn is not None and self.conn.engine.mode is not Mode.RAW

    def _apply_config(self, cfg: PipelineConfig, what: str) -> bool:
        """``cfg`` in force from the engine's next block, and remembered; False (and the
        reason in the status bar) if the engine refused it."""
        if self.conn is not None:
            try:
                self.conn.engine.apply_config(cfg)
            except EngineError as exc:
                self.notify(f"{what} not applied: {one_line(exc)}", 30_000)
                return False
        self.config = cfg
        self.prefs.save_pipeline_config(cfg)
        self.live.set_fsr_threshold(cfg.fsr_threshold)
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
        dlg = SettingsDialog(self, self.config, note=note)
        dlg.accepted.connect(self._settings_accepted)
        self.settings_dialog = dlg
        dlg.open()

    @guarded
    def _settings_accepted(self) -> None:
        dlg = self.settings_dialog
        if dlg is None or dlg.config is None:
            return
        # the tilt filter is chosen in its own menu, perhaps while the dialog was open
        cfg = dlg.config.replace(tilt_method=self.config.tilt_method)
        if not self._apply_config(cfg, "Settings"):
            return
        logged = " and logged in the recording" if self._recording else ""
        self.notify(
            f"Settings applied{logged}: cut-off {cfg.cutoff_hz:g} Hz, Q_angle {cfg.q_angle:g}, "
            f"Q_gyro {cfg.q_gyro:g}, R {cfg.r:g}, FSR threshold {cfg.fsr_threshold:g}."
        )

    @guarded
    def set_tilt_method(self, method: str, on: bool = True) -> None:
        """Device ▸ Tilt filter: the filter that makes the Kalman (green) angles."""
        if not on:
            return  # the group is exclusive: the other action's trigger does the work
        if method == self.config.tilt_method:
            self.show_tilt_method()
            return
        cfg = self.config.replace(tilt_method=method)
        if not self._apply_config(cfg, "Tilt filter"):
            self.show_tilt_method()  # the menu goes back to the filter in force
            return
        if self._unit_computes():
            self.notify(
                f"Tilt filter: {cfg.tilt_method_label}, saved; it takes effect when gaitmon "
                "computes (mode “PC computes”): the unit computes the angles in this mode."
            )
        else:
            logged = " (logged in the recording)" if self._recording else ""
            self.notify(f"Tilt filter: {cfg.tilt_method_label}, from now on{logged}.")

    def show_tilt_method(self) -> None:
        """The menu's check mark and, until a snapshot says otherwise, the plots' titles."""
        for key, act in self.tilt_actions.items():
            if act.isChecked() != (key == self.config.tilt_method):
                act.setChecked(key == self.config.tilt_method)
        if self.conn is None:
            self.live.set_angle_method(self.config.tilt_method_label)
