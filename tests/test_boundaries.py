"""Only gaitmon.ui may import Qt: the engine, command line and tests run headless."""

import subprocess
import sys

import pytest

QT_MODULES = ("PySide6", "pyqtgraph", "shiboken6")


@pytest.mark.parametrize("package", ["gaitmon.dsp", "gaitmon.io", "gaitmon.cli"])
def test_package_does_not_import_qt(package):
    import gaitmon

    root = __import__("pathlib").Path(gaitmon.__file__).parent
    sub = package.split(".")[1:]
    pkg_dir = root.joinpath(*sub)
    modules = [package]
    if pkg_dir.is_dir():
        for path in sorted(pkg_dir.rglob("*.py")):
            rel = path.relative_to(root.parent).with_suffix("")
            name = ".".join(rel.parts)
            modules.append(name.removesuffix(".__init__"))
    code = (
        "import importlib, sys\n"
        f"for m in {modules!r}: importlib.import_module(m)\n"
        f"bad = [m for m in {QT_MODULES!r} if m in sys.modules]\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"{package} pulled in Qt: {out.stdout.strip()}"
    assert len(modules) >= 1
