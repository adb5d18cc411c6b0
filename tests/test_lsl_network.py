"""LSL's network settings (``gaitmon.lsl.network``) and a marker stream's budget
(``gaitmon.lsl.inlet.MarkerBudget``): pure parts, no socket (the sockets themselves:
tests/test_lsl_hostile.py)."""

from __future__ import annotations

import configparser
from types import SimpleNamespace

import pytest

from gaitmon.errors import UserError
from gaitmon.lsl import network
from gaitmon.lsl.inlet import MarkerBudget
from gaitmon.lsl.network import config_text


def _ini(text: str) -> dict[str, dict[str, str]]:
    p = configparser.ConfigParser(interpolation=None)
    p.optionxform = str  # type: ignore[assignment,method-assign]
    p.read_string(text)
    return {s: dict(p.items(s)) for s in p.sections()}


def test_machine_scope_is_loopback_discovery_without_ipv6():
    ini = _ini(config_text("machine"))
    assert ini["multicast"] == {"ResolveScope": "machine", "ListenAddress": "127.0.0.1"}
    assert ini["ports"] == {"IPv6": "disable"}
    assert ini["log"] == {"level": "-2"}


def test_a_users_file_is_kept_and_completed_where_it_is_silent():
    user = "[lab]\nSessionID = ward-3\n[ports]\nBasePort = 17000\n[log]\nlevel = 0\n"
    ini = _ini(config_text("machine", user))
    assert ini["lab"] == {"SessionID": "ward-3"}
    assert ini["ports"] == {"BasePort": "17000", "IPv6": "disable"}
    assert ini["log"] == {"level": "0"}  # the user's log level, not gaitmon's
    assert ini["multicast"]["ResolveScope"] == "machine"


def test_a_users_file_that_sets_the_scope_decides_it(tmp_path, monkeypatch):
    user = "[multicast]\nresolvescope = site\n"
    ini = _ini(config_text("machine", user))
    assert ini["multicast"] == {"resolvescope": "site"}  # no loopback address added to it
    assert "ports" not in ini
    cfg = tmp_path / "lsl_api.cfg"
    cfg.write_text(user)
    monkeypatch.setenv("LSLAPICFG", str(cfg))
    monkeypatch.setattr(network, "_applied", None)
    calls: list[str] = []
    fake = SimpleNamespace(set_config_content=calls.append)
    with pytest.raises(UserError, match="sets ResolveScope itself"):
        network.configure(fake, "link")
    assert network.configure(fake, None) == f"the file {cfg}"
    assert calls == ["[multicast]\nresolvescope = site\n[log]\nlevel = -2\n"]


def test_an_unknown_scope_is_one_line():
    with pytest.raises(UserError, match="--lsl-scope must be one of machine, link, site"):
        config_text("global")


def test_budget_allows_a_burst_then_its_rate_and_a_total():
    b = MarkerBudget(rate_hz=10.0, burst=5, total=12)
    assert [b.take(0.0) for _ in range(7)] == [True] * 5 + [False] * 2
    assert [b.take(0.5) for _ in range(6)] == [True] * 5 + [False]  # 0.5 s x 10/s refilled
    assert [b.take(10.0) for _ in range(5)] == [True, True, False, False, False]  # total 12
    chunk = MarkerBudget(rate_hz=10.0, burst=5, total=12)
    assert (chunk.allow(0.0, 7), chunk.allow(0.5, 6), chunk.allow(10.0, 5)) == (5, 5, 2)
