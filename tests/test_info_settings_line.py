"""``gaitmon info``'s settings line: a method that reads the Kalman settings is shown by them
(the review's settings table, loaded only then: issue 28), the others by their label."""

from __future__ import annotations

from pathlib import Path

from gaitmon.analysis import analyse_session
from gaitmon.commands.info import _lines
from gaitmon.finish import open_session

GOLDEN = Path(__file__).parent / "data" / "golden" / "one_leg.h5"


def _settings_line(method: str) -> str:
    with open_session(GOLDEN) as s:
        an = analyse_session(s)
        s.config = s.config.replace(tilt_method=method)
        return next(line for line in _lines(s, an, False) if "settings" in line)


def test_the_paper_method_is_shown_by_its_kalman_settings_the_default_by_its_label():
    assert ("low-pass 4 Hz order 2, Kalman Q_angle 0.001 Q_gyro 0.003 R 0.3 (paper form), FSR "
            "threshold 1000 LSB;") in _settings_line("paper")  # fmt: skip
    assert "low-pass 4 Hz order 2, gait-aware Kalman, FSR threshold 1000 LSB;" in _settings_line(
        "gait-aware"
    )
