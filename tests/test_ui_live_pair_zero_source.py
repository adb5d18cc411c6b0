"""The both-legs live view says, per leg, what made its angles and where their zero comes from
("angles: M · zero: Z"), as the one-leg window's status bar, info, review and the report do
(gaitmon.dsp.calibration.zero_source, through each engine's snapshot). Offscreen."""

from __future__ import annotations

import math

import pytest
from helpers import make_engine, wait_for

from gaitmon.dsp.calibration import ZERO_ESTIMATED, ZERO_STANDING
from gaitmon.engine.pair import EngineGroup


@pytest.fixture
def view(qtbot):
    from gaitmon.ui.live.pair_view import PairView
    from gaitmon.ui.theme import current_colours

    v = PairView(current_colours())
    qtbot.addWidget(v)
    v.show()
    return v


def test_each_leg_shows_its_own_angle_method_and_zero_source(view):
    engines = {}
    units = {}
    for side, seed in (("L", 4), ("R", 6)):
        units[side], engines[side] = make_engine(speed=50.0, standing_s=math.inf, seed=seed)
    with engines["L"], engines["R"]:
        wait_for(lambda: min(e.samples_total for e in engines.values()) >= 200, what="data")
        snaps = {s: e.snapshot(0.5) for s, e in engines.items()}
        view.show_links(snaps, {"L": "sim-L", "R": "sim-R"})
        for s in ("L", "R"):
            text = view.status[s].method_label.text()
            assert text == f"angles: {snaps[s].angle_method} · zero: {ZERO_ESTIMATED}"
            assert snaps[s].angle_method and view.status[s].method_label.isVisible()
        # zero the right leg only: only its line changes
        EngineGroup({"R": engines["R"]}).zero(from_start=True)
        wait_for(lambda: engines["R"].snapshot(0.1).calibrated, what="the zero in force")
        snaps = {s: e.snapshot(0.5) for s, e in engines.items()}
        view.show_links(snaps, {"L": "sim-L", "R": "sim-R"})
    assert view.status["R"].method_label.text().endswith(f"zero: {ZERO_STANDING}")
    assert view.status["L"].method_label.text().endswith(f"zero: {ZERO_ESTIMATED}")
    view.clear()
    assert view.status["L"].method_label.text() == ""
