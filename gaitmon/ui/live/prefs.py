"""What the live monitor remembers between runs: typed access to its QSettings, by the keys
named once in :mod:`gaitmon.review.settings` (:class:`LiveKey`, :attr:`PipelineSetting.key`)."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from PySide6.QtCore import QSettings, QStandardPaths

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.review.settings import PIPELINE_SETTINGS, LiveKey

log = logging.getLogger("gaitmon.ui")


class Prefs:
    """Typed access to the QSettings the window remembers."""

    def __init__(self, settings: QSettings) -> None:
        self.s = settings

    def get(self, key: LiveKey, default: Any = None) -> Any:
        """``key``'s stored value as its type; ``default`` (None: the key's own) when nothing
        is stored or it does not read as that type."""
        return self._read(key.key, key.default if default is None else default, key.kind)

    def set(self, key: LiveKey, value: Any) -> None:
        self.s.setValue(key.key, value)

    def _read(self, key: str, default: Any, kind: type) -> Any:
        value = self.s.value(key, default)
        if value is None:
            return default
        if kind is object:  # as Qt stores it
            return value
        try:
            if kind is bool:
                return value if isinstance(value, bool) else str(value).lower() in ("1", "true")
            return kind(value)
        except (TypeError, ValueError):
            return default

    def pipeline_config(self) -> PipelineConfig:
        """The processing settings last applied: the Settings dialog's numbers and the tilt
        filter (Device ▸ Tilt filter); the defaults for any that are missing or invalid."""
        base = PipelineConfig()
        changes: dict[str, Any] = {}
        for setting in PIPELINE_SETTINGS:
            changes[setting.name] = self._read(setting.key, getattr(base, setting.name), float)
        method = self.get(LiveKey.TILT_METHOD, base.tilt_method)
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
        for setting in PIPELINE_SETTINGS:
            self.s.setValue(setting.key, float(getattr(cfg, setting.name)))
        self.set(LiveKey.TILT_METHOD, cfg.tilt_method)


def default_session_folder() -> Path:
    docs = QStandardPaths.writableLocation(QStandardPaths.StandardLocation.DocumentsLocation)
    return Path(docs or Path.home()) / "gaitmon"
