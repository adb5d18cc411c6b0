"""What a reprocessing changes: the settings ``gaitmon process`` and ``gaitmon batch`` take.

One place for the names, the checks and how the changes are laid over a recorded
:class:`PipelineConfig`, so that a single file and a whole study are reprocessed by the same
rules. :class:`Reprocessing` is a frozen, picklable value: ``gaitmon batch`` hands it to every
worker (a local process or a Dask worker), which applies it to each file's own settings.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from gaitmon.dsp.methods import get_method, live_names, settings_read_by
from gaitmon.errors import UserError

if TYPE_CHECKING:  # applied to a recorded one: the settings and their help need no pipeline
    from gaitmon.dsp.pipeline import PipelineConfig

# setting (PipelineConfig field; the command-line option is --the-name-with-dashes) -> help
SETTINGS = {
    "cutoff_hz": "low-pass cut-off (Hz)",
    "q_angle": "Kalman Q_angle",
    "q_gyro": "Kalman Q_gyro",
    "r": "Kalman R (accelerometer tilt variance)",
    "fsr_threshold": "FSR contact threshold (ADC counts)",
}
# settings that only the paper's filter reads: given with the gait-aware filter they would
# silently change nothing (each method says which settings it reads: gaitmon.dsp.methods;
# the registry's declaration, so that building the options imports no method's filter)
PAPER_ONLY = settings_read_by("paper")


def method_only_settings() -> dict[str, tuple[str, ...]]:
    """Settings that only some of the app's tilt methods read -> the methods that read them."""
    out: dict[str, tuple[str, ...]] = {}
    for method in live_names():
        for name in settings_read_by(method):
            out[name] = (*out.get(name, ()), method)
    return out

# The FSR channels are 12-bit ADC counts: a threshold at or above the top is never crossed.
FSR_MAX_COUNTS = 4095


def option(name: str) -> str:
    """``cutoff_hz`` -> ``--cutoff-hz``."""
    return f"--{name.replace('_', '-')}"


def check_settings(changes: Mapping[str, float]) -> None:
    """Reject settings that cannot work, one line naming the option (the pipeline's own checks
    follow, for the combinations only it knows, such as a cut-off above Nyquist)."""
    for name, value in changes.items():
        opt = option(name)
        if not math.isfinite(value):
            raise UserError(f"{opt} must be a number, got {value:g}")
        if value <= 0:
            raise UserError(f"{opt} must be above 0, got {value:g}")
    t = changes.get("fsr_threshold")
    if t is not None and t >= FSR_MAX_COUNTS:
        raise UserError(
            f"--fsr-threshold must be above 0 and below {FSR_MAX_COUNTS} counts (the 12-bit "
            f"ADC's top, never crossed), got {t:g}"
        )


@dataclass(frozen=True)
class Reprocessing:
    """Settings to change (``changes``: SETTINGS name -> value) and the tilt filter
    (``method``); ``None`` / empty keep what each file was recorded with."""

    changes: tuple[tuple[str, float], ...] = ()
    method: str | None = None

    @classmethod
    def of(cls, changes: Mapping[str, float], method: str | None = None) -> Reprocessing:
        """Checked (:func:`check_settings`); the changes in SETTINGS order, so that equal
        settings are equal values (and fingerprints)."""
        unknown = sorted(set(changes) - set(SETTINGS))
        if unknown:
            raise UserError(f"unknown setting {unknown[0]!r}; known: {', '.join(SETTINGS)}")
        if method is not None and method not in live_names():
            raise UserError(f"method must be one of {', '.join(live_names())}, got {method!r}")
        values = {k: float(changes[k]) for k in SETTINGS if k in changes}
        check_settings(values)
        return cls(tuple(values.items()), method)

    @property
    def as_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = dict(self.changes)
        if self.method is not None:
            d["method"] = self.method
        return d

    def fingerprint(self) -> str:
        """A stable text for "the same settings" (JSON, keys sorted)."""
        return json.dumps(self.as_dict, sort_keys=True)

    def describe(self) -> str:
        """``cutoff_hz=4, method=paper``, or "the recorded settings"."""
        parts = [f"{k}={v:g}" for k, v in self.changes]
        if self.method is not None:
            parts.append(f"method={self.method}")
        return ", ".join(parts) or "the recorded settings"

    def apply(self, recorded: PipelineConfig) -> PipelineConfig:
        """``recorded`` with these changes; :class:`UserError` (one line) when they do not fit
        it: settings of the paper's filter without that filter, or what the pipeline rejects."""
        choices: dict[str, object] = {}
        if self.method is not None:
            choices["tilt_method"] = self.method
        changes = dict(self.changes)
        try:
            config = recorded.replace(**changes, **choices)
        except ValueError as exc:
            raise UserError(f"bad setting: {exc}") from None
        only = method_only_settings()
        unread = [k for k in only if k in changes and config.tilt_method not in only[k]]
        if unread:
            owner = get_method(only[unread[0]][0])
            raise UserError(
                f"{', '.join(option(k) for k in unread)} tune {owner.noun_phrase}, which this "
                f"reprocessing does not use ({config.tilt_method_label}); add --method "
                f"{owner.name}"
            )
        return config


def from_json(text: str) -> Reprocessing:
    """Settings from a JSON object: ``{"cutoff_hz": 4, "method": "paper"}`` (dashes or
    underscores in the names; ``gaitmon batch --settings``)."""
    try:
        doc = json.loads(text)
    except ValueError as exc:
        raise UserError(f"--settings is not valid JSON ({exc})") from None
    if not isinstance(doc, dict):
        raise UserError('--settings must be a JSON object such as {"cutoff_hz": 4}')
    changes: dict[str, float] = {}
    method = None
    for key, value in doc.items():
        name = str(key).strip().lstrip("-").replace("-", "_")
        if name in ("method", "tilt_method"):
            method = None if value is None else str(value)
            continue
        if name not in SETTINGS:
            raise UserError(
                f"--settings: unknown setting {key!r}; known: method, {', '.join(SETTINGS)}"
            )
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise UserError(f"--settings: {key} must be a number, got {value!r}")
        changes[name] = float(value)
    return Reprocessing.of(changes, method)
