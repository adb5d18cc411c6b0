"""The user's folders gaitmon writes to, by each operating system's rules (platformdirs).

One place for all three, so no module spells a folder of one OS (``~/.local/share``) on every
OS: data (exclusions kept when a recording's folder is read-only), cache (numba's compiled
loops) and logs. On Linux they follow the XDG variables: ``$XDG_DATA_HOME/gaitmon``
(``~/.local/share/gaitmon``), ``$XDG_CACHE_HOME/gaitmon`` (``~/.cache/gaitmon``),
``$XDG_STATE_HOME/gaitmon/log`` (``~/.local/state/gaitmon/log``); on Windows under
``%LOCALAPPDATA%\\gaitmon``, on macOS under ``~/Library``. Nothing here creates a folder.

On Linux the XDG base-directory rule is applied here when it is plain (the variable unset,
blank or an absolute path, ``$HOME`` absolute): what platformdirs answers there, without
importing it, whose Linux module costs every command ~8 ms (tempfile, shutil, regexes;
issue 28). Anything else (another OS, a relative variable, Android) asks platformdirs.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

APP = "gaitmon"

# Linux, where the XDG rule below is platformdirs' own (Android, which reports "linux" too,
# has folders of its own)
_XDG = sys.platform == "linux" and "ANDROID_DATA" not in os.environ


def _xdg(variable: str, default: str) -> Path | None:
    """``$variable/gaitmon`` or ``~/<default>/gaitmon`` by the XDG rule, where it is plain;
    None where platformdirs must decide."""
    if not _XDG:
        return None
    value = os.environ.get(variable, "")
    if os.path.isabs(value):
        return Path(value, APP)
    home = os.environ.get("HOME")
    if value.strip() or (home is not None and not os.path.isabs(home)):
        return None  # a relative variable or home: platformdirs' versions differ on them
    return Path(os.path.expanduser(f"~/{default}"), APP)


def user_data_dir() -> Path:
    if (plain := _xdg("XDG_DATA_HOME", ".local/share")) is not None:
        return plain
    import platformdirs

    return Path(platformdirs.user_data_dir(APP, False))


def user_cache_dir() -> Path:
    if (plain := _xdg("XDG_CACHE_HOME", ".cache")) is not None:
        return plain
    import platformdirs

    return Path(platformdirs.user_cache_dir(APP, False))


def user_log_dir() -> Path:
    if (plain := _xdg("XDG_STATE_HOME", ".local/state")) is not None:
        return plain / "log"
    import platformdirs

    return Path(platformdirs.user_log_dir(APP, False))


def log_file() -> Path:
    """The log file of the command line and the windows (:mod:`gaitmon.logs`)."""
    return user_log_dir() / "gaitmon.log"
