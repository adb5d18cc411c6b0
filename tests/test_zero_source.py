"""Where the angles' zero comes from, said beside the method everywhere from one function
(``gaitmon.dsp.calibration.zero_source``): the live window's status bar and guide, ``gaitmon
info``, the review window's status bar and the report (its settings rows, in the PDF)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import write_simulated_session

from gaitmon.cli import main
from gaitmon.dsp.calibration import (
    ZERO_ESTIMATED,
    ZERO_STANDING,
    ZERO_UNIT,
    Calibration,
    zero_source,
)
from gaitmon.finish import open_session
from gaitmon.report import gather_report

ZEROED = Calibration(np.radians([1.0, -2.0, 3.0, 0.5]), np.zeros(4))


def test_the_phrases() -> None:
    ident = Calibration.identity()
    assert zero_source(ident) == ZERO_ESTIMATED
    assert zero_source(ZEROED) == ZERO_STANDING
    assert zero_source(ident, [(1230, ZEROED)], 100.0) == (
        f"estimated until 12.3 s, then {ZERO_STANDING}"
    )
    assert zero_source(ident, [(500, ident)], 100.0) == ZERO_ESTIMATED  # no offsets: no Zero
    assert zero_source(ZEROED, mode="tilt") == ZERO_UNIT
    assert ZERO_STANDING != ZERO_ESTIMATED


@pytest.fixture(scope="module")
def sessions(tmp_path_factory, record_simulated) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("zero_source")
    return {
        "estimated": write_simulated_session(d / "not_zeroed.h5", n=1500),
        "standing": record_simulated(d / "zeroed.h5", "--zero", duration_s=6, standing_s=3),
    }


@pytest.mark.parametrize(("kind", "phrase"), [("estimated", ZERO_ESTIMATED),
                                              ("standing", ZERO_STANDING)])  # fmt: skip
def test_info_and_the_report_say_it_beside_the_method(
    kind: str, phrase: str, sessions, capsys
) -> None:
    path = sessions[kind]
    with open_session(path) as s:
        assert s.zero_source == phrase
        method = s.angle_method
        settings = dict(gather_report(s).settings)
    assert f"tilt: {method}" in settings["Signal chain"]  # the method, and in the next row
    assert settings["Calibration"].startswith(f"zero: {phrase}")  # where its zero comes from
    assert list(settings).index("Calibration") == list(settings).index("Signal chain") + 1
    assert main(["info", str(path)]) == 0
    angles = next(ln for ln in capsys.readouterr().out.splitlines() if "angles " in ln)
    assert method in angles and f"zero: {phrase}" in angles


def test_the_report_pdf_says_it(qapp, sessions, tmp_path) -> None:
    if not shutil.which("pdftotext"):
        pytest.skip("pdftotext (poppler-utils) is not installed")
    out = tmp_path / "report.pdf"
    assert main(["report", str(sessions["standing"]), "-o", str(out)]) == 0
    text = subprocess.run(["pdftotext", str(out), "-"], capture_output=True, text=True,
                          check=True).stdout  # fmt: skip
    assert f"zero: {ZERO_STANDING}" in " ".join(text.split())


def test_the_review_status_bar_says_it(qtbot, review_win, sessions) -> None:
    w = review_win
    with qtbot.waitSignal(w.analysis_done, timeout=30_000):
        w.open_file(sessions["estimated"])
    text = w.status.angles.text()
    assert w.doc.angle_method in text and f"zero: {ZERO_ESTIMATED}" in text


def test_the_live_window_says_it_in_the_status_bar_and_the_guide(
    qtbot, tmp_path, no_leaked_threads
) -> None:
    from PySide6.QtCore import QSettings

    from gaitmon.io.sim import SimConfig
    from gaitmon.live.connection import SIMULATED_PORT
    from gaitmon.ui.live.window import MainWindow

    settings = QSettings(str(tmp_path / "gaitmon.ini"), QSettings.Format.IniFormat)
    win = MainWindow(settings, sim=SimConfig(standing_s=1.0), autoconnect=SIMULATED_PORT,
                     mode="raw", confirm_close=False)  # fmt: skip
    qtbot.addWidget(win)
    win.show()
    try:
        qtbot.waitUntil(lambda: win.engine is not None, timeout=30_000)
        status, guide = win.status.method_label, win.guide.hint_label
        qtbot.waitUntil(lambda: f"zero: {ZERO_ESTIMATED}" in status.text(), timeout=30_000)
        assert win.engine.config.tilt_method_label in status.text()
        assert ZERO_ESTIMATED in guide.text()
        win.engine.use_calibration(ZEROED)  # as the Zero action does, from the next block on
        qtbot.waitUntil(lambda: f"zero: {ZERO_STANDING}" in status.text(), timeout=30_000)
        qtbot.waitUntil(lambda: ZERO_STANDING in guide.text(), timeout=30_000)
    finally:
        win.close()
    assert win.errors == []
