"""The simulated unit on a pty answers the client's first command however long the simulator's
first import takes. Its first samples need scipy's interpolator (``io.sim.kinematics`` imports
it lazily: ~1 s, more on a busy machine); that import ran in the pty's thread, after the port
existed, so a client asking IDENTIFY (3 attempts of 0.5 s) got no answer: the real-cut fixture
of ``tests/test_review_gaps.py`` failed so 4 times in 6 beside four busy processes. Here the
import is made to take 2 s (longer than the client's 1.5 s) in a fresh process, where scipy's
interpolator is not imported yet: that is the premise, checked."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gaitmon

_SLOW_IMPORT = """
import importlib.abc, sys, time

class SlowInterpolate(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "scipy.interpolate":
            time.sleep(2.0)  # a busy machine's import, longer than the client waits
        return None

sys.meta_path.insert(0, SlowInterpolate())
from gaitmon.io.device import Device
from gaitmon.io.sim import GaitConfig, SimulatedUnit
from gaitmon.io.sim.pty import PtySimulator
from gaitmon.io.transport import SerialTransport

print("premise", "scipy.interpolate" not in sys.modules)
unit = SimulatedUnit(GaitConfig(seed=3, standing_s=2.0), speed=5.0)
with PtySimulator(unit) as sim:
    dev = Device(SerialTransport(str(sim.link_path)))
    dev.connect()
    try:
        print("answered", dev.identify().name)
    finally:
        dev.close()
"""


def test_the_pty_unit_answers_its_first_command_despite_a_slow_first_import():
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(Path(gaitmon.__file__).parents[1])}
    r = subprocess.run([sys.executable, "-c", _SLOW_IMPORT], capture_output=True, text=True,
                       timeout=60, env=env)  # fmt: skip
    lines = r.stdout.splitlines()
    assert lines[:1] == ["premise True"], (r.stdout, r.stderr)
    assert r.returncode == 0, r.stderr.strip().splitlines()[-1:]
    assert len(lines) == 2 and lines[1].startswith("answered "), (r.stdout, r.stderr)
