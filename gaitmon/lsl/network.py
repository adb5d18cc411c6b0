"""Which network gaitmon's Lab Streaming Layer talks to (``--lsl-scope``), applied once per
process through liblsl's own configuration (``pylsl.set_config_content``, the text of an
``lsl_api.cfg``) before liblsl opens its first socket.

``machine`` (the default): discovery stays on this computer. liblsl answers resolve queries
only on the loopback interface (``[multicast] ResolveScope = machine``, ``ListenAddress =
127.0.0.1``), sends its own queries only there, and opens no IPv6 socket (``[ports] IPv6 =
disable``). Programs on this computer (LabRecorder, a stimulator's script) find gaitmon's
streams and gaitmon finds theirs; other computers do not discover them. liblsl has no setting
that binds an outlet's data (TCP) and time (UDP) ports to one interface: they stay bound to
every IPv4 interface (ports 16572 and up), so a peer that already knows the port can still
connect; a host firewall is what closes them (docs/lsl.md, docs/trust-model.md).

``link`` / ``site``: liblsl's own scopes (its default is ``site``): discovery on the local
network segment, or across the site's routers; IPv6 as liblsl's default allows.

A user's own ``lsl_api.cfg`` (``LSLAPICFG``, ``./lsl_api.cfg``, ``~/lsl_api/lsl_api.cfg``,
``/etc/lsl_api/lsl_api.cfg``) may hold the lab's settings: every setting it makes is kept
(gaitmon gives liblsl the file's text with its own settings added only where the file is
silent), and ``--lsl-scope`` is refused when the file sets the scope itself (the file
decides). A file that cannot be read is left to liblsl, untouched.
"""

from __future__ import annotations

import configparser
import contextlib
import os
from pathlib import Path
from types import ModuleType

from gaitmon.errors import UserError

SCOPES: tuple[str, ...] = ("machine", "link", "site")
DEFAULT_SCOPE = "machine"

_LOG = {"level": "-2"}  # liblsl logs at INFO on standard error: errors only
_SETTINGS: dict[str, dict[str, dict[str, str]]] = {
    "machine": {
        "multicast": {"ResolveScope": "machine", "ListenAddress": "127.0.0.1"},
        "ports": {"IPv6": "disable"},
    },
    "link": {"multicast": {"ResolveScope": "link"}},
    "site": {"multicast": {"ResolveScope": "site"}},
}

_applied: str | None = None  # the scope applied in this process, or "file" (the user's)


def config_text(scope: str, user_text: str = "") -> str:
    """The ``lsl_api.cfg`` text gaitmon gives liblsl for ``scope``: ``user_text`` (the user's
    own file) with gaitmon's settings added where it makes none (none of the network ones
    when it sets the scope itself: its scope comes with its own addresses)."""
    if scope not in _SETTINGS:
        raise UserError(f"--lsl-scope must be one of {', '.join(SCOPES)}; got {scope!r}")
    ini = _parse(user_text)
    ours = {"log": _LOG} if _sets_scope(user_text) else {**_SETTINGS[scope], "log": _LOG}
    for section, values in ours.items():
        have = ini.setdefault(section, {})
        for key, value in values.items():
            if key.lower() not in {k.lower() for k in have}:
                have[key] = value
    return "".join(
        f"[{section}]\n" + "".join(f"{k} = {v}\n" for k, v in values.items())
        for section, values in ini.items()
    )


def _parse(text: str) -> dict[str, dict[str, str]]:
    """An ``lsl_api.cfg`` as sections of keys (their spelling kept); a UserError if it is
    not one."""
    parser = configparser.ConfigParser(interpolation=None, strict=False,
                                       comment_prefixes=(";", "#"))  # fmt: skip
    parser.optionxform = str  # type: ignore[assignment,method-assign]
    try:
        parser.read_string(text)
    except configparser.Error as exc:
        raise UserError(f"LSL configuration file: {' '.join(str(exc).split())[:200]}") from None
    return {s: dict(parser.items(s, raw=True)) for s in parser.sections()}


def _sets_scope(user_text: str) -> bool:
    ini = {s.lower(): {k.lower() for k in v} for s, v in _parse(user_text).items()}
    return "resolvescope" in ini.get("multicast", set())


def user_config() -> Path | None:
    """The user's own liblsl configuration file, if there is one (liblsl's search order)."""
    env = os.environ.get("LSLAPICFG")
    if env:
        return Path(env)
    for p in (Path("lsl_api.cfg"), Path.home() / "lsl_api" / "lsl_api.cfg",
              Path("/etc/lsl_api/lsl_api.cfg")):  # fmt: skip
        if p.is_file():
            return p
    return None


def configure(pylsl: ModuleType, scope: str | None = None) -> str:
    """Apply ``scope`` (None: the default, ``machine``) to this process's liblsl, once; what
    is in force ("machine", "link", "site" or "the file PATH"). A second call with another
    explicit scope is a UserError (liblsl reads its configuration once per process)."""
    global _applied
    wanted = DEFAULT_SCOPE if scope is None else scope
    config_text(wanted)  # a bad name is one line, whatever else happens
    if _applied is not None:
        if scope is not None and _applied != scope:
            raise UserError(
                f"--lsl-scope {scope}: LSL is already set to {_applied} in this process"
            )
        return _applied
    cfg = user_config()
    user_text = ""
    if cfg is not None:
        try:
            user_text = cfg.read_text(encoding="utf-8", errors="replace")
        except OSError:
            _applied = f"the file {cfg}"  # liblsl reads it (or says it cannot)
            return _applied
        if _sets_scope(user_text):
            if scope is not None:
                raise UserError(
                    f"--lsl-scope {scope}: your LSL configuration file {cfg} sets ResolveScope "
                    "itself; change it there, or leave --lsl-scope out"
                )
            _applied = f"the file {cfg}"
    text = config_text(wanted, user_text)
    with contextlib.suppress(Exception):  # too late (LSL already in use) or an old liblsl
        pylsl.set_config_content(text)
    _applied = _applied or wanted
    return _applied
