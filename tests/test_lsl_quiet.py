"""``gaitmon record --lsl -q`` prints no liblsl log line, one leg or two (liblsl logs at INFO
on standard error unless told otherwise; gaitmon tells it through the lsl_api.cfg text of
``gaitmon.lsl.network``). A user's own configuration that asks for INFO gets it: the check
below would see liblsl's lines, so its passing says something."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("pylsl")

ROOT = Path(__file__).resolve().parents[1]
# liblsl's (loguru) line: "2026-11-29 13:56:13.131 (  26.821s) [thread] file.cpp:375 INFO| ..."
LIBLSL_LINE = re.compile(r"\(\s*[\d.]+s\)\s*\[|\b(INFO|WARN|ERR)\|")


def _record(tmp_path: Path, source: str, name: str, cfg: Path | None = None) -> list[str]:
    env = {k: v for k, v in os.environ.items() if k != "LSLAPICFG"}
    env["PYTHONPATH"] = str(ROOT)
    if cfg is not None:
        env["LSLAPICFG"] = str(cfg)
    proc = subprocess.run(
        [sys.executable, "-m", "gaitmon", "record", source, "--duration", "1", "--lsl", "-q",
         "-o", str(tmp_path / name)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=180,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return proc.stderr.splitlines()


@pytest.mark.parametrize("source", ["--simulate", "--simulate-bilateral"])
def test_record_lsl_quiet_prints_no_liblsl_line(tmp_path, source):
    lines = _record(tmp_path, source, "a.h5")
    assert [x for x in lines if LIBLSL_LINE.search(x)] == []
    assert all(x.startswith("gaitmon record:") for x in lines), lines  # its one-line results


def test_a_users_configuration_asking_for_info_gets_it(tmp_path):
    cfg = tmp_path / "lsl_api.cfg"
    cfg.write_text("[log]\nlevel = 0\n")
    lines = _record(tmp_path, "--simulate", "b.h5", cfg)
    assert [x for x in lines if LIBLSL_LINE.search(x)], lines
