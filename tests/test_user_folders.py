"""The user's folders (gaitmon.paths: platformdirs) and the command line's log (gaitmon.logs)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import platformdirs
import pytest

from gaitmon import paths
from gaitmon.cli import main
from gaitmon.io.session import exclusions

ROOT = Path(__file__).resolve().parents[1]


def test_folders_follow_the_xdg_variables(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    assert paths.user_data_dir() == tmp_path / "data" / "gaitmon"
    assert paths.user_cache_dir() == tmp_path / "cache" / "gaitmon"
    assert paths.log_file() == tmp_path / "state" / "gaitmon" / "log" / "gaitmon.log"


@pytest.mark.skipif(not paths._XDG, reason="the XDG rule is applied by gaitmon.paths on Linux")
@pytest.mark.parametrize("value", [None, "", "  ", "ABS", "ABS/", "relative/dir"])
@pytest.mark.parametrize("home", ["HOME", None, "relative-home"])
def test_folders_are_what_platformdirs_says(tmp_path, monkeypatch, value, home):
    """gaitmon.paths applies the XDG rule itself (importing platformdirs costs every command
    ~8 ms): the same folders as platformdirs for every form of the variables and of $HOME."""
    if home is None:
        monkeypatch.delenv("HOME", raising=False)
    else:
        monkeypatch.setenv("HOME", str(tmp_path / "home") if home == "HOME" else home)
    for var in ("XDG_DATA_HOME", "XDG_CACHE_HOME", "XDG_STATE_HOME"):
        if value is None:
            monkeypatch.delenv(var, raising=False)
        else:
            monkeypatch.setenv(var, value.replace("ABS", str(tmp_path / var)))
    assert paths.user_data_dir() == Path(platformdirs.user_data_dir("gaitmon", False))
    assert paths.user_cache_dir() == Path(platformdirs.user_cache_dir("gaitmon", False))
    assert paths.user_log_dir() == Path(platformdirs.user_log_dir("gaitmon", False))


def test_exclusions_fallback_is_the_systems_data_folder(tmp_path, monkeypatch):
    """Not ~/.local/share on every OS: where platformdirs puts the data of this system (here
    one that is no XDG folder, as on Windows or macOS)."""
    elsewhere = tmp_path / "AppData" / "Local" / "gaitmon"
    monkeypatch.setattr(paths, "_XDG", False)  # not Linux: platformdirs decides
    monkeypatch.setattr(platformdirs, "user_data_dir", lambda *a, **k: str(elsewhere))
    store = exclusions.user_store_path(tmp_path / "walk.h5")
    assert store.parent == elsewhere / "exclusions"
    assert store.name.startswith("walk.h5.") and store.name.endswith(".review.json")


def test_numba_cache_is_in_the_user_cache_folder(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(XDG_CACHE_HOME=str(tmp_path / "cache"), PYTHONPATH=str(ROOT))
    code = "from gaitmon.dsp.kernels import numba_cache_dir; print(numba_cache_dir())"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=120, check=True).stdout.strip()  # fmt: skip
    assert Path(out) == tmp_path / "cache" / "gaitmon" / "numba"


def _log(tmp_path: Path) -> Path:
    return tmp_path / "state" / "gaitmon" / "log" / "gaitmon.log"


def test_a_commands_error_is_logged_and_shown_once(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    missing = tmp_path / "nowhere.h5"
    assert main(["info", str(missing)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nowhere.h5" in err
    text = _log(tmp_path).read_text(encoding="utf-8")
    assert f"gaitmon info {missing} (gaitmon " in text  # the command run
    assert "INFO gaitmon.cli: gaitmon info: error:" in text and "nowhere.h5" in text


def test_an_internal_error_is_one_line_and_its_traceback_is_in_the_log(tmp_path, monkeypatch,
                                                                        capsys):  # fmt: skip
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    monkeypatch.delenv("GAITMON_DEBUG", raising=False)

    def broken(args):
        raise TypeError("a bug somewhere")

    from gaitmon.commands import ports

    monkeypatch.setattr(ports, "run", broken)
    assert main(["ports"]) == 1
    err = capsys.readouterr().err
    log = _log(tmp_path)
    assert err == f"gaitmon ports: internal error: a bug somewhere; details in {log}\n"
    text = log.read_text(encoding="utf-8")
    assert "Traceback (most recent call last)" in text and "TypeError: a bug somewhere" in text


def test_verbose_echoes_the_log_to_stderr(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    assert main(["ports"]) == 0
    assert "gaitmon ports (gaitmon" not in capsys.readouterr().err
    assert main(["--verbose", "ports"]) == 0
    assert "gaitmon --verbose ports (gaitmon" in capsys.readouterr().err
    assert main(["ports", "--verbose"]) == 0
    assert "gaitmon ports --verbose (gaitmon" in capsys.readouterr().err


def test_log_path_and_version_say_where_the_log_is(tmp_path):
    env = {**os.environ, "XDG_STATE_HOME": str(tmp_path / "state"), "PYTHONPATH": str(ROOT)}
    log = _log(tmp_path)
    for flag in ("--log-path", "--version"):
        proc = subprocess.run([sys.executable, "-m", "gaitmon", flag], env=env, cwd=tmp_path,
                              capture_output=True, text=True, timeout=120)  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        assert str(log) in proc.stdout, (flag, proc.stdout)


def test_a_warning_goes_to_the_terminal_of_the_moment(tmp_path, monkeypatch):
    """As Python's last-resort handler did before the log was set up: a library warning after
    a command (in the same process) reaches the stderr of that moment, message only."""
    import io
    import logging

    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    first = io.StringIO()
    monkeypatch.setattr(sys, "stderr", first)
    assert main(["ports"]) == 0
    first.close()  # as a test's captured stderr is, after the test
    later = io.StringIO()
    monkeypatch.setattr(sys, "stderr", later)
    logging.getLogger("gaitmon.session").warning("stride measures not stored in x.h5: full")
    assert later.getvalue() == "stride measures not stored in x.h5: full\n"
    assert "stride measures not stored" in _log(tmp_path).read_text(encoding="utf-8")


def test_the_log_rotates_as_the_standard_rotating_handler_does(tmp_path):
    """gaitmon.logs rotates its file itself (logging.handlers costs every command ~4 ms to
    import): the same records give the same files as the standard RotatingFileHandler's."""
    import logging
    import logging.handlers

    from gaitmon import logs

    ours_dir, ref_dir = tmp_path / "ours", tmp_path / "ref"
    ours_dir.mkdir()
    ref_dir.mkdir()
    ours = logs._RotatingFile(ours_dir / "gaitmon.log", 2000, 3)
    ref = logging.handlers.RotatingFileHandler(
        ref_dir / "gaitmon.log", maxBytes=2000, backupCount=3, encoding="utf-8", delay=True
    )
    for n in range(300):
        record = logging.LogRecord("gaitmon.t", logging.INFO, __file__, 1,
                                   "line %d %s", (n, "x" * (n % 37)), None)  # fmt: skip
        ours.handle(record)
        ref.handle(record)
    ours.close()
    ref.close()
    names = sorted(p.name for p in ref_dir.iterdir())
    assert names == ["gaitmon.log", "gaitmon.log.1", "gaitmon.log.2", "gaitmon.log.3"]
    assert sorted(p.name for p in ours_dir.iterdir()) == names
    for name in names:
        assert (ours_dir / name).read_text() == (ref_dir / name).read_text()
    assert (ours_dir / "gaitmon.log").read_text().rstrip().endswith("line 299 " + "x" * (299 % 37))
