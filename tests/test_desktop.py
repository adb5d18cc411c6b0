"""Desktop integration: the shipped entry and icon, ``gaitmon desktop install|uninstall``, and
the windows' icon and desktop file name (issue 27)."""

from __future__ import annotations

import configparser
import shlex
import shutil
import subprocess
import sys

import numpy as np
import pytest

from gaitmon.cli import main
from gaitmon.ui import desktop

VALIDATE = shutil.which("desktop-file-validate")


def _entry(path):
    cp = configparser.ConfigParser(interpolation=None, strict=True)
    cp.optionxform = str  # keys are case-sensitive
    cp.read(path, encoding="utf-8")
    return cp["Desktop Entry"]


def test_install_writes_the_entry_and_icons_into_xdg_data_home(tmp_path, monkeypatch, capsys):
    home = tmp_path / "share"
    monkeypatch.setenv("XDG_DATA_HOME", str(home))
    assert main(["desktop", "install"]) == 0
    entry_path = home / "applications" / "gaitmon.desktop"
    png = home / "icons" / "hicolor" / "256x256" / "apps" / "gaitmon.png"
    svg = home / "icons" / "hicolor" / "scalable" / "apps" / "gaitmon.svg"
    out = capsys.readouterr().out
    for f in (entry_path, png, svg):
        assert f.is_file() and str(f) in out
    assert png.read_bytes() == desktop.ICON_PNG.read_bytes()
    entry = _entry(entry_path)
    assert entry["Type"] == "Application" and entry["Icon"] == "gaitmon"
    assert entry["Terminal"] == "false"
    # Exec starts this installation's gaitmon: run it, it answers as gaitmon
    argv = shlex.split(entry["Exec"])
    proc = subprocess.run([*argv, "--version"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.startswith("gaitmon "), proc.stderr

    assert main(["desktop", "uninstall"]) == 0
    assert not entry_path.exists() and not png.exists() and not svg.exists()
    assert "removed" in capsys.readouterr().out
    assert main(["desktop", "uninstall"]) == 0
    assert "nothing to remove" in capsys.readouterr().out


def test_exec_falls_back_to_the_interpreter(monkeypatch, tmp_path):
    monkeypatch.setattr(sys, "executable", str(tmp_path / "my env" / "bin" / "python3"))
    monkeypatch.setenv("PATH", str(tmp_path))  # no gaitmon on it
    command = desktop.exec_command()
    assert command == [sys.executable, "-m", "gaitmon"]
    line = desktop.entry_text(command).split("Exec=", 1)[1].splitlines()[0]
    # a path with a space is quoted (the spec's quoting, then the string escapes)
    assert line == f'"{tmp_path}/my env/bin/python3" -m gaitmon'


@pytest.mark.parametrize("arg,quoted", [
    ("/usr/bin/gaitmon", "/usr/bin/gaitmon"),
    ("/a b/gaitmon", '"/a b/gaitmon"'),
    ('/a"b/g', '"/a\\\\"b/g"'),
    ("/a$b/g", '"/a\\\\$b/g"'),
    ("/100%/g", "/100%%/g"),
])  # fmt: skip
def test_exec_arguments_are_quoted_as_the_spec_says(arg, quoted):
    assert desktop.quote_exec_arg(arg) == quoted


@pytest.mark.skipif(VALIDATE is None, reason="desktop-file-validate (desktop-file-utils) missing")
def test_the_installed_entry_is_valid(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    monkeypatch.setattr(sys, "executable", str(tmp_path / "an env" / "bin" / "python3"))
    monkeypatch.setenv("PATH", "")
    for path in (desktop.ENTRY, *[p for p in desktop.install() if p.suffix == ".desktop"]):
        proc = subprocess.run([VALIDATE, str(path)], capture_output=True, text=True, timeout=60)
        assert proc.returncode == 0 and not proc.stdout.strip(), (path, proc.stdout)


def test_install_on_windows_is_one_line(monkeypatch, capsys, tmp_path):
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    monkeypatch.setattr(sys, "platform", "win32")
    assert main(["desktop", "install"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Linux desktops" in err
    assert not any(tmp_path.iterdir())


def test_the_windows_take_the_shipped_icon_and_desktop_name(qapp):
    from PySide6.QtGui import QGuiApplication, QImage

    from gaitmon.ui.app import app_icon, draw_icon, make_application

    make_application("gaitmon test")
    assert QGuiApplication.desktopFileName() == "gaitmon"
    shipped = QImage(str(desktop.ICON_PNG))
    assert shipped.width() == 256
    got = app_icon().pixmap(256, 256).toImage()
    drawn = draw_icon(256).toImage()

    def rgba(img):
        img = img.convertToFormat(QImage.Format.Format_RGBA8888)
        return np.frombuffer(img.constBits(), np.uint8).reshape(256, 256, 4).astype(int)

    assert np.array_equal(rgba(got), rgba(shipped))  # the file, not a drawing
    # the file is the in-code drawing (anti-aliasing may differ by a few levels across Qt)
    assert np.abs(rgba(shipped) - rgba(drawn)).max() <= 8
