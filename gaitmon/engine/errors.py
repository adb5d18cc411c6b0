"""The engine's one error type (``gaitmon.engine.core`` re-exports it)."""

from __future__ import annotations


class EngineError(Exception):
    """A one-line, actionable problem (no device data, a refused zeroing, ...)."""
