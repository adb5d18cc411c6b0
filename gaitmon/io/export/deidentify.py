"""De-identification of exports: which session fields identify a patient, and their removal.

Kept free of numpy so that the package's public names (``REDACTED``, ``ANONYMOUS``) cost
nothing to import.
"""

from __future__ import annotations

from typing import Any

REDACTED = "[removed]"  # what an identifying value becomes wherever else it appears
ANONYMOUS = "anonymous"  # C3D subject name when there is none or it is withheld
IDENTIFYING_FIELDS: tuple[str, ...] = ("patient_id", "operator", "notes")


class Scrubber:
    """Blanks the identifying fields and removes their values wherever else they appear."""

    FIELDS = IDENTIFYING_FIELDS

    def __init__(self, session_attrs: dict[str, Any], enabled: bool) -> None:
        """``session_attrs``: the /session attributes as plain values (Source.group_attrs)."""
        self.enabled = enabled
        values = [str(session_attrs.get(k, "")).strip() for k in self.FIELDS]
        # Longest first so a value containing another is removed whole.
        self.secrets = sorted({v for v in values if v}, key=len, reverse=True)

    def text(self, s: str) -> str:
        if not self.enabled:
            return s
        for secret in self.secrets:
            s = s.replace(secret, REDACTED)
        return s

    def value(self, v: Any) -> Any:
        if isinstance(v, str):
            return self.text(v)
        if isinstance(v, list):
            return [self.value(x) for x in v]
        if isinstance(v, dict):
            return {k: self.value(x) for k, x in v.items()}
        return v

    def session(self, attrs: dict[str, Any]) -> dict[str, Any]:
        out = dict(attrs)
        if self.enabled:
            for k in self.FIELDS:
                out[k] = ""
        return self.value(out) if self.enabled else out
