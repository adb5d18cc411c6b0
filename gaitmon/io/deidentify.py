"""De-identification of exports: what identifies a patient or a session, and its removal.

With ``--deidentify`` an export keeps the measurements and drops (docs/file-format.md,
"De-identified exports"):

* the patient id, operator and notes (blanked, and their values removed from what a person
  typed, e.g. a marker label or an exclusion's label, and from the file names and paths that
  gaitmon's own messages quote, e.g. a stop reason "imported from P123.xdf"; gaitmon's own
  words are never rewritten, so a patient id "both" leaves "a session of both legs" alone);
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

import contextlib
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

from gaitmon.values import JsonObject, JsonValue

REDACTED = "[removed]"  # what an identifying value becomes wherever else it appears
ANONYMOUS = "anonymous"  # C3D subject name when there is none or it is withheld
IDENTIFYING_FIELDS: tuple[str, ...] = ("patient_id", "operator", "notes")
DEVICE_FIELDS_DROPPED: tuple[str, ...] = ("serial", "transport")  # name the very unit used
ROOT_FIELDS_DROPPED: tuple[str, ...] = ("created_utc",)  # when the recording was made
DEIDENTIFIED_STEM = "deidentified"  # default output names: deidentified-<8 random hex>


# a token that names a file or a folder: it holds a path separator, or ends in an extension
# (a letter after the last dot: "P123.h5", "visit.xdf:", not "1.2.3" or "0.5")
_TOKEN = re.compile(r"\S+")
_PATHISH = re.compile(r"[/\\]|\w\.[A-Za-z][A-Za-z0-9]{0,7}\W*$")


def scrub_free_text(text: str, secrets: Sequence[tuple[str, str]]) -> str:
    """Text a person typed (a marker label, an exclusion's label): each ``(secret, by)``
    replaced wherever it occurs (``secrets`` longest first)."""
    for secret, by in secrets:
        if secret:
            text = text.replace(secret, by)
    return text


def scrub_file_names(text: str, secrets: Sequence[tuple[str, str]]) -> str:
    """A message gaitmon composed (a gap's reason, a stop reason, an error line): each
    ``(secret, by)`` replaced only inside the file names and paths it quotes, never in
    gaitmon's own words (a patient id "both" must not turn "a session of both legs" into
    "a session of [removed] legs")."""
    if not any(s for s, _ in secrets):
        return text

    def token(m: re.Match[str]) -> str:
        t = m.group(0)
        return scrub_free_text(t, secrets) if _PATHISH.search(t) else t

    return _TOKEN.sub(token, text)


class Scrubber:
    """Blanks the identifying fields and removes their values from what a person typed
    (:meth:`text`) and from the file names in gaitmon's own texts (:meth:`value`,
    :meth:`mapping`)."""

    FIELDS = IDENTIFYING_FIELDS

    def __init__(self, session_attrs: Mapping[str, JsonValue], enabled: bool) -> None:
        """``session_attrs``: the /session attributes as plain values (Source.group_attrs)."""
        self.enabled = enabled
        values = [str(session_attrs.get(k, "")).strip() for k in self.FIELDS]
        # Longest first so a value containing another is removed whole.
        self.secrets = sorted({v for v in values if v}, key=len, reverse=True)
        self._pairs = [(v, REDACTED) for v in self.secrets]

    def text(self, s: str) -> str:
        """Text a person typed: every identifying value removed."""
        return scrub_free_text(s, self._pairs) if self.enabled else s

    def names(self, s: str) -> str:
        """A text gaitmon composed: identifying values removed from the file names it quotes."""
        return scrub_file_names(s, self._pairs) if self.enabled else s

    def value(self, v: JsonValue) -> JsonValue:
        """Stored values (settings, reasons): :meth:`names` of every string in them."""
        if isinstance(v, str):
            return self.names(v)
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


# -- the re-identification key: private from its creation -------------------------------------

PRIVATE_DIR_MODE = 0o700  # the key folder and every folder in it: its owner's only
PRIVATE_FILE_MODE = 0o600  # every file in it (it links labels to patient ids)


def make_private_dir(path: Path) -> None:
    """Make ``path`` and its missing parents, each created 0700 (``os.mkdir``'s mode, not a
    chmod afterwards: no moment when another user could open it). A folder that is already
    there (a key folder of an older gaitmon, made 0755) is tightened to 0700."""
    missing: list[Path] = []
    p = Path(path)
    while not p.exists():
        missing.append(p)
        p = p.parent
    for d in reversed(missing):
        with contextlib.suppress(FileExistsError):
            os.mkdir(d, PRIVATE_DIR_MODE)
    if not missing and os.name == "posix" and Path(path).stat().st_mode & 0o077:
        os.chmod(path, PRIVATE_DIR_MODE)


def create_private_file(path: Path) -> int:
    """A new, empty ``path`` created 0600 (whatever the umask lets through less), open for
    writing: its file descriptor. A left-over file of that name is replaced, not reused (it
    may have been created with other permissions)."""
    with contextlib.suppress(FileNotFoundError):
        os.unlink(path)
    return os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0),
                   PRIVATE_FILE_MODE)  # fmt: skip
