"""What ``pip install .`` ships and pulls in: the licence, and only the runtime's dependencies.

Read from the source (pyproject.toml, LICENSE, README.md, the package's imports): fast, and no
build or network needed. The built wheel's metadata was checked by hand at the change (issue 27:
``License-Expression: MIT`` and ``licenses/LICENSE`` in the dist-info).
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import gaitmon

ROOT = Path(gaitmon.__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))

# a distribution's name -> the module it is imported as, where they differ
IMPORT_NAME = {"pyside6-essentials": "PySide6", "pyserial": "serial"}


def _name(requirement: str) -> str:
    return re.split(r"[<>=!~;\[ ]", requirement, maxsplit=1)[0].strip().lower()


def runtime_dependencies() -> list[str]:
    return [_name(r) for r in PYPROJECT["project"]["dependencies"]]


def test_licence_is_an_spdx_string_with_its_text_shipped():
    project = PYPROJECT["project"]
    assert project["license"] == "MIT"  # PEP 639: a string, not the deprecated table
    assert project["license-files"] == ["LICENSE"]
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License")
    assert "Copyright (c) 2026 the gaitmon authors" in text
    assert "WITHOUT WARRANTY OF ANY KIND" in text
    # setuptools reads the SPDX string and license-files from 77 on
    (setuptools,) = [r for r in PYPROJECT["build-system"]["requires"] if _name(r) == "setuptools"]
    assert int(setuptools.split(">=")[1].split(".")[0]) >= 77


def test_readme_names_every_runtime_dependency_licence():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split("### Licences", 1)[1].split("\n## ", 1)[0]
    for dep in runtime_dependencies():
        shown = {"pyside6-essentials": "PySide6"}.get(dep, dep)
        assert shown.lower() in section.lower(), dep
    assert "LGPL-3.0" in section


def _imports(path: Path) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            out.add(node.module.split(".")[0])
    return out


def test_every_runtime_dependency_is_imported_by_the_runtime():
    """A package only tests or ``gaitmon lab`` import belongs in an extra (``test``, ``lab``),
    not in what a clinician's ``pip install .`` downloads."""
    lab = ROOT / "gaitmon" / "lab"
    used: set[str] = set()
    for path in (ROOT / "gaitmon").rglob("*.py"):
        if lab not in path.parents:
            used |= _imports(path)
    for dep in runtime_dependencies():
        assert IMPORT_NAME.get(dep, dep) in used, f"{dep} is a runtime dependency nothing imports"


def test_extras_keep_what_left_the_runtime():
    optional = PYPROJECT["project"]["optional-dependencies"]
    extras = {k: [_name(r) for r in v] for k, v in optional.items()}
    assert "matplotlib" in extras["lab"]
    assert {"matplotlib", "ezc3d"} <= set(extras["test"])


def test_lab_without_matplotlib_says_how_to_install_it(tmp_path):
    code = (
        "import sys; sys.modules['matplotlib'] = None\n"  # as if not installed: import fails
        "from gaitmon.cli import main\n"
        f"raise SystemExit(main(['lab', 'p000', '--quick', '-o', {str(tmp_path / 'out')!r}]))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "gaitmon lab needs matplotlib: pip install 'gaitmon[lab]'" in lines[0]
    assert not (tmp_path / "out").exists()  # nothing made before the check
