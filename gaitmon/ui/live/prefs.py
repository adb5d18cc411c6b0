"""What the live monitor remembers between runs: typed access to its QSettings."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from PySide6.QtCore import QSettings, QStandardPaths

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.ui.dialogs import SETTINGS_FIELDS

log = logging.getLogger("gaitmon.ui")


class Prefs:
    """Typed access to the QSettings the window remembers."""

    def __init__(self, settings: QSettings) -> None:
        self.s = settings

    def get(self, key: str, default: Any, kind: type = str) -> Any:
        value = self.s.value(key, default)
        if value is None:
            return default
        try:
            if kind is bool:
                return value if isinstance(value, bool) else str(value).lower() in ("1", "true")
            return kind(value)
        except (TypeError, ValueError):
            return default

    def set(self, key: str, value: Any) -> None:
        self.s.setValue(key, value)

    def pipeline_config(self) -> PipelineConfig:
        """The processing settings last applied: the Settings dialog's numbers and the tilt
        filter (Device ▸ Tilt filter); the defaults for any that are missing or invalid."""
        base = PipelineConfig()
        changes: dict[str, Any] = {}
        for name, _label, _tip in SETTINGS_FIELDS:
            changes[name] = self.get(f"pipeline/{name}", getattr(base, name), float)
        method = self.get("pipeline/tilt_method", base.tilt_method, str)
        try:
            base = base.replace(tilt_method=method)
        except ValueError:
            log.warning("stored tilt filter %r is unknown; using %s", method, base.tilt_method)
        try:
            return base.replace(**changes)
        except (ValueError, TypeError):
            log.warning("stored processing settings are invalid; using the paper's values")
            return base

    def save_pipeline_config(self, cfg: PipelineConfig) -> None:
        for name, _label, _tip in SETTINGS_FIELDS:
            self.set(f"pipeline/{name}", float(getattr(cfg, name)))
        self.set("pipeline/tilt_method", cfg.tilt_method)


def default_session_folder() -> Path:
    docs = QStandardPaths.writableLocation(QStandardPaths.StandardLocation.DocumentsLocation)
    return Path(docs or Path.home()) / "gaitmon"
