"""Issue 25, then 28: the first Connect after an install used to wait for numba compiling the
filters (30-40 s on a busy machine) and said so; now nothing compiles on the way (the live
loops run interpreted, and numba's cache is filled by a background process), so it neither
waits nor says it does. A connect that takes a while says what it waits for.

Each run is a fresh process whose numba cache folder starts empty (``NUMBA_CACHE_DIR``: a new
install as far as the compiled loops go): the real window connects to the simulated unit and
its status bar is read until it is connected. ``connect_text`` (the line itself) is checked for
each step of a connect.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from gaitmon.ui.live.jobs import FILTERS, UNIT, connect_text

ROOT = Path(__file__).resolve().parents[1]
FIRST_RUN = "first run after install"  # what the old first connect said while compiling

# the window in a process of its own: every status-bar message until a unit is connected
SCRIPT = r"""
import json, sys, time
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QApplication
from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.ui.live import MainWindow

app = QApplication([])
settings = QSettings(sys.argv[1], QSettings.Format.IniFormat)
win = MainWindow(settings, sim=SimConfig(standing_s=1.0), autoconnect=SIMULATED_PORT,
                 mode="raw", confirm_close=False)
win.show()
seen = []
deadline = time.monotonic() + 240
while time.monotonic() < deadline:
    app.processEvents()
    msg = win.statusBar().currentMessage()
    if not seen or seen[-1] != msg:
        seen.append(msg)
    if win.engine is not None:
        break
    time.sleep(0.02)
connected = win.engine is not None
numba_loaded = "numba" in sys.modules  # (the window's process: nothing compiled in it)
win.close()
from gaitmon.dsp import kernel_cache
filler = kernel_cache.wait_fill(240)  # the background fill this connect started, if any
print(json.dumps({"messages": seen, "connected": connected, "errors": win.errors,
                  "numba": numba_loaded, "filler": filler, "ready": kernel_cache.cache_ready()}))
"""


def connect_messages(tmp_path: Path, cache: Path) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "QT_QPA_PLATFORM": "offscreen",
           "PYTHONPATH": str(ROOT)}  # fmt: skip
    ini = str(tmp_path / "gaitmon.ini")
    run = subprocess.run([sys.executable, "-c", SCRIPT, ini], env=env, capture_output=True,
                         text=True, timeout=290, cwd=ROOT)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout.strip().splitlines()[-1])


@pytest.mark.timeout(600)
def test_the_first_connect_after_an_install_waits_for_no_compile(tmp_path):
    cache = tmp_path / "numba-cache"  # empty: nothing compiled yet
    first = connect_messages(tmp_path, cache)
    assert first["connected"] and first["errors"] == []
    assert not any(FIRST_RUN in m for m in first["messages"]), first["messages"]
    assert any(m.startswith("Connected to") for m in first["messages"]), first["messages"]
    assert first["numba"] is False  # the live loops ran interpreted
    # numba's cache was filled meanwhile, by a background process, for long batch work
    assert first["filler"] == 0 and first["ready"] is True
    assert any(cache.rglob("*.nbi"))
    again = connect_messages(tmp_path, cache)  # the same install, the next run
    assert again["connected"] and again["numba"] is False
    assert again["filler"] is None  # the cache is ready: no second fill


def test_the_connect_line_names_what_it_waits_for():
    unit = "Simulated device"
    # quiet for 2 s, then what it waits for and for how long
    for step in ("", FILTERS, UNIT):
        assert connect_text(unit, step, 1.9) == f"Connecting to {unit}…"
    assert connect_text(unit, FILTERS, 2.0) == f"Connecting to {unit}: preparing the filters… (2 s)"
    assert connect_text(unit, UNIT, 5.5) == (
        f"Connecting to {unit}: waiting for the unit to answer… (5 s)"
    )
