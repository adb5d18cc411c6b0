"""mypy stays clean on what pyproject.toml's [tool.mypy] lists: the whole package.

Runs the real mypy with the project's configuration in a subprocess, so the result is the one
a developer gets from ``python -m mypy`` at the repository root. The incremental cache
(.mypy_cache, git-ignored) makes repeat runs take a second or two; a cold run takes a few.
"""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _mypy_config() -> dict[str, Any]:
    with open(ROOT / "pyproject.toml", "rb") as f:
        return tomllib.load(f).get("tool", {}).get("mypy", {})


def test_the_configuration_names_the_checked_packages() -> None:
    # An empty or missing `files` would make mypy check nothing (or fail to start) and the test
    # below would prove little; the style guide asks for dsp and io at least.
    files = _mypy_config().get("files", [])
    required = ("gaitmon/dsp", "gaitmon/io", "gaitmon/engine", "gaitmon/analysis.py",
                "gaitmon/ui", "gaitmon/commands", "gaitmon/cli.py")  # fmt: skip
    for path in required:
        covered = any(path == f or path.startswith(f.rstrip("/") + "/") for f in files)
        assert covered, f"[tool.mypy] files no longer covers {path}"
        assert (ROOT / path).exists(), f"[tool.mypy] covers {path}, which does not exist"


def test_mypy_is_clean() -> None:
    pytest.importorskip("mypy", reason="mypy is not installed (pip install -e '.[test]')")
    proc = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(ROOT / "pyproject.toml")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
    )
    report = (proc.stdout + proc.stderr).strip()
    assert proc.returncode == 0, f"mypy found problems (exit {proc.returncode}):\n{report}"
    # guard against a configuration that silently checks nothing
    assert "no issues found" in proc.stdout and " 0 source files" not in proc.stdout, report
