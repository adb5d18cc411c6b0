"""Issue 25: a stalled link is said live, "no data for N s", until its backlog arrives.

The simulated unit stops sending for 5 s and then delivers every frame it held (Device ▸
Simulator ▸ Stall link: ``SimulatedUnit.stall``), over a pty, through the real SerialTransport
and decoder. While nothing arrives, the window's banner says "no data for N s" from the first
second on, N counting up, also while the transport's watchdog reopens the silent port (before,
the banner came after 2 s and then read "Connection to the unit lost — reconnecting" without
the time: the count started again). It clears when the data flows, and since no frame was lost
(sequence numbers) no gap is shown. In the one-leg window and, per leg, in the two-leg window;
the banner's text is whole where it is drawn.
"""

import re

from PySide6.QtCore import QPoint

from gaitmon.io.sim.bilateral import BilateralConfig
from gaitmon.io.sim.config import SimConfig
from gaitmon.live.connection import SIMULATED_PORT
from gaitmon.live.pair import PairSource
from gaitmon.ui.live import MainWindow

WAIT_MS = 60_000
STALL_S = 5.0  # the menu's stall, device seconds (real time here: speed 1)
NO_DATA = re.compile(r"no data (?:from the unit )?for (\d+) s", re.IGNORECASE)


def whole(label, win) -> bool:
    """``label``'s text is drawn whole: the wrapped text's height fits the label (one line
    unwrapped: its width), and the label lies inside the window."""
    if label.wordWrap():
        if not 0 < label.heightForWidth(label.width()) <= label.height():
            return False
    elif label.sizeHint().width() > label.width():
        return False
    right = label.mapTo(win, QPoint(label.width(), label.height()))
    return 0 < right.x() <= win.width() and 0 < right.y() <= win.height()


def watch(qtbot, win, over, *extra):
    """Poll the window (its own timer draws it meanwhile) until ``over()``: for each poll, the
    banner's text ("" hidden), whether that text, shown since the last poll, is whole, and the
    values of ``extra`` callables."""
    seen = []
    last = [""]

    def poll():
        b = win.status.link_banner
        text = b.text() if b.isVisible() else ""
        fits = not text or text != last[0] or whole(b, win)  # judged once laid out
        last[0] = text
        seen.append((text, fits, *(f() for f in extra)))
        return over()

    qtbot.waitUntil(poll, timeout=WAIT_MS)
    return seen


def counts(texts):
    """The N of each "no data for N s" in ``texts``; every text must say it."""
    out = []
    for t in texts:
        m = NO_DATA.search(t)
        assert m, f"a banner during the stall does not say how long no data came: {t!r}"
        out.append(int(m.group(1)))
    return out


def test_a_stalled_unit_shows_no_data_for_n_seconds_then_its_backlog_fills_in(
    qtbot, ui_settings, no_leaked_threads
):
    win = MainWindow(ui_settings, sim=SimConfig(standing_s=1.0), autoconnect=SIMULATED_PORT,
                     mode="raw", confirm_close=False)  # fmt: skip
    win.show()
    try:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=WAIT_MS)
        eng, unit, panel = win.engine, win.conn.unit, win.gait_panel
        qtbot.waitUntil(lambda: eng.snapshot(0.05).gait.n_strides >= 2, timeout=WAIT_MS)
        lost0 = eng.device.stats.decoder.frames_lost
        assert not win.status.link_banner.isVisible()
        assert win._actions["stall"].isEnabled()
        win._actions["stall"].trigger()  # Device ▸ Simulator ▸ Stall link for 5 s
        start = eng.samples_total
        n_held = round(STALL_S * unit.fs_hz)

        def over():  # the backlog is in and the engine has frames again
            fresh = eng.snapshot(0.05).last_data_age_s < 0.5
            return eng.samples_total >= start + n_held + 50 and fresh

        seen = watch(qtbot, win, over, panel.stale_text, lambda: win.status.state_text)
        texts = [s[0] for s in seen if s[0]]
        assert texts, "nothing said while no data came"
        ns = counts(texts)
        assert ns == sorted(ns)  # N only grows, through the watchdog's reopening too
        assert ns[0] <= 2 and ns[-1] >= 3 and len(set(ns)) >= 3  # counted up each second
        assert all(s[1] for s in seen), "the banner's text is cut"
        assert any(s[2].startswith("⚠ stale: no data for") for s in seen)  # the Gait panel
        assert "No data" in {s[3] for s in seen}  # the state pill never says "Connected"...
        # ...while nothing comes: each poll that showed a banner showed no "Connected" pill
        assert all(s[3] != "Connected" for s in seen if s[0].startswith("No data"))
        # the data flows again: the banner goes, and the backlog was complete
        qtbot.waitUntil(lambda: not win.status.link_banner.isVisible(), timeout=WAIT_MS)
        assert win.status.state_text == "Connected"
        assert eng.device.stats.decoder.frames_lost == lost0
        snap = eng.snapshot(30.0)
        assert len(snap.series["lost"]) >= n_held and snap.series["lost"].sum() == 0  # no gap
    finally:
        win.close()


def test_a_stalled_leg_says_no_data_on_its_own_line_in_the_two_leg_window(
    qtbot, ui_settings, no_leaked_threads
):
    win = MainWindow(ui_settings, pair=PairSource(sim=BilateralConfig(standing_s=1.0)),
                     mode="raw", confirm_close=False)  # fmt: skip
    win.show()
    try:
        qtbot.waitUntil(lambda: win.pair is not None, timeout=WAIT_MS)
        left, right = win.pair.engines["L"], win.pair.engines["R"]
        view = win.pair_part.view
        qtbot.waitUntil(lambda: min(left.samples_total, right.samples_total) >= 200,
                        timeout=WAIT_MS)  # fmt: skip
        lost0 = left.device.stats.decoder.frames_lost
        assert win._actions["stall_L"].isEnabled()
        win._actions["stall_L"].trigger()  # Device ▸ Simulator ▸ Stall left leg's link
        start = left.samples_total

        def over():
            return (
                left.samples_total >= start + round(STALL_S * 100) + 50
                and left.snapshot(0.05).last_data_age_s < 0.5
            )

        def measures():
            return view.measures_box.title(), view.values["cadence"].isEnabled()

        seen = watch(qtbot, win, over, lambda: view.status["R"].state_text,
                     lambda: view.status["L"].health_label.text(),
                     lambda: win.status.state_text, measures)  # fmt: skip
        texts = [s[0] for s in seen if s[0]]
        assert texts and all(t.startswith("Left leg: ") for t in texts)
        assert not any("Right leg" in t for t in texts)  # the right leg streams on
        ns = counts(texts)
        assert ns == sorted(ns) and ns[0] <= 2 and ns[-1] >= 3 and len(set(ns)) >= 3
        assert all(s[1] for s in seen), "the banner's text is cut"
        assert {s[2] for s in seen} == {"Connected"}
        assert any("no data for" in s[3] for s in seen)  # the left leg's own health line
        # the window's state pill names the leg without data, never "Connected: both legs"
        assert "Left leg: No data" in {s[4] for s in seen}
        assert all(s[4] != "Connected: both legs" for s in seen if s[0].startswith("Left leg: No"))
        # both legs' measures are greyed, their box saying whose data is missing
        assert any(t.startswith("Both legs — ⚠ stale (left leg: no data for") and not on
                   for t, on in (s[5] for s in seen))  # fmt: skip
        qtbot.waitUntil(lambda: not win.status.link_banner.isVisible(), timeout=WAIT_MS)
        assert view.status["L"].state_text == "Connected"
        qtbot.waitUntil(lambda: win.status.state_text == "Connected: both legs", timeout=WAIT_MS)
        qtbot.waitUntil(lambda: view.measures_box.title() == "Both legs", timeout=WAIT_MS)
        assert view.values["cadence"].isEnabled()
        assert left.device.stats.decoder.frames_lost == lost0
        assert left.snapshot(30.0).series["lost"].sum() == 0
    finally:
        win.close()
