"""The user's folders gaitmon writes to, by each operating system's rules (platformdirs).

One place for all three, so no module spells a folder of one OS (``~/.local/share``) on every
OS: data (exclusions kept when a recording's folder is read-only), cache (numba's compiled
loops) and logs. On Linux they follow the XDG variables: ``$XDG_DATA_HOME/gaitmon``
(``~/.local/share/gaitmon``), ``$XDG_CACHE_HOME/gaitmon`` (``~/.cache/gaitmon``),
``$XDG_STATE_HOME/gaitmon/log`` (``~/.local/state/gaitmon/log``); on Windows under
``%LOCALAPPDATA%\\gaitmon``, on macOS under ``~/Library``. Nothing here creates a folder.
"""

from __future__ import annotations

from pathlib import Path

APP = "gaitmon"


def user_data_dir() -> Path:
    import platformdirs

    return Path(platformdirs.user_data_dir(APP, False))


def user_cache_dir() -> Path:
    import platformdirs

    return Path(platformdirs.user_cache_dir(APP, False))


def user_log_dir() -> Path:
    import platformdirs

    return Path(platformdirs.user_log_dir(APP, False))


def log_file() -> Path:
    """The log file of the command line and the windows (:mod:`gaitmon.logs`)."""
    return user_log_dir() / "gaitmon.log"
