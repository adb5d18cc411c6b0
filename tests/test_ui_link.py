"""The live window's reconnect banner over the simulated unit's real pty: words a clinician
understands, a countdown that is right at every refresh, the technical reason in a tooltip."""

import math
import re
import threading
import time

import pytest
from PySide6.QtCore import QSettings

from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.ui.live import MainWindow

WAIT_MS = 15_000
BANNER = re.compile(
    r"^Connection to the unit lost — reconnecting \(attempt (\d+), (?:next in (\d+) s|trying now)\)"
)


@pytest.fixture
def window(qtbot, tmp_path):
    before = {t for t in threading.enumerate() if t.name.startswith("gaitmon")}
    settings = QSettings(str(tmp_path / "gaitmon.ini"), QSettings.Format.IniFormat)
    win = MainWindow(
        settings, sim=SimConfig(standing_s=1.0), autoconnect=SIMULATED_PORT, confirm_close=False
    )
    win.show()
    qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
    yield win
    win.close()
    assert win.conn is None and win.errors == []
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        left = [t for t in threading.enumerate() if t.name.startswith("gaitmon")]
        if not set(left) - before:
            break
        time.sleep(0.05)
    assert not set(left) - before


def test_reconnect_banner_counts_down_in_plain_words(qtbot, window):
    win = window
    qtbot.waitUntil(lambda: win.engine.samples_total >= 50, timeout=WAIT_MS)
    transport = win.engine.device.transport
    win.device_part.cut_simulated_link(30.0)  # the port is gone until restored below
    qtbot.waitUntil(lambda: win.status.link_banner.isVisible(), timeout=WAIT_MS)

    # Refresh as the window's timer does and compare with the transport at that moment:
    # (attempt, whole seconds shown, seconds really left) for each refresh.
    seen: list[tuple[int, int | None, float, float]] = []
    t_end = time.monotonic() + 7.5  # spans the 2 s and 4 s waits of the backoff
    while time.monotonic() < t_end:
        before = transport.status
        win._tick()
        banner = win.status.link_banner
        text, tip, pill = banner.text(), banner.toolTip(), win.status.state_text
        after = transport.status
        now = time.monotonic()
        qtbot.wait(40)
        if (before.attempt, before.next_attempt_s) != (after.attempt, after.next_attempt_s):
            continue  # an attempt happened during the refresh: no fixed truth to compare with
        m = BANNER.match(text)
        assert m, text
        assert "(" not in text[m.end() :] and "Errno" not in text and "gaitmon" not in text
        assert "link lost" in tip and str(transport.port) in tip  # the reason, for a technician
        shown = int(m.group(2)) if m.group(2) else None
        left = after.next_attempt_s - now
        seen.append((int(m.group(1)), shown, left, after.next_attempt_s))
        assert int(m.group(1)) == after.attempt + 1
        if left > 0.1:
            # whole seconds, rounded up; the refresh was a few ms before `now`
            assert shown in (math.ceil(left), math.ceil(left) + 1), (text, left)
            assert pill == f"Reconnecting ({shown} s)"
    win.device_part.restore_simulated_link()
    qtbot.waitUntil(lambda: win.status.state_text == "Connected", timeout=WAIT_MS)
    qtbot.waitUntil(lambda: not win.status.link_banner.isVisible(), timeout=WAIT_MS)

    # the countdown moves within one wait (the old banner read the same value 1.5 s apart)
    by_wait: dict[float, set[int]] = {}
    for _, shown, _, due in seen:
        if shown is not None:
            by_wait.setdefault(due, set()).add(shown)
    assert max(len(v) for v in by_wait.values()) >= 3
    assert max(a for a, *_ in seen) >= 4  # several attempts, numbered
