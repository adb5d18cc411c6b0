"""De-identification of exports: what identifies a patient or a session, and its removal.

With ``--deidentify`` an export keeps the measurements and drops (docs/file-format.md,
"De-identified exports"):

* the patient id, operator and notes (blanked, and their values removed wherever else they
  appear, e.g. in a marker label);
* the unit's serial number and the transport (a Bluetooth address names the unit);
* the recording's date and time: ``created_utc`` and the wall-clock offset are left out, and
  the host clock column is shifted to start at 0, so every time in the export counts from the
  start of the recording and none says when it was made;
* the input's file name (often a patient code): the default output name is
  ``deidentified-<random>`` instead of the input's name.

Kept free of numpy so that the package's public names (``REDACTED``, ``ANONYMOUS``) cost
nothing to import.
"""

from __future__ import annotations

from collections.abc import Mapping

from gaitmon.values import JsonObject, JsonValue

REDACTED = "[removed]"  # what an identifying value becomes wherever else it appears
ANONYMOUS = "anonymous"  # C3D subject name when there is none or it is withheld
IDENTIFYING_FIELDS: tuple[str, ...] = ("patient_id", "operator", "notes")
DEVICE_FIELDS_DROPPED: tuple[str, ...] = ("serial", "transport")  # name the very unit used
ROOT_FIELDS_DROPPED: tuple[str, ...] = ("created_utc",)  # when the recording was made
DEIDENTIFIED_STEM = "deidentified"  # default output names: deidentified-<8 random hex>


class Scrubber:
    """Blanks the identifying fields and removes their values wherever else they appear."""

    FIELDS = IDENTIFYING_FIELDS

    def __init__(self, session_attrs: Mapping[str, JsonValue], enabled: bool) -> None:
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

    def value(self, v: JsonValue) -> JsonValue:
        if isinstance(v, str):
            return self.text(v)
        if isinstance(v, list):
            return [self.value(x) for x in v]
        if isinstance(v, dict):
            return self.mapping(v)
        return v

    def mapping(self, attrs: Mapping[str, JsonValue]) -> JsonObject:
        """:meth:`value` of a mapping, as a dict."""
        return {k: self.value(x) for k, x in attrs.items()}

    def session(self, attrs: Mapping[str, JsonValue]) -> JsonObject:
        out = dict(attrs)
        if self.enabled:
            for k in self.FIELDS:
                out[k] = ""
        return self.mapping(out) if self.enabled else out

    def device(self, attrs: Mapping[str, JsonValue]) -> JsonObject:
        """The /device attributes without the unit's serial and transport."""
        if not self.enabled:
            return dict(attrs)
        return self.mapping({k: v for k, v in attrs.items() if k not in DEVICE_FIELDS_DROPPED})

    def root(self, attrs: Mapping[str, JsonValue]) -> JsonObject:
        """The file's root attributes without the recording's date and time."""
        if not self.enabled:
            return dict(attrs)
        return self.mapping({k: v for k, v in attrs.items() if k not in ROOT_FIELDS_DROPPED})
